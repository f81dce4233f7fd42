"""``turn-eval profile``: every number of the three tables against an independent computation.

The detections are drawn here with known rates, angles and speeds for participants in two
time zones; the expected values are computed the slow, obvious way (pandas group-bys, Python
``datetime`` walking hour by hour, scikit-learn's ``roc_auc_score``, Hedges' g from its
formula), never through turnbench's own code.
"""

from __future__ import annotations

import json
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_datasets, run_turn_eval
from sklearn.metrics import roc_auc_score

from turn_eval.profile import turning_profile

PD = ["P01", "P02", "P03", "P04", "P05"]
HC = ["C01", "C02", "C03", "C04"]
SMALL = "P09"  # a PD participant with three turns: suppressed at --min-turns 5


def run(args, capsys) -> tuple[int, str, str]:
    """``turn-eval profile args``."""
    return run_turn_eval(["profile", *args], capsys)


def _write_inputs(folder: Path, seed: int = 7) -> dict[str, Path]:
    """Two sessions per participant on consecutive days, starts in +01:00 and -05:00; PD
    participants turn less far, more slowly; durations cross hour and day boundaries."""
    rng = np.random.default_rng(seed)
    sessions, detections = [], []
    for k, subject in enumerate([*PD, *HC, SMALL]):
        pd_like = subject.startswith("P")
        zone = "+01:00" if k % 2 else "-05:00"
        for day in range(2):
            session = f"{subject}-d{day}"
            hour = 21 if day == 1 and k % 3 == 0 else 9 + k % 5
            start = f"2024-03-{10 + day:02d}T{hour:02d}:{rng.integers(0, 60):02d}:17{zone}"
            duration = float(rng.uniform(2.5, 4.5) * 3600)
            sessions.append((session, subject, duration, start))
            t = float(rng.uniform(5, 60))
            n = 3 if subject == SMALL and day == 0 else (0 if subject == SMALL else 10**6)
            while n > 0:
                angle = float(rng.uniform(60, 150) if pd_like else rng.uniform(80, 200))
                speed = float(rng.uniform(30, 60) if pd_like else rng.uniform(50, 100))
                end = t + angle / speed
                if end > duration:
                    break
                steps = int(rng.integers(3, 8) if pd_like else rng.integers(1, 5))
                kind = "step" if steps >= 3 and rng.random() < 0.8 else "pivot"
                detections.append((session, subject, t, end, angle, speed * 1.4, steps, kind))
                t = end + float(rng.exponential(240 if pd_like else 150))
                n -= 1
    paths = {
        "sessions": folder / "sessions.csv",
        "detections": folder / "detections.csv",
        "participants": folder / "participants.csv",
    }
    pd.DataFrame(sessions, columns=["session", "subject", "duration_s", "start_time"]).to_csv(
        paths["sessions"], index=False
    )
    pd.DataFrame(
        detections,
        columns=[
            "session",
            "subject",
            "start_s",
            "end_s",
            "angle_deg",
            "peak_speed_deg_s",
            "steps",
            "turn_type",
        ],
    ).to_csv(paths["detections"], index=False)
    cohorts = [(s, "PD", "on" if i % 2 else "off") for i, s in enumerate([*PD, SMALL])]
    cohorts += [(s, "HC", "on" if i % 2 else "off") for i, s in enumerate(HC)]
    pd.DataFrame(cohorts, columns=["subject", "cohort", "medication"]).to_csv(
        paths["participants"], index=False
    )
    return paths


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    return _write_inputs(tmp_path_factory.mktemp("profile"))


@pytest.fixture(scope="module")
def result(inputs):
    return turning_profile(
        inputs["detections"], inputs["sessions"], inputs["participants"], n_resamples=200, seed=3
    )


