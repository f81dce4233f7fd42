"""Outputs that are not ours to replace, and output folders that own only what they wrote.

- an output path that exists and is not a regular file (a FIFO, a socket, a device, a folder,
  a symbolic link) is refused in one line, exit 2, and left as it was; no manifest is written
  beside it;
- an output folder's clean-up removes only files its previous run wrote (listed, with their
  sha256, in that run's record) and still holding what it wrote, never a file for matching
  a pattern; no input may lie among what an output folder owns.
"""

from __future__ import annotations

import json
import os
import socket
import stat
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _eaf_builder import two_raters
from conftest import run_cli as _run
from test_detect import WALK_TURN_WALK, stream
from test_predict import turning_skeleton

from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import (
    atomic_path,
    check_owned,
    read_run_record,
    staged_dir,
    write_csv,
)
from turn_eval.cli import cli as eval_cli

REF = "session,subject,start_s,end_s,angle_deg\ns1,P1,0,2,90\ns1,P1,10,12,180\n"
DET = "session,subject,start_s,end_s,angle_deg,score\ns1,P1,0,2,80,0.9\ns1,P1,10.5,12,200,0.8\n"
CLIP_REF = "clip_id,angle_deg,duration_s\na,90,1.0\nb,180,2.0\n"
CLIP_PRED = "clip_id,angle_deg\na,92.5\nb,170\n"


def _fifo(path: Path) -> None:
    os.mkfifo(path)


def _socket(path: Path) -> None:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.bind(str(path))
    sock.close()


def _device(path: Path) -> None:
    # A character device like /dev/null (1, 3), made in the test's own folder: replacing it
    # harms nothing, while the real /dev/null must never be a test's target.
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    os.mknod(path, 0o600 | stat.S_IFCHR, os.makedev(1, 3))


def _symlink(path: Path) -> None:
    target = path.with_name("target.txt")
    target.write_text("the target\n")
    path.symlink_to(target.name)


def _dangling(path: Path) -> None:
    path.symlink_to("nowhere.txt")


def _folder(path: Path) -> None:
    path.mkdir()


KINDS: dict[str, Callable[[Path], None]] = {
    "fifo": _fifo,
    "socket": _socket,
    "device": _device,
    "symlink": _symlink,
    "dangling symlink": _dangling,
    "folder": _folder,
}


def _node(path: Path) -> tuple[int, str | None]:
    """What a path is, to see it unchanged: its file type and, for a link, its target."""
    st = os.lstat(path)
    return stat.S_IFMT(st.st_mode), os.readlink(path) if path.is_symlink() else None


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_atomic_write_refuses_a_target_that_is_not_a_regular_file(tmp_path, kind):
    out = tmp_path / "out.csv"
    KINDS[kind](out)
    before = _node(out)
    with pytest.raises(TurnbenchError, match="not a regular file: refusing to replace it"):
        write_csv(pd.DataFrame({"a": [1]}), out)
    assert _node(out) == before
    if kind == "symlink":
        assert (tmp_path / "target.txt").read_text() == "the target\n"
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())  # no temporary left


def test_atomic_write_refuses_a_fifo_that_appears_while_writing(tmp_path):
    out = tmp_path / "out.csv"
    with pytest.raises(TurnbenchError, match="FIFO"), atomic_path(out) as tmp:
        tmp.write_text("x")
        os.mkfifo(out)
    assert stat.S_ISFIFO(os.lstat(out).st_mode)


@pytest.mark.parametrize("kind", ["fifo", "symlink", "device"])
def test_staged_folder_refuses_a_destination_that_is_not_a_regular_file(tmp_path, kind):
    out = tmp_path / "o"
    out.mkdir()
    (out / "a.csv").write_text("old a\n")
    KINDS[kind](out / "b.csv")
    before = _node(out / "b.csv")
    with pytest.raises(TurnbenchError, match="refusing to replace it"), staged_dir(out) as stage:
        (stage / "a.csv").write_text("new a\n")
        (stage / "b.csv").write_text("new b\n")
    assert _node(out / "b.csv") == before
    assert (out / "a.csv").read_text() == "old a\n"  # nothing moved: all or none


