"""Shared fixtures. Real files live in ``../shared/data`` beside the clone (CI puts it there)."""

from __future__ import annotations

import os
from pathlib import Path

import click
import pytest

from turn_datasets.cli import cli as turn_datasets_cli
from turn_datasets.cli.common import run_group
from turn_eval.cli import cli as turn_eval_cli

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


# --- the optional `video` extra (mediapipe) -------------------------------------------------
# In .venv the video tests skip; `make test` runs the suite a second time in .venv-video with
# TURNBENCH_REQUIRE_VIDEO=1, where a skip would mean they silently never ran: a failure there.
REQUIRE_VIDEO = os.environ.get("TURNBENCH_REQUIRE_VIDEO") == "1"


def require_mediapipe() -> None:
    """Skip the calling test without mediapipe, or fail if the video env must have it."""
    try:
        import mediapipe  # noqa: F401
    except ImportError:
        if REQUIRE_VIDEO:
            pytest.fail("TURNBENCH_REQUIRE_VIDEO=1 but mediapipe is not importable")
        pytest.skip("needs the video extra (mediapipe); make test runs it in .venv-video")


@pytest.fixture(scope="session")
def sports2d_video(shared_data: Path) -> Path:
    """The real BSD clip of people walking (../shared/data/video/SOURCE.md)."""
    path = shared_data / "video" / "sports2d_demo.mp4"
    if not path.is_file():
        pytest.fail(f"real test video not found at {path}")
    return path


# --- running a command in-process -----------------------------------------------------------
# The tests run the console scripts' click groups as the scripts do (run_group maps errors to
# exit codes), with pytest's capsys capturing stdout and stderr. Test modules import these:
# ``from conftest import run_turn_eval as run``.


def run_cli(group: click.Group, prog: str, args: list, capsys) -> tuple[int, str, str]:
    """Run ``prog args`` (every argument as text): its exit code, stdout and stderr."""
    code = run_group(group, prog, [str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def run_turn_eval(args: list, capsys) -> tuple[int, str, str]:
    """``turn-eval args``, as :func:`run_cli`."""
    return run_cli(turn_eval_cli, "turn-eval", args, capsys)


def run_turn_datasets(args: list, capsys) -> tuple[int, str, str]:
    """``turn-datasets args``, as :func:`run_cli`."""
    return run_cli(turn_datasets_cli, "turn-datasets", args, capsys)
