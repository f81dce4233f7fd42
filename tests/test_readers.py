"""Readers: every format written by our writers, then read back; layout detection; bad input."""

from __future__ import annotations

import io
import pickle
import zipfile
from pathlib import Path

import cdflib
import cdflib.cdfwrite
import h5py
import numpy as np
import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap import arrays, h36m, readers
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, H36M32
from turn_datasets.synthetic import h36m_files


def _arr(n_frames: int, n_joints: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(n_frames, n_joints, 3))


# --- iter_arrays --------------------------------------------------------------------------


def test_iter_arrays_npy_yields_stem(tmp_path: Path) -> None:
    a = _arr(5, 17)
    np.save(tmp_path / "walk.npy", a)
    out = list(arrays.iter_arrays(tmp_path / "walk.npy"))
    assert [k for k, _ in out] == ["walk"]
    np.testing.assert_array_equal(out[0][1], a)


def test_iter_arrays_npz_one_per_key_sorted(tmp_path: Path) -> None:
    a, b = _arr(4, 17, 1), _arr(6, 32, 2)
    np.savez(tmp_path / "two.npz", zeta=a, alpha=b)
    out = list(arrays.iter_arrays(tmp_path / "two.npz"))
    assert [k for k, _ in out] == ["alpha", "zeta"]
    np.testing.assert_array_equal(out[0][1], b)
    np.testing.assert_array_equal(out[1][1], a)


def test_iter_arrays_h5_walks_nested_groups(tmp_path: Path) -> None:
    a, b, c = _arr(3, 17, 3), _arr(4, 17, 4), _arr(5, 17, 5)
    with h5py.File(tmp_path / "nested.h5", "w") as fh:
        fh["top"] = a
        fh.create_group("g").create_group("inner")["x"] = b
        fh["g"]["a"] = c
    out = dict(arrays.iter_arrays(tmp_path / "nested.h5"))
    assert list(out) == ["g/a", "g/inner/x", "top"]
    np.testing.assert_array_equal(out["g/inner/x"], b)
    np.testing.assert_array_equal(out["top"], a)


@pytest.mark.parametrize("shape", [(5, 17), (5, 17, 2), (5, 17, 3, 1), (0, 17, 3)])
def test_iter_arrays_wrong_shape_names_file_key_shape(tmp_path: Path, shape) -> None:
    np.savez(tmp_path / "bad.npz", seq=np.zeros(shape))
    with pytest.raises(TurnbenchError) as exc:
        list(arrays.iter_arrays(tmp_path / "bad.npz"))
    text = str(exc.value)
    assert "bad.npz" in text and "seq" in text and str(shape) in text


def test_iter_arrays_non_numeric(tmp_path: Path) -> None:
    np.save(tmp_path / "s.npy", np.full((2, 3, 3), "x"))
    with pytest.raises(TurnbenchError, match="dtype"):
        list(arrays.iter_arrays(tmp_path / "s.npy"))


def test_iter_arrays_truncated_files(tmp_path: Path) -> None:
    for name, save in (
        ("t.npy", lambda p: np.save(p, _arr(50, 17))),
        ("t.npz", lambda p: np.savez(p, a=_arr(50, 17))),
    ):
        path = tmp_path / name
        save(path)
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
        with pytest.raises(TurnbenchError, match="t.np"):
            list(arrays.iter_arrays(path))
    h5 = tmp_path / "t.h5"
    h5.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 20)
    with pytest.raises(TurnbenchError, match="t.h5"):
        list(arrays.iter_arrays(h5))


def test_iter_arrays_refuses_pickles(tmp_path: Path) -> None:
    np.savez(tmp_path / "p.npz", obj=np.array([{"a": 1}], dtype=object))
    with pytest.raises(TurnbenchError, match="p.npz"):
        list(arrays.iter_arrays(tmp_path / "p.npz"))


def test_iter_arrays_unknown_suffix_and_missing(tmp_path: Path) -> None:
    (tmp_path / "x.txt").write_text("1")
    with pytest.raises(TurnbenchError, match="x.txt"):
        list(arrays.iter_arrays(tmp_path / "x.txt"))
    with pytest.raises(TurnbenchError, match="nope.npy"):
        list(arrays.iter_arrays(tmp_path / "nope.npy"))


# --- helpers ------------------------------------------------------------------------------


def _walking_h36m(n_frames: int = 40, seed: int = 0) -> np.ndarray:
    """Plausible Human3.6M positions (mm): random joints, hips 260 mm apart, turning left."""
    rng = np.random.default_rng(seed)
    p = rng.normal(scale=200.0, size=(n_frames, 32, 3))
    yaw = np.linspace(0.0, np.pi / 2, n_frames)
    half = 130.0 * np.stack([np.cos(yaw), np.sin(yaw), np.zeros(n_frames)], axis=1)
    p[:, H36M32.index("left_hip")] = 900.0 * np.array([0, 0, 1]) + half
    p[:, H36M32.index("right_hip")] = 900.0 * np.array([0, 0, 1]) - half
    return p


