"""What every reader of skeletons checks before and while reading: the size an array
declares (against the documented bound and the machine's memory, before a byte of it is
inflated), HDF5 data held in other files, and the magnitude of the coordinates (one check
for ``h36m mine``, ``predict`` and ``detect``)."""

from __future__ import annotations

import io
import pickle
import struct
import subprocess
import sys
import zipfile
import zlib

import cdflib.cdfwrite
import h5py
import numpy as np
import pytest
from conftest import run_cli as run

from turn_datasets import limits, machine
from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap.checks import check_declared_size, check_magnitude
from turn_datasets.mocap.readers import read_source
from turn_datasets.skeleton import H36M17, UP_AXES, to_z_up
from turn_datasets.synthetic.h36m_files import write_h36m_cdf
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


# --- Human3.6M's CDF and VideoPose3D's pickled npz: the same declared-size check ----------

#: Address space a child run may take: past it an allocation fails (MemoryError) instead of
#: taking this shared machine's memory, so a regression shows as a wrong message, not an OOM.
CHILD_ADDRESS_SPACE = 3 * 2**30
#: Peak resident memory a refused run may reach: turnbench imported is about 180 MB.
REFUSED_PEAK_BYTES = 500 * 2**20
HUGE_H36M = (40_000_000, 32, 3)  # 15.4 GB of float32

_CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))
from turn_datasets.cli import main as datasets
from turn_eval.cli import main as evaluation
try:
    (datasets if sys.argv[1] == "turn-datasets" else evaluation)(sys.argv[2:])
finally:
    # this process's own high-water mark (VmHWM): ru_maxrss of a process started by
    # vfork + exec also counts the parent's resident memory at the fork
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            hwm = [ln.split()[1] for ln in fh if ln.startswith("VmHWM:")][0]
    except (OSError, IndexError):
        hwm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(f"peak_kb={{hwm}}", file=sys.stderr)
"""


def run_bounded(tool: str, args: list, cwd) -> tuple[int, list[str], int]:
    """Run ``tool args`` in a child process with :data:`CHILD_ADDRESS_SPACE`; its exit code,
    its stderr lines (progress lines aside) and its peak resident memory in bytes."""
    child = _CHILD.format(limit=CHILD_ADDRESS_SPACE)
    done = subprocess.run(
        [sys.executable, "-c", child, tool, *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
    )
    lines = done.stderr.strip().splitlines()
    peak = int(lines[-1].removeprefix("peak_kb=")) * 1024
    progress = ("mining", "detecting", "predicting")
    return done.returncode, [x for x in lines[:-1] if not x.startswith(progress)], peak


def assert_refused(tool: str, path, message: str, tmp_path) -> None:
    """``h36m mine`` and ``detect --from mocap`` refuse ``path`` with ``message``, exit 2,
    in little memory, and write nothing."""
    out = tmp_path / "out.csv"
    if tool == "mine":
        code, lines, peak = run_bounded(
            "turn-datasets", ["h36m", "mine", path, "--out", out], tmp_path
        )
        # mine lists each unreadable file, then the summary
        assert code == EXIT_BAD_INPUT and len(lines) == 2, lines
        assert lines[1].startswith("turn-datasets: error: 1 of 1 files could not be read")
    else:
        args = ["detect", path, "--from", "mocap", "--out", out]
        code, lines, peak = run_bounded("turn-eval", args, tmp_path)
        assert code == EXIT_BAD_INPUT and len(lines) == 1, lines
    assert "Traceback" not in lines[0]
    assert message in lines[0], lines[0]
    assert peak < REFUSED_PEAK_BYTES, f"peak {peak / 2**20:.0f} MiB"
    assert not out.exists()


def h36m_walking(n: int = 5) -> np.ndarray:
    """(n, 32, 3) millimetres: hips 260 mm apart, facing +x."""
    p = np.zeros((n, 32, 3), dtype=np.float32)
    p[:, 1, 1], p[:, 6, 1] = -130.0, 130.0  # right hip, left hip (h36m32)
    p[:, :, 2] = 900.0
    return p


def cdf_declaring(path, frames: int) -> None:
    """A Human3.6M CDF of 5 frames whose variable ``Pose`` declares ``frames`` instead."""
    write_h36m_cdf(path, h36m_walking())
    data = bytearray(path.read_bytes())
    # the variable's descriptor: its name in 256 bytes, the number of dimensions, then each
    # dimension's size (big-endian int32): (5, 96) becomes (frames, 96)
    dims = data.index(b"Pose" + b"\0" * 252) + 256 + 4
    assert int.from_bytes(data[dims : dims + 4], "big") == 5
    data[dims : dims + 4] = frames.to_bytes(4, "big")
    path.write_bytes(bytes(data))


def videopose_npz(path, pickled: bytes) -> None:
    """A ``data_3d_h36m.npz`` whose ``positions_3d`` member is ``pickled`` behind the header
    VideoPose3D writes (a 0-d object array)."""
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "|O", "fortran_order": False, "shape": ()})
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("positions_3d.npy", head.getvalue() + pickled)


class _Reconstructed:
    """Pickles as NumPy's first step of an array, given a 15.4 GB float32 shape."""

    def __reduce__(self):
        return (_numpy_reconstruct(), (np.ndarray, HUGE_H36M, b"f"))


