"""What a new user trips on: a folder walk that passes files over, a frame rate that
contradicts its manifest, detections in the wrong unit, an agreement gate that forgets
missed turns (each check fails without its fix)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import run_turn_datasets as _run_datasets
from conftest import run_turn_eval as _run_eval

from turn_datasets.synthetic import mocap as sm
from turn_datasets.synthetic.h36m_files import write_h36m_cdf, write_videopose_npz


def _walk_and_turn(seed: int) -> np.ndarray:
    segs = [sm.Segment.stand(1.0), sm.Segment.walk(2.0, 1.2), sm.Segment.pivot_turn(90.0, 1.4)]
    segs += [sm.Segment.walk(2.0, 1.2), sm.Segment.stand(1.0)]
    return sm.generate_sequence(seed=seed, segments=segs, noise_mm=5.0).positions


def test_a_folder_walk_names_every_file_it_passes_over(tmp_path, capsys) -> None:
    """VideoPose3D's npz one folder down, a stray array and a camera-coordinate CDF are not
    read by a walk; each is named on stderr and in the manifest's skipped, with what to run."""
    root = tmp_path / "corpus"
    cdf = root / "h36m" / "S1" / "MyPoseFeatures" / "D3_Positions" / "Walking 1.cdf"
    cdf.parent.mkdir(parents=True)
    write_h36m_cdf(cdf, _walk_and_turn(1))
    mono = root / "h36m" / "S1" / "MyPoseFeatures" / "D3_Positions_mono" / "Walking 1.cdf"
    mono.parent.mkdir(parents=True)
    write_h36m_cdf(mono, _walk_and_turn(1))
    npz = root / "vp" / "data_3d_h36m.npz"
    npz.parent.mkdir()
    write_videopose_npz(npz, {"S9": {"Walking": _walk_and_turn(2) / 1000.0}})
    stray = root / "cache.npy"
    np.save(stray, np.zeros((3, 17, 3)))
    (root / "notes.txt").write_text("not motion data\n")
    out = tmp_path / "index.csv"

    code, _, err = _run_datasets(["h36m", "mine", root, "--out", out], capsys)
    assert code == 0, err
    manifest = json.loads(out.with_name("index.manifest.json").read_text())
    passed = {Path(s["path"]).name: s for s in manifest["skipped"] if s.get("passed_over")}
    assert sorted(passed) == ["Walking 1.cdf", "cache.npy", "data_3d_h36m.npz"]
    assert str(mono) == passed["Walking 1.cdf"]["path"]
    assert f"run on {npz.parent}" in passed["data_3d_h36m.npz"]["error"]
    assert "--format array" in passed["cache.npy"]["error"]
    # each named on stderr, one warning per reason
    assert str(npz) in err and str(stray) in err and str(mono) in err
    assert err.count("passed over 1 file that may hold motion data") == 3
    # and the one file read is still the only one read
    assert [i["path"] for i in manifest["inputs"]] == [str(cdf)]

    # pointing at the npz's folder reads it, and nothing is passed over
    code, _, err = _run_datasets(["h36m", "mine", npz.parent, "--out", out], capsys)
    assert code == 0, err
    manifest = json.loads(out.with_name("index.manifest.json").read_text())
    assert manifest["skipped"] == [] and "passed over" not in err


# --- detect takes the frame rate estimate's manifest records -----------------------------


def _estimate_like(folder: Path, fps_hz: float) -> Path:
    """An npz as ``turn-eval estimate`` writes it (camera axes, metres, keyed by its stem)
    with the manifest beside it recording ``fps_hz``."""
    from test_detect import WALK_TURN_WALK, stream

    zup = stream(WALK_TURN_WALK)
    cam = np.stack([zup[..., 0], -zup[..., 2], zup[..., 1]], axis=-1).astype(np.float32)
    folder.mkdir(parents=True, exist_ok=True)
    npz = folder / "home01.npz"
    np.savez(npz, home01=cam)
    manifest = {"time": {"fps_hz": fps_hz, "n_frames": len(cam)}}
    (folder / "home01.manifest.json").write_text(json.dumps(manifest))
    return npz


