"""Atomic, reproducible output: every command writes through these helpers.

Files are written to a temporary file in the target folder and renamed into place, so a
crash or a bad input never leaves a half-written file. Several files that belong together
(``--out-dir``) are staged in a temporary folder and moved in only when all are written.

A rename replaces whatever has the target's name, so an output path that exists and is not
a regular file (a symbolic link, a FIFO, a device, a socket, a folder) is refused, never
replaced (:func:`check_output_path`): ``--out /dev/null`` run as root would otherwise turn
the machine's null device into a CSV. A symbolic link is refused too rather than written
through: its target may be anywhere, and replacing the link with a file silently breaks it.

An output folder that a command cleans up (files one run writes and another does not:
figures, review copies) holds a run record, ``<name>.manifest.json``: every file the run
wrote with its sha256 (:func:`staged_dir`). The next run removes only files listed there
that still hold what was written, never a file matched by a pattern; and no input may lie
among what the folder owns (:func:`check_owned`).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import io
import json
import os
import shutil
import stat
import tempfile
import zipfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError

__all__ = [
    "manifest_path",
    "atomic_path",
    "staged_dir",
    "check_output_path",
    "check_owned",
    "check_files_and_folders",
    "read_run_record",
    "remove_recorded",
    "write_run_record",
    "write_text",
    "write_csv",
    "write_json",
    "write_npz",
    "to_json_text",
    "check_not_input",
    "sha256_file",
    "typed_frame",
    "walk_files",
]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _user_path(exc: OSError, tmp: Path, target: Path) -> OSError:
    """The error with the user's path in place of our hidden temporary one (which the user
    never gave and cannot find afterwards)."""
    name = exc.filename
    if name is None:
        return exc
    p = Path(name)
    if p == tmp or tmp in p.parents:
        shown = target if p == tmp else target / p.relative_to(tmp)
        return type(exc)(exc.errno, exc.strerror, str(shown))
    return exc


#: What a file type is called in a refusal (``stat.S_IFMT`` of ``lstat``).
_KINDS = {
    stat.S_IFLNK: "a symbolic link",
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
    stat.S_IFDIR: "a folder",
}


def check_output_path(path: str | os.PathLike[str], *, option: str = "--out") -> None:
    """Refuse an output path that exists and is not a regular file, before anything is
    written to it or beside it (a manifest, a temporary file).

    A rename onto a FIFO, a device or a socket replaces the node itself (as root, ``--out
    /dev/null`` leaves every process on the machine without a null device), so such a path
    is refused. So is a symbolic link, dangling or not: replacing it would break the link
    while its target kept the old content, and writing through it would write wherever it
    points; the message names its target, so the user may give that. A missing path,
    or one that cannot be examined (a folder without permission), is left to the write.

    Raises
    ------
    TurnbenchError
        Naming ``path``, what it is, and ``option``.
    """
    target = Path(path)
    try:
        mode = os.lstat(target).st_mode
    except OSError:
        return
    if stat.S_ISREG(mode):
        return
    kind = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
    if stat.S_ISLNK(mode):
        try:
            kind += f" to {os.readlink(target)}"
        except OSError:
            pass
    hint = f"choose another {option}"
    raise TurnbenchError(
        f"is {kind}, not a regular file: refusing to replace it", file=str(target), hint=hint
    )


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    The temporary file is hidden in the destination's own folder (the only folder the user
    asked us to write into), and an error names ``path``, not the temporary file. A ``path``
    that exists and is not a regular file is refused (:func:`check_output_path`) before the
    block runs, and again just before the rename (it may have appeared meanwhile).
    """
    target = Path(path)
    check_output_path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as exc:
        raise type(exc)(exc.errno, exc.strerror, str(target)) from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes owner-only files; an output should get the user's usual permissions
        os.chmod(tmp_path, 0o666 & ~_umask())
        check_output_path(target)
        os.replace(tmp_path, target)
    except OSError as exc:
        raise _user_path(exc, tmp_path, target) from None
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def _stage_folder(target: Path) -> tuple[Path, bool]:
    """A hidden temporary folder for ``target``'s files, and whether ``target`` was made.

    Beside ``target`` when its parent is writable (so a new ``target`` appears whole), else
    inside ``target`` itself: ``--out-dir ~/x`` or ``--out ~/labels.csv`` must work for a
    user who may write into their home but not into ``/home``.
    """
    parent = target.parent
    if parent.is_dir() and os.access(parent, os.W_OK | os.X_OK):
        try:
            return Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=parent)), False
        except OSError:
            pass  # a parent that says yes but refuses (a read-only mount): try inside
    created = not target.exists()
    target.mkdir(parents=True, exist_ok=True)
    try:
        return Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target)), created
    except OSError as exc:
        if created:
            target.rmdir()
        raise OSError(exc.errno, exc.strerror, str(target)) from None