# --- writers then readers: the exact inverse layouts --------------------------------------


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_cdf_round_trip(tmp_path: Path, dtype) -> None:
    x = _walking_h36m().astype(dtype)
    path = tmp_path / "S7" / "MyPoseFeatures" / "D3_Positions" / "Walking 1.cdf"
    h36m_files.write_h36m_cdf(path, x)
    # the file's own layout, read with cdflib directly: Pose (1, N, 96), joint-major
    raw = cdflib.CDF(path).varget("Pose")
    assert raw.shape == (1, 40, 96) and raw.dtype == dtype
    assert raw[0, 5, 3 * 6 + 1] == x[5, 6, 1]  # frame 5, joint 6 (left hip), y
    (seq,) = readers.read_source(readers.SourceFile(path, "cdf"))
    assert (seq.subject, seq.action, seq.subaction) == ("S7", "Walking", "1")
    assert seq.positions.dtype == np.float64 and seq.layout is H36M32
    np.testing.assert_array_equal(seq.positions, x.astype(np.float64))
    assert (seq.fps, seq.units, seq.source) == (50.0, "mm", str(path))
    assert not list(tmp_path.rglob(".*"))  # no temporary file left


def test_h36m_h5_round_trip_is_transposed(tmp_path: Path) -> None:
    x = _walking_h36m()
    path = tmp_path / "S11" / "MyPoses" / "3D_positions" / "WalkingDog 1.h5"
    h36m_files.write_h36m_h5(path, x)
    with h5py.File(path, "r") as fh:
        raw = fh["3D_positions"][()]
    # 3d-pose-baseline stores (96, N): row 3 * joint + axis, column frame
    assert raw.shape == (96, 40)
    assert raw[3 * 6 + 2, 7] == x[7, 6, 2]
    (seq,) = readers.read_source(path)  # a path: format sniffed from the dataset inside
    assert (seq.subject, seq.action, seq.subaction) == ("S11", "WalkDog", "1")
    np.testing.assert_array_equal(seq.positions, x)
    assert (seq.fps, seq.units) == (50.0, "mm")


def test_videopose_npz_round_trip_in_metres(tmp_path: Path) -> None:
    a, b, c = (_walking_h36m(n, seed=n) / 1000.0 for n in (30, 40, 50))
    path = tmp_path / "data_3d_h36m.npz"
    h36m_files.write_videopose_npz(
        path, {"S11": {"Walking": a}, "S9": {"TakingPhoto 1": b, "Directions": c}}
    )
    # VideoPose3D's own way of reading it
    raw = np.load(path, allow_pickle=True)["positions_3d"].item()
    assert raw["S9"]["TakingPhoto 1"].dtype == np.float32
    seqs = list(readers.read_source(path))
    # subjects in natural order (S9 before S11), actions sorted
    assert [(s.subject, s.action, s.subaction) for s in seqs] == [
        ("S9", "Directions", ""),
        ("S9", "Photo", "1"),
        ("S11", "Walking", ""),
    ]
    for seq, want in zip(seqs, (c, b, a), strict=True):
        np.testing.assert_array_equal(seq.positions, want.astype(np.float32).astype(np.float64))
        assert (seq.units, seq.fps, seq.layout) == ("m", 50.0, H36M32)
    assert seqs[1].meta["key"] == "S9/TakingPhoto 1"


def _videopose_npz_pickled(path: Path, data: dict, protocol: int) -> None:
    """``data_3d_h36m.npz`` as ``np.savez_compressed`` writes it, its pickle in ``protocol``
    (NumPy 1 wrote 3, NumPy 2 writes 4: large arrays outside the 64 KiB frames)."""
    obj = np.empty((), dtype=object)
    obj[()] = data
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "|O", "fortran_order": False, "shape": ()})
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("positions_3d.npy", head.getvalue() + pickle.dumps(obj, protocol=protocol))


@pytest.mark.parametrize("protocol", [3, 4])
def test_videopose_npz_reads_as_numpy_does_in_either_pickle_protocol(tmp_path, protocol) -> None:
    # arrays in and out of frames, names and an action with a space (SHORT_BINUNICODE), the
    # memo (BINPUT/BINGET) shared by the dtype and the reconstructor
    data = {
        f"S{k}": {name: (_walking_h36m(n, seed=k * n) / 1000).astype(np.float32) for name, n in
                  (("Walking", 3), ("Walking 1", 700), ("Eating", 4000))}
        for k in (1, 5, 11)
    }  # fmt: skip
    path = tmp_path / "data_3d_h36m.npz"
    _videopose_npz_pickled(path, data, protocol)
    raw = np.load(path, allow_pickle=True)["positions_3d"].item()
    seqs = list(readers.read_source(path))
    assert len(seqs) == 9
    for seq in seqs:
        subject, name = seq.meta["key"].split("/")
        np.testing.assert_array_equal(seq.positions, raw[subject][name].astype(np.float64))


