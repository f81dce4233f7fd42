"""Shared fixtures. Real files live in ``../shared/data`` beside the clone (CI puts it there)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def _shared_data_dir() -> Path:
    env = os.environ.get("TURNBENCH_SHARED_DATA")
    return Path(env) if env else REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data``; a missing folder is a failure, not a skip: the real files are tests."""
    path = _shared_data_dir()
    if not (path / "real-eaf").is_dir() or not (path / "cmu-mocap").is_dir():
        pytest.fail(
            f"real test data not found at {path}: clone beside shared/ or set TURNBENCH_SHARED_DATA"
        )
    return path


@pytest.fixture(scope="session")
def real_eaf_dir(shared_data: Path) -> Path:
    return shared_data / "real-eaf"


@pytest.fixture(scope="session")
def cmu_dir(shared_data: Path) -> Path:
    return shared_data / "cmu-mocap"
