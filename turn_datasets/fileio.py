"""Atomic, reproducible output: every command writes through these helpers.

Files are written to a temporary file in the target folder and renamed into place, so a
crash or a bad input never leaves a half-written file. Several files that belong together
(``--out-dir``) are staged in a temporary folder and moved in only when all are written.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError

__all__ = [
    "atomic_path",
    "staged_dir",
    "write_text",
    "write_csv",
    "write_json",
    "to_json_text",
    "check_not_input",
    "sha256_file",
    "typed_frame",
]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes owner-only files; an output should get the user's usual permissions
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, target)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


@contextlib.contextmanager
def staged_dir(out_dir: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary folder; on success move everything in it into ``out_dir``.

    Files already in ``out_dir`` that the block did not write are left alone; files it did
    write replace their old versions. On failure nothing in ``out_dir`` changes.
    """
    target = Path(out_dir)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    try:
        yield tmp
        target.mkdir(parents=True, exist_ok=True)
        for src in sorted(tmp.rglob("*")):
            if src.is_dir():
                continue
            dst = target / src.relative_to(tmp)
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.chmod(src, 0o666 & ~_umask())
            os.replace(src, dst)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 text atomically with ``\\n`` line endings."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="\n")
    return Path(path)


def write_csv(df: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write a table as CSV (UTF-8, comma, header, no index) atomically and reproducibly."""
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, lineterminator="\n")
    return Path(path)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return None if not np.isfinite(obj) else float(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def _nan_to_none(obj: Any) -> Any:
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    if isinstance(obj, Mapping):
        return {k: _nan_to_none(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_nan_to_none(v) for v in obj]
    return obj


def to_json_text(obj: Any) -> str:
    """JSON text as every command writes it: NaN becomes null, two-space indent, newline."""
    return json.dumps(_nan_to_none(obj), indent=2, default=_json_default, allow_nan=False) + "\n"


def write_json(path: str | os.PathLike[str], obj: Any) -> Path:
    """Write JSON atomically (see :func:`to_json_text`)."""
    return write_text(path, to_json_text(obj))


def check_not_input(out: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]]) -> None:
    """Refuse to write over one of the command's own inputs."""
    out_path = Path(out).resolve()
    for item in inputs:
        p = Path(item)
        if p.exists() and p.resolve() == out_path:
            raise TurnbenchError(
                "the output would overwrite this input; choose another --out", file=str(item)
            )


def sha256_file(path: str | os.PathLike[str], chunk_size: int = 1 << 20) -> str:
    """Hex sha256 of a file, read in chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(chunk_size), b""):
            h.update(block)
    return h.hexdigest()


def typed_frame(df: pd.DataFrame, dtypes: Mapping[str, str]) -> pd.DataFrame:
    """Return ``df`` with exactly the columns of ``dtypes``, in that order and of those dtypes.

    The one place a result table's contract is enforced (as mobgap's ``_turn_df_types``).
    """
    missing = [c for c in dtypes if c not in df.columns]
    if missing:
        raise ValueError(f"table lacks columns {missing}")
    out = df.loc[:, list(dtypes)].copy()
    for col, dtype in dtypes.items():
        out[col] = out[col].astype(dtype)
    return out.reset_index(drop=True)
