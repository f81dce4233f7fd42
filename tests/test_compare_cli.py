"""``turn-eval compare``: a hand-worked pair of submissions, JSON keys, errors and exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import run_turn_eval as run

from turn_datasets import __version__
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_eval.clips import metrics

IDS = [f"clip{i}" for i in range(10)]
REF = [45, 90, 90, 135, 180, 180, 90, 45, 225, 135]
# A is one bin too high on clips 0-3 (off by 30°) and right elsewhere:
#   accuracy 6/10; |errors| 30,30,30,30,0,10,10,5,5,5 -> MAE 155/10 = 15.5°.
A = [75, 120, 120, 165, 180, 190, 80, 50, 220, 140]
# B is right on clips 0-8 and puts clip 9 (135°) in the 90° bin:
#   accuracy 9/10; |errors| 5,5,5,5,5,0,0,0,5,35 -> MAE 65/10 = 6.5°.
B = [50, 95, 85, 130, 175, 180, 90, 45, 230, 100]
# Weighted precision by hand (support per reference bin: 45:2, 90:3, 135:2, 180:2, 225:1):
#   A predicts 45:{7} 1/1, 90:{0,6} 1/2, 135:{1,2,9} 1/3, 180:{3,4,5} 2/3, 225:{8} 1/1
#     -> (2*1 + 3*1/2 + 2*1/3 + 2*2/3 + 1*1) / 10 = 6.5 / 10 = 0.65
#   B predicts 45:{0,7} 1, 90:{1,2,6,9} 3/4, 135:{3} 1, 180:{4,5} 1, 225:{8} 1
#     -> (2 + 3*3/4 + 2 + 2 + 1) / 10 = 9.25 / 10 = 0.925
# McNemar: b (A right, B wrong) = {clip9} = 1; c (A wrong, B right) = {clip0..3} = 4;
#   p = 2 * P(X <= 1), X ~ Bin(5, 1/2) = 2 * (1 + 5) / 32 = 0.375.
# Speed (equation 4, every reference duration 2 s, no predicted speeds): speed errors are the
#   angle errors / 2, so A's speed MAE is 7.75 °/s, B's 3.25 °/s.


def write_csv(path: Path, header: str, rows: list[tuple]) -> Path:
    lines = [header] + [",".join(str(v) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.fixture
def files(tmp_path):
    ref = write_csv(
        tmp_path / "ref.csv",
        "clip_id,angle_deg,duration_s",
        [(i, r, 2.0) for i, r in zip(IDS, REF, strict=True)],
    )
    a = write_csv(tmp_path / "a.csv", "clip_id,angle_deg", list(zip(IDS, A, strict=True)))
    # B's rows in another order and header spelt differently: matched by id and name.
    b = write_csv(tmp_path / "b.csv", " Clip_ID ,Angle_Deg", list(zip(IDS, B, strict=True))[::-1])
    return ref, a, b


def test_markdown_table_by_hand(files, capsys):
    ref, a, b = files
    code, out, err = run(["compare", a, b, "--reference", ref], capsys)
    assert code == 0, err
    lines = out.splitlines()
    table = lines[lines.index("| metric | A | B | B - A | 95% CI | p |") :]
    assert table[1] == "|---|---:|---:|---:|---:|---:|"
    cells = [row.strip("|").split("|") for row in table[2:6]]
    assert [c[0].strip() for c in cells] == [
        "Accuracy (%)",
        "MAE (°)",
        "WPrec (%)",
        "MAE speed (°/s)",
    ]
    assert [[c.strip() for c in row[1:4]] for row in cells] == [
        ["60.0", "90.0", "+30.0"],
        ["15.5", "6.5", "-9.0"],
        ["65.0", "92.5", "+27.5"],
        ["7.8", "3.3", "-4.5"],  # 7.75 -> 7.8 and 3.25 -> 3.3: half up, as score's tables
    ]
    mcnemar = next(line for line in lines if line.startswith("McNemar"))
    assert "b = 1 " in mcnemar and "c = 4 " in mcnemar and mcnemar.endswith("p = 0.375")
    signature = next(line for line in lines if line.startswith("signature: "))
    parts = signature.removeprefix("signature: ").split("|")
    assert {"n:10", "seed:0", "bootstrap:paired-percentile-1000", f"version:{__version__}"} <= set(
        parts
    )
    assert err == ""  # nothing to warn about, nothing written


def test_json_keys_and_values_by_hand(files, capsys):
    ref, a, b = files
    args = ["compare", a, b, "--reference", ref, "--format", "json", "--bootstrap", "500"]
    code, out, err = run([*args, "--seed", "3"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert list(doc) == [
        "a",
        "b",
        "reference",
        "n_missing",
        "n",
        "metrics",
        "mcnemar",
        "settings",
        "signature",
    ]
    assert (doc["a"], doc["b"], doc["reference"]) == (str(a), str(b), str(ref))
    assert doc["n"] == 10 and doc["n_missing"] == 0
    expected = {
        "accuracy": (0.6, 0.9),
        "mae_deg": (15.5, 6.5),
        "wprec": (0.65, 0.925),
        "mae_speed_deg_s": (7.75, 3.25),
    }
    assert list(doc["metrics"]) == list(expected)
    for name, (va, vb) in expected.items():
        m = doc["metrics"][name]
        assert list(m) == ["a", "b", "diff", "mean_diff", "ci95", "p_value"]
        assert (m["a"], m["b"], m["diff"]) == pytest.approx((va, vb, vb - va))
        assert m["ci95"][0] <= m["diff"] <= m["ci95"][1]
        assert 1 / 501 <= m["p_value"] <= 1
    assert doc["mcnemar"] == {"b": 1, "c": 4, "n_discordant": 5, "p_value": pytest.approx(0.375)}
    assert doc["settings"]["bootstrap"] == 500 and doc["settings"]["seed"] == 3
    assert doc["settings"]["version"] == __version__
    assert "seed:3" in doc["signature"]["options"].split("|")


def test_identical_submissions(files, capsys):
    ref, a, _ = files
    code, out, _ = run(["compare", a, a, "--reference", ref, "--format", "json"], capsys)
    assert code == 0
    doc = json.loads(out)
    for m in doc["metrics"].values():
        assert (m["diff"], m["ci95"], m["p_value"]) == (0.0, [0.0, 0.0], 1.0)
    assert doc["mcnemar"] == {"b": 0, "c": 0, "n_discordant": 0, "p_value": 1.0}


def test_same_inputs_same_bytes_and_out_file(files, tmp_path, capsys):
    ref, a, b = files
    first = run(["compare", a, b, "--reference", ref], capsys)[1]
    out = tmp_path / "cmp.md"
    code, second, err = run(["compare", a, b, "--reference", ref, "--out", out], capsys)
    assert code == 0 and first == second
    assert out.read_text(encoding="utf-8") == second
    assert f"wrote comparison {out}" in err


def test_allow_missing_compares_the_common_clips(tmp_path, files, capsys):
    ref, _, _ = files
    # Both leave out clip9, where only A was right: on clips 0-8 A has 5/9 and B 9/9, and
    # the McNemar counts become b = 0, c = 4 (p = 2 / 16 = 0.125).
    a = write_csv(tmp_path / "a9.csv", "clip_id,angle_deg", list(zip(IDS, A, strict=True))[:9])
    b = write_csv(tmp_path / "b9.csv", "clip_id,angle_deg", list(zip(IDS, B, strict=True))[:9])
    code, _, err = run(["compare", a, b, "--reference", ref], capsys)
    assert code == EXIT_BAD_INPUT
    assert str(a) in err and "missing" in err and "--allow-missing" in err
    args = ["compare", a, b, "--reference", ref, "--allow-missing", "--format", "json"]
    code, out, err = run(args, capsys)
    assert code == 0
    doc = json.loads(out)
    assert (doc["n"], doc["n_missing"]) == (9, 1)
    assert doc["metrics"]["accuracy"]["a"] == pytest.approx(5 / 9)
    assert doc["metrics"]["accuracy"]["b"] == pytest.approx(1.0)
    assert (doc["mcnemar"]["b"], doc["mcnemar"]["c"]) == (0, 4)
    assert doc["mcnemar"]["p_value"] == pytest.approx(0.125)
    assert "missing" in err  # the reader's warning, on stderr


def test_submissions_covering_different_clips_are_refused(tmp_path, files, capsys):
    ref, _, _ = files
    a = write_csv(tmp_path / "a.csv", "clip_id,angle_deg", list(zip(IDS, A, strict=True))[1:])
    b = write_csv(tmp_path / "b.csv", "clip_id,angle_deg", list(zip(IDS, B, strict=True))[:-1])
    args = ["compare", a, b, "--reference", ref, "--allow-missing"]
    code, out, err = run(args, capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    error = err.strip().splitlines()[-1]
    assert "do not cover the same clips" in error
    assert f"1 only in {a} ('clip9')" in error and f"1 only in {b} ('clip0')" in error


def test_a_bad_row_names_the_file_and_line(tmp_path, files, capsys):
    ref, a, _ = files
    rows = list(zip(IDS, B, strict=True))
    rows[4] = ("clip4", "nan")
    b = write_csv(tmp_path / "bad.csv", "clip_id,angle_deg", rows)
    out = tmp_path / "cmp.json"
    args = ["compare", a, b, "--reference", ref, "--format", "json", "--out", out]
    code, stdout, err = run(args, capsys)
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert f"{b}:6" in err  # header is line 1, clip4 line 6
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_bad_options_and_output_over_an_input(files, capsys):
    ref, a, b = files
    before = a.read_bytes()
    code, _, err = run(["compare", a, b, "--reference", ref, "--out", a], capsys)
    assert code == EXIT_BAD_INPUT and "overwrite" in err
    assert a.read_bytes() == before
    for bad in (["--bootstrap", "0"], ["--seed", "-1"], ["--format", "csv"]):
        code, out, _ = run(["compare", a, b, "--reference", ref, *bad], capsys)
        assert code == EXIT_BAD_INPUT and out == "", bad


def test_compare_values_agree_with_the_score_metrics(tmp_path, capsys):
    # On a larger random set the A and B columns must be the numbers `turn-eval score`'s
    # library computes for each file, speed included.
    rng = np.random.default_rng(4)
    n = 150
    ids = [f"c{i}" for i in range(n)]
    ref_deg, duration_s = rng.uniform(40, 240, n), rng.uniform(1.0, 4.0, n)
    ref = write_csv(
        tmp_path / "ref.csv",
        "clip_id,angle_deg,duration_s",
        list(zip(ids, ref_deg, duration_s, strict=True)),
    )
    preds = {}
    for side, sd in (("a", 30.0), ("b", 15.0)):
        preds[side] = np.abs(ref_deg + rng.normal(0, sd, n))
        write_csv(
            tmp_path / f"{side}.csv", "clip_id,angle_deg", list(zip(ids, preds[side], strict=True))
        )
    args = ["compare", tmp_path / "a.csv", tmp_path / "b.csv", "--reference", ref]
    code, out, _ = run([*args, "--format", "json", "--bootstrap", "100"], capsys)
    assert code == 0
    doc = json.loads(out)
    for side in ("a", "b"):
        scored = metrics.compute_metrics(preds[side], ref_deg, ref_duration_s=duration_s)
        for name in ("accuracy", "mae_deg", "wprec", "mae_speed_deg_s"):
            assert doc["metrics"][name][side] == pytest.approx(scored[name], rel=1e-9)


def test_help_example_and_console_script(files):
    ref, a, b = files
    exe = Path(sys.executable).parent / "turn-eval"
    help_text = subprocess.run([exe, "compare", "--help"], capture_output=True, text=True)
    assert help_text.returncode == 0
    lines = [line.strip() for line in help_text.stdout.splitlines()]
    assert lines[lines.index("Example:") + 1].startswith("turn-eval compare baseline.csv ours.csv")
    missing = subprocess.run(
        [exe, "compare", a, b, "--reference", ref.with_name("nope.csv")],
        capture_output=True,
        text=True,
    )
    assert missing.returncode == EXIT_BAD_INPUT
    assert missing.stdout == "" and "Traceback" not in missing.stderr
    assert "nope.csv" in missing.stderr
    ok = subprocess.run(
        [exe, "compare", a, b, "--reference", ref, "--bootstrap", "200", "--format", "json"],
        capture_output=True,
        text=True,
    )
    assert ok.returncode == 0
    assert np.isclose(json.loads(ok.stdout)["metrics"]["accuracy"]["diff"], 0.3)


def test_an_out_file_that_cannot_be_written_prints_nothing_and_exits_2(files, capsys):
    ref, a, b = files
    out = ref / "cmp.md"  # under a file: its folder cannot be made
    code, stdout, err = run(
        ["compare", a, b, "--reference", ref, "--bootstrap", "20", "--out", out], capsys
    )
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert err == f"turn-eval: error: {out}: cannot write the comparison: {ref}: File exists\n"


def test_plots_dir_draws_a_beside_b_on_shared_axes(files, tmp_path, capsys, monkeypatch):
    from turn_eval.clips import plots

    ref, a, b = files
    figures = tmp_path / "figures"
    args = ["compare", a, b, "-r", ref, "--bootstrap", "20", "--plots-dir", figures]
    code, out, err = run([*args, "--names", "base", "ours"], capsys)
    assert code == 0 and "| metric |" in out
    assert sorted(p.name for p in figures.iterdir()) == sorted(plots.PLOT_FILES)
    assert f"wrote base beside ours: {figures / 'confusion_matrix.png'}" in err
    first = {p.name: p.read_bytes() for p in figures.iterdir()}
    assert all(data[:8] == b"\x89PNG\r\n\x1a\n" for data in first.values())
    # the figures as drawn: one panel per file, titled by --names (else the file names)
    drawn = {}
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: drawn.setdefault(path.name, fig))
    assert run(args, capsys)[0] == 0
    for name, fig in drawn.items():
        panels = [ax for ax in fig.axes if ax.get_title()]
        assert [ax.get_title() for ax in panels] == ["a", "b"], name
        assert panels[0].get_ylim() == panels[1].get_ylim(), name
    # same inputs, same bytes
    monkeypatch.undo()
    assert run([*args, "--names", "base", "ours"], capsys)[0] == 0
    assert {p.name: p.read_bytes() for p in figures.iterdir()} == first


def test_plots_dir_refusals(files, tmp_path, capsys):
    ref, a, b = files
    base = ["compare", a, b, "-r", ref, "--bootstrap", "20"]
    code, out, err = run([*base, "--names", "x", "y"], capsys)
    assert code == EXIT_BAD_INPUT and out == "" and "--plots-dir" in err
    code, out, err = run([*base, "--plots-dir", tmp_path / "f", "--names", "x", "x"], capsys)
    assert code == EXIT_BAD_INPUT and out == "" and not (tmp_path / "f").exists()
    # a file where the folder should be: one line, nothing replaced
    code, out, err = run([*base, "--plots-dir", a], capsys)
    assert code == EXIT_BAD_INPUT and out == "" and "is a file" in err
    assert a.read_text(encoding="utf-8").startswith("clip_id,angle_deg")