def _record_parts(name: str) -> tuple[str, ...] | None:
    """A run record's file name as path parts inside its folder, or None for a name that would
    leave the folder (absolute, ``..``) or is not a plain relative path."""
    path = PurePosixPath(name)
    if path.is_absolute() or not path.parts or any(p in (".", "..") for p in path.parts):
        return None
    if "\\" in name or "\0" in name:
        return None
    return path.parts


def read_run_record(folder: str | os.PathLike[str], name: str) -> dict[str, str]:
    """The files a previous run listed in its run record ``folder/name``, with their sha256.

    Empty when there is no record, or it is not a regular file, not JSON of the form
    :func:`staged_dir` writes, or unreadable: a record we cannot trust lists nothing, so
    nothing is removed on its word. Names that would leave ``folder`` are dropped.
    """
    path = Path(folder) / name
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return {}
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    files = doc.get("files") if isinstance(doc, dict) else None
    if not isinstance(files, dict):
        return {}
    return {
        k: v
        for k, v in files.items()
        if isinstance(k, str) and isinstance(v, str) and k != name and _record_parts(k)
    }


def _record_text(files: Mapping[str, str]) -> str:
    """A run record's JSON: who wrote it, and every file the run wrote with its sha256."""
    return to_json_text({"written_by": f"turnbench {__version__}", "files": dict(files)})


def write_run_record(folder: str | os.PathLike[str], name: str, files: Mapping[str, str]) -> Path:
    """Write the run record ``folder/name`` (atomically): ``files`` maps each file the run
    wrote, relative to ``folder`` and ``/``-separated, to its sha256. :func:`staged_dir`
    writes one for its files; a run that writes into its folder directly (the demo) writes
    its own, and cleans up with :func:`remove_recorded`."""
    return write_text(Path(folder) / name, _record_text(files))


def remove_recorded(
    folder: str | os.PathLike[str], listed: Mapping[str, str], *, keep: Iterable[str] = ()
) -> tuple[list[Path], list[Path]]:
    """Remove the files of a previous run's record (``listed``, from :func:`read_run_record`)
    that still hold what that run wrote, except those in ``keep`` (this run's, about to be
    replaced); return the paths removed and those kept (changed since, or no longer a
    regular file reached through real folders). Nothing else is ever removed."""
    target = Path(folder)
    keep = set(keep)
    removed: list[Path] = []
    kept: list[Path] = []
    for name, digest in sorted(listed.items()):
        if name in keep:
            continue
        path = target.joinpath(*PurePosixPath(name).parts)
        if _still_ours(target, name, digest):
            path.unlink()
            removed.append(path)
        elif os.path.lexists(path):
            kept.append(path)
    return removed, kept