def _expected_profile(inputs) -> pd.DataFrame:
    """The profile by pandas group-bys and datetime arithmetic."""
    ses = pd.read_csv(inputs["sessions"])
    det = pd.read_csv(inputs["detections"]).merge(ses, on=["session", "subject"])
    det["duration"] = det["end_s"] - det["start_s"]
    det["angle"] = det["angle_deg"].abs()
    det["speed"] = det["angle"] / det["duration"]
    det["date"] = [
        (datetime.fromisoformat(t) + timedelta(seconds=s)).date()
        for t, s in zip(det["start_time"], det["start_s"], strict=True)
    ]
    g = det.groupby("subject")
    out = pd.DataFrame({"recorded_h": ses.groupby("subject")["duration_s"].sum() / 3600})
    out["turns"] = g.size().reindex(out.index, fill_value=0)
    out["turns_per_hour"] = out["turns"] / out["recorded_h"]
    out["mean_angle_deg"] = g["angle"].mean()
    out["median_duration_s"] = g["duration"].median()
    out["mean_speed_deg_s"] = g["speed"].mean()
    out["peak_speed_deg_s"] = g["peak_speed_deg_s"].mean()
    out["mean_steps"] = g["steps"].mean()
    out["pivot_share"] = g["turn_type"].apply(lambda s: float((s == "pivot").mean()))
    for centre in (45, 90, 135, 180, 225):
        lo = -np.inf if centre == 45 else centre - 22.5
        hi = np.inf if centre == 225 else centre + 22.5
        out[f"share_bin_{centre}"] = g["angle"].apply(
            lambda a, lo=lo, hi=hi: ((a >= lo) & (a < hi)).mean()
        )
    for name in ("angle", "duration", "speed"):
        out[f"cv_{name}"] = g[name].std(ddof=1) / g[name].mean()
    daily = det.groupby(["subject", "date"])[["angle", "duration", "speed"]].mean()
    for name in ("angle", "duration", "speed"):
        per = daily[name].groupby("subject")
        out[f"cv_days_{name}"] = per.std(ddof=1) / per.mean()
    return out


def test_profile_numbers_equal_group_bys(result, inputs):
    got = result.profile.set_index("subject")
    want = _expected_profile(inputs)
    assert sorted(got.index) == sorted(want.index)
    assert list(result.profile.columns[:8]) == [
        "subject",
        "cohort",
        "recorded_h",
        "turns",
        "turns_per_hour",
        "mean_angle_deg",
        "median_duration_s",
        "mean_speed_deg_s",
    ]
    kept = [s for s in want.index if s != SMALL]
    for col in want.columns:
        np.testing.assert_allclose(
            got.loc[kept, col].to_numpy(float),
            want.loc[kept, col].to_numpy(float),
            rtol=1e-9,
            err_msg=col,
        )
    assert got.loc[SMALL, "turns"] == 3
    assert got.loc[SMALL, "recorded_h"] == pytest.approx(want.loc[SMALL, "recorded_h"])
    measures = [c for c in got.columns if c not in ("cohort", "recorded_h", "turns")]
    assert got.loc[SMALL, measures].isna().all()
    assert result.doc["suppressed"] == 1


def _expected_by_hour(inputs, skip=(SMALL,)) -> dict[tuple[str, str, int], list[float]]:
    """Hour cells by walking each session hour by hour in its own local time."""
    ses = pd.read_csv(inputs["sessions"])
    det = pd.read_csv(inputs["detections"]).merge(ses, on=["session", "subject"])
    cells: dict[tuple[str, str, int], list[float]] = {}
    for row in ses.itertuples(index=False):
        if row.subject in skip:
            continue
        t = datetime.fromisoformat(row.start_time)
        end = t + timedelta(seconds=row.duration_s)
        while t < end:
            nxt = min(t.replace(minute=0, second=0, microsecond=0) + timedelta(hours=1), end)
            key = (row.subject, t.date().isoformat(), t.hour)
            cells.setdefault(key, [0.0, 0.0])[1] += (nxt - t).total_seconds() / 60
            t = nxt
    for row in det.itertuples(index=False):
        if row.subject in skip:
            continue
        t = datetime.fromisoformat(row.start_time) + timedelta(seconds=row.start_s)
        cells[(row.subject, t.date().isoformat(), t.hour)][0] += 1
    return cells


