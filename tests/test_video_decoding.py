"""What ``turn-eval estimate`` decodes: exactly the named local file (never a network address
or other files ffmpeg's protocols would name), and the whole of it (a truncated copy or a
still image is refused). No MediaPipe needed: these run in .venv as well."""

from __future__ import annotations

import shutil
import socket
import threading
import zlib
from pathlib import Path
from struct import pack

import pytest
from test_estimate import _write_numbered_video

from turn_datasets.errors import TurnbenchError
from turn_eval.estimate.video import open_video


class _Listener:
    """A loopback TCP listener that counts the connections it gets (it must get none)."""

    def __init__(self) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.connections = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            self.connections += 1
            conn.close()  # ffmpeg then reads nothing and gives up: no hang either way

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.sock.close()


@pytest.fixture()
def listener():
    server = _Listener()
    try:
        yield server
    finally:
        server.close()


def test_a_file_named_like_a_network_address_is_read_as_the_local_file(
    tmp_path, monkeypatch, listener
) -> None:
    # ffmpeg given the bare name `tcp:127.0.0.1:PORT` connected to it: video must never
    # leave the machine, and the frames must be the file's own.
    monkeypatch.chdir(tmp_path)
    _write_numbered_video(tmp_path / "walk.mp4", 12)
    name = f"tcp:127.0.0.1:{listener.port}"
    shutil.copy(tmp_path / "walk.mp4", tmp_path / name)
    frames = [f.tobytes() for f, _ in open_video(name)]
    assert listener.connections == 0
    assert frames == [f.tobytes() for f, _ in open_video(tmp_path / "walk.mp4")]
    assert len(frames) == 12


@pytest.mark.parametrize(
    "name", ["concat:walk.mp4|walk.mp4", "subfile,,start,0,end,0,,:walk.mp4", "file:walk.mp4"]
)
def test_a_file_named_like_a_protocol_is_that_file_not_another(tmp_path, monkeypatch, name):
    # Bare, these names made ffmpeg read walk.mp4 (twice, or a part of it), exit 0, and the
    # manifest recorded the sha256 of the empty file named so.
    monkeypatch.chdir(tmp_path)
    _write_numbered_video(tmp_path / "walk.mp4", 12)
    (tmp_path / name).write_bytes(b"")
    with pytest.raises(TurnbenchError, match="cannot decode this video"):
        list(open_video(name))


def test_a_truncated_video_is_refused_naming_what_decoded_and_what_was_declared(
    sports2d_video, tmp_path
) -> None:
    # The first 1 MB of the 7.73 s clip: ffmpeg decodes 60 frames and exits 0; the result
    # was a "93.3% detected" skeleton of 2 s, with no flag.
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(Path(sports2d_video).read_bytes()[:1_000_000])
    with pytest.raises(TurnbenchError) as info:
        list(open_video(cut))
    assert str(info.value).startswith(
        f"{cut}: truncated: 60 frames decode to 2.00 s of the 7.73 s its container declares"
    )


def test_the_whole_video_is_not_refused(sports2d_video) -> None:
    assert sum(1 for _ in open_video(sports2d_video)) == 230


def _png(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return pack(">I", len(data)) + kind + data + pack(">I", zlib.crc32(kind + data))

    rows = b"".join(b"\x00" + bytes([90] * width * 3) for _ in range(height))
    header = pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )


def test_a_still_image_renamed_mp4_is_not_a_one_frame_video(tmp_path) -> None:
    fake = tmp_path / "holiday.mp4"
    fake.write_bytes(_png(64, 48))
    with pytest.raises(TurnbenchError, match="one decoded frame: a still image, not a video"):
        list(open_video(fake))


def test_a_progress_bar_is_sized_from_the_containers_header(sports2d_video, tmp_path) -> None:
    from turn_eval.estimate.video import expected_frames

    assert expected_frames(sports2d_video) == 232  # 7.73 s at 30 fps, from the header alone
    (tmp_path / "x.mp4").write_bytes(_png(8, 8))
    assert expected_frames(tmp_path / "x.mp4") == 0  # no duration stated
    assert expected_frames(tmp_path / "none.mp4") == 0
