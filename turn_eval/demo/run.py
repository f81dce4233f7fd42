"""``make demo``: everything turnbench does, on the bundled synthetic corpus, in one run.

Run as ``python -m turn_eval.demo --out-dir demo-output``. The steps are the commands a user
runs, called in process through the same click groups as the console scripts (so the demo
exercises exactly what users run, without paying for a Python start per command), each
printed as ``$ turn-datasets ...`` before it runs:

1. write the demo corpus (:mod:`turn_datasets.synthetic.demo_corpus`): Turn-H3.6M-like motion capture
   in the three Human3.6M layouts, and Turn-REMAP-like ELAN sessions;
2. ``turn-datasets h36m mine`` the clip index, ``h36m stats`` (the paper's Table 3), and a
   check of the mined clips against the turns the generator planted;
3. ``turn-datasets remap labels``, ``remap stats`` (Tables 1 and 2) and ``remap agreement``
   with its kappa gate (``--min-kappa 0.8``) and the review EAFs;
4. skeletons as a monocular estimator would give them (:mod:`turn_datasets.synthetic.degrade`), then
   ``turn-eval predict`` with both methods (``paper``: equation 3 as printed; ``net``);
5. ``turn-eval score --plots`` of each method on each set (Tables 4 and 5, Figure 5);
6. ``turn-eval compare`` of the two methods on each set;
7. untrimmed sessions: ``turn-eval detect`` and ``score-events`` (:mod:`turn_eval.demo.untrimmed`);
8. Turn-REMAP as released: a REMAP-Open-shaped tree, ``turn-datasets remap open``, ``predict``
   and ``score`` by medication, DBS, turn type and steps (:mod:`turn_eval.demo.remap_open`);
9. ``report.html``: one self-contained page of all of it (:mod:`turn_eval.report`).

It ends by printing where each result is. Same seed, same outputs.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import shlex
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import click
import numpy as np
import pandas as pd

from turn_datasets import __version__
from turn_datasets import cli as datasets_cli
from turn_datasets.cli.common import Terminated, run_group, sigterm_unwinds
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import (
    check_files_and_folders,
    manifest_path,
    read_run_record,
    remove_recorded,
    sha256_file,
    write_csv,
    write_run_record,
    write_text,
)
from turn_datasets.render.markdown import markdown_table
from turn_datasets.render.numbers import MISSING, elan_time, fixed, format_metric
from turn_datasets.synthetic.degrade import degrade_skeleton
from turn_datasets.synthetic.demo_corpus import (
    DEMO_SEED,
    write_h36m_corpus,
    write_h36m_estimates,
    write_remap_corpus,
    write_remap_estimates,
)
from turn_eval import cli as eval_cli
from turn_eval.demo.profile import PROFILE_DIR, profile_section, run_profile_stage
from turn_eval.demo.remap_open import (
    OPEN_DIR,
    RemapOpenResults,
    load_remap_open,
    remap_open_section,
    run_remap_open_stage,
)
from turn_eval.demo.untrimmed import FPS_HZ as UNTRIMMED_FPS_HZ
from turn_eval.demo.untrimmed import (
    UNTRIMMED_DIR,
    UntrimmedResults,
    load_untrimmed,
    run_untrimmed_stage,
    untrimmed_section,
)
from turn_eval.report import Report, load_json

__all__ = [
    "DemoFailed",
    "DemoResults",
    "SetScores",
    "load_results",
    "run_demo",
    "prepare_out_dir",
    "match_planted",
    "write_report",
    "main",
]

METHODS = ("paper", "net")
#: Where ``compare --plots-dir`` draws the two methods side by side, in each set's folder.
COMPARE_FIGURES = "compare-figures"
MIN_KAPPA = 0.8
#: A planted turn counts as found when a mined clip of the same sequence and direction
#: covers at least this share of its frames.
FOUND_COVERAGE = 0.5


class DemoFailed(RuntimeError):
    """A step of the demo exited with an unexpected code."""


def _say(text: str = "") -> None:
    click.echo(text)


def _run(group: click.Group, prog: str, args: Sequence[str], *, show: bool = False) -> str:
    """Run one command in process, as its console script would; return what it printed.

    The command's stdout is captured (and echoed when ``show``); its stderr (progress and
    "wrote ..." lines) goes to the terminal as usual.
    """
    _say(f"\n$ {prog} {shlex.join(args)}")
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        code = run_group(group, prog, list(args))
    out = buffer.getvalue()
    if show and out:
        _say(out.rstrip("\n"))
    if code != 0:
        raise DemoFailed(f"`{prog} {shlex.join(args)}` exited with code {code}")
    return out


def _datasets(args: Sequence[str], *, show: bool = False) -> str:
    return _run(datasets_cli.cli, "turn-datasets", args, show=show)


def _eval(args: Sequence[str], *, show: bool = False) -> str:
    return _run(eval_cli.cli, "turn-eval", args, show=show)


def match_planted(
    planted: pd.DataFrame, index: pd.DataFrame, *, min_coverage: float = FOUND_COVERAGE
) -> pd.DataFrame:
    """Each planted turn with the mined clip that covers it best, if any.

    A planted turn is ``found`` by a clip of the same subject, action, subaction and
    direction that covers at least ``min_coverage`` of its frames. Returns the planted rows
    with ``found``, ``clip_id``, ``mined_angle_deg``, ``start_error_s`` and ``end_error_s``
    (mined minus planted boundary).
    """
    rows = []
    keys = ["subject", "action", "subaction"]
    index = index.assign(subaction=index["subaction"].fillna("").astype(str))
    by_seq = {k: g for k, g in index.groupby(keys, sort=False)}
    for turn in planted.itertuples(index=False):
        best = None
        clips = by_seq.get((turn.subject, turn.action, turn.subaction))
        if clips is not None:
            same = clips[clips["direction"] == turn.direction]
            overlap = np.minimum(same["end_frame"], turn.end_frame) - np.maximum(
                same["start_frame"], turn.start_frame
            )
            coverage = np.clip(overlap, 0, None) / (turn.end_frame - turn.start_frame)
            if len(same) and coverage.max() >= min_coverage:
                best = same.iloc[int(np.argmax(coverage.to_numpy()))]
        fps = 50.0 if best is None else float(best["fps"])
        rows.append(
            {
                **turn._asdict(),
                "found": best is not None,
                "clip_id": "" if best is None else str(best["clip_id"]),
                "mined_angle_deg": np.nan if best is None else float(best["angle_deg"]),
                "start_error_s": np.nan
                if best is None
                else (int(best["start_frame"]) - turn.start_frame) / fps,
                "end_error_s": np.nan
                if best is None
                else (int(best["end_frame"]) - turn.end_frame) / fps,
            }
        )
    return pd.DataFrame(rows)


def _miner_check(planted: pd.DataFrame, index: pd.DataFrame) -> tuple[pd.DataFrame, str]:
    """Recall of planted turns, precision of mined clips, angle and boundary errors."""
    matched = match_planted(planted, index)
    rows = []
    # The range is the planted hips' own: the generator asks for 48° to 233° of heading, and
    # the pelvic sway at a turn's ends moves the hip rotation a few degrees either way.
    low, high = planted["angle_deg"].min(), planted["angle_deg"].max()
    for label, group in (
        (f"all ({fixed(low, 0)}° to {fixed(high, 0)}°)", matched),
        ("at least 60°", matched[matched["angle_deg"] >= 60.0]),
    ):
        found = group[group["found"]]
        rows.append(
            [
                label,
                len(group),
                len(found),
                fixed(100.0 * len(found) / max(len(group), 1), 1) + "%",
                fixed(np.median(np.abs(found["mined_angle_deg"] - found["angle_deg"])), 1),
                fixed(np.median(np.abs(found["start_error_s"])), 2),
                fixed(np.median(np.abs(found["end_error_s"])), 2),
            ]
        )
    header = [
        "planted turns",
        "planted",
        "found",
        "recall",
        "median angle error (°)",
        "median start error (s)",
        "median end error (s)",
    ]
    lines = markdown_table(header, rows, align="lrrrrrr")
    claimed = set(matched.loc[matched["found"], "clip_id"])
    spurious = len(index) - len(claimed & set(index["clip_id"]))
    precision = 100.0 * (len(index) - spurious) / max(len(index), 1)
    lines.append("")
    lines.append(
        f"Mined clips: {len(index)}, of which {len(index) - spurious} cover a planted turn "
        f"(precision {fixed(precision, 1)}%); {spurious} cover none (a sway or a wander read as a turn, "
        "or the second half of a planted turn split in two)."
    )
    return matched, "\n".join(lines) + "\n"


def _overall_line(scores: dict) -> str:
    o = scores["overall"]
    speed = o.get("mae_speed_deg_s")
    speed_text = (
        "" if speed is None else f", MAE speed {format_metric('mae_speed_deg_s', speed)}°/s"
    )
    return (
        f"n {o['n']}: accuracy {format_metric('accuracy', o['accuracy'])}%, "
        f"MAE {format_metric('mae_deg', o['mae_deg'])}°, "
        f"WPrec {format_metric('wprec', o['wprec'])}%{speed_text}"
    )


#: The demo's run record in its output folder: every file a run wrote, with its sha256
#: (:func:`turn_datasets.fileio.write_run_record`). A folder holding it is an earlier run's.
RECORD = "demo.manifest.json"
#: What marked a demo folder before the run record: such a folder is known as the demo's,
#: but lists nothing, so nothing in it is removed.
MARKER = ".turnbench-demo"
#: Where the demo writes in its output folder: only what its record lists is removed there.
OWNED = ("corpus", "h36m", "remap", UNTRIMMED_DIR, OPEN_DIR, "report.html")
#: Folders whose every file the demo reads (the corpus, the streams, a release's tree): a
#: file left there that the demo did not write would be read as its own input.
READ_WHOLE = ("corpus", f"{UNTRIMMED_DIR}/streams", f"{OPEN_DIR}/release")


def prepare_out_dir(out: Path) -> list[Path]:
    """Make ``out`` ready for a demo run, or refuse with a :class:`TurnbenchError`; return
    the files of the previous run removed.

    The folder keeps a run record (:data:`RECORD`), as every output folder does: clean-up
    removes only the files it lists that still hold what the demo wrote; a file of the
    user's, or one changed since, is never removed. Anything in the demo's places
    (:data:`OWNED`) that is not a regular file or a real folder (a symbolic link, a FIFO) is
    refused, since rewriting would replace it or write through it. A file left in a folder
    the demo reads whole (:data:`READ_WHOLE`) is refused too: the miner reads every file
    under ``corpus/h36m``, and a ``--quick`` run over a full one would mine both. A folder
    that is not empty and holds no earlier run is refused, so a mistyped ``--out-dir`` never
    costs a user files.
    """
    if out.exists() and any(out.iterdir()):
        ours = any(
            os.path.lexists(p)
            for p in (out / RECORD, out / MARKER, out / "corpus" / "h36m" / "planted.csv")
        )
        if not ours:
            raise TurnbenchError(
                "--out-dir is not empty and holds no earlier demo run; give a new or empty folder",
                file=str(out),
            )
    for name in (*OWNED, RECORD):
        check_files_and_folders(out / name)
    previous = read_run_record(out, RECORD)
    for folder in READ_WHOLE:  # before anything is removed: a refused run changes nothing
        left = [k for k, v in _files_under(out, (folder,)).items() if previous.get(k) != v]
        if left and not os.path.lexists(out / RECORD):
            raise TurnbenchError(
                f"--out-dir holds a demo run from before the demo kept a run record ({RECORD}): "
                "which of its files are the demo's is not known, and the demo reads every file "
                f"in {folder}; remove the folder, or give another --out-dir",
                file=str(out),
            )
        if left:
            raise TurnbenchError(
                f"is in {folder}, whose every file the demo reads, and is not a file of the "
                f"previous demo run as it wrote it ({len(left)} such file"
                f"{'' if len(left) == 1 else 's'} there): move "
                f"{'it' if len(left) == 1 else 'them'} out, or give another --out-dir",
                file=str(out / left[0]),
            )
    removed, _ = remove_recorded(out, previous)
    out.mkdir(parents=True, exist_ok=True)
    write_run_record(out, RECORD, {})  # the folder is the demo's from here on
    return removed


def _files_under(out: Path, names: Sequence[str]) -> dict[str, str]:
    """The regular files at or under ``out/name`` for each of ``names``, by path relative to
    ``out`` (``/``-separated, sorted), with their sha256."""
    found: dict[str, str] = {}
    for name in names:
        top = out / name
        paths = [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file())
        for path in paths:
            if os.path.lexists(path) and not path.is_symlink():
                found[path.relative_to(out).as_posix()] = sha256_file(path)
    return dict(sorted(found.items()))


@contextlib.contextmanager
def _recorded(out: Path) -> Iterator[None]:
    """Record in :data:`RECORD` every file the block writes (new, or changed) in the demo's
    places, whether it finishes or stops (a failed step, Ctrl-C, SIGTERM), so that the next
    run may remove them; a file that was there before and is unchanged is not the run's."""
    before = _files_under(out, OWNED)
    try:
        yield
    finally:
        after = _files_under(out, OWNED)
        write_run_record(out, RECORD, {k: v for k, v in after.items() if before.get(k) != v})


