"""Synthetic untrimmed sessions: labels in the ``remap labels`` format, the statistics the
module states, every artefact where planted.csv says, same seed same bytes."""

from __future__ import annotations

from dataclasses import replace
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from turn_datasets.geometry import frame_yaw_deg
from turn_datasets.remap.context import CONTEXT_COLUMNS
from turn_datasets.remap.labels import LABEL_COLUMNS
from turn_datasets.skeleton import H36M17, to_z_up
from turn_datasets.synthetic.untrimmed import (
    LABEL_BIN_MIX,
    TURN_SPEED_DEG_S,
    camera_frame_m,
    draw_turn_labels,
    write_streams_for_labels,
    write_untrimmed_corpus,
)
from turn_eval.detect import DetectParams, MinerRule, detect_files
from turn_eval.detect.rule import DETECT_MINER_DEFAULTS
from turn_eval.events import score_events

FPS = 30.0


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("untrimmed")
    write_untrimmed_corpus(out, seed=3, n_pairs=2, duration_s=120.0, root_relative_every=2)
    return out


def test_same_seed_same_bytes(corpus: Path, tmp_path: Path) -> None:
    write_untrimmed_corpus(tmp_path, seed=3, n_pairs=2, duration_s=120.0, root_relative_every=2)
    for name in ("labels.csv", "context.csv", "sessions.csv", "planted.csv", "streams/home01.npz"):
        assert (tmp_path / name).read_bytes() == (corpus / name).read_bytes(), name


def test_labels_are_remap_labels_of_the_planted_turns(corpus: Path) -> None:
    labels = pd.read_csv(corpus / "labels.csv", keep_default_na=False)
    assert list(labels.columns) == list(LABEL_COLUMNS)
    assert set(labels.angle_deg) <= set(LABEL_BIN_MIX)
    assert set(labels.cohort) == {"PD", "HC"}
    assert labels.groupby(["session", "subject"]).size().min() >= 3
    planted = pd.read_csv(corpus / "planted.csv")
    turns = planted[planted.kind == "turn"].sort_values(["session", "subject", "start_s"])
    ordered = labels.sort_values(["session", "subject", "start_s"])
    np.testing.assert_allclose(ordered.start_s, turns.start_s.round(3))
    np.testing.assert_allclose(ordered.end_s, turns.end_s.round(3))
    np.testing.assert_array_equal(ordered.angle_deg, turns.label_deg)
    # the planted heading change is the label's bin, give or take the 45° rounding
    assert ((turns.heading_deg.abs() - turns.label_deg).abs() <= 20.0 + 1e-9).all()
    # every scenario and location from context.csv at the turn's midpoint
    context = pd.read_csv(corpus / "context.csv")
    for row in labels.itertuples():
        mid = 0.5 * (row.start_s + row.end_s)
        ctx = context[
            (context.session == row.session)
            & (context.subject == row.subject)
            & (context.start_s <= mid)
            & (mid < context.end_s)
        ]
        assert ctx[["scenario", "location"]].values.tolist() == [[row.scenario, row.location]]


def test_turn_speeds_are_the_stated_ones() -> None:
    # label / duration is the drawn mean speed: PD 30-70 °/s, controls 50-110 °/s, and
    # 25-45 °/s for the turns along a curved walk
    rng = np.random.default_rng(0)
    for cohort, (lo, hi) in TURN_SPEED_DEG_S.items():
        t = draw_turn_labels(rng, duration_s=3600.0, cohort=cohort)
        speed = t.angle_deg / (t.end_s - t.start_s)
        curved = t.movement == "curved"
        assert speed[~curved].between(lo - 1e-9, hi + 1e-9).all()
        assert speed[curved].between(25.0 - 1e-9, 45.0 + 1e-9).all()
        # about 15% each of curved walks and of turns within a second of the one before
        assert 0.08 <= curved.mean() <= 0.22
        quick = t.movement == "quick"
        assert 0.08 <= quick.mean() <= 0.22
        gaps = (t.start_s.to_numpy()[1:] - t.end_s.to_numpy()[:-1])[quick.to_numpy()[1:]]
        assert ((gaps >= 0.3 - 1e-9) & (gaps <= 0.9 + 1e-9)).all()
        # about 25 turns in 10 minutes
        assert 120 <= len(t) <= 200


