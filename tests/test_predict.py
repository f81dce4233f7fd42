"""predict.predict_angles: the paper's estimator on skeletons built by hand with known turns."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.skeleton import H36M17, H36M32, Layout
from turn_eval.predict import predict_angle, predict_angles

# Half-widths (metres) and heights of each left/right pair: any non-zero values do.
_PAIRS = {"hip": (0.10, 0.9), "knee": (0.09, 0.5), "shoulder": (0.18, 1.4)}
# Heights of the trunk and the feet, so that --up-axis auto (the default for generic arrays)
# finds z up as it would in a person: pelvis to neck along z, the head above the feet.
_HEIGHTS = {"pelvis": 0.9, "neck": 1.5, "head": 1.65, "left_foot": 0.05, "right_foot": 0.05}


def turning_skeleton(
    yaw_deg: np.ndarray, layout: Layout = H36M17, *, knee_yaw_deg: np.ndarray | None = None
) -> np.ndarray:
    """A z-up skeleton walking along x whose left-minus-right vectors point at ``yaw_deg``.

    Left joint = centre + r (cos yaw, sin yaw), right joint = centre - r (cos yaw, sin yaw),
    so the frontal vector of equations 1-2 is 2r (cos yaw, sin yaw) and its rotation from
    frame to frame is exactly the change in ``yaw_deg``.
    """
    yaw_deg = np.asarray(yaw_deg, dtype=float)
    n = yaw_deg.size
    p = np.zeros((n, layout.n_joints, 3))
    p[:, :, 0] = np.linspace(0.0, 1.5, n)[:, None]  # walking forward: translation is not rotation
    p[:, :, 2] = 1.0
    for joint, z in _HEIGHTS.items():
        p[:, layout.index(joint), 2] = z
    for pair, (r, z) in _PAIRS.items():
        yaw = np.radians(knee_yaw_deg if pair == "knee" and knee_yaw_deg is not None else yaw_deg)
        offset = np.stack([r * np.cos(yaw), r * np.sin(yaw)], axis=1)
        left, right = layout.index(f"left_{pair}"), layout.index(f"right_{pair}")
        p[:, left, :2] = p[:, left, :2] + offset
        p[:, right, :2] = p[:, right, :2] - offset
        p[:, left, 2] = p[:, right, 2] = z
    return p


def y_up_copy(p: np.ndarray) -> np.ndarray:
    """The same skeleton with y vertical, written out by hand.

    Keep x; the vertical z becomes y; for a right-handed frame the new third axis is
    x cross y_new = x cross z = -y. So (x, y, z) -> (x, z, -y).
    """
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)


def minus_y_up_copy(p: np.ndarray) -> np.ndarray:
    """Camera frame (y down): new y = -z, new third axis = x cross (-z) = +y: (x, -z, y)."""
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)


@pytest.mark.parametrize("angle_deg", [45.0, 90.0, 180.0, 234.7])
@pytest.mark.parametrize("method", ["net", "paper"])
def test_monotonic_turn_gives_its_angle_by_both_methods(angle_deg, method):
    # A steady turn of angle_deg over 60 frames (< 4° per frame): both equation 3 and the net
    # rotation add up to angle_deg exactly.
    p = turning_skeleton(np.linspace(0.0, angle_deg, 60))
    out = predict_angle(p, layout="h36m17", method=method)
    assert out["angle_deg"] == pytest.approx(angle_deg, abs=1e-9)
    assert out["direction"] == "left"  # yaw increasing = counter-clockwise from above


def test_right_turn_is_right_with_positive_magnitude():
    p = turning_skeleton(np.linspace(30.0, -60.0, 40))
    out = predict_angle(p, layout="h36m17")
    assert out["angle_deg"] == pytest.approx(90.0)
    assert out["direction"] == "right"


@pytest.mark.parametrize(
    "convert, up_axis", [(lambda p: p, "z"), (y_up_copy, "y"), (minus_y_up_copy, "-y")]
)
def test_up_axis_conversions_by_hand(convert, up_axis):
    # A 135° left turn seen in each convention must still be a 135° left turn: a wrong
    # (improper) conversion would flip the direction, a wrong vertical axis the angle.
    p = convert(turning_skeleton(np.linspace(0.0, 135.0, 50)))
    out = predict_angle(p, layout=H36M17, up_axis=up_axis)
    assert out["angle_deg"] == pytest.approx(135.0)
    assert out["direction"] == "left"


def test_paper_and_net_differ_on_a_turn_back():
    # 0 -> 90° then back to 45°: the net rotation is 45°, while equation 3 as printed sums
    # the magnitudes of every step, 90 + 45 = 135°.
    yaw = np.concatenate([np.linspace(0.0, 90.0, 31), np.linspace(90.0, 45.0, 31)[1:]])
    p = turning_skeleton(yaw)
    assert predict_angle(p, layout="h36m17", method="net")["angle_deg"] == pytest.approx(45.0)
    assert predict_angle(p, layout="h36m17", method="paper")["angle_deg"] == pytest.approx(135.0)


def test_speed_is_angle_over_frames_over_fps():
    # 100 frames at 50 Hz last 2 s; a 90° turn in them is 45 °/s (equation 4).
    p = turning_skeleton(np.linspace(0.0, 90.0, 100))
    out = predict_angle(p, layout="h36m17", fps_hz=50.0)
    assert out["speed_deg_s"] == pytest.approx(45.0)


def test_several_joint_pairs_are_averaged():
    # Hips (and shoulders) turn 90°, knees only 60°: with hip,knee the mean is 75°.
    n = 50
    p = turning_skeleton(np.linspace(0, 90, n), knee_yaw_deg=np.linspace(0, 60, n))
    assert predict_angle(p, layout="h36m17", joints="knee")["angle_deg"] == pytest.approx(60.0)
    assert predict_angle(p, layout="h36m17", joints=("hip", "knee"))["angle_deg"] == pytest.approx(
        75.0
    )


def test_table_columns_dtypes_and_order():
    clips = [
        ("b_clip", turning_skeleton(np.linspace(0, 45, 20), H36M32)),
        ("a_clip", turning_skeleton(np.linspace(0, -180, 40), H36M32)),
    ]
    table = predict_angles(clips, layout="h36m32", up_axis="z")
    assert list(table.columns) == ["clip_id", "angle_deg", "direction"]
    assert table["angle_deg"].dtype == np.float64
    assert list(table["clip_id"]) == ["b_clip", "a_clip"]  # input order, not sorted
    assert table["angle_deg"].tolist() == pytest.approx([45.0, 180.0])
    assert list(table["direction"]) == ["left", "right"]

    with_speed = predict_angles(clips, layout="h36m32", fps_hz=20.0)
    assert list(with_speed.columns) == [
        "clip_id",
        "angle_deg",
        "direction",
        "speed_deg_s",
        "peak_speed_deg_s",
        "steps",
        "turn_type",
    ]
    # 20 frames at 20 Hz = 1 s -> 45 °/s; 40 frames = 2 s -> 90 °/s
    assert with_speed["speed_deg_s"].tolist() == pytest.approx([45.0, 90.0])
    pd.testing.assert_frame_equal(with_speed.iloc[:, :3], table)


def test_duplicate_clip_id_and_bad_clips_are_named():
    p = turning_skeleton(np.linspace(0, 90, 10))
    with pytest.raises(TurnbenchError, match="duplicate") as err:
        predict_angles([("x", p), ("x", p)], layout="h36m17")
    assert err.value.where.item == "x"

    with pytest.raises(TurnbenchError, match="17 joints") as err:
        predict_angles([("h36m17_clip", p)], layout="h36m32")
    assert err.value.where.item == "h36m17_clip"

    nan_clip = p.copy()
    nan_clip[:, H36M17.index("left_hip")] = np.nan
    with pytest.raises(TurnbenchError, match="usable frames") as err:
        predict_angles([("ok", p), ("lost", nan_clip)], layout="h36m17")
    assert err.value.where.item == "lost"


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"up_axis": "w"}, "up axis"),
        ({"method": "sum"}, "method"),
        ({"joints": "elbow"}, "joint pair"),
        ({"fps_hz": 0.0}, "frame rate"),
        ({"layout": "coco"}, "layout"),
    ],
)
def test_bad_options_fail_before_reading(kwargs, message):
    def never():
        raise AssertionError("options must be checked before any clip is read")
        yield  # pragma: no cover

    options = {"layout": "h36m17", **kwargs}
    with pytest.raises(TurnbenchError, match=message):
        predict_angles(never(), **options)


def test_clip_arrays_reads_generic_or_named_files_with_their_up_axis(tmp_path):
    from turn_datasets.up_axis import AxesFound
    from turn_eval.predict import clip_arrays

    body = turning_skeleton(np.linspace(0.0, 90.0, 5))  # z up
    np.savez(tmp_path / "two.npz", a=body, b=minus_y_up_copy(body))
    (tmp_path / "clip7").mkdir()
    np.save(tmp_path / "clip7" / "X3D.npy", minus_y_up_copy(body))
    found = AxesFound("auto")
    generic, axis = clip_arrays(
        tmp_path / "two.npz", source_format="arrays", layout=H36M17, up_axis=None, found=found
    )
    # generic arrays: each one's axis inferred (a: z, b: camera axes) and turned z up
    pairs = list(generic)
    assert [k for k, _ in pairs] == ["a", "b"] and axis == "z"
    for _, array in pairs:
        np.testing.assert_allclose(array, body)
    assert dict(found.counts) == {"z": 1, "-y": 1}
    found = AxesFound("motionbert")
    named, _ = clip_arrays(
        tmp_path / "clip7" / "X3D.npy",
        source_format="motionbert",
        layout=H36M17,
        up_axis=None,
        found=found,
    )
    ((key, array),) = list(named)
    assert key == "clip7" and dict(found.counts) == {"-y": 1}  # MotionBERT's camera axes
    np.testing.assert_allclose(array, body)
    found = AxesFound("y")
    named, _ = clip_arrays(
        tmp_path / "clip7" / "X3D.npy",
        source_format="motionbert",
        layout=H36M17,
        up_axis="y",
        found=found,
    )
    list(named)
    assert dict(found.counts) == {"y": 1}  # the caller's word wins
    with pytest.raises(TurnbenchError, match="16 joints but layout 'h36m17' has 17"):
        np.save(tmp_path / "short.npy", np.zeros((5, 16, 3)))
        list(clip_arrays(tmp_path / "short.npy", source_format="arrays", layout=H36M17,
                         up_axis=None)[0])  # fmt: skip
