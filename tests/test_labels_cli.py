"""turn-datasets remap inspect | labels | stats: exit codes, outputs, no partial files."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from io import StringIO
from pathlib import Path

import pandas as pd
import pytest
from _eaf_builder import Tier, two_raters, write_eaf
from conftest import run_turn_datasets as run

from turn_datasets.cli.common import EXIT_BAD_INPUT, EXIT_OK
from turn_datasets.remap.eaf import ANNOTATION_COLUMNS
from turn_datasets.remap.labels import LABEL_COLUMNS

HEADER = "subject,cohort,pair,sex,age,years_since_diagnosis\n"


def _eaf_dir(tmp_path: Path, *, disagree: bool) -> Path:
    d = tmp_path / "eaf"
    d.mkdir()
    two_raters(
        d / "S01.eaf",
        [(1000, 2000, "90"), (5000, 6000, "180")],
        [(1050, 2000, "90"), (5000, 6000, "135" if disagree else "180")],
        Tier(
            "Turn alice HC",
            annotator="alice",
            participant="HC01",
            annotations=[(3000, 4500, "270")],
        ),
        Tier("Scenario", annotations=[(0, 10000, "free living")]),
        Tier("Location", annotations=[(0, 10000, "Lounge")]),
    )
    write_eaf(
        d / "S02.eaf",
        [
            Tier("Turn bob", annotator="bob", participant="PD02", annotations=[(500, 1500, "90°")]),
            Tier("Scenario", annotations=[(0, 9000, "scripted")]),
        ],
    )
    return d


def _participants(tmp_path: Path, rows: str | None = None) -> Path:
    path = tmp_path / "participants.csv"
    path.write_text(
        HEADER + (rows or "PD01,PD,a,F,60,4\nHC01,HC,a,M,64,\nPD02,PD,b,M,70,10\n"),
        encoding="utf-8",
    )
    return path


# ---------------------------------------------------------------------------------------
# inspect


def test_inspect_every_real_file_markdown_and_json(capsys, real_eaf_dir: Path) -> None:
    files = sorted(real_eaf_dir.glob("*.eaf"))
    code, out, err = run(["remap", "inspect", real_eaf_dir], capsys)
    assert code == EXIT_OK, err
    for f in files:
        assert f"## {f.name}" in out
    assert out.count("Turn tiers: **none**.") == len(files)
    # Privacy: no media path unless asked, and an external vocabulary by its file name only
    # (its path, file:/home/tuananh/..., names a person).
    assert "| MarkerType | external: fables_cv.ecv |" in out
    assert "r03_v20_s5.wav" not in out and "elan-example1" not in out and "/home/" not in out
    small = [real_eaf_dir / "pygamma_MaureenMarvinRobin.eaf", real_eaf_dir / "speach_test.eaf"]
    code, out, err = run(["remap", "inspect", *small, "--format", "json"], capsys)
    assert code == EXIT_OK, err
    doc = json.loads(out)
    assert [Path(f["file"]).name for f in doc["files"]] == [p.name for p in small]
    assert all(f["turn_tiers"] == [] for f in doc["files"])
    assert [t["tier"] for t in doc["files"][0]["tiers"]] == [
        "default",
        "Maureen",
        "Marvin",
        "Robin",
    ]


def test_inspect_keep_media_paths(capsys, real_eaf_dir: Path) -> None:
    code, out, _ = run(
        ["remap", "inspect", real_eaf_dir / "pympi_sample_2.8.eaf", "--keep-media-paths"], capsys
    )
    assert code == EXIT_OK
    assert "file:///Users/Shared/MPI/DemoMaterial/yele/r03_v20_s5.wav" in out
    code, out, _ = run(
        [
            "remap",
            "inspect",
            real_eaf_dir / "speach_fables_01_03_aesop_64kb.eaf",
            "--keep-media-paths",
        ],
        capsys,
    )
    assert code == EXIT_OK
    assert "external: file:/home/tuananh/Documents/ELAN/fables_cv.ecv" in out


def test_inspect_turn_file_shows_roles(capsys, tmp_path: Path) -> None:
    d = _eaf_dir(tmp_path, disagree=False)
    code, out, _ = run(["remap", "inspect", d / "S01.eaf", "--format", "json"], capsys)
    assert code == EXIT_OK
    doc = json.loads(out)["files"][0]
    assert [t["tier"] for t in doc["turn_tiers"]] == ["Turn alice", "Turn bob", "Turn alice HC"]
    assert doc["context_tiers"]["scenario"] == [{"tier": "Scenario", "participant": None}]
    roles = {t["tier"]: t["role"] for t in doc["tiers"]}
    assert roles["Location"] == "location"
    tier = {t["tier"]: t for t in doc["tiers"]}["Turn alice"]
    assert (tier["annotations"], tier["start_s"], tier["end_s"]) == (2, 1.0, 6.0)
    assert (tier["annotator"], tier["participant"]) == ("alice", "PD01")


def test_inspect_refuses_billion_laughs(capsys, tmp_path: Path) -> None:
    evil = tmp_path / "evil.eaf"
    evil.write_text(
        '<?xml version="1.0"?>\n<!DOCTYPE l [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;&a;">]>\n'
        "<ANNOTATION_DOCUMENT>&b;</ANNOTATION_DOCUMENT>\n",
        encoding="utf-8",
    )
    code, out, err = run(["remap", "inspect", evil], capsys)
    assert code == EXIT_BAD_INPUT
    assert out == ""
    errors = [line for line in err.splitlines() if "error" in line]
    assert len(errors) == 1 and str(evil) in errors[0] and "refused" in errors[0]
    assert err.strip().splitlines()[-1] == errors[0]
    assert "Traceback" not in err


# ---------------------------------------------------------------------------------------
# labels


def test_labels_writes_both_files(capsys, tmp_path: Path) -> None:
    d = _eaf_dir(tmp_path, disagree=False)
    out = tmp_path / "release" / "labels.csv"
    code, stdout, err = run(
        ["remap", "labels", d, "--participants", _participants(tmp_path), "--out", out], capsys
    )
    assert code == EXIT_OK, err
    assert stdout == ""
    assert "wrote 4 turns (2 double-annotated) from 6 annotations" in err
    labels = pd.read_csv(out, dtype={"clip_id": str})
    assert labels.columns.tolist() == list(LABEL_COLUMNS)
    # S01: PD01 1-2 s (alice+bob agree), HC01 3-4.5 s (alice), PD01 5-6 s (agree);
    # S02: PD02 0.5-1.5 s (bob). Sorted by session, subject, time.
    assert labels["clip_id"].tolist() == [
        "S01_HC01_3000-4500",
        "S01_PD01_1000-2000",
        "S01_PD01_5000-6000",
        "S02_PD02_500-1500",
    ]
    assert labels["cohort"].tolist() == ["HC", "PD", "PD", "PD"]
    assert labels["angle_deg"].tolist() == [270.0, 90.0, 180.0, 90.0]
    assert labels["double_annotated"].tolist() == [False, True, True, False]
    assert labels["scenario"].tolist() == ["free-living"] * 3 + ["scripted"]
    assert labels["location"].fillna("").tolist() == ["living room"] * 3 + [""]
    assert labels["duration_s"].tolist() == [1.5, 1.0, 1.0, 1.0]
    raw = pd.read_csv(out.parent / "annotations.csv")
    assert raw.columns.tolist() == list(ANNOTATION_COLUMNS)
    assert len(raw) == 6
    assert sorted(raw["annotator"].unique()) == ["alice", "bob"]


def test_labels_byte_identical(capsys, tmp_path: Path) -> None:
    d = _eaf_dir(tmp_path, disagree=False)
    p = _participants(tmp_path)
    outs = []
    for name in ("a", "b"):
        out = tmp_path / name / "labels.csv"
        assert run(["remap", "labels", d, "--participants", p, "--out", out], capsys)[0] == EXIT_OK
        outs.append((out.read_bytes(), (out.parent / "annotations.csv").read_bytes()))
    assert outs[0] == outs[1]


def _no_outputs(folder: Path) -> bool:
    return not folder.exists() or not any(folder.iterdir())


def test_labels_unresolved_exit_2_lists_and_writes_nothing(capsys, tmp_path: Path) -> None:
    d = _eaf_dir(tmp_path, disagree=True)
    out = tmp_path / "release" / "labels.csv"
    code, stdout, err = run(
        ["remap", "labels", d, "--participants", _participants(tmp_path), "--out", out], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert stdout == ""
    assert "unresolved: " in err and "participant PD01, 5.000-6.000 s: alice 180, bob 135" in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("turn-datasets: error:") and "'Turn alice'" in last and "5.000 s" in last
    assert _no_outputs(out.parent)
    # --resolve first-rater takes alice's 180.
    code, _, err = run(
        [
            "remap",
            "labels",
            d,
            "--participants",
            _participants(tmp_path),
            "--out",
            out,
            "--resolve",
            "first-rater",
        ],
        capsys,
    )
    assert code == EXIT_OK, err
    labels = pd.read_csv(out)
    row = labels[labels["start_s"] == 5.0]
    assert row[["annotator", "angle_deg"]].values.tolist() == [["alice", 180.0]]


def test_labels_failures_leave_old_outputs_alone(capsys, tmp_path: Path) -> None:
    d = _eaf_dir(tmp_path, disagree=False)
    out_dir = tmp_path / "release"
    out_dir.mkdir()
    (out_dir / "labels.csv").write_text("old labels\n", encoding="utf-8")
    (out_dir / "annotations.csv").write_text("old annotations\n", encoding="utf-8")
    # PD02 is missing from the table: the error names the .eaf file, tier and time.
    missing = _participants(tmp_path, "PD01,PD,a,F,60,4\nHC01,HC,a,M,64,\n")
    code, _, err = run(
        ["remap", "labels", d, "--participants", missing, "--out", out_dir / "labels.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert "'PD02'" in err and "S02.eaf" in err and "'Turn bob'" in err and "0.500 s" in err
    # An angle outside the vocabulary.
    write_eaf(
        d / "S03.eaf",
        [Tier("Turn x", annotator="x", participant="PD01", annotations=[(2000, 3000, "100")])],
    )
    code, _, err = run(
        [
            "remap",
            "labels",
            d,
            "--participants",
            _participants(tmp_path),
            "--out",
            out_dir / "labels.csv",
        ],
        capsys,
    )
    assert code == EXIT_BAD_INPUT
    assert "S03.eaf" in err and "'Turn x'" in err and "2.000 s" in err
    assert (out_dir / "labels.csv").read_text(encoding="utf-8") == "old labels\n"
    assert (out_dir / "annotations.csv").read_text(encoding="utf-8") == "old annotations\n"
    assert sorted(p.name for p in out_dir.iterdir()) == ["annotations.csv", "labels.csv"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".release")]


@pytest.mark.parametrize("value", ["nan", "0", "1.5"])
def test_labels_bad_min_overlap_is_a_usage_error(capsys, tmp_path: Path, value: str) -> None:
    # "nan" passes click's FloatRange unless refused (every comparison with NaN is false).
    d = _eaf_dir(tmp_path, disagree=False)
    out = tmp_path / "o" / "labels.csv"
    code, stdout, err = run(
        [
            "remap",
            "labels",
            d,
            "--participants",
            _participants(tmp_path),
            "--min-overlap",
            value,
            "--out",
            out,
        ],
        capsys,
    )
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert "--min-overlap" in err and "Traceback" not in err
    assert not out.parent.exists()


def test_labels_refuses_to_overwrite_an_input(capsys, tmp_path: Path) -> None:
    d = _eaf_dir(tmp_path, disagree=False)
    p = _participants(tmp_path)
    before = p.read_bytes()
    code, _, err = run(["remap", "labels", d, "--participants", p, "--out", p], capsys)
    assert code == EXIT_BAD_INPUT and "overwrite" in err
    assert p.read_bytes() == before
    code, _, err = run(
        ["remap", "labels", d, "--participants", p, "--out", tmp_path / "annotations.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT


def _annotation_id(path: Path, value: str) -> str:
    """The ANNOTATION_ID of the annotation whose text is ``value``, read with the standard
    library (independent of the reader)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    (aid,) = [
        a.get("ANNOTATION_ID")
        for a in root.iter("ALIGNABLE_ANNOTATION")
        if a.findtext("ANNOTATION_VALUE") == value
    ]
    return str(aid)


