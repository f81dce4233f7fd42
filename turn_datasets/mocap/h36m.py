"""Human3.6M's three releases of 3-D positions, and its subject and action names.

``cdf``
    The original release, ``S*/MyPoseFeatures/D3_Positions/<Action>.cdf``: variable
    ``Pose`` of shape ``(1, N, 96)``, millimetres, 50 Hz, z up, 32 joints (read with cdflib;
    the record count and dimensions the variable declares are checked before it is read, and
    compressed data, which cdflib inflates whole, must fit in free memory at its most).
``h36m-h5``
    3d-pose-baseline's copy, ``S*/MyPoses/3D_positions/<Action>.h5``: dataset
    ``3D_positions`` stored ``(96, N)``; transposed, then ``(N, 32, 3)``, millimetres.
``videopose-npz``
    VideoPose3D's ``data_3d_h36m.npz``: ``positions_3d``, a *pickled* dict subject -> action
    -> float32 ``(N, 32, 3)`` in metres. Unpickling can run code, so such a file is only
    read when the user named it, or when it is exactly ``data_3d_h36m.npz`` at a dataset
    root the user named (:mod:`turn_datasets.mocap.readers`); its member's header is checked
    first (a 0-d object array), and the pickle is read by an unpickler that builds NumPy
    arrays, dtypes and plain containers only, so a file whose pickle would import anything
    else (``os.system``) is refused before any of it runs. What the pickle may build is
    bounded: the size the zip declares for it before it is inflated, each opcode before the
    unpickler acts on it, and every array's shape before NumPy allocates it. It is inflated
    once, as it is unpickled, and its sequences yielded one by one.

The subject comes from the ``S<n>`` folder (or the npz key) and the action and trial from
the name on disk (:func:`parse_h36m_action`). The three share these names and the frame
rate, so they live together.
"""

from __future__ import annotations

import importlib
import os
import pickle
import pickletools
import re
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any, NamedTuple

import cdflib
import h5py
import numpy as np

from turn_datasets import limits
from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap.arrays import npy_header, read_h5_dataset
from turn_datasets.mocap.checks import (
    CORRUPT,
    OnBadSequence,
    check_declared_size,
    check_inflation,
    checked_positions,
    skip_bad,
    unreadable,
)
from turn_datasets.render.order import natural_key
from turn_datasets.skeleton import (
    H36M17,
    H36M32,
    MocapSequence,
)

__all__ = [
    "H36M_FPS",
    "H36M_ACTIONS",
    "H36M_ACTION_ALIASES",
    "parse_h36m_action",
    "h36m_subject_of",
    "H36M_CDF_VARIABLE",
    "H36M_H5_DATASET",
    "VIDEOPOSE_KEY",
    "read_h36m_cdf",
    "read_h36m_h5",
    "read_videopose_npz",
]


H36M_FPS = 50.0


H36M_CDF_VARIABLE = "Pose"


H36M_H5_DATASET = "3D_positions"


VIDEOPOSE_KEY = "positions_3d"


#: The 15 Human3.6M actions, in the one spelling the clip index uses.
H36M_ACTIONS = (
    "Directions",
    "Discussion",
    "Eating",
    "Greeting",
    "Phoning",
    "Photo",
    "Posing",
    "Purchases",
    "Sitting",
    "SittingDown",
    "Smoking",
    "Waiting",
    "WalkDog",
    "Walking",
    "WalkTogether",
)


#: Other spellings found on disk -> the canonical one. Matching ignores case, spaces and
#: underscores, so "Walking Dog" and "walkingdog" are WalkDog too.
H36M_ACTION_ALIASES: Mapping[str, str] = MappingProxyType(
    {
        "TakingPhoto": "Photo",  # S1's name, and some copies of the other subjects
        "WalkingDog": "WalkDog",  # some copies of S1 and of 3d-pose-baseline's files
        "WalkingTogether": "WalkTogether",
    }
)


def _action_key(name: str) -> str:
    return re.sub(r"[\s_]+", "", name).lower()


_ACTION_TABLE: Mapping[str, str] = MappingProxyType(
    {
        **{_action_key(a): a for a in H36M_ACTIONS},
        **{_action_key(k): v for k, v in H36M_ACTION_ALIASES.items()},
    }
)


# "<name>[ <trial>][.<camera id>]", e.g. "Walking", "Walking 1", "Walking 1.54138969"
_ACTION_RE = re.compile(
    r"^(?P<name>[A-Za-z][A-Za-z _]*?)(?:[ _]+(?P<trial>\d+))?(?:\.(?P<camera>\d+))?$"
)


