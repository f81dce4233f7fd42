"""``h36m export-clips``: frame-accurate cuts of videos the test writes with imageio's ffmpeg."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_datasets as run

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.h36m import export

FPS = 50
N_FRAMES = 150  # 3 s at 50 fps
CAMERAS = ("54138969", "55011271")


def _write_video(path: Path, *, seed: int) -> None:
    """A 3 s, 50 fps, 32x32 video whose frame n is flat grey, its level rising with n.

    Levels 30 + n + seed are all different, so a decoded frame says which frame it is. Key
    frames every 25 frames, so a cut starting mid-group needs an accurate seek.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    source = (
        f"nullsrc=s=32x32:r={FPS}:d={N_FRAMES / FPS},"
        f"geq=lum='30+N+{seed}':cb=128:cr=128,format=yuv420p"
    )
    cmd = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-loglevel", "error", "-y",
        "-f", "lavfi", "-i", source, "-c:v", "libx264", "-qp", "0", "-g", "25", str(path),
    ]  # fmt: skip
    subprocess.run(cmd, check=True, capture_output=True)


def _grey_levels(path: Path) -> np.ndarray:
    frames = imageio_ffmpeg.read_frames(str(path), pix_fmt="gray", bpp=1)
    next(frames)  # metadata
    return np.array([np.frombuffer(f, np.uint8).mean() for f in frames])


def _source_frames(cut: Path, source: Path) -> list[int]:
    """Which frame of ``source`` each frame of ``cut`` is (the nearest grey level)."""
    src, got = _grey_levels(source), _grey_levels(cut)
    # the flat frames survive the re-encode: each level matches one source frame within 1
    assert np.abs(src[None, :] - got[:, None]).min(axis=1).max() < 1.0
    return [int(np.argmin(np.abs(src - level))) for level in got]