def test_videopose_pickle_is_unpickled_as_it_is_inflated_never_held_whole(
    tmp_path, monkeypatch
) -> None:
    # four arrays of 153,600 bytes: no read of the member may return more than one of them
    # (reading the whole pickle first holds it twice over, inflated and unpickled)
    data = {f"S{k}": {"Walking": _walking_h36m(400, seed=k) / 1000} for k in (1, 5, 6, 7)}
    path = h36m_files.write_videopose_npz(tmp_path / "data_3d_h36m.npz", data)
    read = zipfile.ZipExtFile.read
    sizes: list[int] = []

    def recording(self, n=-1):
        out = read(self, n)
        sizes.append(len(out))
        return out

    monkeypatch.setattr(zipfile.ZipExtFile, "read", recording)
    seqs = list(readers.read_source(path))
    assert [s.subject for s in seqs] == ["S1", "S5", "S6", "S7"]
    assert 400 * 32 * 3 * 4 == max(sizes)


def test_writers_are_reproducible(tmp_path: Path) -> None:
    x = _walking_h36m()
    for name, write in (
        ("a.cdf", lambda p: h36m_files.write_h36m_cdf(p, x)),
        ("a.h5", lambda p: h36m_files.write_h36m_h5(p, x)),
        ("a.npz", lambda p: h36m_files.write_videopose_npz(p, {"S1": {"Walking": x / 1000}})),
    ):
        write(tmp_path / "1" / name)
        write(tmp_path / "2" / name)
        assert (tmp_path / "1" / name).read_bytes() == (tmp_path / "2" / name).read_bytes()


def test_writers_refuse_wrong_shapes(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"\(N, 32, 3\)"):
        h36m_files.write_h36m_h5(tmp_path / "x.h5", np.zeros((5, 17, 3)))
    assert not (tmp_path / "x.h5").exists()


@pytest.mark.parametrize(
    ("up_axis", "expected"),
    # (x, y, z) of one joint as stored -> z up, by hand (skeleton.to_z_up's docstring)
    [("z", (1.0, 2.0, 3.0)), ("y", (1.0, -3.0, 2.0)), ("-y", (1.0, 3.0, -2.0))],
)
def test_generic_array_up_axis(tmp_path: Path, up_axis: str, expected) -> None:
    x = _walking_h36m(10)[:, list(H36M17_FROM_32)]
    x[:, 0] = (1.0, 2.0, 3.0)
    if up_axis != "z":  # keep the hips apart on the ground plane whatever the axis
        x[:, H36M17.index("left_hip")] = (1.0, 0.0, 1.0) if up_axis == "y" else (1.0, 1.0, 0.0)
        x[:, H36M17.index("right_hip")] = (-1.0, 0.0, -1.0) if up_axis == "y" else (-1.0, -1.0, 0.0)
    np.save(tmp_path / "walk.npy", x)
    (seq,) = readers.read_source(
        tmp_path / "walk.npy", layout="h36m17", fps=30, up_axis=up_axis, units="m"
    )
    np.testing.assert_array_equal(seq.positions[:, 0], np.tile(expected, (10, 1)))
    assert (seq.subject, seq.action, seq.fps, seq.units) == (tmp_path.name, "walk", 30.0, "m")


def test_generic_npz_and_h5_one_sequence_per_key(tmp_path: Path) -> None:
    a, b = _walking_h36m(10, 1), _walking_h36m(12, 2)
    np.savez(tmp_path / "poses.npz", b=b, a=a)
    with h5py.File(tmp_path / "poses.h5", "w") as fh:
        fh.create_group("S1")["walk"] = a
    got = [
        (s.action, s.n_frames)
        for f in ("poses.npz", "poses.h5")
        for s in readers.read_source(
            readers.SourceFile(tmp_path / f, "array"),
            layout=H36M32,
            fps=50,
            up_axis="z",
            units="mm",
        )
    ]
    assert got == [("poses.a", 10), ("poses.b", 12), ("poses.S1.walk", 10)]


