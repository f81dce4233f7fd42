"""``turn-eval detect``: formats and naming, the manifest, bad files, a 2-worker Dask cluster
giving the serial CSV byte for byte, and a user's own detector through the same command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_eval as run
from test_detect import WALK_TURN_WALK, stream

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.fileio import sha256_file
from turn_eval.detect.streams import stream_files, stream_names
from turn_eval.events.contract import DETECTION_DTYPES

BASE = ["--layout", "h36m17", "--up-axis", "-y", "--fps", "30", "--min-turn-deg", "67.5"]


def camera_axes(p_zup: np.ndarray) -> np.ndarray:
    """z up back to camera axes (y down): the inverse of to_z_up(-y), (x, y, z) -> (x, -z, y)."""
    return np.stack([p_zup[..., 0], -p_zup[..., 2], p_zup[..., 1]], axis=-1).astype(np.float32)


@pytest.fixture(scope="module")
def turn_stream() -> np.ndarray:
    return camera_axes(stream(WALK_TURN_WALK))


def test_stream_names_and_folder_walk(tmp_path: Path) -> None:
    assert stream_names("a/home01.npz", "P01") == ("home01", "P01")
    assert stream_names("a/home01.h5", "grp/P01") == ("home01", "grp/P01")
    assert stream_names("a/home01__P01.npy", "home01__P01") == ("home01", "P01")
    assert stream_names("a/walk.npy", "walk") == ("walk", "walk")
    (tmp_path / "sub").mkdir()
    for name in ("b10.npz", "b2.npz", "sub/a.npy", "notes.txt"):
        (tmp_path / name).write_bytes(b"")
    files = stream_files([tmp_path, tmp_path / "b2.npz"])
    assert [f.relative_to(tmp_path).as_posix() for f in files] == ["b2.npz", "b10.npz", "sub/a.npy"]


def test_every_format_gives_the_same_turn_and_a_manifest(tmp_path, capsys, turn_stream) -> None:
    np.savez(tmp_path / "home01.npz", P01=turn_stream, C01=turn_stream[:200])
    with h5py.File(tmp_path / "home02.h5", "w") as fh:
        fh.create_dataset("P02", data=turn_stream)
    np.save(tmp_path / "home03__P03.npy", turn_stream)
    out = tmp_path / "out" / "detections.csv"
    code, stdout, stderr = run(["detect", tmp_path, *BASE, "--out", out], capsys)
    assert code == 0, stderr
    assert stdout == ""
    assert "wrote 3 turns in 4 streams" in stderr and "of 3 files" in stderr
    table = pd.read_csv(out, keep_default_na=False)
    assert list(table.columns) == list(DETECTION_DTYPES)
    # C01 stops at 6.7 s, before the turn: a stream without turns has no row
    assert table[["session", "subject"]].values.tolist() == [
        ["home01", "P01"],
        ["home02", "P02"],
        ["home03", "P03"],
    ]
    # one planted left turn of 90° at 8-10 s, the same stream in three formats
    assert (table.direction == "left").all()
    np.testing.assert_allclose(table.angle_deg, table.angle_deg.iloc[0], rtol=1e-6)
    assert abs(table.angle_deg.iloc[0] - 90.0) < 6.0
    manifest = json.loads((tmp_path / "out" / "detections.manifest.json").read_text())
    assert manifest["tool"] == "turn-eval detect" and manifest["detector"] == "miner-rule"
    assert (
        manifest["params"]["min_turn_deg"] == 67.5
        and manifest["params"]["joints"] == "hip,shoulder"
    )
    assert manifest["reading"] == {
        "from": "arrays",
        "layout": "h36m17",
        "up_axis": "-y",
        "fps_hz": 30.0,
    }
    first = manifest["inputs"][0]
    assert first["file"] == str(tmp_path / "home01.npz")
    assert first["sha256"] == sha256_file(tmp_path / "home01.npz")
    assert [(s["subject"], s["n_frames"]) for s in first["streams"]] == [("C01", 200), ("P01", 540)]
    assert manifest["counts"]["frames"] == 200 + 3 * 540 and manifest["skipped"] == []


def test_bad_file_is_named_exit_2_or_skipped(tmp_path, capsys, turn_stream) -> None:
    np.savez(tmp_path / "good.npz", P01=turn_stream)
    (tmp_path / "broken.npz").write_bytes(b"PK\x03\x04 truncated")
    np.savez(tmp_path / "wrong.npz", P09=turn_stream[:, :5])
    out = tmp_path / "d.csv"
    code, _, stderr = run(["detect", tmp_path, *BASE, "--out", out], capsys)
    assert code == EXIT_BAD_INPUT
    assert (
        stderr.strip().splitlines()[-1].startswith(f"turn-eval: error: {tmp_path / 'broken.npz'}")
    )
    assert not out.exists()  # nothing half-written
    code, _, stderr = run(["detect", tmp_path, *BASE, "--skip-bad", "--out", out], capsys)
    assert code == 0, stderr
    assert f"skipped {tmp_path / 'wrong.npz'}, P09: array has 5 joints" in stderr
    manifest = json.loads((tmp_path / "d.manifest.json").read_text())
    assert [Path(s["file"]).name for s in manifest["skipped"]] == ["broken.npz", "wrong.npz"]
    assert pd.read_csv(out).session.tolist() == ["good"]


def test_duplicate_session_subject_and_unknown_option_values(tmp_path, capsys, turn_stream) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    np.savez(tmp_path / "a" / "home.npz", P01=turn_stream)
    np.savez(tmp_path / "b" / "home.npz", P01=turn_stream)
    code, _, stderr = run(["detect", tmp_path, *BASE, "--out", tmp_path / "d.csv"], capsys)
    assert code == EXIT_BAD_INPUT and "subject 'P01' is also in" in stderr
    code, _, stderr = run(
        ["detect", tmp_path / "a", *BASE, "--joints", "elbow", "--out", tmp_path / "d.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT and "unknown joint pair 'elbow'" in stderr
    code, _, stderr = run(
        [
            "detect",
            tmp_path / "a",
            *BASE,
            "--detector",
            "nosuch:thing",
            "--out",
            tmp_path / "d.csv",
        ],
        capsys,
    )
    assert code == EXIT_BAD_INPUT and "cannot load detector" in stderr


class HalfwayDetector:
    """A user's detector: one 'turn' in the middle second of every stream."""

    name = "halfway"

    def detect(self, positions, fps_hz, layout):
        mid = positions.shape[0] / fps_hz / 2
        return pd.DataFrame({"start_s": [mid - 0.5], "end_s": [mid + 0.5], "angle_deg": [100.0]})