def parse_h36m_action(name: str) -> tuple[str, str]:
    """A Human3.6M action name as found on disk -> ``(canonical action, subaction)``.

    ========================================  ==================  ==========
    on disk                                   action              subaction
    ========================================  ==================  ==========
    ``Walking``                               ``Walking``         ``""``
    ``Walking 1``                             ``Walking``         ``"1"``
    ``Walking 1.54138969`` (camera suffix)    ``Walking``         ``"1"``
    ``TakingPhoto``, ``TakingPhoto 1``        ``Photo``           ``""``, ``"1"``
    ``Photo``, ``Photo 2``                    ``Photo``           ``""``, ``"2"``
    ``WalkDog 1``, ``WalkingDog``             ``WalkDog``         ``"1"``, ``""``
    ``WalkTogether``, ``WalkingTogether 1``   ``WalkTogether``    ``""``, ``"1"``
    ``Discussion 1``, ``Directions 2``        as written          ``"1"``, ``"2"``
    ========================================  ==================  ==========

    The canonical actions are :data:`H36M_ACTIONS`; the other spellings are
    :data:`H36M_ACTION_ALIASES` (case, spaces and underscores are ignored when matching).

    The subaction is the trial number exactly as the file name writes it, ``""`` when there
    is none. Human3.6M records each action twice per subject and names the two files
    inconsistently: mostly ``"Walking"`` and ``"Walking 1"``, but S1 has ``"Eating"`` and
    ``"Eating 2"`` and S5 ``"Discussion 2"`` and ``"Discussion 3"``. Keeping the number as
    written keeps every (subject, action, subaction) unique and traceable to its file;
    renumbering to 1/2 would need a per-subject table that no release documents. S11 lacks
    ``"Directions 2"`` in some copies; that is a missing file, not a naming problem.

    Raises
    ------
    TurnbenchError
        A name that is none of the 15 actions.
    """
    match = _ACTION_RE.match(name.strip())
    canonical = _ACTION_TABLE.get(_action_key(match.group("name"))) if match else None
    if match is None or canonical is None:
        raise TurnbenchError(
            f"{name!r} is not a Human3.6M action name; expected one of "
            f"{', '.join(H36M_ACTIONS)} (or {', '.join(H36M_ACTION_ALIASES)}), optionally "
            "followed by a trial number"
        )
    return canonical, match.group("trial") or ""


_SUBJECT_RE = re.compile(r"^S\d+$")


def h36m_subject_of(path: str | os.PathLike[str]) -> str:
    """The Human3.6M subject (``"S9"``) of a file: the nearest ``S<n>`` folder above it."""
    for parent in Path(path).absolute().parents:
        if _SUBJECT_RE.match(parent.name):
            return parent.name
    raise TurnbenchError(
        "cannot tell the Human3.6M subject: the file is not inside an S<n> folder",
        file=path,
        hint="keep the release's layout, e.g. S1/MyPoseFeatures/D3_Positions/Walking.cdf",
    )


def _h36m_file_sequence(
    path: Path, positions: np.ndarray, fmt: str, subject: str, action: tuple[str, str]
) -> MocapSequence:
    """One Human3.6M sequence stored one per file (CDF, h5): 32 joints, 50 Hz, millimetres."""
    return MocapSequence(
        subject=subject,
        action=action[0],
        subaction=action[1],
        positions=checked_positions(positions, H36M32, path=path, item=None),
        layout=H36M32,
        fps=H36M_FPS,
        units="mm",
        source=str(path),
        meta={"format": fmt, "name_on_disk": path.stem},
    )


#: CDF data types (the CDF specification's codes) -> the NumPy type cdflib reads them as.
_CDF_NUMBER_TYPES: Mapping[int, str] = MappingProxyType(
    {
        1: "i1", 2: "i2", 4: "i4", 8: "i8", 11: "u1", 12: "u2", 14: "u4", 21: "f4",
        22: "f8", 31: "f8", 32: "c16", 33: "i8", 41: "i1", 44: "f4", 45: "f8",
    }
)  # fmt: skip
_CDF_MAGIC = (b"\xcd\xf3\x00\x01", b"\xcd\xf2\x60\x02", b"\x00\x00\xff\xff")
_CDF_UNCOMPRESSED = b"\x00\x00\xff\xff"
_CDF_DECOMPRESS_HINT = (
    "write it again uncompressed, e.g. with NASA's cdfconvert and its -compression option"
)