#: The corpus of ``--quick`` (and of the tests): three subjects (both splits), two actions, three
#: pairs; every step still runs.
class QuickCorpus(TypedDict):
    """The size of a ``--quick`` demo corpus."""

    subjects: tuple[str, ...]
    actions: dict[str, tuple[int, int]]
    n_pairs: int


QUICK: QuickCorpus = {
    "subjects": ("S1", "S5", "S9"),
    "actions": {"Walking": (3, 4), "Phoning": (1, 2)},
    "n_pairs": 3,
}


@dataclass
class SetScores:
    """One benchmark's scores in the demo: per method, the scores document and its figures."""

    title: str
    groupings: tuple[str, ...]
    scores: dict[str, dict]
    figures: dict[str, list[Path]]
    compare_md: str | None = None
    #: ``compare --plots-dir``'s figures: the methods side by side on shared axes.
    compare_figures: list[Path] = field(default_factory=list)


@dataclass
class DemoResults:
    """What the demo computed, for the report (:func:`write_report`) and the listing."""

    seed: int
    table3_md: str
    miner_md: str | None
    tables12_md: str
    audit: dict
    agreement_md: str | None
    confusion_pngs: list[Path]
    disagreements: pd.DataFrame | None
    sets: list[SetScores]
    paths: dict[str, Path] = field(default_factory=dict)
    untrimmed: UntrimmedResults | None = None
    remap_open: RemapOpenResults | None = None


