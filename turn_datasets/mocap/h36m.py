"""Human3.6M's three releases of 3-D positions, and its subject and action names.

``cdf``
    The original release, ``S*/MyPoseFeatures/D3_Positions/<Action>.cdf``: variable
    ``Pose`` of shape ``(1, N, 96)``, millimetres, 50 Hz, z up, 32 joints (read with cdflib).
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
    else (``os.system``) is refused before any of it runs. It is loaded once and its
    sequences yielded one by one.

The subject comes from the ``S<n>`` folder (or the npz key) and the action and trial from
the name on disk (:func:`parse_h36m_action`). The three share these names and the frame
rate, so they live together.
"""

from __future__ import annotations

import importlib
import os
import pickle
import re
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from types import MappingProxyType

import cdflib
import h5py
import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap.arrays import read_h5_dataset
from turn_datasets.mocap.checks import (
    CORRUPT,
    OnBadSequence,
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


def read_h36m_cdf(path: Path) -> Iterator[MocapSequence]:
    # subject and action first: a file outside the release's layout is refused unread
    subject = h36m_subject_of(path)
    action = _action_of(path.stem, path)
    with unreadable(f"variable {H36M_CDF_VARIABLE!r}", path, guess="truncated or corrupt CDF?"):
        pose = np.asarray(cdflib.CDF(path).varget(H36M_CDF_VARIABLE))
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


class _ArraysOnly(pickle.Unpickler):
    """An unpickler that builds NumPy arrays and plain containers, and refuses any other
    global: a pickle that names ``os.system`` (or anything else) fails before it runs."""

    def find_class(self, module: str, name: str):
        if (module, name) not in _PICKLE_ALLOWED:
            raise pickle.UnpicklingError(f"refused to load {module}.{name}")
        try:
            return getattr(
                importlib.import_module(module.replace("numpy.core", "numpy._core")), name
            )
        except ImportError:  # numpy 1 has no numpy._core
            return getattr(importlib.import_module(module), name)


def load_videopose_dict(path: Path) -> object:
    """VideoPose3D's ``positions_3d`` member, without NumPy's unrestricted unpickling.

    The member's ``.npy`` header is read first and must describe what VideoPose3D writes, a
    0-d object array (a pickled dict); the pickle is then read by :class:`_ArraysOnly`.

    Raises
    ------
    TurnbenchError
        No ``positions_3d`` member, another header, a corrupt archive, or a pickle that
        needs anything but NumPy arrays.
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
            with zf.open(member) as fh:
                version = np.lib.format.read_magic(fh)
                read_header = (
                    np.lib.format.read_array_header_1_0
                    if version == (1, 0)
                    else np.lib.format.read_array_header_2_0
                )
                shape, _, dtype = read_header(fh)
                if dtype != np.dtype(object) or shape != ():
                    raise TurnbenchError(
                        f"{VIDEOPOSE_KEY!r} is a {dtype} array of shape {shape}, not "
                        "a dict subject -> action -> array (VideoPose3D's pickled dict)",
                        file=path,
                    )
                array = _ArraysOnly(fh).load()
    except TurnbenchError:
        raise
    except pickle.UnpicklingError as exc:
        raise TurnbenchError(
            f"refused: {VIDEOPOSE_KEY!r} is a pickle that would run code ({exc})", file=path
        ) from None
    except CORRUPT as exc:
        raise TurnbenchError(
            f"cannot read this npz (truncated or corrupt?): {exc}", file=path
        ) from None
    return array.item() if isinstance(array, np.ndarray) and array.shape == () else array


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