def _check_whole_file_compression(path: Path) -> None:
    """A CDF compressed as a whole is inflated by cdflib whole, at open, into memory:
    refused unless the most it can inflate to fits in free memory
    (:func:`~turn_datasets.mocap.checks.check_inflation`)."""
    with unreadable("the CDF header", path, guess="truncated or corrupt CDF?"):
        with open(path, "rb") as fh:
            head = fh.read(8)
        size = path.stat().st_size
    if head[:4] in _CDF_MAGIC and head[4:8] != _CDF_UNCOMPRESSED:
        check_inflation(
            size,
            path=path,
            item=None,
            what="the CDF (compressed as a whole)",
            hint=_CDF_DECOMPRESS_HINT,
        )


def _check_cdf_variable(cdf: cdflib.CDF, path: Path) -> None:
    """Check what variable ``Pose`` declares, its record count and dimensions (``varinq``),
    with :func:`~turn_datasets.mocap.checks.check_declared_size` before cdflib allocates it
    (cdflib makes the whole zero-filled buffer first); a compressed variable's blocks are
    inflated whole, whatever they hold, so they must fit in free memory at their most."""
    with unreadable(f"variable {H36M_CDF_VARIABLE!r}", path, guess="truncated or corrupt CDF?"):
        info = cdf.varinq(H36M_CDF_VARIABLE)
        stored = Path(cdf.file).stat().st_size  # the inflated copy, for a compressed file
    dtype = _CDF_NUMBER_TYPES.get(int(info.Data_Type))
    if dtype is None:
        raise TurnbenchError(
            f"variable {H36M_CDF_VARIABLE!r} holds {info.Data_Type_Description}, not numbers",
            file=path,
        )
    records = max(int(info.Last_Rec) + 1, 0) if info.Rec_Vary else 1
    dims = [int(n) for n, vary in zip(info.Dim_Sizes, info.Dim_Vary, strict=False) if vary]
    check_declared_size((records, *dims), dtype, path=path, item=H36M_CDF_VARIABLE)
    if info.Compress:
        check_inflation(
            stored,
            path=path,
            item=H36M_CDF_VARIABLE,
            what="the variable (compressed)",
            hint=_CDF_DECOMPRESS_HINT,
        )


def read_h36m_cdf(path: Path) -> Iterator[MocapSequence]:
    # subject and action first: a file outside the release's layout is refused unread
    subject = h36m_subject_of(path)
    action = _action_of(path.stem, path)
    _check_whole_file_compression(path)
    with unreadable("CDF", path, guess="truncated or corrupt CDF?"):
        cdf = cdflib.CDF(path)
    with cdf:
        _check_cdf_variable(cdf, path)
        with unreadable(f"variable {H36M_CDF_VARIABLE!r}", path, guess="truncated or corrupt CDF?"):
            pose = np.asarray(cdf.varget(H36M_CDF_VARIABLE))
    if pose.ndim == 3 and pose.shape[0] == 1:
        pose = pose[0]
    if pose.ndim != 2 or pose.shape[1] != 96:
        raise TurnbenchError(
            f"variable {H36M_CDF_VARIABLE!r} has shape {pose.shape}, expected (1, N, 96)",
            file=path,
        )
    yield _h36m_file_sequence(path, pose.reshape(pose.shape[0], 32, 3), "cdf", subject, action)


def read_h36m_h5(path: Path) -> Iterator[MocapSequence]:
    subject = h36m_subject_of(path)
    action = _action_of(path.stem, path)
    stored, names = None, []
    with unreadable("HDF5", path), h5py.File(path, "r") as fh:
        dset = fh.get(H36M_H5_DATASET)
        if isinstance(dset, h5py.Dataset):
            stored = read_h5_dataset(fh, H36M_H5_DATASET, path)  # size and storage checked
        else:
            names = sorted(fh)
    if stored is None:
        raise TurnbenchError(f"no dataset {H36M_H5_DATASET!r} (datasets: {names})", file=path)
    if stored.ndim != 2 or stored.shape[0] != 96:
        raise TurnbenchError(
            f"dataset {H36M_H5_DATASET!r} has shape {stored.shape}, expected (96, N)",
            file=path,
        )
    # 3d-pose-baseline stores one column per frame: transpose, then 32 joints x 3
    yield _h36m_file_sequence(
        path, stored.T.reshape(stored.shape[1], 32, 3), "h36m-h5", subject, action
    )