class _StatedObjects:
    """Pickles as an empty array whose state declares 40 M x 32 x 3 objects (30.7 GB,
    zero-filled by NumPy before any item is set) and holds none."""

    def __reduce__(self):
        return (
            _numpy_reconstruct(),
            (np.ndarray, (0,), b"b"),
            (1, HUGE_H36M, np.dtype(object), False, []),
        )


def _numpy_reconstruct():
    core = getattr(np, "_core", None) or np.core
    return core.multiarray._reconstruct


@pytest.mark.parametrize("tool", ["mine", "detect"])
def test_a_cdf_declaring_15_gb_is_refused_before_cdflib_allocates_it(tmp_path, tool) -> None:
    path = tmp_path / "S1" / "MyPoseFeatures" / "D3_Positions" / "Walking.cdf"
    cdf_declaring(path, HUGE_H36M[0])
    assert path.stat().st_size < 5_000
    # cdflib makes a zero-filled buffer of every declared byte before reading one record
    assert_refused(
        tool,
        path,
        f"{path}, Pose: the array declares 1 x 40000000 x 96 float32 values (15.4 GB): "
        f"more than the {limits.MAX_ARRAY_VALUES:,} values",
        tmp_path,
    )


@pytest.mark.parametrize("tool", ["mine", "detect"])
@pytest.mark.parametrize(
    "array, declared",
    [
        (_Reconstructed(), "40000000 x 32 x 3 float32"),
        (_StatedObjects(), "40000000 x 32 x 3 object"),
    ],
    ids=["reconstruct", "state"],
)
def test_a_pickled_array_declaring_gigabytes_is_refused_before_numpy_allocates_it(
    tmp_path, tool, array, declared
) -> None:
    path = tmp_path / "data_3d_h36m.npz"
    videopose_npz(path, pickle.dumps({"S1": {"Walking": array}}, protocol=3))
    assert path.stat().st_size < 1_000
    message = f"{path}, positions_3d: the array declares {declared} values"
    assert_refused(tool, path, message, tmp_path)


