"""The bundled demo corpus: Turn-H3.6M-like motion capture and Turn-REMAP-like ELAN sessions.

Human3.6M and the REMAP videos are licensed or private, so ``make demo``, the notebooks and
the end-to-end tests run on this look-alike, generated from a fixed seed (same seed, same
bytes). It is built from the project's generators, not from any real recording:

Turn-H3.6M-like motion capture (:func:`write_h36m_corpus`)
    Subjects S1, S5, S6, S7, S8, S9 and S11, each with two trials (``"Walking"`` and
    ``"Walking 1"``, as on disk) of several actions, 50 Hz, the 32-joint layout, millimetres,
    z up, made by :func:`turn_datasets.synthetic.mocap.generate_sequence`: walking with pelvic
    sway, standing, pivot and walking turns, joint noise and a few capture dropouts. Turns
    are planted with heading changes from 48° to 233°, drawn per 45° bin with the shares of
    :data:`H36M_BIN_MIX` (most turns small, as in the paper's Table 3), more of them in the
    walking actions than in the standing ones. ``planted.csv``'s ``angle_deg`` is the
    heading change (what the clip index's ``angle_deg`` measures); its
    ``hip_rotation_deg``, the hips' own rotation over the planted frames, differs from it by
    the pelvic sway at the turn's ends, a few degrees. The files are written in all three layouts
    Human3.6M is distributed in: S1 as the original release's CDF (with S1's own spellings
    ``TakingPhoto`` and ``WalkingDog``), S5 as 3d-pose-baseline's h5, the other subjects in
    one VideoPose3D ``data_3d_h36m.npz``. ``planted.csv`` lists every planted turn.
Turn-REMAP-like ELAN sessions (:func:`write_remap_corpus`)
    :func:`turn_datasets.synthetic.eaf.write_sessions`: 12 PD-HC pairs, two sessions each, two
    clinicians on about half of the sessions with boundary jitter (0.15 s per boundary), a few
    planted angle disagreements (2.5%) and missed turns (3%), a consensus tier, scenario and location tiers and the
    participants table; the angle and scenario mix of the paper's Table 2.
Skeleton "predictions" (:func:`write_h36m_estimates`, :func:`write_remap_estimates`)
    What a monocular 3D pose estimator would hand a submitter: for each clip of a mined index
    or each turn of a label table, a 17-joint skeleton in camera axes (y down), metres,
    float32, as 3D pose lifting networks write them, in one ``.npz`` keyed by ``clip_id`` for
    ``turn-eval predict --layout h36m17 --up-axis -y``. Turn-H3.6M's come from its own
    motion capture; each Turn-REMAP turn's skeleton is synthesised with that turn's
    labelled angle (plus the few degrees a 45° label rounds away). Both are degraded by
    :func:`turn_datasets.synthetic.degrade.degrade_skeleton`-style errors (joint noise, depth error growing
    with the angle to the camera, occlusion dropouts). A participant's session keeps one
    camera; its free-living recordings get a larger depth error (30 to 110 mm against 20 to
    80 mm) and six times the dropouts of its scripted ones, as home videos do
    (:data:`_REMAP_DEGRADE`).

The degradation lives in :mod:`turn_datasets.synthetic.degrade`; ``turn_datasets`` may not import
``turn_eval`` (DESIGN.md), so the two estimate writers take the degrading function as an
argument and :mod:`turn_eval.demo` passes it in.
"""

from __future__ import annotations

import os
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.fileio import typed_frame, write_csv, write_npz
from turn_datasets.geometry import direction_of, quantise_deg
from turn_datasets.mocap.readers import discover, read_source
from turn_datasets.skeleton import H36M17, H36M17_FROM_32
from turn_datasets.synthetic.eaf import SyntheticRemap, write_sessions
from turn_datasets.synthetic.h36m_files import write_h36m_cdf, write_h36m_h5, write_videopose_npz
from turn_datasets.synthetic.mocap import Dropout, Segment, generate_sequence

__all__ = [
    "DEMO_SEED",
    "H36M_SUBJECTS",
    "H36M_ACTIONS_DEMO",
    "H36M_BIN_MIX",
    "PLANTED_COLUMNS",
    "DemoH36M",
    "DegradeFn",
    "write_h36m_corpus",
    "write_remap_corpus",
    "write_h36m_estimates",
    "write_remap_estimates",
    "camera_axes_m",
]