def test_by_hour_splits_sessions_at_local_hours(result, inputs):
    want = _expected_by_hour(inputs)
    got = {
        (r.subject, r.date, int(r.hour)): [r.turns, r.recorded_min]
        for r in result.by_hour.itertuples(index=False)
    }
    assert set(got) == set(want)
    for key, (turns, minutes) in want.items():
        assert got[key][0] == turns, key
        assert got[key][1] == pytest.approx(minutes, abs=1e-6), key
    # the sessions that start at 21:xx run past midnight into the next local date
    assert any(date == "2024-03-12" for _, date, _ in got)


def _hedges(a: np.ndarray, b: np.ndarray) -> float:
    n1, n2 = len(a), len(b)
    pooled = np.sqrt(((n1 - 1) * a.var(ddof=1) + (n2 - 1) * b.var(ddof=1)) / (n1 + n2 - 2))
    return (a.mean() - b.mean()) / pooled * (1 - 3 / (4 * (n1 + n2) - 9))


def test_contrasts_equal_formulas_and_sklearn(result):
    prof = result.profile
    table = result.contrasts.set_index("measure")
    assert table.index[0] == "turns_per_hour"
    for measure, row in table.iterrows():
        a = prof.loc[prof["cohort"] == "PD", measure].dropna().to_numpy(float)
        b = prof.loc[prof["cohort"] == "HC", measure].dropna().to_numpy(float)
        assert (row["n_pd"], row["n_hc"]) == (len(a), len(b)) == (len(PD), len(HC))
        assert row["pd_mean"] == pytest.approx(a.mean(), rel=1e-12)
        assert row["hc_mean"] == pytest.approx(b.mean(), rel=1e-12)
        assert row["difference"] == pytest.approx(a.mean() - b.mean(), rel=1e-9, abs=1e-12)
        if np.std(np.concatenate([a, b])) > 0 and (a.var() > 0 or b.var() > 0):
            assert row["hedges_g"] == pytest.approx(_hedges(a, b), rel=1e-9)
        y = np.r_[np.ones(len(a)), np.zeros(len(b))]
        assert row["auc"] == pytest.approx(roc_auc_score(y, np.r_[a, b]), abs=1e-12)
        for stat in ("difference", "hedges_g", "auc"):
            if np.isfinite(row[f"{stat}_lo"]):
                assert row[f"{stat}_lo"] <= row[stat] + 1e-9 or stat != "difference"
                assert row[f"{stat}_lo"] <= row[f"{stat}_hi"]
    # the planted PD participants turn less far and more slowly: the contrasts see it
    assert table.loc["mean_angle_deg", "auc"] < 0.2
    assert table.loc["mean_angle_deg", "hedges_g"] < -1
    assert table.loc["mean_steps", "auc"] > 0.8


def test_bootstrap_intervals_follow_the_documented_draws(result):
    """The intervals of one measure recomputed by a loop over the documented draws (PD rows
    first, then HC, from one generator), each resample scored by sklearn and by hand."""
    prof = result.profile
    measure = "mean_speed_deg_s"
    a = prof.loc[prof["cohort"] == "PD", measure].dropna().to_numpy(float)
    b = prof.loc[prof["cohort"] == "HC", measure].dropna().to_numpy(float)
    rng = np.random.default_rng(3)
    ia = rng.integers(0, len(a), (200, len(a)))
    ib = rng.integers(0, len(b), (200, len(b)))
    diffs, gs, aucs = [], [], []
    for ra, rb in zip(ia, ib, strict=True):
        x, z = a[ra], b[rb]
        diffs.append(x.mean() - z.mean())
        gs.append(_hedges(x, z))
        aucs.append(roc_auc_score(np.r_[np.ones(len(x)), np.zeros(len(z))], np.r_[x, z]))
    row = result.contrasts.set_index("measure").loc[measure]
    for stat, values in (("difference", diffs), ("hedges_g", gs), ("auc", aucs)):
        lo, hi = np.percentile(np.asarray(values)[np.isfinite(values)], [2.5, 97.5])
        assert row[f"{stat}_lo"] == pytest.approx(lo, rel=1e-9, abs=1e-12)
        assert row[f"{stat}_hi"] == pytest.approx(hi, rel=1e-9, abs=1e-12)


