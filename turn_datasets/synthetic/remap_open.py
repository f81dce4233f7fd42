"""A synthetic tree in the REMAP Open release's layout, with known angles, steps and turn types.

:func:`write_remap_open` writes what :func:`turn_datasets.remap.open_release.read_release`
reads, as the release lays it out (:mod:`turn_datasets.remap.open_release`)::

    ROOT/Open_dataset_REMAP/Turning/Data/turning_human_labels/Turning_human_labels.<csv|xlsx>
    ROOT/Open_dataset_REMAP/Turning/Data/turning_2D3D_skeletons_coarsened/Turning_coarsen_CSV/
        Pt<id>_<PD|C>_n_<turn>/input_2D/keypoints.csv, input_3D/keypoints.csv

Each turn is one clip of a Human3.6M-like body (:func:`turn_datasets.synthetic.mocap.
generate_sequence`, clean, 30 fps): a short stand or walk, the turn, a short stand or walk.
A pivot turn turns on the spot, a step turn walks round a curve. The body's heading change
is the label's bin plus a uniform offset within ±10° (so the bin is the nearest multiple of
45 of the true angle, with room for an estimate a few degrees off to stay in it), left or right at random. The 3D keypoints are what Strided
Transformer writes: the 17 joints in the camera's axes (x right, y down, z away), root
relative (the pelvis at the origin), metres, the camera pitched down by ``pitch_deg``. The 2D
keypoints are the same joints projected by a Kinect-like pinhole (640 x 480 px, focal 525
px) with the person 2.5 to 4 m away.

The spreadsheet carries the release's columns with its wording (``90_degrees``,
``pivot_turn``, ``On medication``, ``On DBS``, ``-``, ``yes``/``no``); the truth table
returned gives every value, and the signed heading change, for the tests and the demo.
Everything is drawn from one seed: the same seed gives the same keypoint files and CSV sheet,
byte for byte (an .xlsx also stores its time of writing).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, typed_frame, write_csv
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, to_z_up
from turn_datasets.synthetic.degrade import degrade_skeleton
from turn_datasets.synthetic.mocap import Segment, generate_sequence

__all__ = [
    "OPEN_TRUTH_COLUMNS",
    "RELEASE_DATA",
    "SHEET_RELATIVE",
    "SKELETON_RELATIVE",
    "SyntheticOpen",
    "write_remap_open",
    "write_keypoints_csv",
]

#: The release's folders, relative to the dataset's folder.
RELEASE_DATA = Path("Open_dataset_REMAP") / "Turning" / "Data"
SHEET_RELATIVE = RELEASE_DATA / "turning_human_labels"
SKELETON_RELATIVE = RELEASE_DATA / "turning_2D3D_skeletons_coarsened" / "Turning_coarsen_CSV"

#: The truth of each synthetic turn (one row per turn, in sheet order).
OPEN_TRUTH_COLUMNS = {
    "clip_id": "str",
    "turn_id": "str",
    "subject": "str",
    "cohort": "str",
    "angle_deg": "float64",
    "heading_deg": "float64",
    "direction": "str",
    "steps": "int64",
    "turn_type": "str",
    "medication": "str",
    "dbs": "str",
    "scenario": "str",
    "duration_s": "float64",
    "n_frames": "int64",
}

_FPS_HZ = 30.0
_BINS = (45, 90, 135, 180, 225, 270)
_BIN_MIX = (0.10, 0.35, 0.20, 0.20, 0.10, 0.05)
_FOCAL_PX, _CX, _CY = 525.0, 320.0, 240.0
_MEDICATION_WORDS = {"control": "Control", "on": "On medication", "off": "Off medication"}
_DBS_WORDS = {"control": "Control", "on": "On DBS", "off": "Off DBS", "none": "-"}
_TURN_WORDS = {"pivot": "pivot_turn", "step": "step_turn", "": ""}


@dataclass(frozen=True)
class SyntheticOpen:
    """What :func:`write_remap_open` wrote: the dataset folder, the sheet, and the truth."""

    root: Path
    sheet: Path
    truth: pd.DataFrame


def write_keypoints_csv(path: str | os.PathLike[str], keypoints: np.ndarray) -> Path:
    """One ``keypoints.csv`` as released: a row per frame, ``x0,y0[,z0],...``, no header."""
    k = np.asarray(keypoints, dtype=np.float64)
    flat = k.reshape(k.shape[0], -1)
    text = "".join(",".join(f"{v:.6f}" for v in row) + "\n" for row in flat)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="\n")
    return Path(path)


def _pitch(positions: np.ndarray, pitch_deg: float) -> np.ndarray:
    """Camera axes pitched down by ``pitch_deg``: a rotation about the camera's x axis."""
    a = np.deg2rad(pitch_deg)
    c, s = np.cos(a), np.sin(a)
    y, z = positions[..., 1], positions[..., 2]
    return np.stack([positions[..., 0], c * y - s * z, s * y + c * z], axis=-1)