DEMO_SEED = 20240614
H36M_SUBJECTS = ("S1", "S5", "S6", "S7", "S8", "S9", "S11")
#: Actions of the demo and how many turns each trial plants (low, high inclusive): walking
#: actions turn often, the others now and then.
H36M_ACTIONS_DEMO: Mapping[str, tuple[int, int]] = {
    "Walking": (4, 6),
    "WalkDog": (4, 6),
    "WalkTogether": (3, 5),
    "Phoning": (1, 2),
    "Directions": (1, 2),
    "Photo": (0, 1),
}
#: S1's files carry the spellings of the original release (the readers map them back).
_S1_NAMES = {"Photo": "TakingPhoto", "WalkDog": "WalkingDog"}
#: Share of planted turns per 45° bin (the shape of the paper's Table 3: mostly 45° and 90°,
#: few large turns; the paper's range is 45.2° to 234.7°).
H36M_BIN_MIX: Mapping[int, float] = {45: 0.30, 90: 0.37, 135: 0.18, 180: 0.11, 225: 0.04}
_MIN_PLANT_DEG, _MAX_PLANT_DEG = 48.0, 233.0
FPS_HZ = 50.0

#: ``planted.csv``: one row per planted turn of the motion capture.
PLANTED_COLUMNS = {
    "subject": "str",
    "action": "str",
    "subaction": "str",
    "name_on_disk": "str",
    "format": "str",
    "file": "str",
    "start_frame": "int64",
    "end_frame": "int64",
    "angle_deg": "float64",
    "direction": "str",
    "bin_deg": "int64",
    "hip_rotation_deg": "float64",
    "kind": "str",
    "duration_s": "float64",
}


class _Degraded(Protocol):
    @property
    def positions(self) -> np.ndarray: ...


#: The degradation a writer of estimates applies:
#: ``fn(positions, layout, *, seed, fps, camera_position_mm, mm_per_unit, **params)`` returning
#: an object with ``.positions`` (as :func:`turn_datasets.synthetic.degrade.degrade_skeleton`).
DegradeFn = Callable[..., _Degraded]

# Four cameras at the corners of the capture area, at head height, as Human3.6M's are.
_H36M_CAMERAS_MM = (
    (3800.0, 4200.0, 1600.0),
    (-3900.0, 4100.0, 1500.0),
    (-3800.0, -4300.0, 1550.0),
    (4000.0, -4000.0, 1600.0),
)
#: Degradation per REMAP scenario, the camera unchanged: free-living video is less sure of
#: depth (as if farther) and more occluded.
_REMAP_DEGRADE: Mapping[str, Mapping[str, float]] = {
    "scripted": {"depth_sd_facing_mm": 20.0, "depth_sd_away_mm": 80.0, "dropout_rate_per_s": 0.05},
    "clinical": {"depth_sd_facing_mm": 22.0, "depth_sd_away_mm": 90.0, "dropout_rate_per_s": 0.1},
    "free-living": {
        "depth_sd_facing_mm": 30.0,
        "depth_sd_away_mm": 110.0,
        "dropout_rate_per_s": 0.3,
    },
}


@dataclass(frozen=True)
class DemoH36M:
    """What :func:`write_h36m_corpus` wrote.

    ``root`` is the dataset root (``S1/MyPoseFeatures/D3_Positions/*.cdf``,
    ``S5/MyPoses/3D_positions/*.h5``, ``data_3d_h36m.npz``); ``files`` every file written;
    ``planted`` the planted turns (:data:`PLANTED_COLUMNS`), also in ``planted_path``.
    """

    root: Path
    files: tuple[Path, ...]
    planted: pd.DataFrame
    planted_path: Path
    n_sequences: int
    n_frames: int


def _stable_seed(seed: int, *parts: str) -> int:
    # crc32 of the names, not hash(): Python salts str hashes per process.
    return (int(seed) * 1_000_003 + zlib.crc32("/".join(parts).encode("utf-8"))) % (2**32)


def _draw_angle(rng: np.random.Generator, bin_mix: Mapping[int, float]) -> float:
    bins = np.array(list(bin_mix), dtype=float)
    p = np.array([bin_mix[b] for b in bin_mix], dtype=float)
    centre = float(rng.choice(bins, p=p / p.sum()))
    lo = max(centre - 22.5, _MIN_PLANT_DEG)
    hi = min(centre + 22.5, _MAX_PLANT_DEG)
    return float(rng.uniform(lo, hi))