def test_detect_takes_the_rate_from_estimates_manifest(tmp_path, capsys) -> None:
    import pandas as pd

    npz = _estimate_like(tmp_path / "s", 25.0)
    common = ["--min-turn-deg", "67.5"]
    # the manifest's rate, said on stderr; the same turns as the arrays at --fps 25
    code, _, err = _run_eval(
        ["detect", npz, "--from", "turnbench", *common, "--out", tmp_path / "a.csv"], capsys
    )
    assert code == 0, err
    assert "frame rate 25 Hz, from the estimate manifests" in err
    code, _, err = _run_eval(
        ["detect", npz, "--layout", "h36m17", "--up-axis", "-y", "--fps", "25", *common]
        + ["--out", tmp_path / "b.csv"],
        capsys,
    )
    assert code == 0, err
    a, b = pd.read_csv(tmp_path / "a.csv"), pd.read_csv(tmp_path / "b.csv")
    assert len(a) == 1 and a[["start_s", "end_s", "angle_deg"]].equals(
        b[["start_s", "end_s", "angle_deg"]]
    )

    # the README's --fps 30 on a 25 fps video: one line naming both rates, exit 2, no file
    out = tmp_path / "c.csv"
    code, _, err = _run_eval(
        ["detect", npz, "--from", "turnbench", "--fps", "30", *common, "--out", out], capsys
    )
    assert code == 2 and not out.exists()
    (line,) = [x for x in err.splitlines() if x.startswith("turn-eval: error")]
    assert "--fps 30 contradicts the 25 Hz" in line and "--force-fps" in err
    # forced: the same frames, times scaled by 25/30
    code, _, err = _run_eval(
        ["detect", npz, "--from", "turnbench", "--fps", "30", "--force-fps", *common]
        + ["--out", out],
        capsys,
    )
    assert code == 0 and "from --fps (forced over the manifests' 25 Hz)" in err
    c = pd.read_csv(out)
    assert np.allclose(c["start_s"] * 30, a["start_s"] * 25, atol=1e-3)


def test_a_phone_rate_prints_rounded_and_agrees_with_its_rounding(tmp_path, capsys) -> None:
    npz = _estimate_like(tmp_path / "s", 31.249999999)
    args = ["detect", npz, "--from", "turnbench", "--out", tmp_path / "d.csv"]
    code, _, err = _run_eval(args, capsys)
    assert code == 0 and "frame rate 31.25 Hz" in err and "31.2499" not in err
    code, _, err = _run_eval([*args, "--fps", "31.25"], capsys)
    assert code == 0, err
    # a stream with no manifest still needs --fps, said in one line
    (tmp_path / "s" / "home01.manifest.json").unlink()
    code, _, err = _run_eval(args, capsys)
    assert code == 2 and "--fps is needed" in err


# --- detections in milliseconds ------------------------------------------------------------

EVENT_REF = """session,subject,start_s,end_s,angle_deg
s1,P1,10,12,90
s1,P1,200,203,180
s2,P2,40,42,90
"""


def _ms(tmp_path: Path) -> tuple[Path, Path]:
    """The reference's own turns as a detector in milliseconds writes them: F1 1.0 in seconds."""
    ref = tmp_path / "ref.csv"
    ref.write_text(EVENT_REF)
    det = tmp_path / "det_ms.csv"
    det.write_text(
        "session,subject,start_s,end_s,angle_deg\n"
        "s1,P1,10000,12000,90\ns1,P1,200000,203000,180\ns2,P2,40000,42000,90\n"
    )
    return det, ref


