"""``turn-eval detect``: turns in long skeleton streams, one file at a time or on a Dask cluster."""

from __future__ import annotations

import contextlib
from dataclasses import replace
from pathlib import Path

import click

from turn_datasets import limits
from turn_datasets.cli.common import (
    CONTEXT_SETTINGS,
    FPS_HZ,
    Number,
    file_option,
    info,
    params_from,
    params_options,
    wrote,
)
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, check_not_input, manifest_path, to_json_text
from turn_datasets.h36m.miner import MinerParams, check_position_cutoff
from turn_eval.cli import cli
from turn_eval.cli.common import SkeletonSource, skeleton_source_options
from turn_eval.detect.mapping import build_manifest, detect_files
from turn_eval.detect.plugins import load_detector
from turn_eval.detect.progress import FileProgress
from turn_eval.detect.rate import stream_rate
from turn_eval.detect.rule import DETECT_MINER_DEFAULTS, DetectParams, MinerRule
from turn_eval.detect.streams import axes_found, stream_files
from turn_eval.mapping import check_scheduler_address
from turn_eval.steps import StepParams


@cli.command("detect", context_settings=CONTEXT_SETTINGS)
@click.argument("skeletons", nargs=-1, required=True, type=click.Path(path_type=Path))
@file_option(
    "--out",
    required=True,
    help="Detections CSV to write (score-events reads it); <stem>.manifest.json goes beside it.",
)
@skeleton_source_options(
    from_help="Whose files: generic arrays (give --layout), an estimator's own output by name "
    "(turnbench = `turn-eval estimate`'s npz), or motion capture as `turn-datasets h36m mine` "
    "reads it (mocap: BVH, Human3.6M's CDF/H5; joints, axes and rate from the file).",
    extra_formats=("mocap",),
    layout_help="Joint layout of the skeletons; required with --from arrays.",
    up_axis_help="The vertical axis: z (world), y (y up), -y (camera axes: y down, as estimators "
    "write), x, -x, -z, or auto (inferred per stream from the trunk, signed by the head above the "
    "feet). Default: auto for generic arrays, else the named format's own.",
)
@click.option(
    "--fps",
    "fps_hz",
    type=FPS_HZ,
    default=None,
    help="Frame rate of the streams, Hz; with --from turnbench, the rate estimate's manifests "
    "record (a --fps that contradicts it is refused); with --from mocap, each file's own.",
)
@click.option(
    "--force-fps",
    is_flag=True,
    help="Use --fps even where it contradicts the rate the manifests record.",
)
@click.option(
    "--joints",
    default=",".join(DetectParams().joints),
    show_default=True,
    help="Joint pairs whose frontal vectors are combined: any of hip, knee, shoulder.",
)
@params_options(DetectParams)
@params_options(MinerParams, defaults=DETECT_MINER_DEFAULTS)
@params_options(StepParams, prefix="steps_")
@click.option(
    "--detector",
    "detector_spec",
    default=None,
    metavar="MODULE:NAME",
    help="Your own detector instead of the built-in rule (an object or class with name and detect(positions, fps_hz, layout)).",
)
@click.option(
    "--workers",
    type=Number(int, min=1, max=limits.MAX_LOCAL_WORKERS),
    default=None,
    help="Map over files on a local Dask cluster of N processes, about 200 MB each; refused "
    "beyond the free memory (default: serial, no Dask).",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Use an existing Dask scheduler, e.g. tcp://10.0.0.5:8786.",
)
@click.option(
    "--skip-bad",
    is_flag=True,
    help="Skip files that cannot be read (listed in the manifest) instead of failing.",
)
def detect_command(
    skeletons: tuple[Path, ...],
    out: Path,
    source: SkeletonSource,
    fps_hz: float | None,
    force_fps: bool,
    joints: str,
    detector_spec: str | None,
    workers: int | None,
    scheduler: str | None,
    skip_bad: bool,
    **values: float,
) -> None:
    """Detect turns in long skeleton streams (one person's skeleton per array, whole sessions).

    SKELETONS are .npz files (stem = session, one array per subject), .h5 files (one dataset
    per subject), .npy files (one person; SESSION__SUBJECT.npy) or folders of them; each array
    (frames, joints, 3), NaN where no one is seen, absolute or root-relative. The output is
    the detections contract of score-events: session, subject, start_s, end_s, angle_deg,
    direction, speed_deg_s, peak_speed_deg_s, steps (foot contacts), turn_type (pivot/step),
    score. For Turn-REMAP, whose smallest label is the 90° bin, use
    --min-turn-deg 67.5.

    \b
    Example:
      turn-eval detect streams/ --layout h36m17 --up-axis -y --fps 30 \\
          --min-turn-deg 67.5 --out detections.csv
      turn-eval detect streams/ --layout h36m17 --up-axis -y --fps 30 --workers 4 --out d.csv
      turn-eval detect skeletons/ --from turnbench --out d.csv   (estimate's npz: its rate)
      turn-eval detect cmu/*.bvh --from mocap --out d.csv   (motion capture, its own rate)
      turn-eval score-events detections.csv --reference labels.csv --context context.csv
    """
    miner = params_from(MinerParams, values)
    steps = params_from(StepParams, values, prefix="steps_")
    params = replace(
        params_from(DetectParams, values),
        joints=tuple(joints.split(",")),
        miner=miner,
        steps=steps,
    )
    if scheduler:
        check_scheduler_address(scheduler)
    passed_over: list[tuple[Path, str]] = []
    # first: an AlphaPose JSON is refused with its reason
    files = stream_files(skeletons, source_format=source.format, skipped=passed_over)
    detector = MinerRule(params) if detector_spec is None else load_detector(detector_spec)
    for path, why in passed_over:
        info(f"skipped {path}: {why}")
    layout = source.layout()
    check_not_input(out, files)
    mpath = manifest_path(out)
    check_not_input(mpath, files)
    if source.format == "mocap":
        if fps_hz is not None:
            raise TurnbenchError(
                "--from mocap files state their frame rate: drop --fps",
                hint="each stream is read at its file's own rate (recorded in the manifest)",
            )
    else:
        rate = stream_rate(files, fps_hz, source_format=source.format, force=force_fps)
        if rate.origin != "option":  # a rate the user did not type is said
            info(rate.describe())
        fps_hz = rate.fps_hz
        if detector_spec is None:
            # the rule's low-pass at this frame rate, refused before any stream is read
            check_position_cutoff(miner.position_cutoff_hz, fps_hz)
    where = f"on {scheduler}" if scheduler else (f"on {workers} local workers" if workers else "")
    with contextlib.ExitStack() as stack:
        bars: list[FileProgress] = []

        def start() -> None:  # once the cluster is up: a failure to start is one line
            bars.append(stack.enter_context(FileProgress(len(files), f"detecting {where}".strip())))

        run = detect_files(
            files,
            detector=detector,
            layout=layout,
            up_axis=source.up_axis_option,
            fps_hz=fps_hz,
            source_format=source.format,
            workers=workers,
            scheduler=scheduler,
            skip_bad=skip_bad,
            on_file_done=lambda: bars[0].update(1),
            on_start=start,
        )
    for s in run.skipped:
        info(f"skipped {s['file']}{', ' + s['item'] if s['item'] else ''}: {s['error']}")
    manifest = build_manifest(
        run,
        detector=detector,
        params=params.as_dict() if detector_spec is None else {},
        layout=layout,
        up_axis=source.up_axis_option,
        fps_hz=fps_hz,
        source_format=source.format,
    )
    info(axes_found(run.inputs, source.up_axis_option or source.format).summary())
    try:
        with atomic_path(out) as tmp_csv, atomic_path(mpath) as tmp_manifest:
            run.detections.to_csv(tmp_csv, index=False, lineterminator="\n")
            tmp_manifest.write_text(to_json_text(manifest), encoding="utf-8", newline="\n")
    except OSError as exc:
        raise TurnbenchError(
            f"cannot write the detections: {exc.strerror or exc}", file=str(out)
        ) from None
    c = manifest["counts"]
    wrote(
        out,
        mpath,
        what=f"{c['detections']} turns in {c['streams']} streams ({c['hours']:.2f} h) of {c['files']} files to",
    )