def test_generic_array_needs_its_description(tmp_path: Path) -> None:
    np.save(tmp_path / "walk.npy", _walking_h36m(5))
    with pytest.raises(TurnbenchError) as exc:
        list(readers.read_source(tmp_path / "walk.npy", layout="h36m32"))
    text = str(exc.value)
    assert "walk.npy" in text and "--fps" in text and "--units" in text
    # the vertical axis is not asked for: unless stated it is inferred (--up-axis auto)
    assert "--layout" not in text and "--up-axis" not in text
    with pytest.raises(TurnbenchError, match="walk.npy: unknown layout 'coco'"):
        list(
            readers.read_source(
                tmp_path / "walk.npy", layout="coco", fps=50, up_axis="z", units="mm"
            )
        )
    with pytest.raises(TurnbenchError, match="32 joints but layout 'h36m17' has 17"):
        list(
            readers.read_source(
                tmp_path / "walk.npy", layout="h36m17", fps=50, up_axis="z", units="mm"
            )
        )
    with pytest.raises(TurnbenchError, match="walk.npy: unknown units"):
        list(
            readers.read_source(
                tmp_path / "walk.npy", layout="h36m32", fps=50, up_axis="z", units="furlong"
            )
        )
    with pytest.raises(TurnbenchError, match="walk.npy: unknown up axis 'w'"):
        list(
            readers.read_source(
                tmp_path / "walk.npy", layout="h36m32", fps=50, up_axis="w", units="mm"
            )
        )
    with pytest.raises(TurnbenchError, match="fps must be positive"):
        list(
            readers.read_source(
                tmp_path / "walk.npy", layout="h36m32", fps=0, up_axis="z", units="mm"
            )
        )


def test_bvh_through_read_source(cmu_dir: Path) -> None:
    src = readers.SourceFile(cmu_dir / "69_25.bvh", "bvh")
    (kept,) = readers.read_source(src, skip_first_frame=False)
    (dropped,) = readers.read_source(src, skip_first_frame=True, units="in")
    (auto,) = readers.read_source(src)  # the T-pose is recognised and dropped by default
    np.testing.assert_array_equal(auto.positions, dropped.positions)
    assert (kept.subject, kept.action, kept.subaction, kept.fps) == (
        "cmu-mocap",
        "69_25",
        "",
        120.0,
    )
    assert kept.n_frames == 464 and dropped.n_frames == 463  # SOURCE.md: Frames: 464
    np.testing.assert_array_equal(dropped.positions, kept.positions[1:])
    assert (kept.units, dropped.units) == ("bvh", "in")
    assert kept.layout.index("left_hip") == kept.layout.index("LeftUpLeg")


# --- discovering a dataset tree -------------------------------------------------------------


@pytest.fixture
def fake_root(tmp_path: Path) -> Path:
    """A mixed dataset root laid out like the releases, with the files that must be left alone."""
    x = _walking_h36m(8)
    root = tmp_path / "h36m"
    for subject in ("S11", "S9", "S1"):
        h36m_files.write_h36m_cdf(
            root / subject / "MyPoseFeatures" / "D3_Positions" / "Walking.cdf", x
        )
    # camera-frame and 2-D positions, angles: not world 3-D positions
    h36m_files.write_h36m_cdf(
        root / "S1" / "MyPoseFeatures" / "D3_Positions_mono" / "Walking.54138969.cdf", x
    )
    h36m_files.write_h36m_cdf(
        root / "S1" / "MyPoseFeatures" / "D2_Positions" / "Walking.54138969.cdf", x
    )
    h36m_files.write_h36m_h5(root / "S5" / "MyPoses" / "3D_positions" / "Photo 1.h5", x)
    h36m_files.write_h36m_h5(root / "S5" / "StackedHourglass" / "Photo 1.54138969.h5", x)
    h36m_files.write_videopose_npz(root / "data_3d_h36m.npz", {"S6": {"Walking": x / 1000}})
    np.savez(root / "data_2d_h36m_gt.npz", positions_2d=np.zeros(3))
    np.save(root / "stats.npy", np.zeros((4, 32, 3)))
    (root / "cmu").mkdir()
    (root / "cmu" / "a.bvh").write_text("HIERARCHY\n")
    (root / "cmu" / "._a.bvh").write_text("resource fork")
    (root / "README.txt").write_text("notes")
    return root


def test_discover_detects_the_layouts(fake_root: Path) -> None:
    found = readers.discover([fake_root])
    rel = [(str(s.path.relative_to(fake_root)), s.fmt) for s in found]
    assert rel == [
        ("S1/MyPoseFeatures/D3_Positions/Walking.cdf", "cdf"),
        ("S5/MyPoses/3D_positions/Photo 1.h5", "h36m-h5"),
        ("S9/MyPoseFeatures/D3_Positions/Walking.cdf", "cdf"),
        ("S11/MyPoseFeatures/D3_Positions/Walking.cdf", "cdf"),
        ("cmu/a.bvh", "bvh"),
        ("data_3d_h36m.npz", "videopose-npz"),
    ]