@pytest.fixture(scope="module")
def videos(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("h36m")
    for k, camera in enumerate(CAMERAS):
        _write_video(root / "S1" / "Videos" / f"Walking 1.{camera}.mp4", seed=k)
    _write_video(root / "S1" / "Videos" / f"TakingPhoto.{CAMERAS[0]}.mp4", seed=5)
    _write_video(root / "S1" / "Videos" / f"_ALL.{CAMERAS[0]}.mp4", seed=9)  # a session
    return root


INDEX_HEADER = (
    "clip_id,subject,action,subaction,split,start_frame,end_frame,n_frames,fps,start_s,end_s,"
    "duration_s,angle_deg,direction,bin_deg,speed_deg_s,source"
)


def _index(path: Path, rows: list[tuple]) -> Path:
    """rows: (clip_id, subject, action, subaction, start_frame, end_frame, fps)."""
    lines = [INDEX_HEADER]
    for cid, subject, action, sub, start, end, fps in rows:
        n = end - start
        lines.append(
            f"{cid},{subject},{action},{sub},train,{start},{end},{n},{fps},{start / fps},"
            f"{end / fps},{n / fps},90.0,left,90,100.0,x.cdf"
        )
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


WALK = ("S1_Walking_63-100", "S1", "Walking", "1", 63, 100, 50)
PHOTO = ("S1_Photo_0-25", "S1", "Photo", "", 0, 25, 50)


def test_cuts_are_frame_accurate_for_every_camera(tmp_path: Path, videos: Path, capsys) -> None:
    index = _index(tmp_path / "index.csv", [WALK, PHOTO])
    out = tmp_path / "clips"
    code, stdout, stderr = run(
        ["h36m", "export-clips", index, "--videos", videos, "--out-dir", out], capsys
    )
    assert code == 0, stderr
    assert stdout == ""
    assert sorted(p.name for p in out.iterdir()) == [
        f"S1_Photo_0-25.{CAMERAS[0]}.mp4",  # TakingPhoto.<camera>.mp4 is the canonical Photo
        f"S1_Walking_63-100.{CAMERAS[0]}.mp4",
        f"S1_Walking_63-100.{CAMERAS[1]}.mp4",
    ]
    assert f"wrote 3 cuts (2 clips x 2 cameras) to {out}" in stderr
    for camera in CAMERAS:
        cut = out / f"S1_Walking_63-100.{camera}.mp4"
        # frames 63..99 (end exclusive): 37 frames, 0.74 s
        assert imageio_ffmpeg.count_frames_and_secs(str(cut)) == (37, 0.74)
        source = videos / "S1" / "Videos" / f"Walking 1.{camera}.mp4"
        assert _source_frames(cut, source) == list(range(63, 100))
    photo = out / f"S1_Photo_0-25.{CAMERAS[0]}.mp4"
    assert _source_frames(
        photo, videos / "S1" / "Videos" / f"TakingPhoto.{CAMERAS[0]}.mp4"
    ) == list(range(25))
    assert not [p for p in tmp_path.rglob(".*")]  # no temporary files left


def test_same_inputs_same_bytes(tmp_path: Path, videos: Path) -> None:
    index = _index(tmp_path / "index.csv", [WALK])
    for name in ("a", "b"):
        export.export_clips(index, videos, tmp_path / name, cameras=[CAMERAS[0]])
    clip = f"S1_Walking_63-100.{CAMERAS[0]}.mp4"
    assert (tmp_path / "a" / clip).read_bytes() == (tmp_path / "b" / clip).read_bytes()


def test_index_fps_differs_from_video_fps(tmp_path: Path, videos: Path) -> None:
    # a 25 Hz index: frames 10..19 are 0.4 s to 0.8 s, video frames 20..39 at 50 fps
    index = _index(tmp_path / "index.csv", [("c", "S1", "Walking", "1", 10, 20, 25)])
    export.export_clips(index, videos, tmp_path / "out", cameras=[CAMERAS[1]])
    cut = tmp_path / "out" / f"c.{CAMERAS[1]}.mp4"
    source = videos / "S1" / "Videos" / f"Walking 1.{CAMERAS[1]}.mp4"
    assert _source_frames(cut, source) == list(range(20, 40))


def test_camera_filter(tmp_path: Path, videos: Path, capsys) -> None:
    index = _index(tmp_path / "index.csv", [WALK])
    out = tmp_path / "clips"
    code, _, stderr = run(
        [
            "h36m",
            "export-clips",
            index,
            "--videos",
            videos,
            "--out-dir",
            out,
            "--camera",
            CAMERAS[1],
        ],
        capsys,
    )
    assert code == 0, stderr
    assert [p.name for p in out.iterdir()] == [f"S1_Walking_63-100.{CAMERAS[1]}.mp4"]


def test_missing_video_fails_before_any_cut(tmp_path: Path, videos: Path, capsys) -> None:
    index = _index(
        tmp_path / "index.csv", [WALK, ("S9_Walking_0-10", "S9", "Walking", "", 0, 10, 50)]
    )
    out = tmp_path / "clips"
    code, stdout, stderr = run(
        ["h36m", "export-clips", index, "--videos", videos, "--out-dir", out], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert stdout == ""
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr
    # the index file and the row (line 3: header, WALK, then the S9 clip)
    assert f"{index}:3" in lines[0]
    assert "S9_Walking_0-10 (S9/Videos/Walking.<camera>.mp4)" in lines[0]
    assert "--skip-missing" in lines[0]
    assert not out.exists()


def test_skip_missing_cuts_the_others_and_lists_them(tmp_path: Path, videos: Path, capsys) -> None:
    index = _index(
        tmp_path / "index.csv", [WALK, ("S9_Walking_0-10", "S9", "Walking", "", 0, 10, 50)]
    )
    out = tmp_path / "clips"
    code, _, stderr = run(
        ["h36m", "export-clips", index, "--videos", videos, "--out-dir", out, "--skip-missing"],
        capsys,
    )
    assert code == 0, stderr
    assert "warning: no video for clip S9_Walking_0-10" in stderr
    assert "1 clips without video skipped" in stderr
    assert len(list(out.iterdir())) == 2


def test_clip_past_the_end_of_the_video(tmp_path: Path, videos: Path, capsys) -> None:
    index = _index(tmp_path / "index.csv", [PHOTO, ("long", "S1", "Walking", "1", 100, 151, 50)])
    code, _, stderr = run(
        ["h36m", "export-clips", index, "--videos", videos, "--out-dir", tmp_path / "o"], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert f"{index}:3" in stderr and "ends at video frame 151" in stderr and "150 frames" in stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("rows", "message", "row"),
    [
        ([("a", "S1", "Walking", "1", 20, 10, 50)], "0 <= start_frame < end_frame", 2),
        ([("a", "S1", "Walking", "1", "x", 10, 50)], "not whole numbers", 2),
        ([("a", "S1", "Jogging", "1", 0, 10, 50)], "'Jogging' is not a Human3.6M action", 2),
        ([PHOTO, PHOTO], "clip_id 'S1_Photo_0-25' repeats row 2", 3),
        ([("a", "S1", "Walking", "1", 0, 10, 0)], "fps must be positive", 2),
    ],
)
def test_bad_index_rows(tmp_path: Path, videos: Path, rows, message: str, row: int) -> None:
    lines = ["clip_id,subject,action,subaction,start_frame,end_frame,fps"]
    lines += [",".join(str(v) for v in r) for r in rows]
    index = tmp_path / "index.csv"
    index.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(export.TurnbenchError, match=message) as exc:
        export.export_clips(index, videos, tmp_path / "o")
    assert (exc.value.where.file, exc.value.where.row) == (str(index), row)


def test_index_without_the_columns(tmp_path: Path, videos: Path) -> None:
    index = tmp_path / "index.csv"
    index.write_text("clip_id,angle_deg\na,90\n", encoding="utf-8")
    with pytest.raises(
        export.TurnbenchError, match="the clip index lacks columns 'subject', 'action'"
    ):
        export.export_clips(index, videos, tmp_path / "o")
    with pytest.raises(export.TurnbenchError, match="no such file"):
        export.export_clips(tmp_path / "nope.csv", videos, tmp_path / "o")
    with pytest.raises(export.TurnbenchError, match="no such folder"):
        export.export_clips(_index(index, [WALK]), tmp_path / "novideos", tmp_path / "o")


def test_find_videos_matches_names_on_disk(videos: Path) -> None:
    found = export.find_videos(videos)
    assert sorted(found) == [("S1", "Photo", ""), ("S1", "Walking", "1")]  # _ALL ignored
    assert sorted(found[("S1", "Walking", "1")]) == sorted(CAMERAS)


def test_probe_video(videos: Path) -> None:
    info = export.probe_video(videos / "S1" / "Videos" / f"Walking 1.{CAMERAS[0]}.mp4")
    assert (info.n_frames, info.fps) == (N_FRAMES, 50.0)


def test_help_has_an_example(capsys) -> None:
    code, stdout, _ = run(["h36m", "export-clips", "--help"], capsys)
    assert code == 0
    assert "Example:" in stdout and "--skip-missing" in stdout


def test_console_script_exit_code(tmp_path: Path) -> None:
    # the installed console script, beside the interpreter running the tests
    exe = Path(sys.executable).parent / "turn-datasets"
    proc = subprocess.run(
        [str(exe), "h36m", "export-clips", str(tmp_path / "missing.csv"), "--videos", str(tmp_path),
         "--out-dir", str(tmp_path / "o")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == EXIT_BAD_INPUT
    assert proc.stderr.strip() == f"turn-datasets: error: {tmp_path / 'missing.csv'}: no such file"


def test_read_clip_index_dtypes(tmp_path: Path) -> None:
    df = export.read_export_index(_index(tmp_path / "i.csv", [WALK, PHOTO]))
    assert list(df.columns) == [*export.INDEX_COLUMNS, "row"]
    assert df["start_frame"].dtype == np.int64 and df["fps"].dtype == np.float64
    assert df["subaction"].tolist() == ["1", ""]
    assert isinstance(df, pd.DataFrame)


def _failing_ffmpeg(tmp_path: Path, *, fail_on_cut: int) -> Path:
    """An ffmpeg that is the real one, except that its ``fail_on_cut``-th cut (an encode to
    libx264; probes only copy) writes part of its output and then fails, as a full disk or a
    killed encoder would."""
    real = imageio_ffmpeg.get_ffmpeg_exe()
    counter = tmp_path / "cuts"
    script = tmp_path / "ffmpeg"
    script.write_text(
        "#!/bin/sh\n"
        'case "$*" in *libx264*)\n'
        f'  n=$(($(cat "{counter}" 2>/dev/null || echo 0) + 1)); echo $n > "{counter}"\n'
        f"  if [ $n -eq {fail_on_cut} ]; then\n"
        f'    "{real}" "$@"; echo "Error writing trailer: No space left on device" >&2; exit 1\n'
        "  fi;;\n"
        "esac\n"
        f'exec "{real}" "$@"\n'
    )
    script.chmod(0o755)
    return script


def test_ffmpeg_failing_midway_leaves_the_out_dir_as_it_was(
    tmp_path: Path, videos: Path, capsys, monkeypatch
) -> None:
    # three cuts in index order: Walking by both cameras, then Photo; the third fails
    index = _index(tmp_path / "index.csv", [WALK, PHOTO])
    out = tmp_path / "clips"
    out.mkdir()
    earlier = out / "earlier.mp4"  # a file from an earlier export stays untouched
    earlier.write_bytes(b"kept")
    (tmp_path / "bin").mkdir()
    fake = _failing_ffmpeg(tmp_path / "bin", fail_on_cut=3)
    monkeypatch.setattr(export.imageio_ffmpeg, "get_ffmpeg_exe", lambda: str(fake))
    code, stdout, stderr = run(
        ["h36m", "export-clips", index, "--videos", videos, "--out-dir", out], capsys
    )
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert "Traceback" not in stderr
    last_video = videos / "S1" / "Videos" / f"TakingPhoto.{CAMERAS[0]}.mp4"
    assert stderr.strip().splitlines()[-1] == (
        f"turn-datasets: error: {last_video}: ffmpeg failed to cut frames: "
        "Error writing trailer: No space left on device"
    )
    assert (tmp_path / "bin" / "cuts").read_text().strip() == "3"  # two cuts made, then it failed
    # neither the two good cuts, nor the half-written third, nor the staging folder
    assert [p.name for p in out.iterdir()] == ["earlier.mp4"]
    assert earlier.read_bytes() == b"kept"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_out_is_an_alias_of_out_dir_and_a_file_there_is_refused(
    tmp_path: Path, videos: Path, capsys
) -> None:
    index = _index(tmp_path / "index.csv", [PHOTO])
    out = tmp_path / "clips"
    code, _, stderr = run(["h36m", "export-clips", index, "--videos", videos, "--out", out], capsys)
    assert code == 0, stderr
    assert [p.name for p in out.iterdir()] == [f"S1_Photo_0-25.{CAMERAS[0]}.mp4"]
    a_file = tmp_path / "notes.txt"
    a_file.write_text("x")
    for target in (a_file, a_file / "clips"):
        code, _, stderr = run(
            ["h36m", "export-clips", index, "--videos", videos, "--out-dir", target], capsys
        )
        assert code == EXIT_BAD_INPUT
        assert stderr.strip() == (
            f"turn-datasets: error: {a_file}: is a file, so --out-dir cannot be made there"
        )


def test_an_unreadable_video_is_named_before_any_cut(tmp_path: Path, capsys) -> None:
    broken = tmp_path / "h36m" / "S1" / "Videos" / f"Walking 1.{CAMERAS[0]}.mp4"
    broken.parent.mkdir(parents=True)
    broken.write_bytes(b"\x00\x00\x00\x18ftypmp42" + b"\x00" * 64)  # a header and nothing
    index = _index(tmp_path / "index.csv", [WALK])
    out = tmp_path / "clips"
    code, stdout, stderr = run(
        ["h36m", "export-clips", index, "--videos", tmp_path / "h36m", "--out-dir", out], capsys
    )
    assert code == EXIT_BAD_INPUT and stdout == ""
    lines = stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"turn-datasets: error: {broken}: ffmpeg cannot read this video")
    assert not out.exists()


def test_read_clip_index_takes_a_bom_and_names_true_lines(tmp_path: Path) -> None:
    # A spreadsheet's "CSV UTF-8" starts with a byte-order mark; the index is read as every
    # user table is (turn_datasets.usertable), so the BOM is not part of the first column's
    # name, and a blank line does not shift the line numbers of the rows after it.
    path = _index(tmp_path / "i.csv", [WALK, PHOTO])
    plain = export.read_export_index(path)
    text = path.read_text(encoding="utf-8")
    header, first, second = text.splitlines()
    path.write_text("\ufeff" + "\n".join([header, first, "", second]) + "\n", encoding="utf-8")
    df = export.read_export_index(path)
    assert df["clip_id"].tolist() == plain["clip_id"].tolist()
    assert df["row"].tolist() == [2, 4]
    bad = second.replace(",0,25,", ",30,25,")
    path.write_text("\ufeff" + "\n".join([header, first, "", bad]) + "\n", encoding="utf-8")
    with pytest.raises(export.TurnbenchError, match="0 <= start_frame < end_frame") as err:
        export.read_export_index(path)
    assert str(err.value).startswith(f"{path}:4: ")


def test_an_index_without_clips_is_read_as_empty(tmp_path: Path) -> None:
    df = export.read_export_index(_index(tmp_path / "i.csv", []))
    assert len(df) == 0 and list(df.columns) == [*export.INDEX_COLUMNS, "row"]