#: The benchmarks the demo scores: key, name, folder, groupings shown in the report.
_SETS = (
    ("h36m", "Turn-H3.6M", ("subject", "bin_deg", "action", "split")),
    ("remap", "Turn-REMAP", ("scenario", "location", "cohort", "bin_deg", "subject")),
)


def _corpus_step(out: Path, *, seed: int, quick: bool, paths: dict[str, Path]):
    _say("\n# 1. The demo corpus (synthetic; no licensed data needed)")
    corpus = out / "corpus"
    if quick:
        h36m = write_h36m_corpus(
            corpus / "h36m", seed=seed, subjects=QUICK["subjects"], actions=QUICK["actions"]
        )
        remap = write_remap_corpus(corpus / "remap", seed=seed, n_pairs=QUICK["n_pairs"])
    else:
        h36m = write_h36m_corpus(corpus / "h36m", seed=seed)
        remap = write_remap_corpus(corpus / "remap", seed=seed)
    _say(
        f"Turn-H3.6M-like motion capture: {h36m.n_sequences} sequences, {h36m.n_frames} frames "
        f"at 50 Hz, {len(h36m.planted)} planted turns, in {corpus / 'h36m'} "
        "(S1 as CDF, S5 as 3d-pose-baseline h5, the rest as VideoPose3D npz)"
    )
    _say(
        f"Turn-REMAP-like ELAN sessions: {len(remap.paths)} sessions of "
        f"{len(remap.participants)} participants, {len(remap.truth)} planted turns, in "
        f"{corpus / 'remap'}"
    )
    paths["Demo motion capture (three H3.6M layouts)"] = corpus / "h36m"
    paths["Turns planted in the motion capture"] = h36m.planted_path
    paths["Demo ELAN sessions"] = corpus / "remap" / "eaf"
    paths["Participants table"] = remap.participants_path
    return h36m, remap