def _h36m_segments(
    rng: np.random.Generator, n_turns: int, *, walking_action: bool, bin_mix: Mapping[int, float]
) -> list[Segment]:
    """Stand, then walking (or standing about) and turns, then stand: a trial of an action."""
    segs: list[Segment] = [Segment.stand(float(rng.uniform(1.0, 2.0)))]
    for _ in range(n_turns):
        speed = float(rng.uniform(1.0, 1.5))
        if walking_action or rng.random() < 0.4:
            segs.append(Segment.walk(float(rng.uniform(2.0, 4.0)), speed))
        else:
            segs.append(Segment.stand(float(rng.uniform(2.0, 5.0))))
        magnitude = _draw_angle(rng, bin_mix)
        sign = 1.0 if rng.random() < 0.5 else -1.0
        mean_speed_deg_s = float(rng.uniform(60.0, 200.0))
        duration_s = max(magnitude / mean_speed_deg_s, 0.7)
        if walking_action and rng.random() < 0.6:
            segs.append(Segment.walking_turn(sign * magnitude, duration_s, speed_m_s=speed))
        else:
            segs.append(Segment.pivot_turn(sign * magnitude, duration_s))
    segs.append(Segment.walk(float(rng.uniform(2.0, 3.5)), float(rng.uniform(1.0, 1.5))))
    segs.append(Segment.stand(float(rng.uniform(1.0, 2.0))))
    return segs


def _h36m_dropouts(rng: np.random.Generator, segs: Sequence[Segment]) -> list[Dropout]:
    """One or two short capture dropouts (a marker lost for a few frames) per trial."""
    total_s = sum(max(2, round(s.duration_s * FPS_HZ)) for s in segs) / FPS_HZ
    out = []
    for _ in range(int(rng.integers(1, 3))):
        d = float(rng.uniform(0.04, 0.16))
        out.append(Dropout(float(rng.uniform(1.0, total_s - 1.0 - d)), d))
    return out


def write_h36m_corpus(
    out_dir: str | os.PathLike[str],
    *,
    seed: int = DEMO_SEED,
    subjects: Sequence[str] = H36M_SUBJECTS,
    actions: Mapping[str, tuple[int, int]] = H36M_ACTIONS_DEMO,
    bin_mix: Mapping[int, float] = H36M_BIN_MIX,
    noise_mm: float = 2.0,
) -> DemoH36M:
    """Write the Turn-H3.6M-like motion capture (module docstring) under ``out_dir``.

    Parameters
    ----------
    out_dir
        The dataset root to create (files in it of the same names are replaced).
    seed
        Seed of everything; each trial draws from its own seed derived from this one and its
        names, so dropping a subject leaves the others' bytes unchanged.
    subjects
        Human3.6M subject names; S1 is written as CDF, S5 as h5, the rest as VideoPose3D npz.
    actions
        Action -> (fewest, most) turns planted per trial.
    bin_mix
        Share of planted turns per 45° bin.
    noise_mm
        Standard deviation of the capture noise per coordinate (a marker system's few mm).
    """
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []
    planted_rows: list[pd.DataFrame] = []
    videopose: dict[str, dict[str, np.ndarray]] = {}
    n_frames = n_sequences = 0
    for subject in subjects:
        for action, (lo, hi) in actions.items():
            # S11 lacks its second Directions trial in some copies of the release; so does
            # the demo's (only "Directions", no "Directions 1").
            trials = ("",) if (subject == "S11" and action == "Directions") else ("", " 1")
            for trial in trials:
                rng = np.random.default_rng(_stable_seed(seed, subject, action, trial))
                walking = action.startswith("Walk")
                segs = _h36m_segments(
                    rng, int(rng.integers(lo, hi + 1)), walking_action=walking, bin_mix=bin_mix
                )
                seq = generate_sequence(
                    seed=int(rng.integers(2**31)),
                    segments=segs,
                    fps_hz=FPS_HZ,
                    noise_mm=noise_mm,
                    sway_deg=float(rng.uniform(3.0, 6.0)),
                    dropouts=_h36m_dropouts(rng, segs),
                )
                base = _S1_NAMES.get(action, action) if subject == "S1" else action
                name = base + trial
                if subject == "S1":
                    path = root / subject / "MyPoseFeatures" / "D3_Positions" / f"{name}.cdf"
                    write_h36m_cdf(path, seq.positions.astype(np.float32))
                    fmt = "cdf"
                    files.append(path)
                elif subject == "S5":
                    path = root / subject / "MyPoses" / "3D_positions" / f"{name}.h5"
                    write_h36m_h5(path, seq.positions)
                    fmt = "h36m-h5"
                    files.append(path)
                else:
                    path = root / "data_3d_h36m.npz"
                    videopose.setdefault(subject, {})[name] = seq.positions / 1000.0
                    fmt = "videopose-npz"
                n_frames += seq.n_frames
                n_sequences += 1
                p = seq.planted
                planted_rows.append(
                    pd.DataFrame(
                        {
                            "subject": subject,
                            "action": action,
                            "subaction": trial.strip(),
                            "name_on_disk": name,
                            "format": fmt,
                            "file": str(path.relative_to(root)),
                            "start_frame": p["start_frame"],
                            "end_frame": p["end_frame"],
                            # the clip index's angle_deg is the heading change,
                            # its hip_rotation_deg the hips' own rotation over the frames
                            "angle_deg": p["heading_deg"].abs().round(3),
                            "direction": [direction_of(a) for a in p["heading_deg"]],
                            "bin_deg": quantise_deg(p["heading_deg"].abs().to_numpy()).astype(int),
                            "hip_rotation_deg": p["angle_deg"].abs().round(3),
                            "kind": p["kind"],
                            "duration_s": p["duration_s"],
                        }
                    )
                )
    if videopose:
        files.append(write_videopose_npz(root / "data_3d_h36m.npz", videopose))
    planted = typed_frame(pd.concat(planted_rows, ignore_index=True), PLANTED_COLUMNS)
    planted_path = write_csv(planted, root / "planted.csv")
    return DemoH36M(
        root=root,
        files=tuple(files),
        planted=planted,
        planted_path=planted_path,
        n_sequences=n_sequences,
        n_frames=n_frames,
    )