def _turn_clip(rng: np.random.Generator, *, heading_deg: float, pivot: bool) -> np.ndarray:
    """One turn's 17 joints, z-up world, millimetres (lead-in, turn, lead-out)."""
    duration = abs(heading_deg) / float(rng.uniform(70.0, 110.0))
    if pivot:
        segs = [
            Segment.stand(0.3),
            Segment.pivot_turn(heading_deg, duration),
            Segment.stand(0.3),
        ]
    else:
        speed = float(rng.uniform(0.6, 1.0))
        segs = [
            Segment.walk(0.4, speed),
            Segment.walking_turn(heading_deg, duration, speed_m_s=speed),
            Segment.walk(0.4, speed),
        ]
    seq = generate_sequence(
        seed=int(rng.integers(2**31)),
        segments=segs,
        fps_hz=_FPS_HZ,
        noise_mm=0.0,
        start_heading_deg=float(rng.uniform(-180.0, 180.0)),
    )
    return seq.positions[:, list(H36M17_FROM_32), :]


def _keypoints(
    world_mm: np.ndarray, distance_m: float, pitch_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """(3D root-relative camera axes in metres, 2D pixels) of one clip."""
    p = np.asarray(world_mm, dtype=np.float64) / 1000.0
    # world z up -> camera axes (x right, y down, z away): the inverse (transpose) of
    # to_z_up's rotation for "-y", so (x, y, z) -> (x, -z, y)
    cam = p @ to_z_up(np.eye(3), "-y").T
    cam = _pitch(cam, pitch_deg)
    pelvis = cam[:, :1, :]
    relative = cam - pelvis
    # for the image: the person's first pelvis 2.5 to 4 m straight ahead, at the image centre
    placed = cam - cam[:1, :1, :] + np.array([0.0, 0.0, distance_m])
    uv = np.stack(
        [
            _FOCAL_PX * placed[..., 0] / placed[..., 2] + _CX,
            _FOCAL_PX * placed[..., 1] / placed[..., 2] + _CY,
        ],
        axis=-1,
    )
    return relative, uv


def _estimated(
    world_mm: np.ndarray, rng: np.random.Generator, distance_m: float, scenario: str
) -> np.ndarray:
    """``world_mm`` as a monocular estimator sees it from ``distance_m`` in front (world -y)."""
    facing, away = (30.0, 110.0) if scenario == "free-living" else (20.0, 80.0)
    pelvis = world_mm[0, 0]
    camera = (float(pelvis[0]), float(pelvis[1]) - 1000.0 * distance_m, float(pelvis[2]))
    return degrade_skeleton(
        world_mm,
        H36M17,
        seed=rng,
        fps=_FPS_HZ,
        camera_position_mm=camera,
        joint_noise_mm=5.0,
        depth_sd_facing_mm=facing,
        depth_sd_away_mm=away,
        dropout_rate_per_s=0.0,
    ).positions


def _participants(n_pd: int, n_hc: int) -> list[tuple[str, str, bool]]:
    """``(participant number, PD|C, has a stimulator)``: PD from 201, controls after."""
    out = [(str(201 + i), "PD", i % 3 == 2) for i in range(n_pd)]
    out += [(str(201 + n_pd + i), "C", False) for i in range(n_hc)]
    return out


def _turn_row(
    rng: np.random.Generator, number: str, group: str, has_dbs: bool, turn_id: int
) -> dict:
    angle = int(rng.choice(_BINS, p=_BIN_MIX))
    pivot = bool(rng.random() < (0.6 if group == "PD" else 0.35))
    turn_type = "pivot" if pivot else "step"
    if rng.random() < 0.08:
        turn_type = ""  # the raters left it empty
    steps = (
        int(rng.integers(1, 3)) if pivot else int(max(3, round(angle / 45) + rng.integers(1, 3)))
    )
    if group == "PD":
        medication = "on" if rng.random() < 0.6 else "off"
        dbs = ("on" if rng.random() < 0.7 else "off") if has_dbs else "none"
    else:
        medication, dbs = "control", "control"
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return {
        "turn_id": str(turn_id),
        "subject": f"Pt{number}",
        "cohort": "PD" if group == "PD" else "HC",
        "group": group,
        "angle_deg": float(angle),
        "heading_deg": sign * (angle + float(rng.uniform(-10.0, 10.0))),
        "pivot": pivot,
        "steps": steps,
        "turn_type": turn_type,
        "medication": medication,
        "dbs": dbs,
        "scenario": "clinical" if rng.random() < 0.4 else "free-living",
    }


def _sheet_row(t: dict) -> dict:
    return {
        "Turn ID": t["turn_id"],
        "Participant ID number": t["subject"][2:],
        "PD_or_C": t["group"],
        "number_of_turning_steps": t["steps"],
        "turning_angle": f"{t['angle_deg']:g}_degrees",
        "type_of_turn": _TURN_WORDS[t["turn_type"]],
        "turning_duration": round(t["duration_s"], 2),
        "On_or_Off_medication": _MEDICATION_WORDS[t["medication"]],
        "DBS_state": _DBS_WORDS[t["dbs"]],
        "clinical_assessment": "yes" if t["scenario"] == "clinical" else "no",
    }


def write_remap_open(
    root: str | os.PathLike[str],
    *,
    n_pd: int = 3,
    n_hc: int = 3,
    turns_per_participant: int = 6,
    seed: int = 0,
    sheet_format: str = "csv",
    pitch_deg: float = 10.0,
    first_turn_id: int = 350,
    estimator_error: bool = False,
) -> SyntheticOpen:
    """Write a REMAP-Open-shaped tree under ``root`` (module docstring) and return its truth.

    Parameters
    ----------
    root
        Folder to write ``Open_dataset_REMAP/`` into.
    n_pd, n_hc, turns_per_participant
        People with Parkinson's disease, controls, and turns each.
    seed
        Seed of everything drawn.
    sheet_format
        ``csv`` (an export) or ``xlsx`` (openpyxl); a ``.xls`` needs a writer turnbench does
        not depend on (the tests convert the CSV with xlwt).
    pitch_deg
        The camera's downward pitch, degrees.
    first_turn_id
        The first ``Turn ID`` (the release's example folder is ``Pt204_C_n_350``).
    estimator_error
        Degrade the 3D as a monocular estimator would
        (:func:`turn_datasets.synthetic.degrade.degrade_skeleton`: 5 mm joint jitter, depth
        error along the camera ray of 20 to 80 mm, 30 to 110 mm in free-living turns, no
        dropouts: the release's files hold no missing values); without it the skeletons are
        clean and a prediction's error is the label's rounding alone.
    """
    if sheet_format not in ("csv", "xlsx"):
        raise TurnbenchError(f"sheet_format must be csv or xlsx, got {sheet_format!r}")
    if min(n_pd, n_hc, turns_per_participant) < 0 or n_pd + n_hc < 1 or turns_per_participant < 1:
        raise TurnbenchError("need at least one participant and one turn each")
    top = Path(root)
    rng = np.random.default_rng(seed)
    turns = []
    turn_id = first_turn_id
    for number, group, has_dbs in _participants(n_pd, n_hc):
        for _ in range(turns_per_participant):
            t = _turn_row(rng, number, group, has_dbs, turn_id)
            turn_id += 1
            world = _turn_clip(rng, heading_deg=t["heading_deg"], pivot=t["pivot"])
            distance = float(rng.uniform(2.5, 4.0))
            if estimator_error:
                world = _estimated(world, rng, distance, t["scenario"])
            k3, k2 = _keypoints(world, distance, pitch_deg)
            t["clip_id"] = f"{t['subject']}_{t['group']}_n_{t['turn_id']}"
            t["n_frames"] = int(world.shape[0])
            t["duration_s"] = world.shape[0] / _FPS_HZ
            t["direction"] = "left" if t["heading_deg"] > 0 else "right"
            folder = top / SKELETON_RELATIVE / t["clip_id"]
            write_keypoints_csv(folder / "input_3D" / "keypoints.csv", k3)
            write_keypoints_csv(folder / "input_2D" / "keypoints.csv", k2)
            turns.append(t)
    sheet = top / SHEET_RELATIVE / f"Turning_human_labels.{sheet_format}"
    table = pd.DataFrame([_sheet_row(t) for t in turns])
    if sheet_format == "csv":
        write_csv(table, sheet)
    else:
        with atomic_path(sheet) as tmp:
            table.to_excel(tmp, index=False, engine="openpyxl")
    truth = typed_frame(pd.DataFrame(turns), OPEN_TRUTH_COLUMNS)
    return SyntheticOpen(root=top / "Open_dataset_REMAP", sheet=sheet, truth=truth)
