"""``turn-datasets remap agreement``: report, JSON keys, gate, outputs, review copies, errors."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_datasets

from turn_datasets.cli.agreement import OUT_FILES
from turn_datasets.cli.common import EXIT_BAD_INPUT, EXIT_GATE, EXIT_OK
from turn_datasets.fileio import sha256_file
from turn_datasets.remap.eaf import load_eaf, read_annotations
from turn_datasets.synthetic.eaf import Raters, write_sessions

REPO = Path(__file__).resolve().parents[1]


def run(args, capsys) -> tuple[int, str, str]:
    """``turn-datasets remap agreement args``."""
    return run_turn_datasets(["remap", "agreement", *args], capsys)


@pytest.fixture(scope="module")
def synth(tmp_path_factory):
    return write_sessions(
        tmp_path_factory.mktemp("eaf") / "eaf",
        seed=3,
        n_pairs=3,
        turns_per_subject=30,
        raters=Raters(disagreement_rate=0.10, missed_rate=0.06, shifted_rate=0.04),
    )


def _expected(synth):
    """Matched pairs and unmatched counts worked out from the generator's truth."""
    t = synth.truth
    double = t[t["double_annotated"]]
    both = double[double["a_angle_deg"].notna() & double["b_angle_deg"].notna()]
    matched = both[both["ratio_ab"] >= 0.6]
    a, b = synth.raters
    unmatched = {
        a: int(double["a_angle_deg"].notna().sum() - len(matched)),
        b: int(double["b_angle_deg"].notna().sum() - len(matched)),
    }
    return matched, unmatched


def test_json_report(synth, capsys):
    code, out, err = run([synth.paths[0].parent, "--format", "json", "--bootstrap", "200"], capsys)
    assert code == EXIT_OK, err
    doc = json.loads(out)  # stdout is only the JSON document
    matched, unmatched = _expected(synth)
    a, b = synth.raters
    for key in (
        "raters",
        "matched",
        "unmatched",
        "percent_agreement",
        "kappa",
        "kappa_linear",
        "kappa_ci95",
        "kappa_with_unmatched",
        "by_session",
        "by_rater_pair",
        "settings",
        "annotations",
        "median_start_diff_s",
        "median_end_diff_s",
        "confusion",
        "labels_deg",
    ):
        assert key in doc, key
    assert doc["raters"] == [a, b]
    assert doc["matched"] == len(matched)
    assert doc["unmatched"] == unmatched
    p_o = float((matched["a_angle_deg"] == matched["b_angle_deg"]).mean())
    assert doc["percent_agreement"] == pytest.approx(p_o)  # a fraction, not a percentage
    # Cohen's kappa from the planted angles: p_e = sum over angles of A's share x B's share.
    pa = matched["a_angle_deg"].value_counts(normalize=True)
    pb = matched["b_angle_deg"].value_counts(normalize=True)
    p_e = float(sum(pa.get(x, 0.0) * pb.get(x, 0.0) for x in set(pa.index) | set(pb.index)))
    assert doc["kappa"] == pytest.approx((p_o - p_e) / (1 - p_e))
    # Linear weights: 1 - sum |i - j| p_ij / sum |i - j| pa_i pb_j over the 45-degree bins.
    steps = {x: i for i, x in enumerate([90.0, 135.0, 180.0, 225.0, 270.0, 315.0, 360.0])}
    i = matched["a_angle_deg"].map(steps).to_numpy()
    j = matched["b_angle_deg"].map(steps).to_numpy()
    observed = float(np.abs(i - j).mean())
    expected = float(np.abs(i[:, None] - j[None, :]).mean())  # every A with every B
    assert doc["kappa_linear"] == pytest.approx(1 - observed / expected)
    lo, hi = doc["kappa_ci95"]
    assert lo <= doc["kappa"] <= hi
    assert doc["labels_deg"] == [90, 135, 180, 225, 270, 315, 360]
    assert doc["settings"]["min_overlap"] == 0.6 and doc["settings"]["bootstrap"] == 200
    assert set(doc["by_session"]) == set(
        synth.truth.loc[synth.truth["double_annotated"], "session"]
    )
    assert "wrote" not in err  # nothing written without --out-dir


def test_markdown_report_prints_percentages(synth, capsys):
    code, out, _ = run([*synth.paths, "--bootstrap", "0"], capsys)
    assert code == EXIT_OK
    matched, _ = _expected(synth)
    p_o = float((matched["a_angle_deg"] == matched["b_angle_deg"]).mean())
    assert out.startswith(
        f"# Inter-rater agreement: {synth.raters[0]} (A) vs {synth.raters[1]} (B)"
    )
    assert f"| {100 * p_o:.1f}% |" in out
    assert "## Per session" in out and "## Per pair of raters" in out