def test_staged_folder_refuses_a_fifo_that_appears_while_moving_in(tmp_path, monkeypatch):
    import turn_datasets.fileio as fileio

    out = tmp_path / "o"
    real_chmod = os.chmod

    def chmod(path, mode, *args, **kwargs):
        # just before the staged b.csv is renamed into place, someone makes a FIFO there
        real_chmod(path, mode, *args, **kwargs)
        if Path(path).name == "b.csv" and not (out / "b.csv").exists():
            os.mkfifo(out / "b.csv")

    monkeypatch.setattr(fileio.os, "chmod", chmod)
    with pytest.raises(TurnbenchError, match="FIFO"), staged_dir(out) as stage:
        (stage / "b.csv").write_text("new b\n")
    assert stat.S_ISFIFO(os.lstat(out / "b.csv").st_mode)


def test_staged_folder_never_writes_through_a_linked_subfolder(tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "o"
    out.mkdir()
    (out / "timelines").symlink_to(elsewhere)
    with pytest.raises(TurnbenchError, match="not a folder"), staged_dir(out) as stage:
        (stage / "timelines").mkdir()
        (stage / "timelines" / "s1.png").write_text("png")
    assert list(elsewhere.iterdir()) == []


def _one_error_line(code: int, out: str, err: str) -> str:
    assert code == EXIT_BAD_INPUT, err
    assert out == ""
    errors = [line for line in err.splitlines() if "error" in line]
    assert len(errors) == 1 and "Traceback" not in err, err
    return errors[0]


@pytest.mark.parametrize("kind", ["fifo", "device", "symlink"])
def test_detect_refuses_an_out_that_is_not_a_regular_file_and_writes_no_manifest(
    tmp_path, capsys, kind
):
    np.savez(tmp_path / "home01.npz", P01=stream(WALK_TURN_WALK))
    out = tmp_path / "detections.csv"
    KINDS[kind](out)
    before = _node(out)
    args = ["detect", tmp_path / "home01.npz", "--layout", "h36m17", "--up-axis", "z"]
    code, stdout, err = _run(eval_cli, "turn-eval", [*args, "--fps", "30", "--out", out], capsys)
    line = _one_error_line(code, stdout, err)
    assert str(out) in line and "refusing to replace it" in line
    assert _node(out) == before
    assert not (tmp_path / "detections.manifest.json").exists()
    if kind == "symlink":
        assert (tmp_path / "target.txt").read_text() == "the target\n"


def test_predict_refuses_an_out_that_is_a_symlink(tmp_path, capsys):
    np.savez(tmp_path / "poses.npz", S9_turn=turning_skeleton(np.linspace(10.0, -110.0, 75)))
    out = tmp_path / "predictions.csv"
    _symlink(out)
    args = ["predict", tmp_path / "poses.npz", "--layout", "h36m17", "--up-axis", "z"]
    line = _one_error_line(*_run(eval_cli, "turn-eval", [*args, "--out", out], capsys))
    assert "a symbolic link to target.txt" in line
    assert out.is_symlink() and (tmp_path / "target.txt").read_text() == "the target\n"


def test_score_events_refuses_a_symlinked_events_csv_in_its_out_dir(tmp_path, capsys):
    (tmp_path / "det.csv").write_text(DET)
    (tmp_path / "ref.csv").write_text(REF)
    out = tmp_path / "ev"
    out.mkdir()
    _symlink(out / "events.csv")
    args = ["score-events", tmp_path / "det.csv", "-r", tmp_path / "ref.csv", "--out-dir", out]
    line = _one_error_line(*_run(eval_cli, "turn-eval", args, capsys))
    assert "events.csv" in line and "symbolic link" in line
    assert sorted(p.name for p in out.iterdir()) == ["events.csv", "target.txt"]
    assert (out / "events.csv").is_symlink()


def test_score_refuses_a_fifo_among_its_out_dir_files(tmp_path, capsys):
    (tmp_path / "pred.csv").write_text(CLIP_PRED)
    (tmp_path / "ref.csv").write_text(CLIP_REF)
    out = tmp_path / "scores"
    out.mkdir()
    os.mkfifo(out / "scores.md")
    args = ["score", tmp_path / "pred.csv", "-r", tmp_path / "ref.csv", "--out-dir", out]
    line = _one_error_line(*_run(eval_cli, "turn-eval", args, capsys))
    assert "scores.md" in line and "FIFO" in line
    assert [p.name for p in out.iterdir()] == ["scores.md"]
    assert stat.S_ISFIFO(os.lstat(out / "scores.md").st_mode)


# -- owned output folders ----------------------------------------------------------------


def test_staged_folder_removes_only_recorded_files_that_still_hold_what_it_wrote(tmp_path):
    out = tmp_path / "o"
    with staged_dir(out, record="run.manifest.json") as stage:
        for name in ("a.png", "b.png", "c.png", "keep.csv"):
            (stage / name).write_text(name)
    assert set(read_run_record(out, "run.manifest.json")) == {"a.png", "b.png", "c.png", "keep.csv"}
    (out / "b.png").write_text("edited by the user")
    (out / "mine.png").write_text("never written by a run")  # matches *.png, not recorded
    removed: list[Path] = []
    kept: list[Path] = []
    with staged_dir(out, record="run.manifest.json", removed=removed, kept=kept) as stage:
        (stage / "keep.csv").write_text("keep.csv, again")
    assert removed == [out / "a.png", out / "c.png"]
    assert kept == [out / "b.png"]
    assert sorted(p.name for p in out.iterdir()) == [
        "b.png",
        "keep.csv",
        "mine.png",
        "run.manifest.json",
    ]
    assert list(read_run_record(out, "run.manifest.json")) == ["keep.csv"]


def test_staged_folder_never_removes_what_a_forged_record_lists_outside_it(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    victim = tmp_path / "precious.txt"
    victim.write_text("x")
    digest = __import__("hashlib").sha256(b"x").hexdigest()
    record = {"files": {"../precious.txt": digest, str(victim): digest}}
    (out / "run.manifest.json").write_text(json.dumps(record))
    with staged_dir(out, record="run.manifest.json") as stage:
        (stage / "a.csv").write_text("a")
    assert victim.read_text() == "x"


def _session(path: Path, bob_deg: str) -> None:
    two_raters(path, [(1000, 2000, "90")], [(1000, 2000, bob_deg)])


def test_agreement_refuses_inputs_inside_its_out_dirs_review_folder(tmp_path, capsys):
    # The re-audit-after-fixing-in-ELAN workflow: the review copies, edited, given back as
    # the input of an audit into the same folder. They were deleted as "the previous run".
    aud = tmp_path / "aud"
    (aud / "review").mkdir(parents=True)
    # Both sessions fixed: the raters agree now, so the run writes no review copies, and the
    # "previous run's" copies (the inputs) were removed by pattern.
    _session(aud / "review" / "pair01_day1.eaf", "90")
    _session(aud / "review" / "pair01_day2.eaf", "90")
    before = {p.name: p.read_bytes() for p in (aud / "review").iterdir()}
    args = ["remap", "agreement", aud / "review", "--bootstrap", "0", "--out-dir", aud]
    line = _one_error_line(*_run(datasets_cli, "turn-datasets", [*args, "--review-eaf"], capsys))
    assert "review" in line and "choose another --out-dir" in line
    assert {p.name: p.read_bytes() for p in (aud / "review").iterdir()} == before
    assert sorted(p.name for p in aud.iterdir()) == ["review"]


def test_score_events_refuses_an_input_named_as_one_of_its_figures(tmp_path, capsys):
    out = tmp_path / "ow"
    (out / "timelines").mkdir(parents=True)
    (out / "pr_curve.png").write_text(REF)
    (out / "det.csv").write_text(DET)
    (out / "timelines" / "0000_s1.png").write_text(REF)
    for ref in (out / "pr_curve.png", out / "timelines" / "0000_s1.png"):
        args = ["score-events", out / "det.csv", "-r", ref, "--bootstrap", "0", "--out-dir", out]
        line = _one_error_line(*_run(eval_cli, "turn-eval", args, capsys))
        assert "choose another --out-dir" in line
        assert ref.read_text() == REF
    assert sorted(p.name for p in out.iterdir()) == ["det.csv", "pr_curve.png", "timelines"]


def test_an_input_listed_in_the_previous_runs_record_is_refused(tmp_path):
    out = tmp_path / "o"
    with staged_dir(out, record="run.manifest.json") as stage:
        (stage / "sub").mkdir()
        (stage / "sub" / "old.csv").write_text("a")
    check_owned(out, [out / "sub" / "old.csv"])  # without the record: not known as owned
    with pytest.raises(TurnbenchError, match="is sub/old.csv of --out-dir"):
        check_owned(out, [out / "sub" / "old.csv"], record="run.manifest.json")
    (tmp_path / "alias").symlink_to(out)  # the same folder by another name
    with pytest.raises(TurnbenchError, match="is run.manifest.json of --out-dir"):
        check_owned(out, [tmp_path / "alias" / "run.manifest.json"], record="run.manifest.json")


def test_score_keeps_a_figure_the_user_changed_and_says_so(tmp_path, capsys):
    (tmp_path / "pred.csv").write_text(CLIP_PRED)
    (tmp_path / "ref.csv").write_text(CLIP_REF)
    out = tmp_path / "scores"
    base = ["score", tmp_path / "pred.csv", "-r", tmp_path / "ref.csv", "--bootstrap", "0"]
    code, _, err = _run(eval_cli, "turn-eval", [*base, "--out-dir", out, "--plots"], capsys)
    assert code == 0, err
    (out / "abs_error.png").write_bytes(b"annotated by hand")
    code, _, err = _run(eval_cli, "turn-eval", [*base, "--out-dir", out], capsys)
    assert code == 0, err
    assert "removed 3 file(s) of the previous run" in err
    assert "kept 1 file(s) of the previous run that were changed since it wrote them" in err
    assert (out / "abs_error.png").read_bytes() == b"annotated by hand"
    assert sorted(p.name for p in out.iterdir()) == [
        "abs_error.png",
        "scores.csv",
        "scores.json",
        "scores.manifest.json",
        "scores.md",
    ]


# -- estimate: every output checked before the first frame --------------------------------


def _no_pose_model(monkeypatch) -> None:
    """``estimate`` as far as its pose model, which fails the test if it is reached: an
    output refused after it would have cost minutes of estimation first."""
    import turn_eval.cli.estimate as estimate_cli
    from turn_eval.estimate import batch

    def estimator(*args, **kwargs):
        pytest.fail("the pose model ran before the outputs were checked")

    monkeypatch.setattr(estimate_cli, "load_mediapipe", lambda: None)
    monkeypatch.setattr(batch, "estimate_file", estimator)
    monkeypatch.setattr(batch, "estimate_video", estimator)


@pytest.mark.parametrize("kind", ["fifo", "symlink"])
@pytest.mark.parametrize(
    "output, option",
    [
        ("o/walk.npz", "--out-dir"),
        ("o/walk.manifest.json", "--out-dir"),
        ("o/estimate.manifest.json", "--out-dir"),
        ("qa/walk.preview.mp4", "--preview"),
        ("walk.npz", "--out"),
        ("walk.manifest.json", "--out"),
    ],
)
def test_estimate_refuses_an_output_that_is_not_a_regular_file_before_the_pose_model(
    tmp_path, capsys, monkeypatch, kind, output, option
):
    from test_estimate import _write_numbered_video

    _no_pose_model(monkeypatch)
    video = tmp_path / "walk.mp4"
    _write_numbered_video(video, 3)
    (tmp_path / "o").mkdir()
    (tmp_path / "qa").mkdir()
    target = tmp_path / output
    KINDS[kind](target)
    before = _node(target)
    outputs = (
        ["--out", tmp_path / "walk.npz"]
        if option == "--out"
        else ["--out-dir", tmp_path / "o", "--preview", tmp_path / "qa"]
    )
    line = _one_error_line(*_run(eval_cli, "turn-eval", ["estimate", video, *outputs], capsys))
    assert line == (
        f"turn-eval: error: {target}: is "
        + ("a FIFO (named pipe)" if kind == "fifo" else "a symbolic link to target.txt")
        + f", not a regular file: refusing to replace it (hint: choose another {option})"
    )
    assert _node(target) == before
    if kind == "symlink":
        assert (target.parent / "target.txt").read_text() == "the target\n"


def test_estimate_refuses_a_preview_path_that_became_a_fifo_while_it_ran(tmp_path, monkeypatch):
    # the outputs are checked before the first frame; a node made there during the minutes
    # of estimation is refused too, not renamed over (as the npz's atomic write refuses it)
    from turn_eval.estimate import batch

    preview = tmp_path / "qa" / "walk.preview.mp4"
    preview.parent.mkdir()

    def estimate_video(path, *, preview, **kwargs):
        Path(preview).write_bytes(b"the preview")
        os.mkfifo(tmp_path / "qa" / "walk.preview.mp4")
        return "skeletons"

    monkeypatch.setattr(batch, "estimate_video", estimate_video)
    with pytest.raises(TurnbenchError) as exc:
        batch.estimate_file(
            str(tmp_path / "walk.mp4"), sha256="0" * 64, params=None, preview=str(preview)
        )
    assert str(exc.value) == (
        f"{preview}: is a FIFO (named pipe), not a regular file: refusing to replace it "
        "(hint: choose another --preview)"
    )
    assert stat.S_ISFIFO(os.lstat(preview).st_mode)
    assert [p.name for p in preview.parent.iterdir()] == ["walk.preview.mp4"]  # no tmp left