def test_discover_mix_dedups_and_forces(fake_root: Path) -> None:
    cdf = fake_root / "S9" / "MyPoseFeatures" / "D3_Positions" / "Walking.cdf"
    both = readers.discover([cdf, fake_root, cdf])
    assert len(both) == 6 and readers.discover([fake_root]) == both
    only_cdf = readers.discover([fake_root], fmt="cdf")
    assert [s.path.parent.parent.parent.name for s in only_cdf] == ["S1", "S9", "S11"]
    arrays = readers.discover([fake_root], fmt="array")
    assert {s.path.name for s in arrays} == {
        "Photo 1.h5",
        "Photo 1.54138969.h5",
        "data_3d_h36m.npz",
        "data_2d_h36m_gt.npz",
        "stats.npy",
    }
    # a named file: sniffed by its contents, or forced
    assert readers.discover([fake_root / "stats.npy"]) == [
        readers.SourceFile(fake_root / "stats.npy", "array")
    ]
    assert readers.discover([fake_root / "data_3d_h36m.npz"])[0].fmt == "videopose-npz"
    assert readers.discover([fake_root / "data_3d_h36m.npz"], fmt="array")[0].fmt == "array"


def test_discover_bad_sources(tmp_path: Path, fake_root: Path) -> None:
    (tmp_path / "empty").mkdir()
    with pytest.raises(TurnbenchError, match="folder is empty") as exc:
        readers.discover([tmp_path / "empty"])
    assert exc.value.where.file == str(tmp_path / "empty")
    (tmp_path / "junk").mkdir()
    np.save(tmp_path / "junk" / "x.npy", np.zeros((2, 32, 3)))
    with pytest.raises(TurnbenchError, match="no motion-capture file recognised") as exc:
        readers.discover([tmp_path / "junk"])
    assert "--format array" in str(exc.value)
    with pytest.raises(TurnbenchError, match="no bvh file recognised"):
        readers.discover([fake_root / "S1"], fmt="bvh")
    with pytest.raises(TurnbenchError, match="no such file or folder") as exc:
        readers.discover([tmp_path / "missing"])
    assert "missing" in str(exc.value)
    with pytest.raises(TurnbenchError, match="unknown format"):
        readers.discover([fake_root / "README.txt"])
    with pytest.raises(TurnbenchError, match=r"a cdf file should end in \.cdf"):
        readers.discover([fake_root / "stats.npy"], fmt="cdf")
    with pytest.raises(TurnbenchError, match="unknown format 'c3d'"):
        readers.discover([fake_root], fmt="c3d")
    with pytest.raises(TurnbenchError, match="no source"):
        readers.discover([])


# --- Human3.6M action names -----------------------------------------------------------------


@pytest.mark.parametrize(
    ("on_disk", "action", "subaction"),
    [
        ("Walking 1", "Walking", "1"),
        ("Walking", "Walking", ""),
        ("WalkDog 1", "WalkDog", "1"),
        ("WalkingDog", "WalkDog", ""),
        ("WalkingDog 1", "WalkDog", "1"),
        ("TakingPhoto", "Photo", ""),
        ("TakingPhoto 1", "Photo", "1"),
        ("Photo 1", "Photo", "1"),
        ("Photo 2", "Photo", "2"),
        ("Directions 2", "Directions", "2"),
        ("WalkTogether", "WalkTogether", ""),
        ("WalkTogether 1", "WalkTogether", "1"),
        ("Discussion 1", "Discussion", "1"),
        ("Discussion 3", "Discussion", "3"),  # S5's second Discussion is numbered 3
        ("Eating 2", "Eating", "2"),  # S1's second Eating
        ("SittingDown", "SittingDown", ""),
        ("Sitting 1", "Sitting", "1"),
        ("Walking 1.54138969", "Walking", "1"),  # 3d-pose-baseline / video names
        ("Walking.54138969", "Walking", ""),
        ("Purchases", "Purchases", ""),
        ("Greeting 1", "Greeting", "1"),
        ("Phoning", "Phoning", ""),
        ("Posing 1", "Posing", "1"),
        ("Smoking", "Smoking", ""),
        ("Waiting 1", "Waiting", "1"),
    ],
)
def test_parse_h36m_action(on_disk: str, action: str, subaction: str) -> None:
    assert h36m.parse_h36m_action(on_disk) == (action, subaction)


def test_every_canonical_action_is_its_own_spelling() -> None:
    assert len(h36m.H36M_ACTIONS) == 15
    for action in h36m.H36M_ACTIONS:
        assert h36m.parse_h36m_action(action) == (action, "")


@pytest.mark.parametrize("name", ["Jogging 1", "", "Walking one", "1", "Box"])
def test_unknown_action_names(name: str) -> None:
    with pytest.raises(TurnbenchError, match="not a Human3.6M action"):
        h36m.parse_h36m_action(name)


