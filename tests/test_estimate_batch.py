"""``turn-eval estimate`` over many videos: --resume, stopping (SIGTERM, a dead worker, a bad
video) with only complete outputs left, --skip-bad and the run manifest.

Needs MediaPipe (run in .venv-video). The videos are synthetic grey clips (nobody in them:
MediaPipe runs its detector on every frame and finds no one), so the runs are short.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import require_mediapipe, run_turn_eval
from test_estimate import _write_numbered_video

from turn_datasets.fileio import sha256_file


def estimate(args: list, capfd) -> tuple[int, list[str]]:
    """``turn-eval estimate args``, with MediaPipe's native stderr (file descriptor 2)."""
    capfd.readouterr()
    code, _, err = run_turn_eval(["estimate", *args], capfd)
    return code, err.strip().splitlines()


def run_manifest(folder: Path) -> dict:
    return json.loads((folder / "estimate.manifest.json").read_text())


def statuses(folder: Path) -> dict[str, str]:
    return {Path(v["video"]).name: v["status"] for v in run_manifest(folder)["videos"]}


def complete_outputs_only(out: Path, previews: Path | None = None) -> list[str]:
    """The stems with complete outputs; fails on anything else (a partial or hidden file)."""
    stems = []
    for folder in [out] + ([previews] if previews else []):
        for p in folder.iterdir():
            assert not p.name.startswith("."), f"left behind: {p}"
    for npz in sorted(out.glob("*.npz")):
        manifest = json.loads((out / f"{npz.stem}.manifest.json").read_text())
        assert manifest["skeletons"]["sha256"] == sha256_file(npz)
        with np.load(npz) as archive:
            assert archive.files
        stems.append(npz.stem)
    names = {p.name for p in out.iterdir()}
    expected = {f"{s}.npz" for s in stems} | {f"{s}.manifest.json" for s in stems}
    assert names - {"estimate.manifest.json"} == expected, names
    return stems


@pytest.fixture()
def clips(tmp_path) -> list[Path]:
    require_mediapipe()
    folder = tmp_path / "videos"
    folder.mkdir()
    paths = []
    for name, n in (("a", 20), ("b", 25), ("c", 30)):
        _write_numbered_video(folder / f"{name}.mp4", n)
        paths.append(folder / f"{name}.mp4")
    return paths


def test_resume_skips_what_is_done_and_redoes_what_changed(clips, tmp_path, capfd):
    out = tmp_path / "out"
    code, lines = estimate([*clips, "--out-dir", out], capfd)
    assert code == 0, lines
    assert statuses(out) == {"a.mp4": "done", "b.mp4": "done", "c.mp4": "done"}
    first = {p.name: p.read_bytes() for p in out.iterdir() if p.name != "estimate.manifest.json"}
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.npz")}

    code, lines = estimate([*clips, "--out-dir", out, "--resume"], capfd)
    assert code == 0, lines
    assert statuses(out) == {"a.mp4": "resumed", "b.mp4": "resumed", "c.mp4": "resumed"}
    assert "a.mp4: done before (same video, version and options): skipped" in lines
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.npz")} == stamps  # untouched
    rows = run_manifest(out)["videos"]
    assert [r["frames"] for r in rows] == [20, 25, 30]  # read back from each manifest
    assert run_manifest(out)["counts"]["resumed"] == 3

    # a replaced video, and one whose manifest is gone (a run stopped between the two files)
    _write_numbered_video(clips[1], 27)
    (out / "c.manifest.json").unlink()
    code, lines = estimate([*clips, "--out-dir", out, "--resume"], capfd)
    assert code == 0, lines
    assert statuses(out) == {"a.mp4": "resumed", "b.mp4": "done", "c.mp4": "done"}
    assert json.loads((out / "b.manifest.json").read_text())["time"]["n_frames"] == 27
    assert (out / "c.npz").read_bytes() == first["c.npz"]

    # another option: everything again
    code, lines = estimate([*clips, "--out-dir", out, "--resume", "--no-level"], capfd)
    assert code == 0, lines
    assert set(statuses(out).values()) == {"done"}
    assert json.loads((out / "a.manifest.json").read_text())["parameters"]["level"] is False
    complete_outputs_only(out)


def _first_manifest(out: Path, proc: subprocess.Popen, deadline: float) -> None:
    while not [p for p in out.glob("*.manifest.json") if p.name != "estimate.manifest.json"]:
        assert time.monotonic() < deadline and proc.poll() is None, "no video finished"
        time.sleep(0.05)


