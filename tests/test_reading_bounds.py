"""What every reader of skeletons checks before and while reading: the size an array
declares (against the documented bound and the machine's memory, before a byte of it is
inflated), HDF5 data held in other files, and the magnitude of the coordinates (one check
for ``h36m mine``, ``predict`` and ``detect``)."""

from __future__ import annotations

import io
import zipfile

import h5py
import numpy as np
import pytest
from conftest import run_cli as run

from turn_datasets import limits, machine
from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap.checks import check_declared_size, check_magnitude
from turn_datasets.skeleton import H36M17, UP_AXES, to_z_up
from turn_eval.cli import cli as eval_cli
from turn_eval.detect.rule import MinerRule
from turn_eval.detect.streams import read_streams

DETECT = ["--layout", "h36m17", "--up-axis", "z", "--fps", "30"]
PREDICT = ["--layout", "h36m17", "--up-axis", "z"]
MINE = ["--layout", "h36m17", "--fps", "30", "--up-axis", "z", "--units", "m"]
HUGE = (40_000_000, 17, 3)  # the 8.2 GB of float32


def one_line(code: int, stderr: str) -> str:
    assert code == EXIT_BAD_INPUT, stderr
    assert "Traceback" not in stderr
    lines = [x for x in stderr.strip().splitlines() if not x.startswith(("detecting", "predict"))]
    assert len(lines) == 1, stderr
    return lines[0]


def walking(n: int = 300) -> np.ndarray:
    """A person walking along x, z up, metres, float32: hips 0.26 m apart, a turn-free stream."""
    rng = np.random.default_rng(0)
    p = np.zeros((n, 17, 3), dtype=np.float32)
    p[:, :, 0] = np.linspace(0, 0.04 * n, n)[:, None]
    p[:, 1, 1], p[:, 4, 1] = 0.13, -0.13  # right hip, left hip (h36m17), facing +x
    p[:, :, 2] = 1.0 + 0.01 * rng.standard_normal((n, 17))
    return p


def huge_npy_bytes() -> bytes:
    """An .npy whose header declares 40 M x 17 x 3 float32 followed by a few bytes of data."""
    buf = io.BytesIO()
    header = {"descr": "<f4", "fortran_order": False, "shape": HUGE}
    np.lib.format.write_array_header_1_0(buf, header)
    return buf.getvalue() + b"\0" * 64


# --- declared size ------------------------------------------------------------------------


def test_a_tiny_gzip_hdf5_declaring_8_gb_is_refused_before_reading(tmp_path, capsys) -> None:
    path = tmp_path / "home.h5"
    with h5py.File(path, "w") as fh:
        fh.create_dataset("P01", shape=HUGE, dtype="f4", chunks=(1000, 17, 3), compression="gzip")
    assert path.stat().st_size < 10_000  # a few kilobytes declare gigabytes
    code, _, err = run(
        eval_cli, "turn-eval", ["detect", path, *DETECT, "--out", tmp_path / "d.csv"], capsys
    )
    line = one_line(code, err)
    assert f"{path}, P01: the array declares 40000000 x 17 x 3 float32 values (8.2 GB)" in line
    assert f"more than the {limits.MAX_ARRAY_VALUES:,} values" in line
    assert not (tmp_path / "d.csv").exists()


@pytest.mark.parametrize("command", ["detect", "predict", "mine"])
def test_an_npz_member_declaring_8_gb_is_refused_by_every_reader(tmp_path, capsys, command) -> None:
    path = tmp_path / "home.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("P01.npy", huge_npy_bytes())
    out = tmp_path / "o.csv"
    if command == "mine":
        code, _, err = run(
            datasets_cli, "turn-datasets", ["h36m", "mine", path, *MINE, "--out", out], capsys
        )
        assert code == EXIT_BAD_INPUT and "Traceback" not in err, err
        assert "P01: the array declares 40000000 x 17 x 3 float32 values" in err
    else:
        opts = DETECT if command == "detect" else PREDICT
        code, _, err = run(eval_cli, "turn-eval", [command, path, *opts, "--out", out], capsys)
        assert "P01: the array declares 40000000 x 17 x 3 float32 values" in one_line(code, err)
    assert not out.exists()