def check_files_and_folders(root: str | os.PathLike[str], *, option: str = "--out-dir") -> None:
    """Refuse anything at or under ``root`` that is neither a regular file nor a real folder
    (a symbolic link, a FIFO, a socket, a device), in one line naming the first, in sorted
    order (:func:`check_output_path`'s words): a run that cleans up or rewrites the folder
    would replace it, or write or remove through it. A missing ``root`` passes."""
    top = Path(root)
    try:
        mode = os.lstat(top).st_mode
    except OSError:
        return
    if not stat.S_ISDIR(mode):
        check_output_path(top, option=option)
        return
    for here, folders, files in os.walk(top):  # links are listed, never followed
        folders.sort()
        for name in sorted([*folders, *files]):
            path = Path(here) / name
            mode = os.lstat(path).st_mode
            if not (stat.S_ISDIR(mode) or stat.S_ISREG(mode)):
                check_output_path(path, option=option)


def _check_destination(target: Path, name: str) -> None:
    """Refuse to move a staged file to ``target/name`` when something there is not ours to
    replace: a path component under ``target`` that is not a real folder (a symbolic link
    would carry the file elsewhere), or a destination that is not a regular file."""
    parts = PurePosixPath(name).parts
    here = target
    for part in parts[:-1]:
        here = here / part
        try:
            mode = os.lstat(here).st_mode
        except OSError:
            break
        if not stat.S_ISDIR(mode):
            kind = _KINDS.get(stat.S_IFMT(mode), "a file")
            raise TurnbenchError(
                f"is {kind}, not a folder: refusing to write {name} through it",
                file=str(here),
                hint="remove it, or choose another --out-dir",
            )
    check_output_path(target / name, option="--out-dir")


def _still_ours(target: Path, name: str, digest: str) -> bool:
    """Whether ``target/name`` is a regular file, reached through real folders, that still
    holds what a run wrote (``digest``, its sha256 then)."""
    here = target
    parts = PurePosixPath(name).parts
    try:
        for part in parts[:-1]:
            here = here / part
            if not stat.S_ISDIR(os.lstat(here).st_mode):
                return False
        path = here / parts[-1]
        return stat.S_ISREG(os.lstat(path).st_mode) and sha256_file(path) == digest
    except OSError:
        return False


def _move_in(tmp: Path, target: Path, record: str | None) -> tuple[set[str], dict[str, str]]:
    """Move the staged files of ``tmp`` into ``target``, the run record last; return their
    names (relative, ``/``-separated) and the previous run's record."""
    staged = [src for src in sorted(tmp.rglob("*")) if not src.is_dir()]
    names = [src.relative_to(tmp).as_posix() for src in staged]
    for name in [*names, *([record] if record else [])]:
        _check_destination(target, name)
    previous = read_run_record(target, record) if record else {}
    if record:
        files = {name: sha256_file(src) for name, src in zip(names, staged, strict=True)}
        staged.append(tmp.joinpath(*PurePosixPath(record).parts))
        staged[-1].write_text(_record_text(files), encoding="utf-8", newline="\n")
        names.append(record)
    for src, name in zip(staged, names, strict=True):
        dst = target.joinpath(*PurePosixPath(name).parts)
        dst.parent.mkdir(parents=True, exist_ok=True)
        os.chmod(src, 0o666 & ~_umask())
        check_output_path(dst, option="--out-dir")  # again: it may have appeared meanwhile
        os.replace(src, dst)
    return set(names), previous


