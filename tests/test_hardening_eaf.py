"""ELAN files older tools write, and values whose text and vocabulary link disagree
(issue 10, #15, #17)."""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import pympi.Elan
from _eaf_builder import Tier, add_cve_refs, write_eaf
from conftest import run_turn_datasets as _run

from turn_datasets.remap.eaf import read_annotations
from turn_datasets.remap.inspect import inspect_eaf

TEMPLATE = Path(__file__).resolve().parents[1] / "annotations" / "turn-remap.etf"


def _without_schema_location(path: Path) -> Path:
    text = path.read_text(encoding="utf-8")
    text, n = re.subn(r'\s+xsi:noNamespaceSchemaLocation="[^"]*"', "", text)
    assert n == 1
    path.write_text(text, encoding="utf-8")
    return path


def test_eaf_without_schema_location_is_read_and_left_as_it_was(tmp_path, capsys):
    path = write_eaf(
        tmp_path / "old.eaf",
        [Tier("Turn a", annotator="a", participant="P1", annotations=[(1000, 2500, "90")])],
    )
    _without_schema_location(path)
    before = hashlib.sha256(path.read_bytes()).hexdigest()
    df = read_annotations(path)
    assert df[["tier", "start_s", "end_s", "angle_deg"]].values.tolist() == [
        ["Turn a", 1.0, 2.5, 90.0]
    ]
    code, out, err = _run(["remap", "inspect", path], capsys)
    assert code == 0, err
    assert "Turn a" in out
    assert hashlib.sha256(path.read_bytes()).hexdigest() == before


def _mislabelled_session(tmp_path: Path) -> Path:
    eaf = pympi.Elan.Eaf(str(TEMPLATE))
    eaf.rename_tier("Turn", "Turn c1 PD01")
    eaf.tiers["Turn c1 PD01"][2].update(ANNOTATOR="c1", PARTICIPANT="PD01")
    eaf.add_annotation("Turn c1 PD01", 2000, 3500, "100°")  # the link says 90
    eaf.add_annotation("Turn c1 PD01", 5000, 6000, "180")  # text and link agree
    path = tmp_path / "S01.eaf"
    pympi.Elan.to_eaf(str(path), eaf)
    add_cve_refs(path, {"100°": "turn_angle_90", "180": "turn_angle_180"})
    return path


def test_text_that_disagrees_with_its_cve_ref_entry_warns_with_file_tier_time(tmp_path):
    path = _mislabelled_session(tmp_path)
    said: list[str] = []
    df = read_annotations(path, warn=said.append)
    assert df["angle_deg"].tolist() == [90.0, 180.0]  # the entry is the truth
    assert len(said) == 1
    assert said[0].startswith(f"{path}, tier 'Turn c1 PD01', at 2.000 s: text '100°'")
    assert "'90'" in said[0]


def test_labels_prints_the_cve_disagreement_on_stderr(tmp_path, capsys):
    path = _mislabelled_session(tmp_path)
    parts = tmp_path / "p.csv"
    parts.write_text("subject,cohort,pair,sex,age,years_since_diagnosis\nPD01,PD,a,F,60,4\n")
    code, _, err = _run(
        ["remap", "labels", path, "--participants", parts, "--out", tmp_path / "o" / "l.csv"],
        capsys,
    )
    assert code == 0, err
    assert "warning: " in err and "text '100°' disagrees" in err


def test_inspect_counts_values_whose_text_disagrees_with_the_entry(tmp_path, capsys):
    path = _mislabelled_session(tmp_path)
    assert inspect_eaf(path)["cve_text_disagreements"] == 1
    code, out, err = _run(["remap", "inspect", path], capsys)
    assert code == 0, err
    assert "1 value(s) whose text disagrees with the vocabulary entry" in out