def test_gate_exit_codes(synth, capsys, tmp_path):
    code, out, err = run([synth.paths[0].parent, "--min-kappa", "0.5", "--bootstrap", "0"], capsys)
    assert code == EXIT_OK and "Gate: kappa >= 0.5 passed." in out
    code, out, err = run(
        [
            synth.paths[0].parent,
            "--min-kappa",
            "0.999",
            "--bootstrap",
            "0",
            "--format",
            "json",
            "--out-dir",
            tmp_path / "audit",
        ],
        capsys,
    )
    assert code == EXIT_GATE
    assert "gate failed" in err and "below --min-kappa 0.999" in err
    doc = json.loads(out)  # the report is printed before the gate fails
    assert doc["gate"] == {
        "min_kappa": 0.999,
        "on": "both",
        "passed": False,
        "kappa": doc["kappa"],
        "kappa_with_unmatched": doc["kappa_with_unmatched"],
        "failed": ["kappa", "kappa_with_unmatched"],
    }
    # the outputs are complete: a failed release still needs its disagreements reviewed
    assert (
        json.loads((tmp_path / "audit" / "agreement.json").read_text())["gate"]["passed"] is False
    )


def _crosstab_by_hand(matched):
    bins = [90.0, 135.0, 180.0, 225.0, 270.0, 315.0, 360.0]
    table = np.zeros((7, 7), dtype=int)
    for x, y in zip(matched["a_angle_deg"], matched["b_angle_deg"], strict=True):
        table[bins.index(x), bins.index(y)] += 1
    return table


