"""Human3.6M fixture files written from positions: the exact inverse of the readers' layouts.

Only the tests and the demo corpus write these (a real corpus comes from the releases).
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Mapping
from pathlib import Path

import cdflib
import h5py
import numpy as np

from turn_datasets.fileio import atomic_path
from turn_datasets.mocap.h36m import H36M_CDF_VARIABLE, H36M_H5_DATASET, VIDEOPOSE_KEY

__all__ = [
    "write_h36m_cdf",
    "write_h36m_h5",
    "write_videopose_npz",
]


def _check_h36m_positions(positions: np.ndarray) -> np.ndarray:
    p = np.asarray(positions)
    if p.ndim != 3 or p.shape[1:] != (32, 3) or not np.issubdtype(p.dtype, np.floating):
        raise ValueError(f"expected float positions of shape (N, 32, 3), got {p.dtype} {p.shape}")
    return p


def write_h36m_cdf(path: str | os.PathLike[str], positions_mm: np.ndarray) -> Path:
    """Write ``positions_mm`` ``(N, 32, 3)`` as Human3.6M's ``D3_Positions`` CDF, atomically.

    Variable ``Pose``, one record of ``(N, 96)`` (read back as ``(1, N, 96)``), float32 data
    stored as CDF_FLOAT and anything else as CDF_DOUBLE, uncompressed, with cdflib's writer.
    """
    p = _check_h36m_positions(positions_mm)
    data = p.reshape(1, p.shape[0], 96)
    cdf_type = 44 if p.dtype == np.float32 else 45  # CDF_FLOAT, CDF_DOUBLE
    if cdf_type == 45:
        data = data.astype(np.float64)
    target = Path(path)
    with atomic_path(target) as tmp:
        # cdflib appends ".cdf" to a name without it and refuses an existing file
        cdf_tmp = tmp.with_name(tmp.name + ".cdf")
        tmp.unlink()
        try:
            writer = cdflib.cdfwrite.CDF(cdf_tmp, cdf_spec={"Compressed": False})
            writer.write_var(
                {
                    "Variable": H36M_CDF_VARIABLE,
                    "Data_Type": cdf_type,
                    "Num_Elements": 1,
                    "Rec_Vary": True,
                    "Dim_Sizes": [p.shape[0], 96],
                    "Compress": 0,
                },
                var_data=data,
            )
            writer.close()
            os.replace(cdf_tmp, tmp)
        finally:
            if cdf_tmp.exists():
                cdf_tmp.unlink()
    return target


def write_h36m_h5(path: str | os.PathLike[str], positions_mm: np.ndarray) -> Path:
    """Write ``positions_mm`` ``(N, 32, 3)`` as 3d-pose-baseline's h5, atomically.

    Dataset ``3D_positions`` of shape ``(96, N)`` (one column per frame), the dtype kept,
    without timestamps so the bytes depend only on the data.
    """
    p = _check_h36m_positions(positions_mm)
    target = Path(path)
    with atomic_path(target) as tmp:
        with h5py.File(tmp, "w", track_order=False) as fh:
            fh.create_dataset(H36M_H5_DATASET, data=p.reshape(p.shape[0], 96).T, track_times=False)
    return target


def write_videopose_npz(
    path: str | os.PathLike[str],
    data: Mapping[str, Mapping[str, np.ndarray]],
    *,
    compressed: bool = True,
) -> Path:
    """Write VideoPose3D's ``data_3d_h36m.npz`` layout, atomically and reproducibly.

    Parameters
    ----------
    data
        subject -> action name (as on disk, e.g. ``"Walking 1"``) -> ``(N, 32, 3)`` metres,
        stored float32 as VideoPose3D does, in a pickled dict under ``positions_3d``.
    compressed
        Deflate the archive as VideoPose3D's ``np.savez_compressed`` does (the default), or
        store it (as ``np.savez``): several times faster to write for a large synthetic
        corpus, and read the same way.

    Notes
    -----
    Written as ``np.savez_compressed`` (or ``np.savez``) would, but with a fixed timestamp
    in the zip entry, so the same data gives the same bytes.
    """
    payload: dict[str, dict[str, np.ndarray]] = {}
    for subject, actions in data.items():
        payload[str(subject)] = {}
        for name, positions in actions.items():
            p = _check_h36m_positions(positions)
            payload[str(subject)][str(name)] = p.astype(np.float32)
    obj = np.empty((), dtype=object)
    obj[()] = payload
    target = Path(path)
    with atomic_path(target) as tmp:
        method = zipfile.ZIP_DEFLATED if compressed else zipfile.ZIP_STORED
        info = zipfile.ZipInfo(f"{VIDEOPOSE_KEY}.npy", date_time=(1980, 1, 1, 0, 0, 0))
        info.compress_type = method
        with zipfile.ZipFile(tmp, "w", compression=method) as zf:
            with zf.open(info, "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, obj, allow_pickle=True)
    return target