def test_sigterm_mid_run_leaves_only_complete_outputs_and_resume_completes(tmp_path, capfd):
    require_mediapipe()
    videos = tmp_path / "videos"
    videos.mkdir()
    _write_numbered_video(videos / "v0.mp4", 120)
    for i in range(1, 6):
        shutil.copy(videos / "v0.mp4", videos / f"v{i}.mp4")
    out, qa = tmp_path / "out", tmp_path / "qa"
    args = [str(p) for p in sorted(videos.iterdir())]
    args += ["--out-dir", str(out), "--preview", str(qa), "--workers", "2"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "turn_eval", "estimate", *args],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        _first_manifest(out, proc, time.monotonic() + 600)
        proc.send_signal(signal.SIGTERM)  # as `timeout`, systemd or a batch system stop a job
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert err.strip().splitlines()[-1] == "turn-eval: terminated", err
    done = complete_outputs_only(out, qa)
    assert 1 <= len(done) < 6
    assert not (out / "estimate.manifest.json").exists()

    code, lines = estimate([*args, "--resume"], capfd)
    assert code == 0, lines
    assert complete_outputs_only(out, qa) == [f"v{i}" for i in range(6)]
    got = statuses(out)
    assert sorted(k[:-4] for k, v in got.items() if v == "resumed") == done
    assert sorted(k[:-4] for k, v in got.items() if v == "done") == sorted(
        {f"v{i}" for i in range(6)} - set(done)
    )
    arrays = []
    for i in range(6):
        with np.load(out / f"v{i}.npz") as archive:
            arrays.append(archive[f"v{i}"].tobytes())
    assert len(set(arrays)) == 1 and len(arrays[0]) == 120 * 17 * 3 * 4  # the same video


def _kill_worker_decoding(video: Path, proc: subprocess.Popen, deadline: float) -> None:
    """SIGKILL the worker process whose ffmpeg is decoding ``video`` (as the OOM killer would)."""
    import psutil

    target = "file:" + os.path.abspath(video)
    while True:
        assert time.monotonic() < deadline and proc.poll() is None, "never started"
        for p in psutil.process_iter(["cmdline"]):
            if target in (p.info["cmdline"] or []) and "rawvideo" in p.info["cmdline"]:
                p.parent().kill()
                return
        time.sleep(0.05)


@pytest.mark.parametrize("skip_bad", [False, True])
def test_a_worker_that_dies_is_one_line_or_with_skip_bad_listed(tmp_path, skip_bad):
    require_mediapipe()
    videos = tmp_path / "videos"
    videos.mkdir()
    _write_numbered_video(videos / "doomed.mp4", 3000)
    _write_numbered_video(videos / "fine.mp4", 20)
    out = tmp_path / "out"
    args = [str(videos / "doomed.mp4"), str(videos / "fine.mp4"), "--out-dir", str(out)]
    args += ["--workers", "2"] + (["--skip-bad"] if skip_bad else [])
    proc = subprocess.Popen(
        [sys.executable, "-m", "turn_eval", "estimate", *args], stderr=subprocess.PIPE, text=True
    )
    try:
        _kill_worker_decoding(videos / "doomed.mp4", proc, time.monotonic() + 600)
        _, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
    lines = err.strip().splitlines()
    died = "the worker running it died (killed, or out of memory)"
    if not skip_bad:
        assert proc.returncode == 2, err
        assert lines[-1].startswith(f"turn-eval: error: {videos / 'doomed.mp4'}: {died}"), err
        assert "Traceback" not in err and "KilledWorker" not in err
        return
    assert proc.returncode == 0, err
    assert f"skipped {videos / 'doomed.mp4'}: {died}" in lines, err
    assert statuses(out) == {"doomed.mp4": "failed", "fine.mp4": "done"}
    assert run_manifest(out)["videos"][0]["error"] == died
    assert complete_outputs_only(out) == ["fine"]


def test_a_video_that_cannot_be_decoded_stops_the_run_or_is_listed(clips, tmp_path, capfd):
    out = tmp_path / "out"
    code, lines = estimate([clips[0], clips[1], "--out-dir", out], capfd)
    assert code == 0, lines
    clips[1].write_text("no longer a video\n")  # replaced by something undecodable
    code, lines = estimate([clips[0], clips[1], clips[2], "--out-dir", out, "--resume"], capfd)
    assert code == 2 and len(lines) == 2, lines  # a.mp4's skip, then the error
    assert lines[-1].startswith(f"turn-eval: error: {clips[1]}: cannot decode this video")
    assert not (out / "c.npz").exists()  # the run stopped there

    code, lines = estimate([*clips, "--out-dir", out, "--resume", "--skip-bad"], capfd)
    assert code == 0, lines
    assert statuses(out) == {"a.mp4": "resumed", "b.mp4": "failed", "c.mp4": "done"}
    assert run_manifest(out)["videos"][1]["error"].startswith("cannot decode this video")
    # b's outputs of the earlier run described another video: gone, so detect cannot read them
    assert complete_outputs_only(out) == ["a", "c"]
    assert lines[-1].startswith("wrote skeletons (and manifests) of 3 videos (1 estimated, ")


def test_progress_counts_every_frame_across_videos(clips, tmp_path):
    from turn_eval.estimate import EstimateParams, VideoJob, estimate_videos

    counted: list[int] = []
    out = tmp_path / "out"
    out.mkdir()
    jobs = [VideoJob(v, out / f"{v.stem}.npz") for v in clips]
    run = estimate_videos(jobs, params=EstimateParams(), on_progress=counted.append)
    assert sum(counted) == 20 + 25 + 30
    assert [v["frames"] for v in run.videos] == [20, 25, 30]