@contextlib.contextmanager
def staged_dir(
    out_dir: str | os.PathLike[str],
    *,
    record: str | None = None,
    removed: list[Path] | None = None,
    kept: list[Path] | None = None,
) -> Iterator[Path]:
    """Yield a temporary folder; on success move everything in it into ``out_dir``.

    Files the block wrote replace their old versions; a destination that is not a regular
    file, or lies behind a path component that is not a real folder, is refused before
    anything moves (:func:`check_output_path`). With ``record`` (a file name such as
    ``scores.manifest.json``), the run is recorded in ``out_dir/record``: every file it wrote
    and its sha256. A file the previous run's record lists and this run did not write is
    removed (appended to ``removed``) when it still holds what that run wrote, and kept
    otherwise (appended to ``kept``: the user has changed it). Nothing else in ``out_dir`` is
    ever removed: no file is removed for matching a pattern. On failure nothing in
    ``out_dir`` changes, and errors name ``out_dir``'s files, not the temporary folder.
    """
    target = Path(out_dir)
    if target.exists() and not target.is_dir():
        raise NotADirectoryError(20, "Not a directory", str(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp, created = _stage_folder(target)
    try:
        yield tmp
        target.mkdir(parents=True, exist_ok=True)
        written, previous = _move_in(tmp, target, record)
        gone, changed = remove_recorded(target, previous, keep=written)
        if removed is not None:
            removed.extend(gone)
        if kept is not None:
            kept.extend(changed)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if created and target.is_dir() and not any(target.iterdir()):
            target.rmdir()
        if isinstance(exc, OSError):
            raise _user_path(exc, tmp, target) from None
        raise
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


def manifest_path(output: str | os.PathLike[str]) -> Path:
    """Where an output's manifest goes: ``turn-h36m.csv`` -> ``turn-h36m.manifest.json``,
    ``poses.npz`` -> ``poses.manifest.json``, beside it."""
    p = Path(output)
    return p.with_name(f"{p.stem}.manifest.json")


def write_json(path: str | os.PathLike[str], obj: Any) -> Path:
    """Write JSON atomically (see :func:`to_json_text`)."""
    return write_text(path, to_json_text(obj))


def write_npz(path: str | os.PathLike[str], arrays: Mapping[str, np.ndarray]) -> Path:
    """An ``.npz``: one ``.npy`` member per key (sorted), atomically, with fixed timestamps, so
    the same arrays give the same bytes (``np.savez`` stamps the current time). Deflated at
    level 1: noisy float32 skeletons hardly compress further, and writing them is timed."""
    target = Path(path)
    with atomic_path(target) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
            for key in sorted(arrays):
                info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                buffer = io.BytesIO()
                np.lib.format.write_array(buffer, np.asarray(arrays[key]), allow_pickle=False)
                zf.writestr(info, buffer.getvalue(), compresslevel=1)
    return target


def write_files(folder: str | os.PathLike[str], files: Mapping[str, Any]) -> list[Path]:
    """Write several outputs into ``folder``, each by its name's suffix, and return the paths.

    ``name.json``: :func:`write_json` of the object; a ``pandas.DataFrame``: :func:`write_csv`;
    text: :func:`write_text`. One call writes a command's set of tables (the JSON document,
    its Markdown and its CSV), so every command writes them alike.
    """
    paths = []
    for name, content in files.items():
        path = Path(folder) / name
        if name.endswith(".json"):
            paths.append(write_json(path, content))
        elif isinstance(content, pd.DataFrame):
            paths.append(write_csv(content, path))
        else:
            paths.append(write_text(path, content))
    return paths


def check_not_input(
    out: str | os.PathLike[str],
    inputs: Iterable[str | os.PathLike[str]],
    *,
    option: str = "--out",
) -> None:
    """Refuse an output path that is one of the command's own inputs, or that exists and is
    not a regular file (:func:`check_output_path`); ``option``, the command's output option,
    is named in the message. Commands call it before any work."""
    check_output_path(out, option=option)
    out_path = Path(out).resolve()
    for item in inputs:
        p = Path(item)
        if p.exists() and p.resolve() == out_path:
            raise TurnbenchError(
                f"{out} would overwrite this input; choose another {option}", file=str(item)
            )


def check_owned(
    out_dir: str | os.PathLike[str],
    inputs: Iterable[str | os.PathLike[str]],
    *,
    names: Iterable[str] = (),
    folders: Iterable[str] = (),
    record: str | None = None,
    option: str = "--out-dir",
) -> None:
    """Refuse an input that lies among what the output folder ``out_dir`` owns.

    The folder owns ``names`` (the files a run writes there), its run record ``record`` and
    every file the previous run's record lists (:func:`read_run_record`), and everything in
    ``folders`` (subfolders a run fills: review copies, one figure per session). Such an
    input would be replaced or removed by the run, or read again as the next run's input.
    Paths are compared after resolving symbolic links.
    """
    target = Path(out_dir)
    files = set(names)
    if record is not None:
        files.add(record)
        files.update(read_run_record(target, record))
    owned = {target.joinpath(*PurePosixPath(f).parts).resolve(): f for f in files}
    owned_dirs = {(target / d).resolve(): d for d in folders}
    for item in inputs:
        p = Path(item)
        if not os.path.lexists(p):
            continue
        real = p.resolve()
        if real in owned:
            raise TurnbenchError(
                f"is {owned[real]} of {option} {target}, which a run overwrites or removes; "
                f"choose another {option}",
                file=str(item),
            )
        for folder, name in owned_dirs.items():
            if real == folder or folder in real.parents:
                raise TurnbenchError(
                    f"lies in {target / name}, whose files a run of {option} {target} "
                    f"overwrites or removes; choose another {option}",
                    file=str(item),
                )


def walk_files(
    root: str | os.PathLike[str],
    *,
    on_unreadable: Callable[[Path, OSError], None] | None = None,
) -> list[Path]:
    """Every non-hidden file under ``root``, subfolders included, in a reproducible order.

    Folders reached through a symbolic link are walked too (a dataset assembled from links,
    ``ROOT/S5 -> /mnt/disk2/S5``, is one dataset), each real folder once, so a link back up
    the tree ends instead of looping. Hidden folders and files (``.git``, macOS's
    ``._name`` forks) are skipped. A folder that cannot be read is passed to
    ``on_unreadable`` with the error, or, without one, raised as :class:`TurnbenchError`
    naming it: never dropped in silence.

    Returns
    -------
    list of Path
        Sorted by their path relative to ``root`` (code points), so the same tree gives the
        same list on every machine.
    """
    top = Path(root)
    found: list[Path] = []
    seen: set[tuple[int, int]] = set()

    def failed(exc: OSError) -> None:
        where = Path(exc.filename) if exc.filename else top
        if on_unreadable is None:
            raise TurnbenchError(
                f"cannot read this folder: {exc.strerror or exc}", file=where
            ) from None
        on_unreadable(where, exc)

    for dirpath, dirnames, filenames in os.walk(top, onerror=failed, followlinks=True):
        here = os.stat(dirpath)
        key = (here.st_dev, here.st_ino)
        if key in seen:  # a link to a folder already walked (or to an ancestor): a loop
            dirnames[:] = []
            continue
        seen.add(key)
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        found.extend(Path(dirpath) / f for f in filenames if not f.startswith("."))
    return sorted(found, key=lambda p: p.relative_to(top).parts)


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
    if not df.columns.is_unique:
        out = df.loc[:, list(dtypes)].copy()
        for col, dtype in dtypes.items():
            out[col] = out[col].astype(dtype)
        return out.reset_index(drop=True)
    # Each column cast by pandas' own rules (a column already of its dtype as it is) and the
    # frame built once from the arrays (a copy): the same table as selecting, casting column
    # by column and re-indexing, at a fraction of the cost (this runs several times per
    # stream in ``turn-eval detect``).
    columns = {}
    for col, dtype in dtypes.items():
        column = df[col]
        same = column.dtype == _pandas_dtype(dtype)
        columns[col] = (column if same else column.astype(dtype)).array
    return pd.DataFrame(columns, index=pd.RangeIndex(len(df)), copy=True)


@functools.cache
def _pandas_dtype(name: str) -> Any:
    """The dtype pandas makes of ``name`` (``"str"``: this pandas' string dtype), found once."""
    return pd.api.types.pandas_dtype(name)