def test_out_dir_files_are_complete_and_reproducible(synth, capsys, tmp_path):
    args = [synth.paths[0].parent, "--bootstrap", "100", "--seed", "4"]
    code, _, err = run([*args, "--out-dir", tmp_path / "one"], capsys)
    assert code == EXIT_OK, err
    assert f"wrote agreement report (8 files) to {tmp_path / 'one'}" in err
    for name in OUT_FILES:
        assert (tmp_path / "one" / name).is_file(), name
    matched, unmatched = _expected(synth)

    confusion = pd.read_csv(tmp_path / "one" / "confusion.csv")
    assert confusion.columns[0] == f"{synth.raters[0]} (rows) / {synth.raters[1]} (columns)"
    assert confusion.iloc[:, 1:].to_numpy().tolist() == _crosstab_by_hand(matched).tolist()

    dis = pd.read_csv(tmp_path / "one" / "disagreements.csv")
    assert (dis["kind"] == "angle").sum() == (matched["kind"] == "disagree").sum()
    assert (dis["kind"] == "unmatched").sum() == sum(unmatched.values())
    assert list(dis.columns)[:3] == ["session", "participant", "kind"]

    pairs = pd.read_csv(tmp_path / "one" / "pairs.csv")
    assert (pairs["status"] == "matched").sum() == len(matched)
    by_session = pd.read_csv(tmp_path / "one" / "by_session.csv")
    assert by_session["matched"].sum() == len(matched)
    assert (tmp_path / "one" / "confusion.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    code, _, _ = run([*args, "--out-dir", tmp_path / "two"], capsys)
    assert code == EXIT_OK
    for name in OUT_FILES:
        assert sha256_file(tmp_path / "one" / name) == sha256_file(tmp_path / "two" / name), name


def _review_annotations(path: Path) -> set[tuple[str, int, int, str]]:
    eaf = load_eaf(path)
    out = set()
    for tier in eaf.tiers:
        if tier.startswith("Disagreement"):
            for s0, s1, value in eaf.get_annotation_data_for_tier(tier):
                out.add((tier, s0, s1, value))
    return out


def _expected_review(synth, session) -> set[tuple[str, int, int, str]]:
    """The Disagreement annotations a session's review copy must hold, from the truth."""
    a, b = synth.raters
    t = synth.truth[synth.truth["session"] == session]
    out = set()

    def ms(x):
        return int(round(x * 1000))

    def deg(x):
        return f"{x:g}"

    for r in t.itertuples():
        tier = f"Disagreement {r.subject}"
        if r.kind == "disagree":
            out.add(
                (
                    tier,
                    ms(min(r.a_start_s, r.b_start_s)),
                    ms(max(r.a_end_s, r.b_end_s)),
                    f"{a}: {deg(r.a_angle_deg)} / {b}: {deg(r.b_angle_deg)}",
                )
            )
        elif r.kind == "missed_a":
            out.add(
                (
                    tier,
                    ms(r.b_start_s),
                    ms(r.b_end_s),
                    f"{a}: none / {b}: {deg(r.b_angle_deg)} (unmatched)",
                )
            )
        elif r.kind == "missed_b":
            out.add(
                (
                    tier,
                    ms(r.a_start_s),
                    ms(r.a_end_s),
                    f"{a}: {deg(r.a_angle_deg)} / {b}: none (unmatched)",
                )
            )
        elif r.kind == "shifted":
            # both unmatched and overlapping: one annotation (ELAN tiers cannot overlap)
            out.add(
                (
                    tier,
                    ms(r.a_start_s),
                    ms(r.b_end_s),
                    f"{a}: {deg(r.a_angle_deg)} / {b}: none (unmatched); "
                    f"{a}: none / {b}: {deg(r.b_angle_deg)} (unmatched)",
                )
            )
    return out


def test_review_eaf_marks_disagreements_and_never_touches_the_original(synth, capsys, tmp_path):
    before = {p: sha256_file(p) for p in synth.paths}
    code, _, err = run(
        [
            synth.paths[0].parent,
            "--bootstrap",
            "0",
            "--out-dir",
            tmp_path / "audit",
            "--review-eaf",
        ],
        capsys,
    )
    assert code == EXIT_OK, err
    assert {p: sha256_file(p) for p in synth.paths} == before
    t = synth.truth
    flagged = sorted(
        t.loc[t["kind"].isin(["disagree", "missed_a", "missed_b", "shifted"]), "session"].unique()
    )
    review = tmp_path / "audit" / "review"
    assert sorted(p.stem for p in review.glob("*.eaf")) == flagged
    assert f"{len(flagged)} review copies" in err
    for session in flagged:
        copy = review / f"{session}.eaf"
        assert _review_annotations(copy) == _expected_review(synth, session)
        # everything else is as it was: the same turns read from the copy
        original = read_annotations(synth.paths[0].parent / f"{session}.eaf")
        again = read_annotations(copy)
        pd.testing.assert_frame_equal(original.drop(columns="file"), again.drop(columns="file"))
        text = copy.read_text(encoding="utf-8")
        assert "MEDIA_DESCRIPTOR" not in text and "/home/clinician" not in text

    code, _, _ = run(
        [
            synth.paths[0].parent,
            "--bootstrap",
            "0",
            "--out-dir",
            tmp_path / "keep",
            "--review-eaf",
            "--keep-media-paths",
        ],
        capsys,
    )
    assert code == EXIT_OK
    kept = (tmp_path / "keep" / "review" / f"{flagged[0]}.eaf").read_text(encoding="utf-8")
    assert f"file:///home/clinician/remap/video/{flagged[0]}.mp4" in kept


# ---------------------------------------------------------------------------------------
# A real file in another convention, through a schema

# pygamma_MaureenMarvinRobin.eaf (bootphon/pygamma-agreement) has one tier per annotator,
# named after them, no PARTICIPANT attribute, and every value "S". Read by hand:
#   Maureen: [1.006, 1.896] S, [3.738, 4.926] S
#   Marvin:  [2.401, 3.422] S
#   Robin:   [5.294, 5.781] S
# No two annotations of different annotators overlap, so no pair is matched at any
# --min-overlap: kappa over matched pairs is undefined. With "unmatched" as a category:
#   Maureen vs Marvin: items (S,U) (S,U) (U,S); p_o = 0; Maureen S 2/3, U 1/3; Marvin S 1/3,
#     U 2/3; p_e = 2/9 + 2/9 = 4/9; kappa = (0 - 4/9) / (5/9) = -0.8.
#   Maureen vs Robin: the same counts, -0.8.  Marvin vs Robin: (S,U) (U,S): p_e = 1/2, -1.
PYGAMMA_SCHEMA = """\
version = 1
[turn]
tier_regex = '^(?P<annotator>Maureen|Marvin|Robin)$'
default_participant = "speaker"
[vocabulary]
# Its single label "S" is not an angle: the schema maps it onto one category.
turn_angle = [90]
[aliases.turn_angle]
S = 90
"""


def test_pygamma_file_through_a_schema(real_eaf_dir, tmp_path, capsys):
    src = real_eaf_dir / "pygamma_MaureenMarvinRobin.eaf"
    schema = tmp_path / "pygamma.toml"
    schema.write_text(PYGAMMA_SCHEMA, encoding="utf-8")
    from turn_datasets.remap.schema import load_schema

    ann = read_annotations(src, schema=load_schema(schema))
    got = sorted(zip(ann["annotator"], ann["start_s"], ann["end_s"], strict=True))
    assert got == [
        ("Marvin", 2.401, 3.422),
        ("Maureen", 1.006, 1.896),
        ("Maureen", 3.738, 4.926),
        ("Robin", 5.294, 5.781),
    ]

    code, out, err = run([src, "--schema", schema], capsys)
    assert code == EXIT_BAD_INPUT
    assert "found 3" in err and "'Marvin', 'Maureen', 'Robin'" in err and "--raters" in err
    assert out == ""

    code, out, err = run(
        [src, "--schema", schema, "--raters", "Maureen", "Marvin", "--format", "json"], capsys
    )
    assert code == EXIT_OK, err
    doc = json.loads(out)
    assert doc["raters"] == ["Maureen", "Marvin"]
    assert doc["annotations"] == {"Maureen": 2, "Marvin": 1}
    assert doc["matched"] == 0
    assert doc["unmatched"] == {"Maureen": 2, "Marvin": 1}
    assert doc["kappa"] is None and doc["kappa_linear"] is None and doc["kappa_ci95"] is None
    assert doc["percent_agreement"] is None
    assert doc["kappa_undefined_reason"] == "no matched pairs"
    assert doc["kappa_with_unmatched"] == pytest.approx(-0.8)
    pairs = {tuple(p["raters"]): p["kappa_with_unmatched"] for p in doc["by_rater_pair"]}
    assert pairs == {
        ("Maureen", "Marvin"): pytest.approx(-0.8),
        ("Marvin", "Robin"): pytest.approx(-1.0),
        ("Maureen", "Robin"): pytest.approx(-0.8),
    }

    code, out, err = run(
        [src, "--schema", schema, "--raters", "Maureen", "Marvin", "--min-kappa", "0.6"], capsys
    )
    assert code == EXIT_GATE
    assert "kappa is undefined (no matched pairs)" in err
    assert "Kappa: no matched pairs." in out

    # No two annotations of different raters overlap at all (gaps of 0.505 s Maureen ->
    # Marvin, 0.316 s Marvin -> Maureen, 0.368 s Maureen -> Robin), so even the smallest
    # threshold links nothing.
    code, out, err = run(
        [
            src,
            "--schema",
            schema,
            "--raters",
            "Maureen",
            "Robin",
            "--min-overlap",
            "0.001",
            "--format",
            "json",
        ],
        capsys,
    )
    assert code == EXIT_OK, err
    doc = json.loads(out)
    assert doc["matched"] == 0 and doc["unmatched"] == {"Maureen": 2, "Robin": 1}
    assert doc["confusion"] == [[0]]
    assert doc["kappa_with_unmatched"] == pytest.approx(-0.8)


# ---------------------------------------------------------------------------------------
# Bad input: exit 2, one line, nothing written


def _bad_value_copy(synth, tmp_path: Path) -> Path:
    folder = tmp_path / "bad"
    shutil.copytree(synth.paths[0].parent, folder)
    path = folder / synth.paths[1].name
    text = path.read_text(encoding="utf-8")
    # the first turn value of the file becomes 100: not in the vocabulary
    first = text.index("<ANNOTATION_VALUE>", text.index('TIER_ID="Turn'))
    end = text.index("</ANNOTATION_VALUE>", first)
    path.write_text(text[:first] + "<ANNOTATION_VALUE>100" + text[end:], encoding="utf-8")
    return folder


@pytest.mark.parametrize(
    "case",
    [
        "missing",
        "bad_value",
        "review_without_out_dir",
        "unknown_rater",
        "min_overlap_zero",
        "min_overlap_nan",
        "min_kappa_nan",
        "not_eaf",
    ],
)
def test_bad_input_exit_2_nothing_written(synth, tmp_path, capsys, case):
    folder = synth.paths[0].parent
    out_dir = tmp_path / "audit"
    args = {
        "missing": [tmp_path / "nope.eaf"],
        "bad_value": [_bad_value_copy(synth, tmp_path)],
        "review_without_out_dir": [folder, "--review-eaf"],
        "unknown_rater": [folder, "--raters", "clinician1", "zed"],
        "min_overlap_zero": [folder, "--min-overlap", "0"],
        # NaN passes click's FloatRange unless refused; a NaN gate would fail every audit.
        "min_overlap_nan": [folder, "--min-overlap", "nan"],
        "min_kappa_nan": [folder, "--min-kappa", "nan"],
        "not_eaf": [synth.participants_path],
    }[case]
    if case != "review_without_out_dir":
        args = [*args, "--out-dir", out_dir]
    code, out, err = run(args, capsys)
    assert code == EXIT_BAD_INPUT
    assert out == ""
    assert "Traceback" not in err
    assert not out_dir.exists()
    if case == "bad_value":
        assert "'100' is not in the turn_angle vocabulary" in err
        assert synth.paths[1].name in err and "tier 'Turn" in err
    if case.endswith("_nan"):
        assert "must be a number, not nan" in err
    if case == "unknown_rater":
        assert "'zed' has no annotations" in err


def test_failure_while_writing_leaves_nothing(synth, tmp_path, capsys, monkeypatch):
    import turn_datasets.cli.agreement as mod
    from turn_datasets.errors import TurnbenchError

    def broken(*args, **kwargs):
        raise TurnbenchError("disk full (simulated)")

    monkeypatch.setattr(mod, "write_confusion_png", broken)
    code, _, err = run(
        [
            synth.paths[0].parent,
            "--bootstrap",
            "0",
            "--out-dir",
            tmp_path / "audit",
            "--review-eaf",
        ],
        capsys,
    )
    assert code == EXIT_BAD_INPUT and "disk full" in err
    assert not (tmp_path / "audit").exists()
    assert list(tmp_path.iterdir()) == []  # no staging folder left behind either


def test_review_copy_never_over_an_input(synth, tmp_path, capsys):
    # An input that lies where its own review copy would go.
    t = synth.truth
    session = sorted(t.loc[t["kind"] == "disagree", "session"].unique())[0]
    review = tmp_path / "audit" / "review"
    review.mkdir(parents=True)
    src = review / f"{session}.eaf"
    shutil.copy(synth.paths[0].parent / f"{session}.eaf", src)
    digest = sha256_file(src)
    code, _, err = run(
        [src, "--bootstrap", "0", "--out-dir", tmp_path / "audit", "--review-eaf"], capsys
    )
    assert code == EXIT_BAD_INPUT and "overwrite" in err
    assert sha256_file(src) == digest
    assert sorted(p.name for p in (tmp_path / "audit").rglob("*")) == sorted(["review", src.name])


def test_help_has_examples(capsys):
    code, out, _ = run(["--help"], capsys)
    assert code == EXIT_OK
    assert "Example:" in out and "turn-datasets remap agreement eaf/ --min-kappa 0.8" in out


def test_console_script(synth):
    exe = Path(sys.executable).parent / "turn-datasets"
    done = subprocess.run(
        [
            exe,
            "remap",
            "agreement",
            synth.paths[0].parent,
            "--min-kappa",
            "0.999",
            "--bootstrap",
            "0",
        ],
        capture_output=True,
        text=True,
    )
    assert done.returncode == EXIT_GATE
    assert done.stdout.startswith("# Inter-rater agreement")
    assert done.stderr.strip().splitlines()[-1].startswith("turn-datasets: gate failed:")


def test_no_header_field_reaches_any_output(synth, tmp_path, capsys):
    # The generator's files carry a clinician's media path, an author and a date in their
    # header (read here from the XML); none of it may reach labels, annotations.csv, the
    # audit's files, its stdout or the review copies without --keep-media-paths.
    import xml.etree.ElementTree as ET

    root = ET.parse(synth.paths[0]).getroot()
    secrets = [root.get("AUTHOR"), root.get("DATE")] + [
        v
        for el in root.iter()
        if el.tag in ("MEDIA_DESCRIPTOR", "LINKED_FILE_DESCRIPTOR")
        for k, v in el.attrib.items()
        if k.endswith("URL")
    ]
    assert len(secrets) >= 3 and all(secrets)
    folder = synth.paths[0].parent
    labels = tmp_path / "release" / "labels.csv"
    code, printed, _ = run_turn_datasets(
        ["remap", "labels", folder, "--participants", synth.participants_path, "--out", labels],
        capsys,
    )
    assert code == EXIT_OK
    for fmt in ("md", "json"):
        code, out, err = run(
            [
                folder,
                "--bootstrap",
                "0",
                "--format",
                fmt,
                "--out-dir",
                tmp_path / f"audit-{fmt}",
                "--review-eaf",
            ],
            capsys,
        )
        assert code == EXIT_OK, err
        printed += out
    written = [p for p in tmp_path.rglob("*") if p.is_file() and p.suffix != ".png"]
    assert {p.name for p in written} >= {
        "labels.csv",
        "annotations.csv",
        "agreement.json",
        "pairs.csv",
        "disagreements.csv",
    }
    assert any(p.suffix == ".eaf" for p in written)
    for text in [printed, *(p.read_text(encoding="utf-8") for p in written)]:
        for secret in secrets:
            assert secret not in text