def _h36m_step(out: Path, h36m, paths: dict[str, Path]) -> tuple[Path, str, str]:
    _say("\n# 2. Turn-H3.6M: mine the clip index, summarise it (Table 3)")
    h36m_dir = out / "h36m"
    index_path = h36m_dir / "turn-h36m.csv"
    _datasets(["h36m", "mine", str(out / "corpus" / "h36m"), "--out", str(index_path)])
    table3 = _datasets(["h36m", "stats", str(index_path)], show=True)
    paths["Turn-H3.6M clip index"] = index_path
    paths["Turn-H3.6M manifest"] = manifest_path(index_path)
    paths["Table 3 (clips per bin)"] = write_text(h36m_dir / "table3.md", table3)
    index = pd.read_csv(index_path, dtype={"subaction": str}, keep_default_na=False)
    matched, miner_md = _miner_check(h36m.planted, index)
    _say("\nThe miner against the turns the generator planted:")
    _say(miner_md.rstrip("\n"))
    paths["Miner vs planted turns"] = write_text(h36m_dir / "miner-check.md", miner_md)
    paths["Each planted turn and the clip that found it"] = write_csv(
        matched, h36m_dir / "miner-check.csv"
    )
    return index_path, table3, miner_md


def _remap_step(out: Path, remap, paths: dict[str, Path]) -> tuple[Path, str, Path]:
    _say("\n# 3. Turn-REMAP: labels, Tables 1 and 2, the inter-rater agreement audit")
    remap_dir = out / "remap"
    labels_path = remap_dir / "labels.csv"
    participants = str(remap.participants_path)
    eaf_dir = str(out / "corpus" / "remap" / "eaf")
    _datasets(
        ["remap", "labels", eaf_dir, "--participants", participants, "--out", str(labels_path)]
    )
    paths["Turn-REMAP labels"] = labels_path
    paths["Turn-REMAP raw annotations"] = labels_path.with_name("annotations.csv")
    tables12 = _datasets(
        ["remap", "stats", str(labels_path), "--participants", participants], show=True
    )
    paths["Tables 1 and 2 (cohorts, scenarios x angles)"] = write_text(
        remap_dir / "tables1-2.md", tables12
    )
    audit_dir = remap_dir / "agreement"
    _datasets(
        [
            "remap",
            "agreement",
            eaf_dir,
            "--min-kappa",
            str(MIN_KAPPA),
            "--out-dir",
            str(audit_dir),
            "--review-eaf",
            "--seed",
            "0",
        ]
    )
    _say(_agreement_line(load_json(audit_dir / "agreement.json")))
    paths["Agreement audit (report, pairs, disagreements, confusion)"] = audit_dir
    paths["Review EAFs (open in ELAN)"] = audit_dir / "review"
    return labels_path, tables12, audit_dir