def test_an_npy_declaring_8_gb_is_refused_by_predict(tmp_path, capsys) -> None:
    path = tmp_path / "clip.npy"
    path.write_bytes(huge_npy_bytes())
    code, _, err = run(
        eval_cli, "turn-eval", ["predict", path, *PREDICT, "--out", tmp_path / "p.csv"], capsys
    )
    assert f"{path}: the array declares 40000000 x 17 x 3 float32 values" in one_line(code, err)


def test_an_array_larger_than_the_free_memory_is_refused(tmp_path, capsys, monkeypatch) -> None:
    np.savez(tmp_path / "home.npz", P01=walking())  # 300 x 17 x 3 float32: 61 kB
    monkeypatch.setattr(machine, "available_memory_bytes", lambda: 100_000)
    code, _, err = run(
        eval_cli, "turn-eval", ["detect", tmp_path, *DETECT, "--out", tmp_path / "d.csv"], capsys
    )
    line = one_line(code, err)
    # 15,300 values x (4 stored + 8 working) bytes = 183,600 bytes > 100,000 free
    assert "reading it needs about 0.0 GB and this machine has 0.0 GB free" in line


def test_the_declared_size_bound_is_the_documented_one() -> None:
    n = limits.MAX_ARRAY_VALUES
    check_declared_size((n // 51, 17, 3), "f4", path="x.npy", item=None)  # at the bound: fine
    with pytest.raises(TurnbenchError, match="more than the 268,435,456 values"):
        check_declared_size((n // 51 + 1, 17, 3), "f4", path="x.npy", item=None)


def test_an_hdf5_virtual_dataset_reading_another_file_is_refused(tmp_path, capsys) -> None:
    other = tmp_path / "elsewhere.h5"
    with h5py.File(other, "w") as fh:
        fh["data"] = walking()
    layout = h5py.VirtualLayout(shape=(300, 17, 3), dtype="f4")
    layout[:] = h5py.VirtualSource(str(other), "data", shape=(300, 17, 3))
    path = tmp_path / "in" / "home.h5"
    path.parent.mkdir()
    with h5py.File(path, "w") as fh:
        fh.create_virtual_dataset("P01", layout)
    code, _, err = run(
        eval_cli, "turn-eval", ["detect", path, *DETECT, "--out", tmp_path / "d.csv"], capsys
    )
    line = one_line(code, err)
    assert f"{path}, P01: the dataset is a virtual dataset, reading {other}" in line


def test_an_hdf5_dataset_with_external_storage_is_refused(tmp_path, capsys) -> None:
    raw = tmp_path / "raw.bin"
    raw.write_bytes(walking().tobytes())
    path = tmp_path / "in" / "home.h5"
    path.parent.mkdir()
    with h5py.File(path, "w") as fh:
        fh.create_dataset(
            "P01", shape=(300, 17, 3), dtype="<f4", external=[(str(raw), 0, h5py.h5f.UNLIMITED)]
        )
    code, _, err = run(
        eval_cli, "turn-eval", ["predict", path, *PREDICT, "--out", tmp_path / "p.csv"], capsys
    )
    assert "P01: the dataset is stored in external files, reading" in one_line(code, err)


def test_a_float32_stream_is_not_widened_whole_and_detects_the_same(tmp_path) -> None:
    p = walking(600)
    np.save(tmp_path / "s32.npy", p)
    np.save(tmp_path / "s64.npy", p.astype(np.float64))
    (s32,) = read_streams(tmp_path / "s32.npy", layout=H36M17, up_axis="-y")
    (s64,) = read_streams(tmp_path / "s64.npy", layout=H36M17, up_axis="-y")
    assert s32.positions.dtype == np.float32 and s64.positions.dtype == np.float64
    # -y: (x, y, z) -> (x, z, -y), exactly
    assert np.array_equal(s32.positions, np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1))
    rule = MinerRule()
    a = rule.detect(s32.positions, 30.0, H36M17)
    b = rule.detect(s64.positions, 30.0, H36M17)
    assert a.equals(b)


# --- magnitude ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "value, message",
    [
        (1e300, "positions hold a coordinate of 1e+300, beyond the plausible +-1e+09"),
        (1e150, "positions hold a coordinate of 1e+150, beyond the plausible +-1e+09"),
        (-1e12, "positions hold a coordinate of -1e+12, beyond the plausible +-1e+09"),
        (np.inf, "positions hold infinite values"),
        (-np.inf, "positions hold infinite values"),
    ],
)
@pytest.mark.parametrize("command", ["detect", "predict", "mine"])
def test_one_magnitude_check_for_every_reader_of_skeletons(
    tmp_path, capsys, value, message, command
) -> None:
    p = walking().astype(np.float64)
    p[100, 4, 0] = value  # the left hip, as the inf in a hip joint
    path = tmp_path / "home.npz"
    np.savez(path, P01=p)
    out = tmp_path / "o.csv"
    if command == "mine":
        code, _, err = run(
            datasets_cli, "turn-datasets", ["h36m", "mine", path, *MINE, "--out", out], capsys
        )
        assert code == EXIT_BAD_INPUT and "Traceback" not in err, err
        assert message in err
    else:
        opts = DETECT if command == "detect" else PREDICT
        code, _, err = run(eval_cli, "turn-eval", [command, path, *opts, "--out", out], capsys)
        assert f"{path}, P01: {message}" in one_line(code, err)
    assert not out.exists()


def test_the_magnitude_check_passes_nan_and_the_bound_itself() -> None:
    p = np.full((10, 17, 3), np.nan, dtype=np.float32)
    check_magnitude(p, path=None, item=None)  # nothing seen: the callers judge that
    p[3, 0, 0] = -limits.MAX_POSITION_ABS
    p[4, 0, 1] = limits.MAX_POSITION_ABS
    check_magnitude(p, path=None, item=None)
    with pytest.raises(TurnbenchError, match="coordinate of 1.1e"):
        check_magnitude(np.array([[[1.1e9, 0.0, 0.0]]]), path=None, item="c")
    with pytest.raises(TurnbenchError, match="coordinate of -2e"):
        check_magnitude(np.array([[[-2_000_000_000, 0, 0]]], dtype=np.int64), path=None, item="c")


@pytest.mark.parametrize("up_axis", [a for a in UP_AXES if a != "auto"])
def test_the_in_place_turn_to_z_up_is_to_z_up(up_axis) -> None:
    from turn_eval.detect.streams import _z_up_in_place

    p = np.random.default_rng(1).standard_normal((50, 17, 3)).astype(np.float32)
    want = to_z_up(p.copy(), up_axis)
    got = _z_up_in_place(p, up_axis)
    assert got is p and got.dtype == np.float32  # no second array
    assert np.array_equal(got, want)


@pytest.mark.parametrize("command", ["detect", "predict"])
def test_the_magnitude_check_comes_before_the_up_axis_inference(tmp_path, capsys, command) -> None:
    p = walking().astype(np.float64)
    p[100, 0, 2] = 1e300  # the pelvis, which the inference reads
    path = tmp_path / "home.npz"
    np.savez(path, P01=p)
    args = [command, path, "--layout", "h36m17", "--out", tmp_path / "o.csv"]
    if command == "detect":
        args += ["--fps", "30"]  # no --up-axis: auto
    code, _, err = run(eval_cli, "turn-eval", args, capsys)
    line = [x for x in err.strip().splitlines() if "error" in x]
    assert code == EXIT_BAD_INPUT and "Traceback" not in err, err
    assert len(line) == 1 and f"{path}, P01: positions hold a coordinate of 1e+300" in line[0]