def deflate_bomb_npz(
    path, n_bytes: int, *, opcode: bytes = b"\x80\x03B", declared: int | None = None
) -> None:
    """A ``data_3d_h36m.npz`` whose pickle is one bytes object of ``n_bytes`` zeros, truly
    deflated (about a thousandth of its size): each 16 MiB block of zeros is deflated once,
    with a full flush, and its identical output repeated. ``opcode`` (after the protocol)
    takes ``n_bytes`` as its 4-byte length, or 8-byte with ``\\x95`` (a frame); the zip
    declares the member's true size, or ``declared`` (a lie)."""
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "|O", "fortran_order": False, "shape": ()})
    length = struct.pack("<Q" if opcode.endswith(b"\x95") else "<I", n_bytes)
    prefix = head.getvalue() + opcode + length
    block = bytes(1 << 24)
    blocks, rest = divmod(n_bytes, len(block))
    deflate = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = deflate.compress(prefix) + deflate.flush(zlib.Z_FULL_FLUSH)
    repeated = deflate.compress(block) + deflate.flush(zlib.Z_FULL_FLUSH)
    data = first + repeated * blocks + deflate.compress(bytes(rest) + b".") + deflate.flush()
    crc = zlib.crc32(prefix)
    for _ in range(blocks):
        crc = zlib.crc32(block, crc)
    crc = zlib.crc32(bytes(rest) + b".", crc)
    size = len(prefix) + n_bytes + 1 if declared is None else declared
    name = b"positions_3d.npy"
    local = struct.pack(
        "<IHHHHHIIIHH", 0x04034B50, 20, 0, 8, 0, 33, crc, len(data), size, len(name), 0
    )
    central = struct.pack(
        "<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, 8, 0, 33, crc, len(data), size, len(name),
        0, 0, 0, 0, 0, 0,
    )  # fmt: skip
    offset = len(local) + len(name) + len(data)
    end = struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, 1, 1, len(central) + len(name), offset, 0)
    path.write_bytes(local + name + data + central + name + end)


def test_a_pickle_inflating_past_the_bound_is_refused_before_it_is_inflated(tmp_path) -> None:
    # 1.2 GB of pickle: more than the 2**28 float32 values (1 GiB) one array may hold
    path = tmp_path / "data_3d_h36m.npz"
    deflate_bomb_npz(path, 1_200_000_000)
    assert path.stat().st_size < 2_000_000
    with zipfile.ZipFile(path) as zf:  # a well-formed archive, declaring what it inflates to
        assert zf.getinfo("positions_3d.npy").file_size == 1_200_000_136
    message = (
        f"{path}, positions_3d: the pickled dict, inflated and counted as float32 (as "
        "VideoPose3D stores it), declares 300000034 float32 values (1.2 GB): more than the "
        f"{limits.MAX_ARRAY_VALUES:,} values"
    )
    assert_refused("mine", path, message, tmp_path)


def test_a_pickle_of_more_opcodes_than_the_bound_is_refused_before_it_runs(tmp_path) -> None:
    # a list of empty lists: each one-byte opcode builds a 56-byte list (a few kilobytes of
    # deflated pickle could build gigabytes); past the bound, nothing is unpickled
    path = tmp_path / "data_3d_h36m.npz"
    videopose_npz(path, b"\x80\x03](" + b"]" * limits.MAX_PICKLE_OPCODES + b"e.")
    message = f"{path}, positions_3d: the pickle holds more than 1,048,576 opcodes"
    assert_refused("mine", path, message, tmp_path)


def test_a_memo_index_far_past_the_pickle_is_refused_before_it_runs(tmp_path) -> None:
    # LONG_BINPUT 2**30: the unpickler sizes its memo by the index (8 GB of pointers,
    # zero-filled) from a pickle of 9 bytes
    path = tmp_path / "data_3d_h36m.npz"
    videopose_npz(path, b"\x80\x03}r" + struct.pack("<I", 2**30) + b".")
    message = f"{path}, positions_3d: the pickle stores an object at memo index 1,073,741,824"
    assert_refused("detect", path, message, tmp_path)


@pytest.mark.parametrize(
    "pickled, index",
    [
        (b"(lp1073741824\n.", "1,073,741,824"),  # PUT, protocol 0: the index as text
        (b"\x80\x02]q\xff.", "255"),  # BINPUT: one byte
    ],
    ids=["PUT", "BINPUT"],
)
def test_a_memo_index_past_the_pickle_is_refused_in_every_form(tmp_path, pickled, index) -> None:
    path = tmp_path / "data_3d_h36m.npz"
    videopose_npz(path, pickled)
    message = f"{path}, positions_3d: the pickle stores an object at memo index {index} after"
    assert_refused("mine", path, message, tmp_path)


def test_a_bytes_object_longer_than_its_member_is_refused_before_it_is_allocated(
    tmp_path,
) -> None:
    # BINBYTES8 of 8 GiB in a pickle of a dozen bytes: the unpickler allocates the bytes
    # object whole before it reads any of it
    path = tmp_path / "data_3d_h36m.npz"
    videopose_npz(path, b"\x80\x04\x8e" + struct.pack("<Q", 2**33) + b".")
    message = (
        f"{path}, positions_3d: the pickle's opcode 2 declares 8,589,934,592 bytes in a member"
    )
    assert_refused("mine", path, message, tmp_path)