def _predict_step(
    out: Path, references: dict[str, Path], *, seed: int, paths: dict[str, Path]
) -> None:
    _say("\n# 4. Skeletons as a monocular estimator gives them, and predictions from them")
    skeletons = {key: out / key / "skeletons.npz" for key in references}
    write_h36m_estimates(
        references["h36m"],
        [out / "corpus" / "h36m"],
        skeletons["h36m"],
        degrade=degrade_skeleton,
        seed=seed,
    )
    write_remap_estimates(
        references["remap"], skeletons["remap"], degrade=degrade_skeleton, seed=seed
    )
    _say(
        "Wrote 17-joint skeletons (camera axes, y down, metres) for every clip: "
        f"{skeletons['h36m']} and {skeletons['remap']}"
    )
    for key, name, _ in _SETS:
        paths[f"{name} estimator skeletons"] = skeletons[key]
        for method in METHODS:
            pred = out / key / f"predictions-{method}.csv"
            _eval(
                [
                    "predict",
                    str(skeletons[key]),
                    "--layout",
                    "h36m17",
                    "--up-axis",
                    "-y",
                    "--fps",
                    "50",
                    "--method",
                    method,
                    "--out",
                    str(pred),
                ]
            )
            paths[f"{name} predictions ({method})"] = pred


def _score_step(
    out: Path, references: dict[str, Path], *, bootstrap: int, paths: dict[str, Path]
) -> list[SetScores]:
    _say("\n# 5. Scores (Tables 4 and 5, Figure 5), per method and set")
    sets = []
    for key, name, groupings in _SETS:
        folder = out / key
        scored = SetScores(f"{name} scores", groupings, {}, {})
        for method in METHODS:
            score_dir = folder / f"scores-{method}"
            _eval(
                [
                    "score",
                    str(folder / f"predictions-{method}.csv"),
                    "--reference",
                    str(references[key]),
                    "--out-dir",
                    str(score_dir),
                    "--plots",
                    "--bootstrap",
                    str(bootstrap),
                    "--seed",
                    "0",
                ],
            )
            scored.scores[method] = load_json(score_dir / "scores.json")
            scored.figures[method] = sorted(score_dir.glob("*.png"), key=_figure_order)
            _say(f"{name}, method {method}: {_overall_line(scored.scores[method])}")
            paths[f"{name} scores ({method}): json, md, csv, figures"] = score_dir
        sets.append(scored)
    return sets


def _compare_step(
    out: Path,
    references: dict[str, Path],
    sets: list[SetScores],
    *,
    bootstrap: int,
    paths: dict[str, Path],
) -> None:
    _say("\n# 6. Is net better than paper? Paired bootstrap and McNemar")
    for (key, name, _), scored in zip(_SETS, sets, strict=True):
        folder = out / key
        args = [
            "compare",
            str(folder / "predictions-paper.csv"),
            str(folder / "predictions-net.csv"),
            "--reference",
            str(references[key]),
            "--bootstrap",
            str(bootstrap),
            "--seed",
            "0",
        ]
        figures = folder / COMPARE_FIGURES
        _eval(
            [*args, "--out", str(folder / "compare.md"), "--plots-dir", str(figures)]
            + ["--names", *METHODS],
            show=True,
        )
        _eval([*args, "--format", "json", "--out", str(folder / "compare.json")])
        scored.compare_md = (folder / "compare.md").read_text(encoding="utf-8")
        scored.compare_figures = sorted(figures.glob("*.png"), key=_figure_order)
        paths[f"{name}: paper vs net"] = folder / "compare.md"
        paths[f"{name}: paper vs net (JSON)"] = folder / "compare.json"
        paths[f"{name}: paper beside net, figures on shared axes"] = figures


def _audit_results(audit_dir: Path) -> dict[str, Any]:
    """The agreement audit as the report shows it, from the folder the command wrote."""
    disagreements = audit_dir / "disagreements.csv"
    return {
        "audit": load_json(audit_dir / "agreement.json"),
        "agreement_md": (audit_dir / "agreement.md").read_text(encoding="utf-8"),
        "confusion_pngs": sorted(audit_dir.glob("*.png")),
        "disagreements": _disagreements_table(disagreements) if disagreements.exists() else None,
    }


def _untrimmed_step(
    out: Path, labels_path: Path, participants: Path, *, seed: int, quick: bool, bootstrap: int
) -> UntrimmedResults:
    _say("\n# 7. Untrimmed sessions: every turn found in long skeleton streams, and scored")
    results = run_untrimmed_stage(
        out,
        labels=labels_path,
        context=labels_path.with_name("context.csv"),
        sessions=labels_path.with_name("sessions.csv"),
        seed=seed,
        run_eval=_eval,
        max_sessions=2 if quick else None,
        bootstrap=bootstrap,
    )
    o = results.scores["overall"]
    m = o.get("matched", {})
    _say(
        f"{o['tp']} of {o['tp'] + o['fn']} labelled turns found, {o['fp']} false: "
        f"precision {fixed(100 * o['precision'], 1)}%, recall "
        f"{fixed(100 * o['recall'], 1)}%, F1 {fixed(100 * o['f1'], 1)}%; "
        f"matched accuracy {format_metric('accuracy', m.get('accuracy'))}%, "
        f"MAE {format_metric('mae_deg', m.get('mae_deg'))}°"
    )
    _say("\n# 7b. Turning profiles: per participant, and PD against controls")
    run_profile_stage(
        results.folder,
        detections=results.detections,
        streams=results.streams,
        sessions=labels_path.with_name("sessions.csv"),
        participants=participants,
        fps_hz=UNTRIMMED_FPS_HZ,
        run_eval=_eval,
        bootstrap=bootstrap,
    )
    return results