def test_milliseconds_past_a_sessions_end_are_refused_in_one_line(tmp_path, capsys) -> None:
    det, ref = _ms(tmp_path)
    sessions = tmp_path / "sessions.csv"
    sessions.write_text("session,subject,duration_s\ns1,P1,500\ns2,P2,500\n")
    code, out, err = _run_eval(
        ["score-events", det, "-r", ref, "--sessions", sessions, "--bootstrap", "0"], capsys
    )
    assert code == 2 and out == ""
    (line,) = [x for x in err.splitlines() if "error" in x]
    # the first detection past its end (line 2: 12000 s in a 500 s session), the count, the unit
    assert f"{det}:2" in line and "12000 s" in line and "500 s" in line
    assert "3 of 3 detections" in line and "milliseconds" in line
    # the same detections in seconds score F1 1.0 against the same sessions
    det.write_text("session,subject,start_s,end_s,angle_deg\n" + EVENT_REF.split("\n", 1)[1])
    code, out, err = _run_eval(
        ["score-events", det, "-r", ref, "--sessions", sessions, "--bootstrap", "0"]
        + ["--format", "json"],
        capsys,
    )
    assert code == 0 and json.loads(out)["overall"]["f1"] == 1.0


def test_milliseconds_without_sessions_are_warned_about(tmp_path, capsys) -> None:
    det, ref = _ms(tmp_path)
    code, out, err = _run_eval(
        ["score-events", det, "-r", ref, "--bootstrap", "0", "--format", "json"], capsys
    )
    assert code == 0 and json.loads(out)["overall"]["f1"] == 0.0
    # 40000 and 200000 start past 100 x 203 s (the last reference end); 10000 does not
    assert "warning: 2 of 3 detections start past 100 x" in err and "milliseconds" in err


# --- the agreement gate counts missed turns ----------------------------------------------


def test_the_agreement_gate_fails_a_rater_who_misses_turns(tmp_path, capsys) -> None:
    """Two raters who agree on every turn they both marked (kappa over matched turns 1.0)
    while one misses a fifth of them: the default gate fails on kappa counting missed turns,
    worked out here with scikit-learn from the generator's truth; --gate-on matched passes."""
    from sklearn.metrics import cohen_kappa_score

    from turn_datasets.synthetic.eaf import Raters, write_sessions

    synth = write_sessions(
        tmp_path / "eaf",
        seed=5,
        n_pairs=3,
        turns_per_subject=30,
        raters=Raters(disagreement_rate=0.0, missed_rate=0.2, shifted_rate=0.0),
    )
    double = synth.truth[synth.truth["double_annotated"]]
    a, b = double["a_angle_deg"], double["b_angle_deg"]
    both = a.notna() & b.notna()
    assert (a[both] == b[both]).all() and (~both).sum() > 0
    # one item per matched pair, one per annotation the other rater has nothing for
    ya = [str(int(x)) if x == x else "unmatched" for x in a]
    yb = [str(int(x)) if x == x else "unmatched" for x in b]
    with_missed = cohen_kappa_score(ya, yb)
    assert with_missed < 0.9

    folder = synth.paths[0].parent
    args = ["remap", "agreement", folder, "--bootstrap", "0", "--min-kappa", "0.9"]
    code, out, err = _run_datasets([*args, "--format", "json"], capsys)
    assert code == 3
    doc = json.loads(out)
    assert doc["kappa"] == 1.0 and doc["kappa_with_unmatched"] == pytest.approx(with_missed)
    assert doc["gate"]["failed"] == ["kappa_with_unmatched"] and doc["gate"]["on"] == "both"
    (line,) = [x for x in err.splitlines() if "gate failed" in x]
    assert f"kappa counting missed turns {with_missed:.3f} is below --min-kappa 0.9" in line
    assert "Cohen's kappa 1.000" not in line  # the kappa that passed is not blamed
    # both printed, on stderr and in the report
    code, out, err = _run_datasets(args, capsys)
    assert code == 3
    gate = f"Kappa over matched turns 1.000 (passed); kappa counting missed turns {with_missed:.3f} (FAILED)."
    assert gate in out and gate in err
    # the old rule, asked for by name, passes and still prints both
    code, out, err = _run_datasets([*args, "--gate-on", "matched"], capsys)
    assert code == 0 and "Gate: kappa >= 0.9 passed." in out
    assert f"kappa counting missed turns {with_missed:.3f} (not gated)" in out