def test_auc_and_g_on_a_hand_worked_case(tmp_path):
    """Three PD values 1, 2, 4 against three HC values 2, 3, 5: of the nine pairs PD wins
    (4>2, 4>3) two, ties one (2=2): AUC = 2.5/9. Means 7/3 and 10/3; variances 7/3 and 7/3;
    pooled sd sqrt(7/3); J = 1 - 3/(4*6-9) = 0.8; g = -1/sqrt(7/3) * 0.8 = -0.5237."""
    from turn_eval.profile.contrasts import group_stats

    a = np.array([[1.0], [2.0], [4.0]])
    b = np.array([[2.0], [3.0], [5.0]])
    st = group_stats(np.ones((1, 3)), np.ones((1, 3)), a, b)
    assert st.auc[0, 0] == pytest.approx(2.5 / 9)
    assert st.hedges_g[0, 0] == pytest.approx(-0.8 / np.sqrt(7 / 3))
    # weights: drawing PD's first participant twice and its third not at all is the sample
    # 1, 1, 2: wins none, ties 1 (2=2) of nine -> AUC 0.5/9
    st = group_stats(np.array([[2.0, 1.0, 0.0]]), np.ones((1, 3)), a, b)
    assert st.auc[0, 0] == pytest.approx(0.5 / 9)
    assert st.pd_mean[0, 0] == pytest.approx(4 / 3)


def test_cli_writes_three_tables_and_json(inputs, tmp_path, capsys):
    out = tmp_path / "out"
    code, stdout, err = run(
        [
            inputs["detections"],
            "--sessions",
            inputs["sessions"],
            "--participants",
            inputs["participants"],
            "--out-dir",
            out,
            "--bootstrap",
            "50",
            "--format",
            "json",
            "--plots",
        ],
        capsys,
    )
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["suppressed"] == 1 and doc["groups"] == {"pd": "PD", "hc": "HC"}
    assert "fewer than 5 turns" in err
    table = pd.read_csv(out / "contrasts.csv")
    assert list(table["measure"]) == [r["measure"] for r in doc["contrasts"]]
    assert (out / "profile.csv").is_file() and (out / "by_hour.csv").is_file()
    assert (out / "forest.png").is_file() and (out / "distributions.png").is_file()
    assert len(list((out / "heatmaps").glob("*.png"))) == len(PD) + len(HC)
    again = tmp_path / "again"
    run(
        [
            inputs["detections"],
            "--sessions",
            inputs["sessions"],
            "--participants",
            inputs["participants"],
            "--out-dir",
            again,
            "--bootstrap",
            "50",
        ],
        capsys,
    )
    for name in ("profile.csv", "by_hour.csv", "contrasts.csv"):
        assert (out / name).read_bytes() == (again / name).read_bytes()


def test_min_turns_zero_keeps_everyone(inputs):
    res = turning_profile(
        inputs["detections"],
        inputs["sessions"],
        inputs["participants"],
        min_turns=0,
        n_resamples=0,
    )
    assert res.doc["suppressed"] == 0
    row = res.contrasts.set_index("measure").loc["mean_angle_deg"]
    assert row["n_pd"] == len(PD) + 1
    assert np.isnan(row["auc_lo"])


def test_by_another_two_level_column(inputs):
    res = turning_profile(
        inputs["detections"],
        inputs["sessions"],
        inputs["participants"],
        by="medication",
        n_resamples=0,
    )
    assert res.doc["groups"] == {"pd": "off", "hc": "on"}
    assert "medication" in res.profile.columns
    prof = res.profile
    a = prof.loc[prof["medication"] == "off", "mean_angle_deg"].dropna().to_numpy(float)
    b = prof.loc[prof["medication"] == "on", "mean_angle_deg"].dropna().to_numpy(float)
    row = res.contrasts.set_index("measure").loc["mean_angle_deg"]
    assert row["auc"] == pytest.approx(
        roc_auc_score(np.r_[np.ones(len(a)), np.zeros(len(b))], np.r_[a, b])
    )