def write_remap_corpus(
    out_dir: str | os.PathLike[str], *, seed: int = DEMO_SEED, n_pairs: int = 12
) -> SyntheticRemap:
    """Write the Turn-REMAP-like ELAN sessions into ``out_dir/eaf`` and the participants
    table as ``out_dir/participants.csv`` (outside the folder of ``.eaf`` files, so that a
    folder given to ``remap labels`` holds only sessions).

    About 58 turns per participant over two sessions (the paper: 1386 turns of 24 people),
    two raters on about half, jitter 0.15 s per boundary, 2.5% angle disagreements and 3%
    missed turns (:func:`turn_datasets.synthetic.eaf.write_sessions`'s defaults).
    """
    out = Path(out_dir)
    eaf_dir = out / "eaf"
    synth = write_sessions(eaf_dir, seed=seed, n_pairs=n_pairs, start_times=True)
    participants_path = out / "participants.csv"
    os.replace(synth.participants_path, participants_path)
    return SyntheticRemap(
        paths=synth.paths,
        participants_path=participants_path,
        participants=synth.participants,
        truth=synth.truth,
        written=synth.written,
        raters=synth.raters,
        consensus=synth.consensus,
    )


def camera_axes_m(positions_mm: np.ndarray) -> np.ndarray:
    """z-up world millimetres -> camera axes (x right, y down, z forward) in metres, float32.

    The inverse of :func:`turn_datasets.skeleton.to_z_up` with ``up_axis="-y"``, which maps
    (x, y, z) to (x, z, -y): here (x, y, z) goes to (x, -z, y).
    """
    p = np.asarray(positions_mm, dtype=float) / 1000.0
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1).astype(np.float32)