def test_subject_from_the_s_folder(tmp_path: Path) -> None:
    assert h36m.h36m_subject_of(tmp_path / "S11" / "MyPoses" / "3D_positions" / "a.h5") == "S11"
    path = tmp_path / "loose" / "Walking.cdf"
    h36m_files.write_h36m_cdf(path, _walking_h36m(4))
    with pytest.raises(TurnbenchError, match="not inside an S<n> folder") as exc:
        list(readers.read_source(path))
    assert exc.value.where.file == str(path)


def test_s11_without_directions_2_is_normal(tmp_path: Path) -> None:
    root = tmp_path / "h36m"
    for name in ("Directions 1", "Directions", "Walking"):
        h36m_files.write_h36m_cdf(
            root / "S11" / "MyPoseFeatures" / "D3_Positions" / f"{name}.cdf", _walking_h36m(4)
        )
    got = [
        (s.action, s.subaction)
        for src in readers.discover([root])
        for s in readers.read_source(src)
    ]
    # by file name: "Directions 1.cdf" sorts before "Directions.cdf" (space before dot)
    assert got == [("Directions", "1"), ("Directions", ""), ("Walking", "")]


# --- bad input ------------------------------------------------------------------------------


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def test_truncated_files_name_the_file(tmp_path: Path) -> None:
    x = _walking_h36m(200)
    cdf = tmp_path / "S1" / "D3_Positions" / "Walking.cdf"
    h5 = tmp_path / "S1" / "3D_positions" / "Walking.h5"
    npz = tmp_path / "data_3d_h36m.npz"
    h36m_files.write_h36m_cdf(cdf, x)
    h36m_files.write_h36m_h5(h5, x)
    h36m_files.write_videopose_npz(npz, {"S1": {"Walking": x / 1000}})
    for path, fmt in ((cdf, "cdf"), (h5, "h36m-h5"), (npz, "videopose-npz")):
        _truncate(path)
        with pytest.raises(TurnbenchError, match="truncated or corrupt") as exc:
            list(readers.read_source(readers.SourceFile(path, fmt)))
        assert exc.value.where.file == str(path)


def test_wrong_shapes(tmp_path: Path) -> None:
    # a 2-D (D2_Positions-like) CDF: 64 values per frame
    cdf = tmp_path / "S1" / "Walking.cdf"
    h36m_files.write_h36m_cdf(cdf, _walking_h36m(5))
    cdf.unlink()
    w = cdflib.cdfwrite.CDF(cdf)
    w.write_var(
        {
            "Variable": "Pose",
            "Data_Type": 45,
            "Num_Elements": 1,
            "Rec_Vary": True,
            "Dim_Sizes": [5, 64],
        },
        var_data=np.zeros((1, 5, 64)),
    )
    w.close()
    with pytest.raises(TurnbenchError, match=r"shape \(5, 64\), expected \(1, N, 96\)"):
        list(readers.read_source(readers.SourceFile(cdf, "cdf")))
    # an h5 stored frame-major (N, 96) instead of 3d-pose-baseline's (96, N)
    h5 = tmp_path / "S1" / "Walking.h5"
    with h5py.File(h5, "w") as fh:
        fh["3D_positions"] = np.zeros((40, 96))
    with pytest.raises(TurnbenchError, match=r"shape \(40, 96\), expected \(96, N\)"):
        list(readers.read_source(readers.SourceFile(h5, "h36m-h5")))
    with h5py.File(h5, "w") as fh:
        fh["poses"] = np.zeros((96, 40))
    with pytest.raises(TurnbenchError, match="no dataset '3D_positions'"):
        list(readers.read_source(readers.SourceFile(h5, "h36m-h5")))
    npz = tmp_path / "v.npz"
    np.savez(npz, positions_3d=np.zeros((3, 32, 3)))
    with pytest.raises(TurnbenchError, match="not a dict"):
        list(readers.read_source(readers.SourceFile(npz, "videopose-npz")))
    np.savez(npz, other=np.zeros(3))
    with pytest.raises(TurnbenchError, match="no 'positions_3d'"):
        list(readers.read_source(readers.SourceFile(npz, "videopose-npz")))
    # the right shape but text instead of numbers: named, not a traceback from float()
    npz = tmp_path / "data_3d_h36m.npz"
    payload = np.empty((), dtype=object)
    payload[()] = {"S1": {"Walking": np.full((4, 32, 3), "x")}}
    np.savez(npz, positions_3d=payload)
    with pytest.raises(TurnbenchError, match="dtype <U1, expected numbers") as exc:
        list(readers.read_source(readers.SourceFile(npz, "videopose-npz")))
    assert (exc.value.where.file, exc.value.where.item) == (str(npz), "S1/Walking")