def _bad(inputs, tmp_path, capsys, *, sessions=None, participants=None, detections=None):
    out = tmp_path / "out"
    args = [
        detections or inputs["detections"],
        "--sessions",
        sessions or inputs["sessions"],
        "--participants",
        participants or inputs["participants"],
        "--out-dir",
        out,
        "--bootstrap",
        "10",
    ]
    code, stdout, err = run(args, capsys)
    assert code == 2, err
    assert stdout == ""
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    assert not out.exists()
    return err


def test_session_missing_from_sessions_table(inputs, tmp_path, capsys):
    ses = pd.read_csv(inputs["sessions"])
    path = tmp_path / "sessions.csv"
    ses[ses["session"] != "P02-d1"].to_csv(path, index=False)
    err = _bad(inputs, tmp_path, capsys, sessions=path)
    assert "'P02-d1'" in err and "not in the sessions table" in err and "detections.csv:" in err


def test_participant_without_cohort(inputs, tmp_path, capsys):
    par = pd.read_csv(inputs["participants"])
    path = tmp_path / "participants.csv"
    par[par["subject"] != "C03"].to_csv(path, index=False)
    err = _bad(inputs, tmp_path, capsys, participants=path)
    assert "'C03' has no cohort" in err and "sessions.csv:" in err
    par.loc[par["subject"] == "C03", "cohort"] = ""
    par.to_csv(path, index=False)
    err = _bad(inputs, tmp_path, capsys, participants=path)
    assert "cohort is empty" in err and "participants.csv:" in err


def test_unparseable_start_time(inputs, tmp_path, capsys):
    ses = pd.read_csv(inputs["sessions"])
    path = tmp_path / "sessions.csv"
    for bad in ("yesterday", "2024-03-10T09:00:00"):
        ses.loc[3, "start_time"] = bad
        ses.to_csv(path, index=False)
        err = _bad(inputs, tmp_path, capsys, sessions=path)
        assert f"start_time '{bad}'" in err and "sessions.csv:5" in err


def test_detection_past_its_session(inputs, tmp_path, capsys):
    det = pd.read_csv(inputs["detections"])
    ses = pd.read_csv(inputs["sessions"]).set_index("session")
    i = int(np.flatnonzero(det["session"] == "C01-d0")[-1])
    det.loc[i, "end_s"] = ses.loc["C01-d0", "duration_s"] + 1.0
    path = tmp_path / "detections.csv"
    det.to_csv(path, index=False)
    err = _bad(inputs, tmp_path, capsys, detections=path)
    assert f"detections.csv:{i + 2}" in err and "after its session's duration_s" in err


def test_existing_out_dir_is_kept_on_bad_input(inputs, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "profile.csv").write_text("old\n")
    ses = pd.read_csv(inputs["sessions"])
    ses.loc[0, "start_time"] = "soon"
    path = tmp_path / "sessions.csv"
    ses.to_csv(path, index=False)
    code, _, _ = run(
        [
            inputs["detections"],
            "--sessions",
            path,
            "--participants",
            inputs["participants"],
            "--out-dir",
            out,
        ],
        capsys,
    )
    assert code == 2
    assert (out / "profile.csv").read_text() == "old\n"