def write_h36m_estimates(
    index: str | os.PathLike[str] | pd.DataFrame,
    sources: Sequence[str | os.PathLike[str]],
    out_npz: str | os.PathLike[str],
    *,
    degrade: DegradeFn,
    seed: int = DEMO_SEED,
    **degrade_params: float,
) -> Path:
    """Estimator skeletons of every clip of a Turn-H3.6M clip index, as one ``.npz``.

    Each sequence the index uses is read back from ``sources`` (as the miner read it),
    degraded once as a whole, seen from one of four corner cameras, and cut at each clip's
    ``start_frame:end_frame``; the member is the clip's ``clip_id``.

    Parameters
    ----------
    index
        The clip index (a path or the table): ``clip_id, subject, action, subaction,
        start_frame, end_frame``.
    sources
        The motion capture the index was mined from (dataset roots or files).
    out_npz
        The ``.npz`` to write (atomically).
    degrade
        :func:`turn_datasets.synthetic.degrade.degrade_skeleton` or a function with its signature.
    seed
        Seed; each sequence derives its own from this and its names.
    **degrade_params
        Passed on to ``degrade`` (``joint_noise_mm=...``, ``depth_sd_away_mm=...``).

    Raises
    ------
    TurnbenchError
        The index lacks a column, or names a sequence the sources do not hold.
    """
    if isinstance(index, pd.DataFrame):
        table, where = index, None
    else:
        table = pd.read_csv(index, dtype={"subaction": str}, keep_default_na=False)
        where = str(index)
    need = ("clip_id", "subject", "action", "subaction", "start_frame", "end_frame")
    require_columns(table.columns, need, what="the clip index", file=where)
    table = table.assign(subaction=table["subaction"].fillna("").astype(str))
    wanted = {(r.subject, r.action, r.subaction) for r in table.itertuples(index=False)}
    arrays: dict[str, np.ndarray] = {}
    found: set[tuple[str, str, str]] = set()
    for src in discover(list(sources)):
        for seq in read_source(src):
            key = (seq.subject, seq.action, seq.subaction)
            if key not in wanted:
                continue
            if seq.layout.n_joints != 32:
                raise TurnbenchError(
                    "the demo's estimates are cut from 32-joint Human3.6M motion capture",
                    file=seq.source,
                    item="/".join(key),
                )
            found.add(key)
            mm_per_unit = 1000.0 if seq.units == "m" else 1.0
            rng_seed = _stable_seed(seed, "h36m-estimate", *key)
            camera = _H36M_CAMERAS_MM[rng_seed % len(_H36M_CAMERAS_MM)]
            clips = table[
                (table["subject"] == key[0])
                & (table["action"] == key[1])
                & (table["subaction"] == key[2])
            ]
            ends = np.concatenate([clips["start_frame"], clips["end_frame"] - 1]).astype(int)
            body17 = (seq.positions * mm_per_unit)[:, list(H36M17_FROM_32), :]
            degraded = degrade(
                body17,
                H36M17,
                seed=rng_seed,
                fps=seq.fps,
                camera_position_mm=camera,
                keep_frames=ends,
                **degrade_params,
            ).positions
            for clip in clips.itertuples(index=False):
                arrays[str(clip.clip_id)] = camera_axes_m(
                    degraded[int(clip.start_frame) : int(clip.end_frame)]
                )
    lost = sorted(wanted - found)
    if lost:
        raise TurnbenchError(
            f"{len(lost)} sequences of the index are not in the sources, e.g. {lost[0]}",
            file=where,
        )
    return write_npz(out_npz, arrays)


def _around(n_frames: int, *, fps_hz: float, speed_m_s: float) -> Segment:
    """Before and after a pivot the person stands; around a walking turn they walk on."""
    if speed_m_s > 0:
        return Segment.walk(n_frames / fps_hz, speed_m_s)
    return Segment.stand(n_frames / fps_hz)


def _remap_segments(
    rng: np.random.Generator, turns: pd.DataFrame, *, fps_hz: float
) -> tuple[list[Segment], list[tuple[str, int, int]]]:
    """Segments for one participant's turns in a session, and each clip's frames.

    Each labelled interval becomes a clip of the same length: a short lead-in, the turn
    (about 80% of the interval), a short lead-out; a second of walking or standing separates
    clips (the rest of the video is not needed). The turn's magnitude is the label plus
    what a 45° label rounds away (normal, sd 8°, within ±20°); its direction is drawn.
    """
    segs: list[Segment] = [Segment.stand(1.0)]
    frame = max(2, round(1.0 * fps_hz))
    clips: list[tuple[str, int, int]] = []
    for turn in turns.itertuples(index=False):
        n_clip = max(10, round(float(turn.end_s - turn.start_s) * fps_hz))
        n_lead = max(2, round(0.1 * n_clip))
        n_tail = max(2, round(0.1 * n_clip))
        n_turn = max(2, n_clip - n_lead - n_tail)
        magnitude = float(turn.angle_deg) + float(np.clip(rng.normal(0.0, 8.0), -20.0, 20.0))
        sign = 1.0 if rng.random() < 0.5 else -1.0
        # PD turns en bloc, on the spot; controls mostly turn while walking on.
        pivot = turn.cohort == "PD" or rng.random() < 0.35
        speed = 0.0 if pivot else float(rng.uniform(0.6, 1.1))
        start = frame
        segs.append(_around(n_lead, fps_hz=fps_hz, speed_m_s=speed))
        if pivot:
            segs.append(Segment.pivot_turn(sign * magnitude, n_turn / fps_hz))
        else:
            segs.append(Segment.walking_turn(sign * magnitude, n_turn / fps_hz, speed_m_s=speed))
        segs.append(_around(n_tail, fps_hz=fps_hz, speed_m_s=speed))
        frame += n_lead + n_turn + n_tail
        clips.append((str(turn.clip_id), start, frame))
        gap = round(1.0 * fps_hz)
        segs.append(_around(gap, fps_hz=fps_hz, speed_m_s=speed))
        frame += gap
    return segs, clips