def _remap_open_step(out: Path, *, seed: int, quick: bool, bootstrap: int) -> RemapOpenResults:
    _say("\n# 8. Turn-REMAP as released (REMAP Open): read, predicted, scored by every label")
    results = run_remap_open_stage(
        out, seed=seed, run_datasets=_datasets, run_eval=_eval, quick=quick, bootstrap=bootstrap
    )
    o = results.scores["overall"]
    _say(
        f"{o['n']} turns: accuracy {format_metric('accuracy', o.get('accuracy'))}%, "
        f"MAE {format_metric('mae_deg', o.get('mae_deg'))}°, "
        f"WPrec {format_metric('wprec', o.get('wprec'))}%"
    )
    return results


def run_demo(
    out_dir: str | Path,
    *,
    seed: int = DEMO_SEED,
    bootstrap: int = 1000,
    quick: bool = False,
) -> dict[str, Path]:
    """Run every step into ``out_dir`` and return the results' paths by description.

    ``out_dir`` is new, empty, or the folder of an earlier demo run, whose files are
    replaced (:func:`prepare_out_dir`); what this run writes is recorded in :data:`RECORD`.
    ``quick`` writes a small corpus (:data:`QUICK`) so that every step runs in seconds.
    """
    out = Path(out_dir)
    removed = prepare_out_dir(out)
    with _recorded(out):
        return _run_steps(out, seed=seed, bootstrap=bootstrap, quick=quick, removed=len(removed))


def _run_steps(
    out: Path, *, seed: int, bootstrap: int, quick: bool, removed: int
) -> dict[str, Path]:
    t0 = time.perf_counter()
    paths: dict[str, Path] = {}
    _say(f"turnbench {__version__} demo, seed {seed}: everything goes to {out}/")
    if removed:
        _say(f"Removed {removed} files of the previous demo run (its record, {RECORD}, lists them)")
    h36m, remap = _corpus_step(out, seed=seed, quick=quick, paths=paths)
    index_path, table3, miner_md = _h36m_step(out, h36m, paths)
    labels_path, tables12, audit_dir = _remap_step(out, remap, paths)
    references = {"h36m": index_path, "remap": labels_path}
    _predict_step(out, references, seed=seed, paths=paths)
    sets = _score_step(out, references, bootstrap=bootstrap, paths=paths)
    _compare_step(out, references, sets, bootstrap=bootstrap, paths=paths)
    untrimmed = _untrimmed_step(
        out, labels_path, remap.participants_path, seed=seed, quick=quick, bootstrap=bootstrap
    )
    paths["Untrimmed streams, detections, event scores"] = untrimmed.folder
    remap_open = _remap_open_step(out, seed=seed, quick=quick, bootstrap=bootstrap)
    paths["REMAP Open: release, read data, predictions, scores"] = remap_open.folder

    _say("\n# 9. The report")
    results = DemoResults(
        seed=seed,
        table3_md=table3,
        miner_md=miner_md,
        tables12_md=tables12,
        sets=sets,
        paths=paths,
        untrimmed=untrimmed,
        remap_open=remap_open,
        **_audit_results(audit_dir),
    )
    paths["The report (open in a browser)"] = write_report(results, out / "report.html")
    elapsed = time.perf_counter() - t0

    _say(f"\nDone in {elapsed:.0f} s. Where each result is:")
    width = max(len(k) for k in paths)
    for what, path in paths.items():
        _say(f"  {what:<{width}}  {path}")
    return paths


def _agreement_line(audit: dict) -> str:
    raters = audit.get("raters", ["A", "B"])
    ci = audit.get("kappa_ci95") or [float("nan"), float("nan")]
    return (
        f"Agreement of {raters[0]} and {raters[1]} on {audit.get('matched')} matched turns: "
        f"{fixed(100 * audit.get('percent_agreement', float('nan')), 1)}% agree, Cohen's kappa "
        f"{fixed(audit.get('kappa', float('nan')), 3)} "
        f"(95% CI {fixed(ci[0], 3)} to {fixed(ci[1], 3)}), "
        f"{fixed(audit.get('kappa_with_unmatched', float('nan')), 3)} counting the turns one "
        f"rater missed; gate kappa >= {MIN_KAPPA} on both passed."
    )


_FIGURE_CAPTIONS = {
    "predicted": "Predicted angles per reference bin (the paper's Figure 5a).",
    "error": "Distribution of absolute errors (the paper's Figure 5b).",
    "confusion": "Confusion matrix of predicted against reference 45° bins.",
    "bland": "Bland-Altman plot: difference against mean of predicted and reference angles.",
}


def _figure_order(png: Path) -> tuple[int, str]:
    # Figure 5a and 5b first, as the paper shows them; anything unknown last, by name
    keys = list(_FIGURE_CAPTIONS)
    stem = png.stem.lower()
    rank = next((i for i, key in enumerate(keys) if key in stem), len(keys))
    return rank, png.name