def test_own_detector_runs_through_the_same_command(tmp_path, capsys, turn_stream) -> None:
    np.savez(tmp_path / "home.npz", P01=turn_stream)
    out = tmp_path / "d.csv"
    code, _, stderr = run(
        [
            "detect",
            tmp_path / "home.npz",
            *BASE,
            "--detector",
            "test_detect_cli:HalfwayDetector",
            "--out",
            out,
        ],
        capsys,
    )
    assert code == 0, stderr
    t = pd.read_csv(out, keep_default_na=False)
    # 540 frames at 30 fps: the middle second is 8.5-9.5 s
    assert t[["start_s", "end_s", "angle_deg"]].values.tolist() == [[8.5, 9.5, 100.0]]
    assert t.direction.tolist() == [""]
    assert json.loads((tmp_path / "d.manifest.json").read_text())["detector"] == "halfway"


def test_two_dask_workers_give_the_serial_csv(tmp_path, turn_stream) -> None:
    # Subprocesses: the cluster's workers are processes and must import the package fresh.
    rng = np.random.default_rng(0)
    for i in range(5):
        shift = rng.integers(0, 200)
        np.savez(
            tmp_path / f"s{i}.npz", A=np.roll(turn_stream, shift, axis=0), B=turn_stream[shift:]
        )
    outs = {}
    for name, extra in (("serial", []), ("dask", ["--workers", "2"])):
        out = tmp_path / f"{name}.csv"
        proc = subprocess.run(
            [
                sys.executable,
                "-m",
                "turn_eval",
                "detect",
                str(tmp_path),
                *BASE,
                *extra,
                "--out",
                str(out),
            ],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout == ""
        outs[name] = out
    assert outs["serial"].read_bytes() == outs["dask"].read_bytes()
    assert len(pd.read_csv(outs["serial"])) >= 10
    assert (tmp_path / "serial.manifest.json").read_bytes() == (
        tmp_path / "dask.manifest.json"
    ).read_bytes()


def test_serial_run_does_not_import_dask(tmp_path, turn_stream) -> None:
    np.savez(tmp_path / "home.npz", P01=turn_stream)
    code = (
        "import sys; from turn_eval.cli import main\n"
        "try:\n"
        f"    main(['detect', {str(tmp_path / 'home.npz')!r}, *{BASE!r}, '--out', {str(tmp_path / 'd.csv')!r}])\n"
        "except SystemExit as e:\n"
        "    assert e.code == 0, e.code\n"
        "print('dask' in sys.modules, 'distributed' in sys.modules)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "False False"


def test_unreachable_scheduler_is_one_line(tmp_path, capsys, turn_stream, monkeypatch) -> None:
    import turn_eval.mapping.cluster as cluster

    monkeypatch.setattr(cluster, "SCHEDULER_TIMEOUT_S", 1)
    np.savez(tmp_path / "home.npz", P01=turn_stream)
    args = ["detect", tmp_path / "home.npz", *BASE, "--scheduler", "tcp://127.0.0.1:9"]
    code, _, stderr = run([*args, "--out", tmp_path / "d.csv"], capsys)
    assert code == EXIT_BAD_INPUT
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in stderr
    assert "Traceback" not in stderr and not (tmp_path / "d.csv").exists()