def write_remap_estimates(
    labels: str | os.PathLike[str] | pd.DataFrame,
    out_npz: str | os.PathLike[str],
    *,
    degrade: DegradeFn,
    seed: int = DEMO_SEED,
    fps_hz: float = FPS_HZ,
) -> Path:
    """Estimator skeletons of every turn of a Turn-REMAP label table, as one ``.npz``.

    For each participant and session, one sequence is synthesised whose turns have the
    labels' durations and angles (:func:`_remap_segments`), seen by a home camera 2.5 to
    4.5 m away at 1.0 to 2.2 m height, degraded per scenario (free-living: larger depth
    error and more occlusion), and cut into the labelled clips.

    Parameters
    ----------
    labels
        The label table (a path or the table): ``clip_id, session, subject, cohort,
        start_s, end_s, angle_deg, scenario``.
    out_npz
        The ``.npz`` to write (atomically).
    degrade
        :func:`turn_datasets.synthetic.degrade.degrade_skeleton` or a function with its signature.
    seed
        Seed; each participant and session derives its own from this and their names.
    fps_hz
        Frame rate of the synthesised skeletons.
    """
    table = (
        labels if isinstance(labels, pd.DataFrame) else pd.read_csv(labels, keep_default_na=False)
    )
    need = ("clip_id", "session", "subject", "cohort", "start_s", "end_s", "angle_deg", "scenario")
    missing = [c for c in need if c not in table.columns]
    if missing:
        raise TurnbenchError(
            f"the labels lack columns {missing}",
            file=None if isinstance(labels, pd.DataFrame) else str(labels),
        )
    arrays: dict[str, np.ndarray] = {}
    for (session, subject), turns in table.sort_values(["session", "subject", "start_s"]).groupby(
        ["session", "subject"], sort=True
    ):
        rng = np.random.default_rng(_stable_seed(seed, "remap", str(session), str(subject)))
        segs, clips = _remap_segments(rng, turns, fps_hz=fps_hz)
        seq = generate_sequence(
            seed=int(rng.integers(2**31)),
            segments=segs,
            fps_hz=fps_hz,
            # the estimator's noise is the degradation's; the body itself is clean
            noise_mm=0.0,
            sway_deg=float(rng.uniform(2.0, 5.0)),
            start_heading_deg=float(rng.uniform(-180.0, 180.0)),
        )
        distance = float(rng.uniform(2500.0, 4500.0))
        bearing = float(rng.uniform(-np.pi, np.pi))
        start = np.nanmean(seq.positions[0, :, :2], axis=0)
        camera = (
            float(start[0] + distance * np.cos(bearing)),
            float(start[1] + distance * np.sin(bearing)),
            float(rng.uniform(1000.0, 2200.0)),
        )
        scenario_of = dict(zip(turns["clip_id"].astype(str), turns["scenario"], strict=True))
        # The estimator sees 17 joints; degrading only those halves the work.
        body17 = seq.positions[:, list(H36M17_FROM_32), :]
        # One degradation per scenario (the camera stays, the conditions change), over the
        # frames of that scenario's clips only.
        for scenario in sorted(set(scenario_of.values())):
            mine = [(c, a, b) for c, a, b in clips if scenario_of[c] == scenario]
            lo, hi = min(a for _, a, _ in mine), max(b for _, _, b in mine)
            params = dict(_REMAP_DEGRADE.get(str(scenario), _REMAP_DEGRADE["free-living"]))
            degraded = degrade(
                body17[lo:hi],
                H36M17,
                seed=_stable_seed(seed, "remap-degrade", str(session), str(subject), str(scenario)),
                fps=fps_hz,
                camera_position_mm=camera,
                keep_frames=[f - lo for _, a, b in mine for f in (a, b - 1)],
                **params,
            ).positions
            for clip_id, a, b in mine:
                arrays[clip_id] = camera_axes_m(degraded[a - lo : b - lo])
    return write_npz(out_npz, arrays)