def _caption(png: Path, note: str = "") -> str:
    """The figure's caption, with ``note`` after its sentence, and the file's name."""
    stem = png.stem.lower()
    for key, text in _FIGURE_CAPTIONS.items():
        if key in stem:
            return (
                f"{text.removesuffix('.')}{note}. ({png.name})" if note else f"{text} ({png.name})"
            )
    return f"{png.name}{note}"


def _scores_section(report: Report, scored: SetScores) -> None:
    sec = report.section(scored.title)
    sec.paragraph(
        "Overall, with percentile-bootstrap 95% confidence intervals over clips "
        f"({scored.scores['net']['settings'].get('bootstrap')} resamples, seed "
        f"{scored.scores['net']['settings'].get('seed')}). `paper` is equation 3 as printed "
        "(every frame-to-frame rotation counted with its magnitude); `net` the signed net "
        "rotation of the hip vector."
    )
    sec.summary(scored.scores, caption=f"{scored.title}: overall")
    for method, scores in scored.scores.items():
        present = [g for g in scored.groupings if g in scores.get("by", {})]
        sec.heading(f"Method {method}")
        sec.scores(scores, groupings=present, caption=f"{scored.title}, {method}")
    # The two methods in one figure each, side by side on shared axes, to be compared
    methods = list(scored.figures)
    if scored.compare_figures:
        sec.heading(f"Figures: {methods[0]} beside {methods[1]}")
        side = f"; {methods[0]} left, {methods[1]} right, on shared axes"
        sec.figures(
            scored.compare_figures,
            captions={p.name: _caption(p, side) for p in scored.compare_figures},
        )
    else:
        for method in methods:
            pngs = scored.figures[method]
            sec.figures(pngs, captions={p.name: f"{method}: {_caption(p)}" for p in pngs})
    if scored.compare_md is not None:
        sec.heading("paper against net on the same clips")
        sec.markdown(scored.compare_md)


def _disagreements_table(path: Path, *, max_rows: int = 60) -> pd.DataFrame:
    """The disagreements for the page: no file paths, angles as whole degrees.

    Only an empty cell is missing: a participant or session called ``NA`` or ``None`` is a name.
    """
    df = pd.read_csv(path, keep_default_na=False, na_values=[""])
    df = df.drop(columns=[c for c in ("file",) if c in df.columns]).head(max_rows)
    for col in [c for c in df.columns if c.startswith("angle_")]:
        df[col] = df[col].map(lambda v: MISSING if pd.isna(v) else fixed(v, 0))
    # Times as ELAN shows them (h:mm:ss.mmm, to find the turn in its player) beside seconds
    for col in [c for c in df.columns if c.startswith(("start_", "end_")) and c.endswith("_s")]:
        df[col] = df[col].map(
            lambda v: MISSING if pd.isna(v) else f"{elan_time(v)} ({fixed(v, 3)} s)"
        )
    return df


def load_results(out_dir: str | Path, *, seed: int = DEMO_SEED) -> DemoResults:
    """The results of a finished demo run, read back from ``out_dir`` (to rebuild its report
    after a step was re-run by hand)."""
    out = Path(out_dir)
    h36m_dir, remap_dir = out / "h36m", out / "remap"
    miner_md = h36m_dir / "miner-check.md"
    sets = []
    for key, name, groupings in _SETS:
        folder = out / key
        compare_md = folder / "compare.md"
        sets.append(
            SetScores(
                f"{name} scores",
                groupings,
                {m: load_json(folder / f"scores-{m}" / "scores.json") for m in METHODS},
                {
                    m: sorted((folder / f"scores-{m}").glob("*.png"), key=_figure_order)
                    for m in METHODS
                },
                compare_md.read_text(encoding="utf-8") if compare_md.exists() else None,
                sorted((folder / COMPARE_FIGURES).glob("*.png"), key=_figure_order),
            )
        )
    return DemoResults(
        seed=seed,
        untrimmed=load_untrimmed(out),
        remap_open=load_remap_open(out),
        table3_md=(h36m_dir / "table3.md").read_text(encoding="utf-8"),
        miner_md=miner_md.read_text(encoding="utf-8") if miner_md.exists() else None,
        tables12_md=(remap_dir / "tables1-2.md").read_text(encoding="utf-8"),
        sets=sets,
        **_audit_results(remap_dir / "agreement"),
    )


