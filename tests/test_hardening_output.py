"""Output folders after a careless or interrupted run (issue 10, #5, #9, #11).

- an output folder holds exactly one run: a command removes the files it owns that this run
  did not write, and says so (#5);
- staging happens where the user asked to write, and errors name the user's path (#9);
- SIGTERM cleans up like SIGINT: no hidden staging folder is left behind (#11).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest
from _eaf_builder import two_raters
from conftest import run_cli as _run

from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, staged_dir
from turn_eval.cli import cli as eval_cli

REFERENCE = "clip_id,angle_deg,duration_s\na,90,1.0\nb,180,2.0\nc,45,0.5\nd,135,1.5\n"
PREDICTIONS = "clip_id,angle_deg\na,92.5\nb,170\nc,40\nd,100\n"


def _hidden(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob(".*"))


@pytest.fixture()
def score_files(tmp_path: Path) -> tuple[Path, Path]:
    ref = tmp_path / "ref.csv"
    ref.write_text(REFERENCE)
    pred = tmp_path / "pred.csv"
    pred.write_text(PREDICTIONS)
    return pred, ref


# -- #5 ----------------------------------------------------------------------------------


def test_score_without_plots_removes_the_previous_runs_figures(score_files, tmp_path, capsys):
    pred, ref = score_files
    out = tmp_path / "scores"
    base = ["score", pred, "-r", ref, "--bootstrap", "0", "--out-dir", out]
    code, _, err = _run(eval_cli, "turn-eval", [*base, "--plots"], capsys)
    assert code == 0, err
    assert (out / "confusion_matrix.png").is_file()
    (out / "notes.txt").write_text("mine")  # not the command's: stays
    code, _, err = _run(eval_cli, "turn-eval", base, capsys)
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == [
        "notes.txt",
        "scores.csv",
        "scores.json",
        "scores.manifest.json",
        "scores.md",
    ]
    assert "removed 4 file(s) of the previous run" in err and "bland_altman.png" in err


def _disagreeing_session(folder: Path, *, disagree: bool) -> None:
    two_raters(
        folder / "S01.eaf",
        [(1000, 2000, "90"), (5000, 6000, "180")],
        [(1000, 2000, "90"), (5000, 6000, "135" if disagree else "180")],
    )


def test_agreement_review_copies_of_an_earlier_run_do_not_survive(tmp_path, capsys):
    eaf = tmp_path / "eaf"
    eaf.mkdir()
    out = tmp_path / "audit"
    args = ["remap", "agreement", eaf, "--bootstrap", "0", "--out-dir", out, "--review-eaf"]
    _disagreeing_session(eaf, disagree=True)
    code, _, err = _run(datasets_cli, "turn-datasets", args, capsys)
    assert code == 0, err
    assert (out / "review" / "S01.eaf").is_file()
    _disagreeing_session(eaf, disagree=False)
    code, _, err = _run(datasets_cli, "turn-datasets", args, capsys)
    assert code == 0, err
    assert not (out / "review" / "S01.eaf").exists()
    assert "removed 1 file(s) of the previous run" in err


def test_staged_dir_failure_keeps_the_old_owned_files(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "a.png").write_text("old")
    with staged_dir(out, record="run.manifest.json") as stage:
        (stage / "a.png").write_text("old")
    with pytest.raises(RuntimeError), staged_dir(out, record="run.manifest.json") as stage:
        (stage / "b.txt").write_text("new")
        raise RuntimeError("boom")
    assert sorted(p.name for p in out.iterdir()) == ["a.png", "run.manifest.json"]


# -- #9 ----------------------------------------------------------------------------------


@pytest.fixture()
def deny_writes(monkeypatch):
    """Make a folder refuse new entries, as it does for an ordinary user (root ignores mode
    bits, so under root the refusal is simulated where the OS would give it)."""

    def deny(folder: Path) -> None:
        folder = folder.resolve()
        if os.geteuid() != 0:
            folder.chmod(0o555)
            return
        real_access, real_mkstemp, real_mkdtemp = os.access, tempfile.mkstemp, tempfile.mkdtemp

        def refuse(where) -> None:
            if where is not None and Path(where).resolve() == folder:
                raise PermissionError(13, "Permission denied", str(Path(where) / ".tmpXXXX"))

        def access(path, mode, *a, **k):
            if Path(path).resolve() == folder and mode & os.W_OK:
                return False
            return real_access(path, mode, *a, **k)

        def mkstemp(*a, dir=None, **k):
            refuse(dir)
            return real_mkstemp(*a, dir=dir, **k)

        def mkdtemp(*a, dir=None, **k):
            refuse(dir)
            return real_mkdtemp(*a, dir=dir, **k)

        monkeypatch.setattr(os, "access", access)
        monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
        monkeypatch.setattr(tempfile, "mkdtemp", mkdtemp)

    yield deny


def test_out_dir_in_a_folder_whose_parent_is_read_only_is_written(tmp_path, deny_writes):
    home = tmp_path / "home" / "user"  # like ~ under a /home the user cannot write
    home.mkdir(parents=True)
    deny_writes(tmp_path / "home")
    with staged_dir(home) as stage:
        (stage / "labels.csv").write_text("x\n")
        (stage / "review").mkdir()
        (stage / "review" / "s.eaf").write_text("e")
    assert (home / "labels.csv").read_text() == "x\n"
    assert (home / "review" / "s.eaf").read_text() == "e"
    assert _hidden(home) == []


def test_remap_labels_out_in_home_works_when_home_parent_is_read_only(
    tmp_path, deny_writes, capsys
):
    eaf = tmp_path / "eaf"
    eaf.mkdir()
    _disagreeing_session(eaf, disagree=False)
    parts = tmp_path / "participants.csv"
    parts.write_text("subject,cohort,pair,sex,age,years_since_diagnosis\nPD01,PD,a,F,60,4\n")
    home = tmp_path / "home" / "user"
    home.mkdir(parents=True)
    deny_writes(tmp_path / "home")
    args = ["remap", "labels", eaf, "--participants", parts, "--out", home / "labels.csv"]
    code, _, err = _run(datasets_cli, "turn-datasets", args, capsys)
    assert code == 0, err
    assert (home / "labels.csv").is_file() and (home / "annotations.csv").is_file()
    assert _hidden(home) == []


def test_write_error_names_the_users_path_not_a_temporary_one(tmp_path, deny_writes):
    folder = tmp_path / "ro"
    folder.mkdir()
    deny_writes(folder)
    with pytest.raises(PermissionError) as info, atomic_path(folder / "out.csv") as tmp:
        tmp.write_text("x")
    assert info.value.filename == str(folder / "out.csv")


def test_staged_dir_error_names_the_users_file(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "scores.md").mkdir()  # a folder where the command's file goes
    with pytest.raises(TurnbenchError) as info, staged_dir(out) as stage:
        (stage / "scores.md").write_text("x")
    assert info.value.where.file == str(out / "scores.md")
    assert _hidden(tmp_path) == []


# -- #11 ---------------------------------------------------------------------------------

_SLOW_SCORE = textwrap.dedent(
    """
    import signal, sys, time
    # score writes its tables with fileio.write_files, which calls fileio.write_text
    import turn_datasets.fileio as mod

    # A shell that starts a job in the background (CI scripts, "cmd &") hands it SIGINT
    # ignored, and Python then installs no KeyboardInterrupt handler: restore what a terminal
    # gives, so the test exercises the command and not how pytest was launched.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    from turn_datasets.cli.common import run_group
    from turn_eval.cli import cli

    real = mod.write_text
    def slow(path, text):
        real(path, text)
        if path.name == "scores.csv":
            print("staged", flush=True)
            time.sleep(60)
    mod.write_text = slow
    sys.exit(run_group(cli, "turn-eval", sys.argv[1:]))
    """
)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_leaves_no_staging_folder_like_sigint(score_files, tmp_path, sig):
    pred, ref = score_files
    out = tmp_path / "scores"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            _SLOW_SCORE,
            "score",
            str(pred),
            "-r",
            str(ref),
            "--bootstrap",
            "0",
            "--out-dir",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().strip() == "staged"
        assert [p for p in tmp_path.iterdir() if p.name.startswith(".scores.")]
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode in (128 + sig, 130) and "Traceback" not in err
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
    assert not out.exists()


def test_out_dir_that_is_a_file_names_it(score_files, tmp_path, capsys):
    pred, ref = score_files
    bad = tmp_path / "file"
    bad.write_text("x")
    code, _, err = _run(eval_cli, "turn-eval", ["score", pred, "-r", ref, "--out-dir", bad], capsys)
    assert code == EXIT_BAD_INPUT and str(bad) in err
