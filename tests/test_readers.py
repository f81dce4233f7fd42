"""Readers: every format written by our writers, then read back; layout detection; bad input."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from turn_datasets import readers
from turn_datasets.errors import TurnbenchError


def _arr(n_frames: int, n_joints: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(n_frames, n_joints, 3))


# --- iter_arrays --------------------------------------------------------------------------


def test_iter_arrays_npy_yields_stem(tmp_path: Path) -> None:
    a = _arr(5, 17)
    np.save(tmp_path / "walk.npy", a)
    out = list(readers.iter_arrays(tmp_path / "walk.npy"))
    assert [k for k, _ in out] == ["walk"]
    np.testing.assert_array_equal(out[0][1], a)


def test_iter_arrays_npz_one_per_key_sorted(tmp_path: Path) -> None:
    a, b = _arr(4, 17, 1), _arr(6, 32, 2)
    np.savez(tmp_path / "two.npz", zeta=a, alpha=b)
    out = list(readers.iter_arrays(tmp_path / "two.npz"))
    assert [k for k, _ in out] == ["alpha", "zeta"]
    np.testing.assert_array_equal(out[0][1], b)
    np.testing.assert_array_equal(out[1][1], a)


def test_iter_arrays_h5_walks_nested_groups(tmp_path: Path) -> None:
    a, b, c = _arr(3, 17, 3), _arr(4, 17, 4), _arr(5, 17, 5)
    with h5py.File(tmp_path / "nested.h5", "w") as fh:
        fh["top"] = a
        fh.create_group("g").create_group("inner")["x"] = b
        fh["g"]["a"] = c
    out = dict(readers.iter_arrays(tmp_path / "nested.h5"))
    assert list(out) == ["g/a", "g/inner/x", "top"]
    np.testing.assert_array_equal(out["g/inner/x"], b)
    np.testing.assert_array_equal(out["top"], a)


@pytest.mark.parametrize("shape", [(5, 17), (5, 17, 2), (5, 17, 3, 1), (0, 17, 3)])
def test_iter_arrays_wrong_shape_names_file_key_shape(tmp_path: Path, shape) -> None:
    np.savez(tmp_path / "bad.npz", seq=np.zeros(shape))
    with pytest.raises(TurnbenchError) as exc:
        list(readers.iter_arrays(tmp_path / "bad.npz"))
    text = str(exc.value)
    assert "bad.npz" in text and "seq" in text and str(shape) in text


def test_iter_arrays_non_numeric(tmp_path: Path) -> None:
    np.save(tmp_path / "s.npy", np.full((2, 3, 3), "x"))
    with pytest.raises(TurnbenchError, match="dtype"):
        list(readers.iter_arrays(tmp_path / "s.npy"))


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
            list(readers.iter_arrays(path))
    h5 = tmp_path / "t.h5"
    h5.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 20)
    with pytest.raises(TurnbenchError, match="t.h5"):
        list(readers.iter_arrays(h5))


def test_iter_arrays_refuses_pickles(tmp_path: Path) -> None:
    np.savez(tmp_path / "p.npz", obj=np.array([{"a": 1}], dtype=object))
    with pytest.raises(TurnbenchError, match="p.npz"):
        list(readers.iter_arrays(tmp_path / "p.npz"))


def test_iter_arrays_unknown_suffix_and_missing(tmp_path: Path) -> None:
    (tmp_path / "x.txt").write_text("1")
    with pytest.raises(TurnbenchError, match="x.txt"):
        list(readers.iter_arrays(tmp_path / "x.txt"))
    with pytest.raises(TurnbenchError, match="nope.npy"):
        list(readers.iter_arrays(tmp_path / "nope.npy"))