@pytest.mark.parametrize("command", ["labels", "agreement"])
def test_every_problem_of_a_folder_in_one_run(capsys, tmp_path: Path, command: str) -> None:
    """A file without a turn tier, unparseable angles, an overlapping pair and a file that is
    not XML: one run names them all (file and annotation), grouped by kind with a count,
    exits 2 and writes nothing."""
    d = tmp_path / "eaf"
    d.mkdir()
    s01 = write_eaf(
        d / "S01.eaf",
        [
            Tier(
                "Turn alice",
                annotator="alice",
                participant="PD01",
                annotations=[(1000, 2000, "90"), (5000, 6000, "ninety")],
            ),
            Tier(
                "Turn bob",
                annotator="bob",
                participant="PD01",
                annotations=[(1050, 2000, "90"), (5000, 6000, "180")],
            ),
        ],
    )
    s02 = write_eaf(
        d / "S02.eaf",
        [
            Tier(
                "Turn bob",
                annotator="bob",
                participant="PD02",
                annotations=[(500, 1500, "90"), (1000, 2500, "135"), (3000, 4000, "180")],
            )
        ],
    )
    write_eaf(d / "S03.eaf", [Tier("Speech", annotations=[(0, 100, "hello")])])
    (d / "S04.eaf").write_text("<ANNOTATION_DOCUMENT><TIER>", encoding="utf-8")
    # Four more angles outside the vocabulary: the kind lists the first three and counts all.
    s05 = write_eaf(
        d / "S05.eaf",
        [
            Tier(
                "Turn alice",
                annotator="alice",
                participant="PD02",
                annotations=[(k * 1000, k * 1000 + 500, f"x{k}") for k in range(1, 5)],
            )
        ],
    )
    out_dir = tmp_path / "o"
    args = (
        ["--participants", _participants(tmp_path), "--out", out_dir / "labels.csv"]
        if command == "labels"
        else ["--out-dir", out_dir, "--min-kappa", "0.5"]
    )
    code, out, err = run(["remap", command, d, *args], capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert "Traceback" not in err
    assert not out_dir.exists()
    lines = err.splitlines()
    head = lines.index("turn-datasets: error: 8 problems of 4 kinds in 5 ELAN files; nothing read:")
    body = lines[head + 1 :]
    assert len(body) == 4
    vocab = "value not in the turn_angle vocabulary (90, 135, 180, 225, 270, 315, 360)"
    assert body[0] == (
        f"  {vocab} (5 annotations): "
        f"{s01}, annotation {_annotation_id(s01, 'ninety')}, tier 'Turn alice', at 5.000 s "
        f"('ninety'); {s05}, annotation {_annotation_id(s05, 'x1')}, tier 'Turn alice', at "
        f"1.000 s ('x1'); {s05}, annotation {_annotation_id(s05, 'x2')}, tier 'Turn alice', "
        "at 2.000 s ('x2'); ... [fix it in ELAN, or add an alias to the schema (--schema)]"
    )
    assert body[1] == (
        f"  turn overlaps the previous turn on its tier: {s02}, annotation "
        f"{_annotation_id(s02, '135')}, tier 'Turn bob', at 1.000 s ('135', the previous "
        "0.500 to 1.500 s)"
    )
    assert body[2].startswith(f"  not readable as an ELAN file: {d / 'S04.eaf'} (not well-formed")
    assert body[3] == (
        f"  no turn tier: no tier name matches '(?i)^turn': {d / 'S03.eaf'} "
        "[see `turn-datasets remap inspect`, or map the tiers with --schema]"
    )


def test_labels_no_turn_tiers(capsys, tmp_path: Path, real_eaf_dir: Path) -> None:
    code, _, err = run(
        [
            "remap",
            "labels",
            real_eaf_dir / "speach_test.eaf",
            "--participants",
            _participants(tmp_path),
            "--out",
            tmp_path / "o" / "labels.csv",
        ],
        capsys,
    )
    assert code == EXIT_BAD_INPUT
    assert "no turn annotations" in err and "remap inspect" in err
    assert not (tmp_path / "o").exists()
    # A session saved from the template before labelling: its "Turn" tier is there, empty.
    blank = tmp_path / "S01.eaf"
    blank.write_bytes(
        (Path(__file__).resolve().parents[1] / "annotations" / "turn-remap.etf").read_bytes()
    )
    for command in (
        [
            "labels",
            "--participants",
            _participants(tmp_path),
            "--out",
            tmp_path / "o" / "labels.csv",
        ],
        ["agreement"],
    ):
        code, out, err = run(["remap", command[0], blank, *command[1:]], capsys)
        assert code == EXIT_BAD_INPUT and out == ""
        last = err.strip().splitlines()[-1]
        assert last.startswith(f"turn-datasets: error: {blank}: no turn annotations in 1 file")
        assert "holds an annotation" in last
    assert not (tmp_path / "o").exists()


# ---------------------------------------------------------------------------------------
# stats


def _labels(capsys, tmp_path: Path) -> Path:
    d = _eaf_dir(tmp_path, disagree=False)
    out = tmp_path / "labels.csv"
    assert (
        run(
            ["remap", "labels", d, "--participants", _participants(tmp_path), "--out", out], capsys
        )[0]
        == EXIT_OK
    )
    return out


def test_stats_markdown_by_hand(capsys, tmp_path: Path) -> None:
    labels = _labels(capsys, tmp_path)
    code, out, err = run(
        ["remap", "stats", labels, "--participants", _participants(tmp_path)], capsys
    )
    assert code == EXIT_OK, err
    # PD: PD01 (60 y, 4 y since diagnosis) and PD02 (70, 10), 3 turns: age 65 ± 7.1
    # (sd sqrt(50)), years 7.0 ± 4.2 (sd sqrt(18)). HC: HC01 (64), 1 turn.
    assert "| PD | 2 | 3 | 65.0 ± 7.1 | 7.0 ± 4.2 |" in out
    assert "| HC | 1 | 1 | 64.0 | – |" in out
    # all: 60, 64, 70: mean 64.67, sd sqrt((21.78 + 0.44 + 28.44) / 2) = 5.03.
    assert "| all | 3 | 4 | 64.7 ± 5.0 | 7.0 ± 4.2 |" in out
    # Table 2: free-living 90 x1, 180 x1, 270 x1; scripted 90 x1.
    assert "| scripted | 1 | 0 | 0 | 0 | 0 | 0 | 0 | 1 |" in out
    assert "| free-living | 1 | 0 | 1 | 0 | 1 | 0 | 0 | 3 |" in out
    assert "| total | 2 | 0 | 1 | 0 | 1 | 0 | 0 | 4 |" in out
    assert "| living room | 2 | 1 | 3 |" in out


def test_stats_csv_and_json(capsys, tmp_path: Path) -> None:
    labels = _labels(capsys, tmp_path)
    code, out, _ = run(["remap", "stats", labels, "--csv"], capsys)
    assert code == EXIT_OK
    long = pd.read_csv(StringIO(out), dtype=str, keep_default_na=False)
    cell = long.set_index(["table", "row", "column"])["value"]
    assert cell[("table2", "free-living", "total")] == "3"
    assert cell[("table1", "all", "turns")] == "4"
    assert cell[("table1", "PD", "age_mean")] == ""  # no participants table given
    code, out, _ = run(["remap", "stats", labels, "--format", "json"], capsys)
    doc = json.loads(out)
    assert doc["table2"]["total"]["total"] == 4
    assert doc["table1"]["PD"]["subjects"] == 2
    assert doc["locations"]["living room"] == {"PD": 2, "HC": 1, "total": 3}


def test_stats_bad_labels_file(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text(
        "clip_id,subject,cohort,angle_deg,scenario,location\nc,P,PD,x,s,l\n", encoding="utf-8"
    )
    code, out, err = run(["remap", "stats", bad], capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert f"{bad}:2" in err


@pytest.mark.parametrize("command", ["inspect", "labels", "stats"])
def test_help_has_examples(capsys, command: str) -> None:
    code, out, _ = run(["remap", command, "--help"], capsys)
    assert code == EXIT_OK
    assert "Example:" in out


def test_console_script_exit_code(tmp_path: Path) -> None:
    # The installed entry point, as a user runs it: a refused file is exit 2, one line.
    exe = Path(sys.executable).with_name("turn-datasets")
    evil = tmp_path / "evil.eaf"
    evil.write_text('<!DOCTYPE x [<!ENTITY e "e">]><ANNOTATION_DOCUMENT/>', encoding="utf-8")
    proc = subprocess.run(
        [str(exe), "remap", "inspect", str(evil)],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "100"},
    )
    assert proc.returncode == EXIT_BAD_INPUT
    assert proc.stdout == ""
    assert proc.stderr.strip().splitlines()[-1].startswith("turn-datasets: error: ")
    assert "Traceback" not in proc.stderr
