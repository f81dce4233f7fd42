"""The leaderboard page as a browser renders it: headless Chromium (Debian's ``chromium``,
which ``.ci/run`` installs where missing) loads ``GET /`` from a real server and its DOM
holds the ranked rows, in the order and with the ranks of ``/api/leaderboard``."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from html.parser import HTMLParser

import pytest

pytest.importorskip("fastapi", reason="needs the server extra (make venv installs it)")
httpx = pytest.importorskip("httpx")

from _server_support import (  # noqa: E402
    MARKER,
    Served,
    bearer,
    wait_scored,
    write_predictions,
    write_reference,
)
from conftest import run_turn_eval as run  # noqa: E402

#: No network, no first-run work, a new empty profile: the flags the issue fixes.
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    if os.environ.get("CI") == "true":
        pytest.fail("CI=true but no chromium: .ci/run installs Debian's chromium")
    pytest.skip("needs chromium (apt-get install chromium)")


def dump_dom(url: str) -> str:
    with tempfile.TemporaryDirectory() as profile:
        out = subprocess.run(
            [chromium(), *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--dump-dom", url],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


class _Rows(HTMLParser):
    """The cells of each ``tr.entry`` of the DOM, as text."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[list[str]] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "tr" and ("class", "entry") in attrs:
            self.rows.append([])
        elif tag == "td" and self.rows:
            self._cell = []

    def handle_endtag(self, tag):
        if tag == "td" and self._cell is not None:
            self.rows[-1].append(" ".join("".join(self._cell).split()))
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def test_chromium_renders_the_ranked_rows(tmp_path, capsys):
    chromium()
    ref = write_reference(tmp_path / "labels.csv")
    root = tmp_path / "challenge"
    args = ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "Page test"]
    assert run([*args, "--by", "cohort", "--bootstrap", "200"], capsys)[0] == 0
    tokens = {
        name: run(["server", "add-team", root, name], capsys)[1].strip()
        for name in ("Team <A>", "Team B")
    }
    constant = tmp_path / "c.csv"
    constant.write_text("clip_id,angle_deg\n" + "".join(f"{c},90\n" for c in ref["clip_id"]))
    assert run(["server", "add-baseline", root, "constant 90", constant], capsys)[0] == 0
    served = Served(root, workers=1).start()
    try:
        with httpx.Client(timeout=60) as c:
            for token, noise in zip(tokens.values(), (5.0, 25.0), strict=True):
                path = write_predictions(tmp_path / f"{noise}.csv", ref, noise_deg=noise, seed=9)
                r = c.post(
                    f"{served.url}/api/submissions",
                    headers=bearer(token),
                    files={"file": (path.name, path.read_bytes())},
                )
                assert r.status_code == 202
                wait_scored(c, served.url, token, [r.json()["id"]])
            board = c.get(f"{served.url}/api/leaderboard").json()
        dom = dump_dom(served.url + "/")
    finally:
        served.stop()
    parser = _Rows()
    parser.feed(dom)
    shown = [(row[0], row[1]) for row in parser.rows]
    want = [
        (str(r["rank"]), r["team"] + (" baseline" if r["baseline"] else "")) for r in board["rows"]
    ]
    assert shown == want == [("1", "Team <A>"), ("2", "Team B"), ("3", "constant 90 baseline")]
    # the public accuracy cell holds the JSON's value as a percentage, and its interval
    first = board["rows"][0]["public"]
    lo, hi = first["ci95"]["accuracy"]
    assert parser.rows[0][2] == (
        f"{first['accuracy'] * 100:.1f}%[{lo * 100:.1f}%, {hi * 100:.1f}%]"
    )
    assert "<script" not in dom.lower() and MARKER not in dom