def _action_of(name: str, path: Path, item: str | None = None) -> tuple[str, str]:
    try:
        return parse_h36m_action(name)
    except TurnbenchError as exc:
        raise TurnbenchError(exc.message, file=path, item=item) from None


#: What a pickled dict of NumPy arrays needs, and nothing else: numpy 1 and 2 names.
_PICKLE_ALLOWED = frozenset(
    {
        ("numpy.core.multiarray", "_reconstruct"),
        ("numpy._core.multiarray", "_reconstruct"),
        ("numpy.core.multiarray", "scalar"),
        ("numpy._core.multiarray", "scalar"),
        ("numpy", "ndarray"),
        ("numpy", "dtype"),
    }
)


def _numpy_global(module: str, name: str):
    try:
        return getattr(importlib.import_module(module.replace("numpy.core", "numpy._core")), name)
    except ImportError:  # numpy 1 has no numpy._core
        return getattr(importlib.import_module(module), name)


def _check_pickled_shape(shape: Any, dtype: Any) -> None:
    """The one declared-size check for an array a pickle asks NumPy to make: its shape with
    any sub-array dtype's own shape, in the dtype's base type."""
    dt = np.dtype(dtype)
    dims = (shape,) if isinstance(shape, (int, np.integer)) else tuple(shape)
    check_declared_size(
        tuple(int(n) for n in dims) + dt.shape, dt.base, path=None, item=VIDEOPOSE_KEY
    )


class _CheckedArray(np.ndarray):
    """The ndarray an unpickled array is built as: the shape and dtype it declares, to
    ``ndarray(...)`` or in its pickled state, are checked before NumPy allocates them (an
    object array is zero-filled at once, 8 bytes a value, whatever data follows)."""

    def __new__(cls, shape, dtype=float, *args, **kwargs):
        _check_pickled_shape(shape, dtype)
        return super().__new__(cls, shape, dtype, *args, **kwargs)

    def __setstate__(self, state, /) -> None:
        # (version, shape, dtype, is_fortran, data), or without the version
        if isinstance(state, tuple) and len(state) in (4, 5):
            _check_pickled_shape(state[-4], state[-3])
        super().__setstate__(state)


def _checked_reconstruct(subtype: Any, shape: Any, dtype: Any) -> np.ndarray:
    """NumPy's ``_reconstruct`` (the pickled array's first step), the shape it is given
    checked first; always a :class:`_CheckedArray`, whatever type the pickle names."""
    _check_pickled_shape(shape, dtype)
    return _numpy_global("numpy.core.multiarray", "_reconstruct")(_CheckedArray, shape, dtype)


class _ArraysOnly(pickle.Unpickler):
    """An unpickler that builds NumPy arrays and plain containers, and refuses any other
    global: a pickle that names ``os.system`` (or anything else) fails before it runs. Every
    array's declared shape is checked before it is allocated (:class:`_CheckedArray`)."""

    def find_class(self, module: str, name: str):
        if (module, name) not in _PICKLE_ALLOWED:
            raise pickle.UnpicklingError(f"refused to load {module}.{name}")
        if name == "_reconstruct":
            return _checked_reconstruct
        if name == "ndarray":
            return _CheckedArray
        return _numpy_global(module, name)


def _plain(obj: object) -> object:
    """``obj`` with every :class:`_CheckedArray` in its dicts a plain ndarray again."""
    if isinstance(obj, _CheckedArray):
        return obj.view(np.ndarray)
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    return obj


def _read_object_header(fh, path: Path) -> None:
    """Read the member's ``.npy`` header; it must be what VideoPose3D writes, a 0-d object
    array (a pickled dict)."""
    shape, dtype = npy_header(fh)
    if dtype != np.dtype(object) or shape != ():
        raise TurnbenchError(
            f"{VIDEOPOSE_KEY!r} is a {dtype} array of shape {shape}, not "
            "a dict subject -> action -> array (VideoPose3D's pickled dict)",
            file=path,
        )


class _Argument(NamedTuple):
    """How an opcode's argument is laid out in the stream (pickletools' table)."""

    #: Bytes of a fixed argument, or of the length before a counted payload.
    size: int
    #: Newline-ended lines instead (GLOBAL and INST take two: module and name).
    lines: int
    #: ``size`` bytes are the length of a payload that follows.
    counted: bool
    #: That length is signed.
    signed: bool