# --- commands: estimate's --help, detect's progress ----------------------------------------


def test_estimate_help_says_what_fps_defaults_to(capsys) -> None:
    code, out, _ = _run_eval(["estimate", "--help"], capsys)
    assert code == 0
    fps_help = " ".join(out.split("--fps", 1)[1].split("--level")[0].split())
    assert "see --help" not in fps_help
    assert "the rate the video declares" in fps_help and "within 1%" in fps_help


def test_detect_prints_a_line_per_file_when_stderr_is_not_a_terminal(tmp_path, capsys) -> None:
    for name in ("a", "b", "c"):
        npz = _estimate_like(tmp_path / name, 30.0)
        npz.rename(tmp_path / f"{name}.npz")
        (tmp_path / name / "home01.manifest.json").rename(tmp_path / f"{name}.manifest.json")
    out = tmp_path / "out" / "d.csv"
    code, _, err = _run_eval(
        ["detect", *(tmp_path / f"{n}.npz" for n in "abc"), "--from", "turnbench"]
        + ["--min-turn-deg", "67.5", "--out", out],
        capsys,
    )
    assert code == 0, err
    lines = [x for x in err.splitlines() if x.startswith("detecting")]
    assert [x.split(":")[1].split(" files")[0].strip() for x in lines] == ["1/3", "2/3", "3/3"]


def test_the_first_time_estimate_leaves_out_the_start_up() -> None:
    """A cluster that takes 60 s to start, then 2 s per file: after the second of ten files
    the estimate is 8 x 2 s (click's bar said 8 x 31 s: the start-up over two files)."""
    import io

    from turn_eval.detect.progress import FileProgress

    times = iter([60.0, 62.0, 64.0])
    stream = io.StringIO()
    bar = FileProgress(10, "detecting", stream=stream, clock=lambda: next(times))
    bar.update()  # at 60 s: the first file, no estimate yet
    bar.update()  # at 62 s (estimate read at 62 s)
    bar.update()  # at 64 s
    assert stream.getvalue().splitlines() == [
        "detecting: 1/10 files",
        "detecting: 2/10 files, about 16 s left",
        "detecting: 3/10 files, about 14 s left",
    ]


def test_a_detection_a_little_past_its_sessions_end_is_said_and_scored(tmp_path, capsys) -> None:
    """A stream runs on past the annotated part (the demo's do, by up to 10 s): warned, not
    refused; the detection there is a false one."""
    ref = tmp_path / "ref.csv"
    ref.write_text(EVENT_REF)
    det = tmp_path / "det.csv"
    det.write_text(
        "session,subject,start_s,end_s,angle_deg\n"
        + EVENT_REF.split("\n", 1)[1]
        + "s2,P2,498,505,90\n"
    )
    sessions = tmp_path / "sessions.csv"
    sessions.write_text("session,subject,duration_s\ns1,P1,500\ns2,P2,500\n")
    code, out, err = _run_eval(
        ["score-events", det, "-r", ref, "--sessions", sessions, "--bootstrap", "0"]
        + ["--format", "json"],
        capsys,
    )
    assert code == 0, err
    assert json.loads(out)["overall"]["fp"] == 1
    assert "warning: 1 of 4 detections end past their session's annotated duration" in err
    assert "line 5, 505 s in session 's2' of 500 s in sessions.csv)" in err


# --- one error per run; a spreadsheet's export read and said -------------------------------

SCORE_REF = """clip_id,angle_deg,duration_s
a,90,2
b,180,3
c,135,2
d,90,1
e,225,3
"""