def test_remap_labels_copies_the_recorded_start_time(tmp_path, capsys):
    """ELAN files that record their start (header property ``start_time``) give sessions.csv
    a ``start_time``, which ``profile`` reads; files without it give the column as before."""
    from turn_datasets.synthetic.eaf import session_start_time, write_sessions

    synth = write_sessions(
        tmp_path / "eaf", seed=4, n_pairs=2, turns_per_subject=8, start_times=True
    )
    out = tmp_path / "labels" / "labels.csv"
    args = [
        "remap",
        "labels",
        str(tmp_path / "eaf"),
        "--participants",
        str(synth.participants_path),
    ]
    code, _, err = run_turn_datasets([*args, "--out", out], capsys)
    assert code == 0, err
    sessions = pd.read_csv(out.parent / "sessions.csv")
    assert list(sessions.columns) == ["session", "subject", "duration_s", "start_time"]
    for row in sessions.itertuples(index=False):
        day = int(row.session.rsplit("day", 1)[1])
        assert row.start_time == session_start_time(4, row.session, day)
        assert datetime.fromisoformat(row.start_time).utcoffset() == timedelta(hours=1)
    # the profile reads it: every participant's hours are in by_hour.csv
    # (the annotated duration runs from the first to the last context annotation: turns
    # after it are outside the recording as sessions.csv states it)
    recorded = sessions.rename(columns={"duration_s": "recorded_s"})
    det = pd.read_csv(out).merge(recorded, on=["session", "subject"])
    det = det[det["end_s"] <= det["recorded_s"]]
    det = det.loc[:, ["session", "subject", "start_s", "end_s", "angle_deg"]]
    det.drop_duplicates(["session", "subject", "start_s", "end_s"]).to_csv(
        tmp_path / "det.csv", index=False
    )
    res = turning_profile(
        tmp_path / "det.csv",
        out.parent / "sessions.csv",
        synth.participants_path,
        min_turns=0,
        n_resamples=0,
    )
    assert set(res.by_hour["subject"]) == set(sessions["subject"])
    assert res.by_hour["recorded_min"].sum() == pytest.approx(sessions["duration_s"].sum() / 60)
    # without the property, no column
    write_sessions(tmp_path / "eaf2", seed=4, n_pairs=2, turns_per_subject=8)
    out2 = tmp_path / "labels2" / "labels.csv"
    args[2] = str(tmp_path / "eaf2")
    assert run_turn_datasets([*args, "--out", out2], capsys)[0] == 0
    assert "start_time" not in pd.read_csv(out2.parent / "sessions.csv").columns


def test_optional_measures_follow_the_detections_columns(inputs, tmp_path):
    """Detections without peak speed, steps and turn type: no such measures, the rest equal."""
    det = pd.read_csv(inputs["detections"])
    path = tmp_path / "plain.csv"
    det.drop(columns=["peak_speed_deg_s", "steps", "turn_type"]).to_csv(path, index=False)
    res = turning_profile(path, inputs["sessions"], inputs["participants"], n_resamples=0)
    full = turning_profile(
        inputs["detections"], inputs["sessions"], inputs["participants"], n_resamples=0
    )
    for col in ("peak_speed_deg_s", "mean_steps", "pivot_share"):
        assert col not in res.profile.columns and col in full.profile.columns
    pd.testing.assert_frame_equal(res.profile, full.profile[list(res.profile.columns)])


@pytest.mark.parametrize(
    ("column", "value", "message"),
    [
        ("steps", "2.5", "steps 2.5 is not a whole number"),
        ("steps", "-1", "steps -1 is outside"),
        ("turn_type", "spin", "turn_type 'spin' is not one of pivot, step"),
        ("peak_speed_deg_s", "1e9", "peak_speed_deg_s 1e+09 is outside"),
    ],
)
def test_bad_step_columns_name_their_line(inputs, tmp_path, capsys, column, value, message):
    det = pd.read_csv(inputs["detections"], dtype=str, keep_default_na=False)
    det.loc[4, column] = value
    path = tmp_path / "detections.csv"
    det.to_csv(path, index=False)
    err = _bad(inputs, tmp_path, capsys, detections=path)
    assert message in err and "detections.csv:6" in err


def test_signature_hashes_the_bytes_read_without_reading_again(inputs, monkeypatch):
    """The detections and sessions are hashed from the bytes their reader read (the
    detections are the profile's largest input); only the participants file, read by the csv
    module, is hashed from the file. The digests are the files' own sha256."""
    import hashlib

    import turn_eval.profile.run as profile_run

    hashed = []

    def hash_file(path):
        hashed.append(Path(path).name)
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()

    monkeypatch.setattr(profile_run, "sha256_file", hash_file)
    res = turning_profile(
        inputs["detections"], inputs["sessions"], inputs["participants"], n_resamples=0
    )
    assert hashed == ["participants.csv"]
    sig = res.doc["signature"]
    for role in ("detections", "sessions", "participants"):
        digest = hashlib.sha256(inputs[role].read_bytes()).hexdigest()
        assert sig[f"{role}_sha256"] == digest