def _argument(arg: pickletools.ArgumentDescriptor | None) -> _Argument:
    if arg is None:
        return _Argument(0, 0, False, False)
    if arg.n >= 0:
        return _Argument(arg.n, 0, False, False)
    if arg.n == pickletools.UP_TO_NEWLINE:
        return _Argument(0, 2 if arg is pickletools.stringnl_noescape_pair else 1, False, False)
    size, signed = {
        pickletools.TAKEN_FROM_ARGUMENT1: (1, False),
        pickletools.TAKEN_FROM_ARGUMENT4: (4, True),
        pickletools.TAKEN_FROM_ARGUMENT4U: (4, False),
        pickletools.TAKEN_FROM_ARGUMENT8U: (8, False),
    }[arg.n]
    return _Argument(size, 0, True, signed)


#: Every opcode (its byte) -> its argument's layout.
_ARGUMENTS: Mapping[int, _Argument] = MappingProxyType(
    {ord(op.code): _argument(op.arg) for op in pickletools.opcodes}
)
_PUT, _BINPUT, _LONG_BINPUT, _STOP, _FRAME = (ord(c) for c in "pqr.\x95")


class _CheckedPickleStream:
    """The pickle as the unpickler reads it, every opcode checked before it is handed over.

    At most :data:`turn_datasets.limits.MAX_PICKLE_OPCODES` opcodes; no object stored at a
    memo index past the opcodes before it (the unpickler sizes its memo by the index: six
    bytes could ask for gigabytes); no counted payload (bytes, a string) or frame longer
    than the member (the unpickler allocates a payload before reading it, and asks zipfile
    for a frame's length at once, which it inflates up to that length whatever the member
    declares). The opcodes are parsed as
    pickletools lays them out, and a payload is passed over by its length, so the arrays'
    bytes cost nothing; the pickle is inflated once, as the unpickler reads it. There is no
    ``peek``, so the unpickler acts only on bytes :meth:`read` or :meth:`readline` returned,
    which are checked before they are returned.
    """

    def __init__(self, raw: Any, size: int) -> None:
        self._raw = raw
        self._size = size
        self._opcodes = 0
        self._code = -1  # the opcode whose argument is still arriving; -1 between opcodes
        self._arg = bytearray()  # that argument so far (not kept for text lines)
        self._lines = 0  # its newlines still to come
        self._skip = 0  # payload bytes still to pass over
        self._stopped = False

    def read(self, size: int = -1) -> bytes:
        return self._checked(self._raw.read(size))

    def readline(self, size: int = -1) -> bytes:
        return self._checked(self._raw.readline(size))

    def _checked(self, data: bytes) -> bytes:
        at = 0
        while at < len(data) and not self._stopped:
            if self._skip:
                step = min(self._skip, len(data) - at)
                self._skip -= step
                at += step
            elif self._code < 0:
                self._opcode(data[at])
                at += 1
            elif self._lines:
                end = data.find(b"\n", at)
                stop = len(data) if end < 0 else end + 1
                if self._code == _PUT:
                    self._arg += data[at:stop]
                at = stop
                if end >= 0:
                    self._lines -= 1
                    if not self._lines:
                        self._done()
            else:
                step = min(_ARGUMENTS[self._code].size - len(self._arg), len(data) - at)
                self._arg += data[at : at + step]
                at += step
                if len(self._arg) == _ARGUMENTS[self._code].size:
                    self._done()
        return data

    def _opcode(self, code: int) -> None:
        self._opcodes += 1
        if self._opcodes > limits.MAX_PICKLE_OPCODES:
            raise TurnbenchError(
                f"the pickle holds more than {limits.MAX_PICKLE_OPCODES:,} opcodes, which "
                "no VideoPose3D dict needs (27 a sequence): corrupt or crafted",
                item=VIDEOPOSE_KEY,
            )
        arg = _ARGUMENTS.get(code)
        if arg is None:
            raise ValueError(f"the pickle's opcode {self._opcodes:,} ({code:#04x}) is unknown")
        self._code, self._lines = code, arg.lines
        if not (arg.size or arg.lines):
            self._done()

    def _done(self) -> None:
        """The opcode's argument is complete: check it."""
        arg = _ARGUMENTS[self._code]
        if arg.counted or self._code == _FRAME:
            length = int.from_bytes(self._arg, "little", signed=arg.signed)
            if not 0 <= length <= self._size:
                raise TurnbenchError(
                    f"the pickle's opcode {self._opcodes:,} declares {length:,} "
                    f"bytes in a member of {self._size:,}: corrupt or crafted",
                    item=VIDEOPOSE_KEY,
                )
            if arg.counted:  # a frame holds opcodes
                self._skip = length
        elif self._code in (_PUT, _BINPUT, _LONG_BINPUT):
            index = int(self._arg) if self._code == _PUT else int.from_bytes(self._arg, "little")
            if index > self._opcodes:
                raise TurnbenchError(
                    f"the pickle stores an object at memo index {index:,} after only "
                    f"{self._opcodes} opcodes: corrupt or crafted",
                    item=VIDEOPOSE_KEY,
                )
        self._stopped = self._code == _STOP
        self._code = -1
        self._arg.clear()