@pytest.mark.parametrize("problem", ["nan", "coincident", "inf", "empty", "one-frame"])
def test_unusable_hips(tmp_path: Path, problem: str) -> None:
    x = _walking_h36m(20)
    lh, rh = H36M32.index("left_hip"), H36M32.index("right_hip")
    if problem == "nan":
        x[:, lh] = np.nan  # only the left hip lost: still no hip vector
        message = "hip is NaN in every frame"
    elif problem == "coincident":
        x[:, rh] = x[:, lh] + (0.0, 0.0, 50.0)  # apart only vertically: same ground point
        message = "coincide"
    elif problem == "inf":
        x[3, 10, 1] = np.inf
        message = "infinite"
    elif problem == "empty":
        x = x[:0]
        message = "no frames"
    else:
        x[1:, lh] = np.nan
        message = "all but 1 of 20 frames"
    path = tmp_path / "S1" / "MyPoses" / "3D_positions" / "Walking.h5"
    h36m_files.write_h36m_h5(path, x)
    with pytest.raises(TurnbenchError, match=message) as exc:
        list(readers.read_source(path))
    assert exc.value.where.file == str(path)


def test_videopose_sequences_one_at_a_time_error_names_the_sequence(tmp_path: Path) -> None:
    good = _walking_h36m(10) / 1000
    bad = good.copy()
    bad[:, H36M32.index("right_hip")] = np.nan
    path = tmp_path / "data_3d_h36m.npz"
    h36m_files.write_videopose_npz(path, {"S1": {"Walking": good, "Waiting": bad, "Jogging": good}})
    it = readers.read_source(path)
    # actions sorted: Jogging (not a Human3.6M action) comes first
    with pytest.raises(TurnbenchError, match="'Jogging' is not a Human3.6M action") as exc:
        next(it)
    assert exc.value.where.item == "S1/Jogging"
    h36m_files.write_videopose_npz(path, {"S1": {"Walking": good}, "S5": {"Waiting": bad}})
    it = readers.read_source(path)
    first = next(it)  # S1 is yielded before S5 is looked at
    assert (first.subject, first.action) == ("S1", "Walking")
    with pytest.raises(TurnbenchError, match="hip is NaN in every frame") as exc:
        next(it)
    assert exc.value.where.item == "S5/Waiting"
    assert exc.value.where.file == str(path)


def test_videopose_npz_stored_uncompressed_reads_the_same(tmp_path: Path) -> None:
    x = _walking_h36m(30) / 1000.0
    h36m_files.write_videopose_npz(tmp_path / "z.npz", {"S1": {"Walking": x}})
    h36m_files.write_videopose_npz(tmp_path / "s.npz", {"S1": {"Walking": x}}, compressed=False)
    with zipfile.ZipFile(tmp_path / "s.npz") as zf:
        assert zf.getinfo("positions_3d.npy").compress_type == zipfile.ZIP_STORED
    with zipfile.ZipFile(tmp_path / "z.npz") as zf:
        assert zf.getinfo("positions_3d.npy").compress_type == zipfile.ZIP_DEFLATED
    (a,) = readers.read_source(tmp_path / "z.npz")
    (b,) = readers.read_source(tmp_path / "s.npz")
    np.testing.assert_array_equal(a.positions, b.positions)


def test_read_source_takes_one_file_not_a_folder(tmp_path: Path) -> None:
    with pytest.raises(TurnbenchError, match="reads one file"):
        list(readers.read_source(tmp_path))