#: The report's closing list of where everything is, relative to the page.
_FILES = {
    "clip index": "h36m/turn-h36m.csv",
    "Table 3": "h36m/table3.md",
    "labels": "remap/labels.csv",
    "agreement audit": "remap/agreement/",
    "review EAFs": "remap/agreement/review/",
    "predictions": "h36m/predictions-{paper,net}.csv, remap/predictions-{paper,net}.csv",
    "scores": "h36m/scores-{paper,net}/, remap/scores-{paper,net}/",
    "comparisons": "h36m/compare.md, remap/compare.md (and .json)",
    "paper beside net": f"h36m/{COMPARE_FIGURES}/, remap/{COMPARE_FIGURES}/",
    "corpus": "corpus/h36m/ (planted.csv lists the planted turns), corpus/remap/",
    "miner check": "h36m/miner-check.md, h36m/miner-check.csv",
    "untrimmed sessions": "untrimmed/streams/ (one .npz per session), untrimmed/detections.csv "
    "(and its manifest), untrimmed/events/ (event scores, timelines, PR curve)",
    "turning profiles": "untrimmed/profile/ (profile.csv, by_hour.csv, contrasts.csv and "
    ".json, heat maps, distributions, forest plot)",
    "Turn-REMAP as released": "remap-open/release/ (the REMAP-Open-shaped tree), remap-open/data/ "
    "(labels, participants, skeletons, manifest), remap-open/predictions.csv, remap-open/scores/",
}


def write_report(results: DemoResults, path: str | Path) -> Path:
    """Write the demo's report page (one self-contained HTML file) from its results."""
    report = Report(
        "turnbench demo: Turn-H3.6M and Turn-REMAP, curated and scored",
        subtitle=(
            f"turnbench {__version__}, on the bundled synthetic corpus (seed {results.seed}). "
            "Every number here comes from the command-line tools run by `make demo`; the "
            "data are generated, not recorded, so they show how the tools work, not how "
            "well any estimator does on real people."
        ),
    )
    sec = report.section("Turn-H3.6M: the mined clip index")
    sec.paragraph(
        "Clips are runs where the hip vector turns by 45° or more about the vertical axis, "
        "found by `turn-datasets h36m mine` in the demo motion capture (S1 as CDF, S5 as "
        "3d-pose-baseline h5, the other subjects in a VideoPose3D npz)."
    )
    sec.markdown(results.table3_md)
    if results.miner_md is not None:
        sec.heading("The miner against the planted turns")
        sec.markdown(results.miner_md)

    sec = report.section("Turn-REMAP: labels and their agreement audit")
    sec.paragraph(
        "Labels from the ELAN sessions by `turn-datasets remap labels` (one row per turn "
        "after adjudication: where the two clinicians disagree, the consensus tier decides)."
    )
    sec.markdown(results.tables12_md)
    sec.heading("Inter-rater agreement")
    sec.paragraph(_agreement_line(results.audit), kind="note")
    if results.agreement_md is not None:
        sec.markdown(results.agreement_md)
    for png in results.confusion_pngs:
        sec.figure(png, caption=f"Agreement confusion matrix ({png.name})")
    if results.disagreements is not None:
        sec.heading("Disagreements to review (also marked in the review EAFs)")
        sec.frame(results.disagreements, float_digits=3)

    for scored in results.sets:
        _scores_section(report, scored)
    if results.untrimmed is not None:
        untrimmed_section(report, results.untrimmed)
        profile_section(report, results.untrimmed.folder / PROFILE_DIR)
    if results.remap_open is not None:
        remap_open_section(report, results.remap_open)

    report.section("Files").files(
        _FILES, caption="Where everything is, relative to this page", link=True
    )
    return report.write(path)


def _int_at_least(low: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"{value} is below {low}")
        return value

    return parse


def main(argv: Sequence[str] | None = None) -> int:
    """Exit 0 when every step ran; 1 when a step's command failed (its message says which);
    2 for a bad option or an output folder that cannot be written (one line, no traceback).
    """
    parser = argparse.ArgumentParser(
        prog="python -m turn_eval.demo",
        description="Run the whole turnbench pipeline on the bundled synthetic corpus.",
        epilog="Example: python -m turn_eval.demo --out-dir demo-output",
    )
    parser.add_argument(
        "--out-dir", type=Path, default=Path("demo-output"), help="Where everything goes."
    )
    # checked here, not after minutes of work: numpy seeds are non-negative, and the
    # comparison's paired bootstrap needs at least one resample
    parser.add_argument(
        "--seed", type=_int_at_least(0), default=DEMO_SEED, help="Seed of the corpus (>= 0)."
    )
    parser.add_argument(
        "--bootstrap", type=_int_at_least(1), default=1000, help="Bootstrap resamples (>= 1)."
    )
    parser.add_argument(
        "--quick", action="store_true", help="A small corpus: every step in a few seconds."
    )
    args = parser.parse_args(argv)
    if args.out_dir.exists() and not args.out_dir.is_dir():
        click.echo(f"error: {args.out_dir}: --out-dir is a file, not a folder", err=True)
        return 2
    try:
        with sigterm_unwinds():  # stopped by SIGTERM, the run is still recorded
            run_demo(args.out_dir, seed=args.seed, bootstrap=args.bootstrap, quick=args.quick)
    except Terminated:
        click.echo("demo stopped: terminated", err=True)
        return 143
    except DemoFailed as exc:
        click.echo(f"demo failed: {exc}", err=True)
        return 1
    except (TurnbenchError, OSError) as exc:
        # a folder that cannot be written, a disk that is full: one line, as the commands say it
        click.echo(f"demo failed: {exc}", err=True)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