def _unpickle_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, path: Path) -> object:
    """The member's pickled object, after what bounds the memory unpickling takes: the
    size the zip declares for the inflated pickle (zipfile inflates no more) checked as the
    float32 values it can hold, then each opcode as it is read
    (:class:`_CheckedPickleStream`), then every array's shape as it is built."""
    check_declared_size(
        (-(-info.file_size // 4),),
        np.dtype(np.float32),
        path=path,
        item=VIDEOPOSE_KEY,
        what="the pickled dict, inflated and counted as float32 (as VideoPose3D stores it),",
    )
    # One pass, inflated once and never held whole: a walk of the opcodes before
    # unpickling needs the pickle twice (inflated twice, or held in one buffer).
    with zf.open(info) as fh:
        _read_object_header(fh, path)
        obj = _ArraysOnly(_CheckedPickleStream(fh, info.file_size)).load()
        while fh.read(1 << 20):  # to the member's end, where zipfile checks its CRC
            pass
    return obj


def load_videopose_dict(path: Path) -> object:
    """VideoPose3D's ``positions_3d`` member, without NumPy's unrestricted unpickling.

    The member's ``.npy`` header is read first and must describe what VideoPose3D writes, a
    0-d object array (a pickled dict); the size the zip declares for the pickle, its opcodes
    and every array's declared shape are checked before they take memory
    (:func:`~turn_datasets.mocap.checks.check_declared_size`, the one check of every
    reader); the pickle is read by :class:`_ArraysOnly` as it is inflated, each opcode
    checked first (:class:`_CheckedPickleStream`).

    Raises
    ------
    TurnbenchError
        No ``positions_3d`` member, another header, a corrupt archive, a pickle that
        needs anything but NumPy arrays, or one declaring more than the bounds allow.
    """
    member = f"{VIDEOPOSE_KEY}.npy"
    try:
        with zipfile.ZipFile(path) as zf:
            names = zf.namelist()
            if member not in names:
                held = sorted(n.removesuffix(".npy") for n in names)
                raise TurnbenchError(
                    f"no {VIDEOPOSE_KEY!r} in this npz (it holds {held})", file=path
                )
            array = _unpickle_member(zf, zf.getinfo(member), path)
    except TurnbenchError as exc:
        if exc.where.file is not None:
            raise
        raise TurnbenchError(exc.message, file=path, item=exc.where.item, hint=exc.hint) from None
    except pickle.UnpicklingError as exc:
        raise TurnbenchError(
            f"refused: {VIDEOPOSE_KEY!r} is a pickle that would run code ({exc})", file=path
        ) from None
    except CORRUPT as exc:
        raise TurnbenchError(
            f"cannot read this npz (truncated or corrupt?): {exc}", file=path
        ) from None
    return _plain(array.item() if isinstance(array, np.ndarray) and array.shape == () else array)


def read_videopose_npz(path: Path, on_bad: OnBadSequence | None) -> Iterator[MocapSequence]:
    data = load_videopose_dict(path)
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise TurnbenchError(
            f"{VIDEOPOSE_KEY!r} is not a dict subject -> action -> array", file=path
        )

    def sequence(key: tuple[object, object]) -> MocapSequence:
        subject, name = key
        item = f"{subject}/{name}"
        array = np.asarray(data[subject][name])
        layout = H36M17 if array.ndim == 3 and array.shape[1] == 17 else H36M32
        action, subaction = _action_of(str(name), path, item)
        return MocapSequence(
            subject=str(subject),
            action=action,
            subaction=subaction,
            positions=checked_positions(array, layout, path=path, item=item),
            layout=layout,
            fps=H36M_FPS,
            units="m",
            source=str(path),
            meta={"format": "videopose-npz", "name_on_disk": str(name), "key": item},
        )

    keys = [
        (subject, name)
        for subject in sorted(data, key=lambda s: natural_key(str(s)))
        for name in sorted(data[subject], key=lambda a: natural_key(str(a)))
    ]
    yield from skip_bad(keys, sequence, on_bad)