def test_score_reports_every_problem_of_a_file_in_one_run(tmp_path, capsys) -> None:
    """A duplicate id, a missing clip, a non-numeric angle and negative angles (which "(1
    more row like it)" used to hide behind the first kind): one run, every kind, exit 2."""
    ref = tmp_path / "ref.csv"
    ref.write_text(SCORE_REF)
    pred = tmp_path / "pred.csv"
    pred.write_text("clip_id,angle_deg\na,90\nb,ninety\na,95\nc,-10\nd,-20\n")
    code, out, err = _run_eval(["score", pred, "-r", ref], capsys)
    assert code == 2 and out == ""
    assert err.startswith(f"turn-eval: error: {pred}:3: 5 problems of 4 kinds; nothing scored:")
    body = err.splitlines()
    assert "  duplicate clip_id 'a', first on line 2: line 4 ('a', first on line 2)" in body
    assert "  angle_deg 'ninety' is not a number: line 3 ('ninety')" in body
    assert any(
        x.startswith("  angle_deg is negative (-10) (2 rows): lines 5 (-10), 6 (-20)") for x in body
    )
    assert any(
        x.startswith("  1 of the reference's 5 clips is missing from the predictions: 'e'")
        for x in body
    )
    assert "Traceback" not in err


def test_a_semicolon_export_with_padded_ids_is_read_and_said(tmp_path, capsys) -> None:
    ref = tmp_path / "ref.csv"
    ref.write_text(SCORE_REF)
    pred = tmp_path / "pred.csv"
    pred.write_text("clip_id;angle_deg\na;90,0\n b;180\nc;135\n  d;90\ne;225\n")
    code, out, err = _run_eval(
        ["score", pred, "-r", ref, "--format", "json", "--bootstrap", "0"], capsys
    )
    assert code == 0, err
    assert json.loads(out)["overall"]["accuracy"] == 1.0
    assert f"{pred}: read as semicolon-separated (a spreadsheet export?)" in err
    assert f"{pred}: 2 cells of clip_id had spaces around the value, read without them" in err


# --- make test says what it does during its quiet minutes ----------------------------------


def test_every_quiet_step_of_make_test_is_announced() -> None:
    """`make test` from a fresh clone: each command of the installs, lint and both suites
    comes after a line saying what it does (pip --quiet and mypy print nothing for minutes)."""
    import shutil
    import subprocess

    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    repo = Path(__file__).resolve().parents[1]
    # -B: as from a fresh clone (every target out of date); -n: print, run nothing
    dry = subprocess.run(
        [
            "make",
            "-B",
            "-n",
            "test",
            "PYTHON=python3",
            "VENV=/nonexistent/v",
            "VENV_VIDEO=/nonexistent/w",
        ],
        cwd=repo,
        capture_output=True,
        text=True,
        check=True,
        # run inside `make test` too: a nested make would announce its directory
        env={k: v for k, v in os.environ.items() if k not in ("MAKELEVEL", "MAKEFLAGS", "MFLAGS")},
    ).stdout.splitlines()
    commands = [x for x in dry if x.strip() and not x.startswith(("echo ", "touch "))]
    assert any("pip install --quiet" in x for x in commands) and any("mypy" in x for x in commands)
    for k, line in enumerate(dry):
        if line in commands:
            assert k > 0 and dry[k - 1].startswith('echo "make: '), line


def test_score_events_reports_every_kind_of_problem_in_one_run(tmp_path, capsys) -> None:
    ref = tmp_path / "ref.csv"
    ref.write_text(EVENT_REF)
    det = tmp_path / "det.csv"
    det.write_text(
        "session,subject,start_s,end_s,angle_deg,direction\n"
        "s1,P1,10,12,90,left\n"
        "s1,,20,22,90,left\n"  # no subject
        "s1,P1,30,31,-90,left\n"  # a negative angle
        "s1,P1,40,41,90,sideways\n"  # no such direction
        "s2,P2,40,42,90,right\n"
    )
    code, out, err = _run_eval(["score-events", det, "-r", ref, "--bootstrap", "0"], capsys)
    assert code == 2 and out == ""
    assert f"{det}:3: 3 problems of 3 kinds; nothing scored:" in err
    assert "  subject is empty: line 3" in err
    assert "  angle_deg -90 is outside the plausible range [0, 3600]" in err and ": line 4" in err
    assert "  direction 'sideways' is not one of left, right (or empty): line 5" in err