def test_a_frame_longer_than_a_lying_member_is_refused_before_it_is_inflated(tmp_path) -> None:
    # the zip declares 10 MB for a member that inflates to 1.2 GB, whose pickle opens a
    # frame of all of it: asked for the frame's length at once, zipfile inflates that much
    # before it cuts the data at the declared size (and finds the CRC wrong)
    path = tmp_path / "data_3d_h36m.npz"
    deflate_bomb_npz(path, 1_200_000_000, opcode=b"\x80\x04\x95", declared=10_000_000)
    assert path.stat().st_size < 2_000_000
    message = f"{path}, positions_3d: the pickle's opcode 2 declares 1,200,000,000 bytes in a"
    assert_refused("mine", path, message, tmp_path)


@pytest.mark.parametrize("compressed", ["variable", "file"])
def test_a_compressed_cdf_must_fit_in_free_memory_at_its_most(
    tmp_path, monkeypatch, compressed
) -> None:
    # cdflib inflates a compressed variable's blocks (its writer's default) and a compressed
    # file whole, with no bound: what they declare does not bound what they inflate to
    path = tmp_path / "S1" / "MyPoseFeatures" / "D3_Positions" / "Walking.cdf"
    path.parent.mkdir(parents=True)
    writer = cdflib.cdfwrite.CDF(path, cdf_spec={"Compressed": compressed == "file"})
    writer.write_var(
        {
            "Variable": "Pose",
            "Data_Type": 44,
            "Num_Elements": 1,
            "Rec_Vary": True,
            "Dim_Sizes": [5, 96],
            "Compress": 6 if compressed == "variable" else 0,
        },
        var_data=h36m_walking().reshape(1, 5, 96),
    )
    writer.close()
    (seq,) = read_source(path)  # read while the worst case fits
    assert np.array_equal(seq.positions, h36m_walking())
    size = path.stat().st_size
    free = size * 1032 - 1  # one byte short of deflate's 1032-fold worst case
    monkeypatch.setattr(machine, "available_memory_bytes", lambda: free)
    with pytest.raises(TurnbenchError) as exc:
        list(read_source(path))
    what = (
        "the CDF (compressed as a whole)" if compressed == "file" else "the variable (compressed)"
    )
    assert exc.value.message == (
        f"{what} is inflated whole when read: up to {size * 1032 / 1e9:.1f} GB from its "
        f"{size:,} bytes (deflate inflates at most 1032-fold), and this machine has "
        f"{free / 1e9:.1f} GB free"
    )


class _Reconstructed2D:
    """Pickles as NumPy's first step of a 40 M x 17 x 2 float32 array (5.4 GB)."""

    def __reduce__(self):
        return (_numpy_reconstruct(), (np.ndarray, (40_000_000, 17, 2), b"f"))


@pytest.mark.parametrize("command", ["predict", "detect"])
def test_videopose3d_2d_keypoints_are_refused_by_name_and_never_unpickled(
    tmp_path, command
) -> None:
    # VideoPose3D's 2D file: positions_2d, a pickled dict (this one declaring 5.4 GB)
    path = tmp_path / "data_2d_h36m_gt.npz"
    payload = np.empty((), dtype=object)
    payload[()] = {"S1": {"Walking": [_Reconstructed2D()]}}
    np.savez(path, positions_2d=payload)
    args = [command, path, "--from", "videopose3d", "--out", tmp_path / "o.csv"]
    code, lines, peak = run_bounded(
        "turn-eval", args + (["--fps", "50"] if command == "detect" else []), tmp_path
    )
    assert code == EXIT_BAD_INPUT and len(lines) == 1, lines
    assert lines[0].startswith(
        f"turn-eval: error: {path}: this is a 2D keypoint file (it holds ['positions_2d'])"
    )
    assert peak < REFUSED_PEAK_BYTES
    assert not (tmp_path / "o.csv").exists()