def test_a_damaged_npy_header_names_the_file(tmp_path: Path) -> None:
    # The header dict cut before its closing brackets: numpy's header parser raises
    # tokenize.TokenError, not one of the usual ValueError/OSError.
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (10, 32, 3"
    header += " " * (118 - len(header) - 1) + "\n"
    path = tmp_path / "S1" / "walk.npy"
    path.parent.mkdir()
    path.write_bytes(
        b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode()
        + np.zeros(960).tobytes()
    )  # fmt: skip
    with pytest.raises(TurnbenchError, match="truncated or corrupt") as exc:
        list(readers.read_source(path, layout="h36m32", fps=50, up_axis="z", units="mm"))
    assert exc.value.where.file == str(path)


def _damaged_copies(data: bytes, *, seed: int, n: int):
    """``(is_cut, bytes)``: cuts at evenly spaced lengths, then copies with one to three bytes
    overwritten."""
    for k in range(1, 10):
        yield True, data[: len(data) * k // 10]
    rng = np.random.default_rng(seed)
    for _ in range(n):
        damaged = bytearray(data)
        for _ in range(int(rng.integers(1, 4))):
            damaged[int(rng.integers(len(damaged)))] = int(rng.integers(256))
        yield False, bytes(damaged)


@pytest.mark.parametrize("fmt", ["cdf", "h36m-h5", "videopose-npz", "array-npz", "array-npy"])
def test_damaged_files_fail_with_one_error_naming_the_file(tmp_path: Path, fmt: str) -> None:
    """Whatever the parsing library raises on damaged bytes (h5py a RuntimeError, zlib an
    error, numpy a TokenError, cdflib a MemoryError were all met), the reader reports the
    file as unreadable; a damaged copy may also still read (a flipped coordinate byte)."""
    x = _walking_h36m(20)
    path = {
        "cdf": tmp_path / "S1" / "D3_Positions" / "Walking.cdf",
        "h36m-h5": tmp_path / "S1" / "3D_positions" / "Walking.h5",
        "videopose-npz": tmp_path / "data_3d_h36m.npz",
        "array-npz": tmp_path / "S1" / "poses.npz",
        "array-npy": tmp_path / "S1" / "poses.npy",
    }[fmt]
    path.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "cdf":
        h36m_files.write_h36m_cdf(path, x)
    elif fmt == "h36m-h5":
        h36m_files.write_h36m_h5(path, x)
    elif fmt == "videopose-npz":
        h36m_files.write_videopose_npz(path, {"S1": {"Walking": x / 1000}})
    elif fmt == "array-npz":
        np.savez_compressed(path, a=x)
    else:
        np.save(path, x)
    src = readers.SourceFile(path, fmt.split("-")[0] if fmt.startswith("array") else fmt)
    kw = {"layout": "h36m32", "fps": 50, "up_axis": "z", "units": "mm"}
    for is_cut, data in _damaged_copies(path.read_bytes(), seed=len(fmt), n=150):
        path.write_bytes(data)
        try:
            list(readers.read_source(src, **kw))
        except TurnbenchError as exc:
            assert exc.where.file == str(path), str(exc)
        else:
            assert not is_cut, f"a copy cut to {len(data)} bytes was read without error"


def test_relative_paths_from_inside_the_tree(tmp_path: Path, monkeypatch) -> None:
    # A curator inside S7/MyPoseFeatures/D3_Positions runs `h36m mine .`: the folder names
    # above the working directory still give the layout and the subject.
    d3 = tmp_path / "S7" / "MyPoseFeatures" / "D3_Positions"
    h36m_files.write_h36m_cdf(d3 / "Walking 1.cdf", _walking_h36m(6))
    np.save(tmp_path / "S7" / "poses.npy", _walking_h36m(6))
    monkeypatch.chdir(d3)
    (src,) = readers.discover(["."])
    assert src.fmt == "cdf"
    (seq,) = readers.read_source(src)
    assert (seq.subject, seq.action, seq.subaction) == ("S7", "Walking", "1")
    # a generic array named without a folder takes the working directory's name as subject
    monkeypatch.chdir(tmp_path / "S7")
    (arr,) = readers.read_source("poses.npy", layout="h36m32", fps=50, up_axis="z", units="mm")
    assert (arr.subject, arr.action, arr.source) == ("S7", "poses", "poses.npy")


def test_one_bad_sequence_of_many_is_reported_and_the_others_read(tmp_path: Path) -> None:
    good = _walking_h36m(10) / 1000
    no_hip = good.copy()
    no_hip[:, H36M32.index("right_hip")] = np.nan
    path = tmp_path / "data_3d_h36m.npz"
    h36m_files.write_videopose_npz(
        path, {"S1": {"Walking": good, "Waiting": no_hip, "Jogging": good}, "S5": {"Eating": good}}
    )
    errors: list[TurnbenchError] = []
    seqs = list(readers.read_source(path, on_bad_sequence=errors.append))
    assert [(s.subject, s.action) for s in seqs] == [("S1", "Walking"), ("S5", "Eating")]
    # sorted: Jogging (no Human3.6M action), Waiting (no right hip), each with file and item
    assert [(e.where.file, e.where.item) for e in errors] == [
        (str(path), "S1/Jogging"),
        (str(path), "S1/Waiting"),
    ]
    assert "not a Human3.6M action" in errors[0].message and "NaN" in errors[1].message
    # generic arrays: a key of the wrong shape, another of the wrong joint count
    arrays = tmp_path / "poses.npz"
    np.savez(arrays, a=_walking_h36m(8), b=np.zeros((8, 32)), c=np.zeros((8, 17, 3)))
    errors.clear()
    kw = {"layout": "h36m32", "fps": 50, "up_axis": "z", "units": "mm"}
    src = readers.SourceFile(arrays, "array")
    seqs = list(readers.read_source(src, **kw, on_bad_sequence=errors.append))
    assert [s.action for s in seqs] == ["poses.a"]
    assert [e.where.item for e in errors] == ["b", "c"]
    assert "expected (frames, joints, 3)" in errors[0].message and "17 joints" in errors[1].message
    # without the callback the first bad sequence is raised, as before
    with pytest.raises(TurnbenchError, match="poses.npz, b: "):
        list(readers.read_source(src, **kw))