def test_context_and_sessions_cover_each_session(corpus: Path) -> None:
    context = pd.read_csv(corpus / "context.csv")
    assert list(context.columns) == list(CONTEXT_COLUMNS)
    for _, c in context.groupby(["session", "subject"]):
        assert c.start_s.iloc[0] == 0.0 and c.end_s.iloc[-1] == 120.0
        np.testing.assert_allclose(c.start_s.iloc[1:], c.end_s.iloc[:-1])
        assert list(dict.fromkeys(c.scenario)) == ["scripted", "clinical", "free-living"]
    sessions = pd.read_csv(corpus / "sessions.csv")
    # each session's start: ISO 8601 with its offset, on day i of March 2024, 07:00-19:59
    starts = [datetime.fromisoformat(t) for t in sessions.pop("start_time")]
    assert [t.utcoffset() for t in starts] == [timedelta(hours=1)] * 4
    assert [t.day for t in starts] == [1, 1, 2, 2] and all(7 <= t.hour < 20 for t in starts)
    assert starts[0] == starts[1] and starts[2] == starts[3]
    assert sessions.values.tolist() == [
        ["home01", "P01", 120.0],
        ["home01", "C01", 120.0],
        ["home02", "P02", 120.0],
        ["home02", "C02", 120.0],
    ]


def test_artefacts_are_where_planted_says(corpus: Path) -> None:
    planted = pd.read_csv(corpus / "planted.csv")
    kinds = set(planted.kind)
    assert {"turn", "swap", "dropout"} <= kinds
    for session in ("home01", "home02"):
        arrays = np.load(corpus / "streams" / f"{session}.npz")
        assert sorted(arrays.files) == sorted({f"P{session[-2:]}", f"C{session[-2:]}"})
        for subject in arrays.files:
            p = arrays[subject]
            assert p.dtype == np.float32 and p.shape == (int(120 * FPS), 17, 3)
            mine = planted[(planted.session == session) & (planted.subject == subject)]
            lost = np.isnan(p).any(axis=(1, 2))
            for ev in mine[mine.kind.isin(["absence", "dropout"])].itertuples():
                assert lost[ev.start_frame : ev.end_frame].all()
            z = to_z_up(p.astype(float), "-y")
            yaw = frame_yaw_deg(z, H36M17)
            for ev in mine[mine.kind == "swap"].itertuples():
                before, first = ev.start_frame - 1, ev.start_frame
                if before >= 0 and not (lost[before] or lost[first]):
                    # the hip vector flips (a few degrees of motion aside) into a swap
                    jump = abs((yaw[first] - yaw[before] + 180.0) % 360.0 - 180.0)
                    assert jump > 140.0
            if session == "home02":  # every 2nd session is written root-relative
                ok = ~lost
                np.testing.assert_allclose(p[ok, 0], 0.0, atol=1e-6)


def test_camera_frame_keeps_the_sense_of_a_turn() -> None:
    # a hip vector turning left by 90° in the world turns left by 90° seen z up again
    t = np.linspace(0.0, np.pi / 2, 10)
    p = np.zeros((10, 17, 3))
    p[:, H36M17.index("left_hip"), :2] = np.stack([np.cos(t), np.sin(t)], axis=1) * 130.0
    p[:, H36M17.index("right_hip"), :2] = -p[:, H36M17.index("left_hip"), :2]
    p[..., 2] += 900.0
    for camera in ((0.0, -4000.0, 1500.0), (3000.0, 2000.0, 2200.0)):
        seen = to_z_up(camera_frame_m(p, camera).astype(float), "-y")
        yaw = frame_yaw_deg(seen, H36M17)
        assert yaw[-1] - yaw[0] == pytest.approx(90.0, abs=1e-3)
        # metres, and y down: the hips (0.9 m up) are below the camera's axis at 1.5-2.2 m
        cam_axes = camera_frame_m(p, camera)
        assert (cam_axes[:, H36M17.index("left_hip"), 1] > 0).all()


def test_streams_for_a_label_table_plant_its_turns(corpus: Path, tmp_path: Path) -> None:
    # the demo's path: streams around given labels (here the corpus's own, 270° added)
    labels = pd.read_csv(corpus / "labels.csv", keep_default_na=False)
    extra = labels.iloc[[0]].assign(start_s=100.0, end_s=105.0, angle_deg=270.0)
    labels = pd.concat([labels[labels.start_s < 95.0], extra], ignore_index=True)
    context = pd.read_csv(corpus / "context.csv", keep_default_na=False)
    written = write_streams_for_labels(labels, tmp_path, seed=5, context=context)
    assert [p.name for p in written] == ["home01.npz", "home02.npz"]
    with np.load(written[0]) as archive:
        # 10 s after each person's last turn
        ends = labels[labels.session == "home01"].groupby("subject").end_s.max()
        for subject, end in ends.items():
            assert archive[subject].shape[0] == round((end + 10.0) * FPS)
    rule = MinerRule(DetectParams(miner=replace(DETECT_MINER_DEFAULTS, min_turn_deg=67.5)))
    run = detect_files(written, detector=rule, layout=H36M17, up_axis="-y", fps_hz=FPS)
    doc = score_events(run.detections, labels, n_resamples=0, by=["cohort"]).doc
    assert doc["overall"]["f1"] >= 0.9
