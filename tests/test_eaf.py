"""Reading ELAN files: turn rows, forgiving values, strict errors, refusals, real exports."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pandas as pd
import pytest
from _eaf_builder import REAL_FILES, Tier, add_cve_refs, write_eaf

from turn_datasets.errors import TurnbenchError
from turn_datasets.remap.eaf import (
    ANNOTATION_COLUMNS,
    expand_eaf_paths,
    load_eaf,
    read_annotations,
)
from turn_datasets.remap.inspect import inspect_eaf
from turn_datasets.remap.schema import load_schema

# ---------------------------------------------------------------------------------------
# Turn rows from a file built with known values


def _session(tmp_path: Path, name: str = "S01") -> Path:
    return write_eaf(
        tmp_path / f"{name}.eaf",
        [
            Tier(
                "Turn rater A",
                annotator="alice",
                participant="P01",
                annotations=[
                    (1000, 2500, "90"),
                    (3000, 4000, "90°"),
                    (5000, 6000, "90 deg"),
                    (7000, 8000, "90 degrees"),
                    (9000, 12000, " 90 "),
                    (13000, 14500, "180"),
                ],
            ),
            Tier(
                "turn rater B",  # "Turn" in any case
                annotator="bob",
                participant="P01",
                annotations=[(1100, 2400, "135")],
            ),
            Tier(
                "Scenario",
                annotations=[(0, 10000, "loosely scripted"), (10000, 20000, "free living")],
            ),
            Tier("Location", annotations=[(0, 20000, "Kitchen")]),
            # Only P02's: must not reach P01's turns.
            Tier("Location P02", participant="P02", annotations=[(0, 20000, "bedroom")]),
            # A tier the schema does not need, with a value outside every vocabulary.
            Tier("notes", annotations=[(0, 500, "anything at all")]),
        ],
    )


def test_rows_columns_and_values(tmp_path: Path) -> None:
    path = _session(tmp_path)
    df = read_annotations(path)
    assert list(df.columns) == list(ANNOTATION_COLUMNS)
    assert df.dtypes["angle_deg"] == "float64"
    a = df[df["annotator"] == "alice"]
    # All five spellings of ninety are 90; the last turn is 180.
    assert a["angle_deg"].tolist() == [90.0, 90.0, 90.0, 90.0, 90.0, 180.0]
    assert a["value"].tolist() == ["90", "90°", "90 deg", "90 degrees", " 90 ", "180"]
    assert a["start_s"].tolist() == [1.0, 3.0, 5.0, 7.0, 9.0, 13.0]
    assert a["end_s"].tolist() == [2.5, 4.0, 6.0, 8.0, 12.0, 14.5]
    # Turn 9-12 s overlaps "loosely scripted" by 1 s and "free living" by 2 s.
    assert a["scenario"].tolist() == ["scripted"] * 4 + ["free-living", "free-living"]
    # The shared tier gives "kitchen" (canonical case); P02's bedroom tier is not P01's.
    assert set(a["location"]) == {"kitchen"}
    assert set(df["session"]) == {"S01"}
    assert set(df["participant"]) == {"P01"}
    assert set(df["file"]) == {str(path)}
    b = df[df["annotator"] == "bob"]
    assert b["tier"].tolist() == ["turn rater B"]
    assert b["angle_deg"].tolist() == [135.0]


def test_participant_specific_context_wins(tmp_path: Path) -> None:
    path = write_eaf(
        tmp_path / "S02.eaf",
        [
            Tier("Turn", annotator="a", participant="P02", annotations=[(1000, 2000, "90")]),
            Tier("Turn 2", annotator="a", participant="P03", annotations=[(1000, 2000, "225")]),
            Tier("Location", annotations=[(0, 5000, "hallway")]),
            Tier("Location (P02)", participant="P02", annotations=[(1500, 1600, "stairs")]),
        ],
    )
    df = read_annotations(path).set_index("participant")
    # P02's own tier overlaps only 0.1 s but still decides for P02 ("stairs" is an alias).
    assert df.loc["P02", "location"] == "staircase"
    assert df.loc["P03", "location"] == "hallway"
    # No scenario tier: empty, not an invented value.
    assert df.loc["P02", "scenario"] == ""


def test_cve_ref_resolved_through_vocabulary(tmp_path: Path) -> None:
    path = write_eaf(
        tmp_path / "S03.eaf",
        [
            Tier(
                "Turn",
                annotator="a",
                participant="P01",
                ling="turn",
                annotations=[(1000, 2000, "ninety"), (3000, 4000, "270")],
            )
        ],
        vocabularies={"turn_angle": {"cveid_a": "90", "cveid_b": "270"}},
        ling_cv={"turn": "turn_angle"},
    )
    add_cve_refs(path, {"ninety": "cveid_a"})
    df = read_annotations(path)
    assert df["angle_deg"].tolist() == [90.0, 270.0]
    assert df["value"].tolist() == ["ninety", "270"]
    # Without the link "ninety" is outside the vocabulary.
    bare = write_eaf(
        tmp_path / "S04.eaf",
        [Tier("Turn", annotator="a", participant="P01", annotations=[(1000, 2000, "ninety")])],
    )
    with pytest.raises(TurnbenchError, match="ninety"):
        read_annotations(bare)


def test_directory_and_file_without_turn_tiers(tmp_path: Path) -> None:
    _session(tmp_path, "S01")
    write_eaf(tmp_path / "S09.eaf", [Tier("speech", annotations=[(0, 100, "hello")])])
    (tmp_path / "notes.txt").write_text("not an eaf", encoding="utf-8")
    # A macOS resource fork copied along with S01.eaf: binary, not ELAN, skipped.
    (tmp_path / "._S01.eaf").write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X")
    assert [p.name for p in expand_eaf_paths(tmp_path)] == ["S01.eaf", "S09.eaf"]
    df = read_annotations(tmp_path)
    assert set(df["session"]) == {"S01"}
    assert len(df) == 7


# ---------------------------------------------------------------------------------------
# Errors name file, tier and time


def _one_turn_tier(tmp_path: Path, annotations=(), raw=(), **kw) -> Path:
    return write_eaf(
        tmp_path / "bad.eaf",
        [Tier("Turn A", annotator="a", participant="P01", annotations=annotations, raw=raw, **kw)],
    )


def _error_text(path_or_paths) -> str:
    with pytest.raises(TurnbenchError) as info:
        read_annotations(path_or_paths)
    return str(info.value)


def test_value_outside_vocabulary(tmp_path: Path) -> None:
    path = _one_turn_tier(tmp_path, [(1000, 2000, "90"), (4250, 5000, "100")])
    msg = _error_text(path)
    assert str(path) in msg and "'Turn A'" in msg and "4.250 s" in msg and "'100'" in msg


def test_context_value_outside_vocabulary(tmp_path: Path) -> None:
    path = write_eaf(
        tmp_path / "ctx.eaf",
        [
            Tier("Turn", annotator="a", participant="P01", annotations=[(1000, 2000, "90")]),
            Tier("Scenario", annotations=[(500, 3000, "weekend")]),
        ],
    )
    msg = _error_text(path)
    assert "'Scenario'" in msg and "0.500 s" in msg and "weekend" in msg


def test_overlapping_turns(tmp_path: Path) -> None:
    path = _one_turn_tier(tmp_path, [(1000, 3000, "90"), (2500, 4000, "180")])
    msg = _error_text(path)
    assert "overlaps" in msg and "'Turn A'" in msg and "2.500 s" in msg and str(path) in msg


def test_touching_turns_are_fine(tmp_path: Path) -> None:
    path = _one_turn_tier(tmp_path, [(1000, 3000, "90"), (3000, 4000, "180")])
    assert read_annotations(path)["angle_deg"].tolist() == [90.0, 180.0]


@pytest.mark.parametrize("start,end", [(2000, 2000), (3000, 1500)])
def test_end_not_after_start(tmp_path: Path, start: int, end: int) -> None:
    path = _one_turn_tier(tmp_path, raw=[(start, end, "90")])
    msg = _error_text(path)
    assert "not after" in msg and "'Turn A'" in msg and f"{start / 1000:.3f} s" in msg


def test_unaligned_turn(tmp_path: Path) -> None:
    path = _one_turn_tier(tmp_path, raw=[(1000, None, "90")])
    msg = _error_text(path)
    assert "unaligned" in msg and "'Turn A'" in msg and "1.000 s" in msg


def test_turn_tier_without_participant_or_rater(tmp_path: Path) -> None:
    path = write_eaf(tmp_path / "np.eaf", [Tier("Turn", annotator="a", annotations=[(0, 9, "90")])])
    assert "participant" in _error_text(path)
    path = write_eaf(
        tmp_path / "nr.eaf", [Tier("Turn", participant="P1", annotations=[(0, 9, "90")])]
    )
    assert "rater" in _error_text(path)


def test_stray_space_in_tier_name(tmp_path: Path) -> None:
    path = write_eaf(
        tmp_path / "sp.eaf",
        [Tier(" Turn A", annotator=" a ", participant="P01 ", annotations=[(0, 900, "90")])],
    )
    df = read_annotations(path)
    assert df[["tier", "annotator", "participant"]].values.tolist() == [[" Turn A", "a", "P01"]]


def test_two_tiers_one_rater_one_participant(tmp_path: Path) -> None:
    path = write_eaf(
        tmp_path / "dup.eaf",
        [
            Tier("Turn 1", annotator="a", participant="P01", annotations=[(0, 900, "90")]),
            Tier("Turn 2", annotator="A", participant="P01", annotations=[(1000, 1900, "90")]),
        ],
    )
    assert "'Turn 2'" in _error_text(path)


def test_one_session_from_two_files(tmp_path: Path) -> None:
    (tmp_path / "x").mkdir()
    (tmp_path / "y").mkdir()
    a = _session(tmp_path / "x", "S01")
    b = _session(tmp_path / "y", "S01")
    msg = _error_text([a, b])
    assert "S01" in msg and str(b) in msg


def _aid(path: Path, tier: str) -> str:
    """The ANNOTATION_ID of the first annotation of ``tier`` (standard library)."""
    (el,) = [t for t in ET.parse(path).getroot().iter("TIER") if t.get("TIER_ID") == tier]
    return str(next(el.iter("ALIGNABLE_ANNOTATION")).get("ANNOTATION_ID"))


def test_every_kind_of_problem_in_one_pass(tmp_path: Path) -> None:
    """Each check of the reader adds to one report instead of stopping the pass: the kinds
    in the order met, each place by file, annotation, tier and time."""
    (tmp_path / "x").mkdir()
    (tmp_path / "y").mkdir()
    s01 = write_eaf(
        tmp_path / "x" / "S01.eaf",
        [
            Tier(
                "Turn A",
                annotator="a",
                participant="P01",
                annotations=[(1000, 2000, "90"), (3000, 4000, "180")],
            ),
            Tier("Turn C", annotator="c", participant="P01", raw=[(1000, None, "90")]),
            Tier("Turn D", annotator="d", participant="P01", raw=[(3000, 1500, "90")]),
            Tier("Turn", participant="P01", annotations=[(0, 900, "90")]),
            Tier("Turn 2", annotator="A", participant="P01", annotations=[(0, 900, "90")]),
            Tier("Scenario", annotations=[(500, 3000, "weekend")]),
        ],
    )
    # The same session again, elsewhere: read too (its own problems would count), and named
    s01_again = _one_turn_tier(tmp_path / "y").rename(tmp_path / "y" / "S01.eaf")
    evil = tmp_path / "y" / "evil.eaf"
    evil.write_text(EXTERNAL_ENTITY, encoding="utf-8")
    with pytest.raises(TurnbenchError) as info:
        read_annotations(tmp_path)
    lines = str(info.value).splitlines()
    assert lines[0] == "7 problems of 7 kinds in 3 ELAN files; nothing read:"
    assert lines[1:] == [
        "  value not in the scenario vocabulary (scripted, clinical, free-living): "
        f"{s01}, annotation {_aid(s01, 'Scenario')}, tier 'Scenario', at 0.500 s ('weekend') "
        "[fix it in ELAN, or add an alias to the schema (--schema)]",
        f"  annotation with an unaligned time slot (align it in ELAN): {s01}, annotation "
        f"{_aid(s01, 'Turn C')}, tier 'Turn C', at 1.000 s ('90', start 1.000 s, end ?)",
        f"  annotation ends not after it starts: {s01}, annotation {_aid(s01, 'Turn D')}, "
        "tier 'Turn D', at 3.000 s ('90', ends at 1.500 s)",
        f"  turn tier names no rater: {s01}, tier 'Turn' [set the tier's ANNOTATOR attribute "
        "in ELAN (Tier > Change Tier Attributes)]",
        f"  a second turn tier for one rater and participant: {s01}, tier 'Turn 2' (rater "
        "'A' and participant 'P01', the first is 'Turn A')",
        f"  a session comes from two files: {s01_again} (the other is {s01}) [one .eaf per "
        "session: the file stem is the session id]",
        f"  not readable as an ELAN file: {evil} (refused: the file declares a DOCTYPE (its "
        "entities could expand without bound or read other files); ELAN never writes one)",
    ]


def test_missing_path_and_empty_folder(tmp_path: Path) -> None:
    assert "not found" in _error_text(tmp_path / "nope.eaf")
    (tmp_path / "empty").mkdir()
    assert "no .eaf" in _error_text(tmp_path / "empty")


# ---------------------------------------------------------------------------------------
# Hostile and broken XML

BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [
 <!ENTITY lol "lol">
 <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
]>
<ANNOTATION_DOCUMENT VERSION="3.0" FORMAT="3.0" AUTHOR="&lol3;"><HEADER/></ANNOTATION_DOCUMENT>
"""

EXTERNAL_ENTITY = """<?xml version="1.0"?>
<!DOCTYPE foo [ <!ENTITY xxe SYSTEM "file:///etc/passwd"> ]>
<ANNOTATION_DOCUMENT VERSION="3.0" FORMAT="3.0" AUTHOR="&xxe;"><HEADER/></ANNOTATION_DOCUMENT>
"""


@pytest.mark.parametrize("text", [BILLION_LAUGHS, EXTERNAL_ENTITY], ids=["laughs", "xxe"])
def test_entity_files_refused(tmp_path: Path, text: str) -> None:
    path = tmp_path / "evil.eaf"
    path.write_text(text, encoding="utf-8")
    for call in (load_eaf, read_annotations, inspect_eaf):
        with pytest.raises(TurnbenchError, match="refused") as info:
            call(path)
        assert str(path) in str(info.value)


def test_broken_xml_and_not_elan(tmp_path: Path) -> None:
    broken = tmp_path / "broken.eaf"
    broken.write_text("<ANNOTATION_DOCUMENT><TIER>", encoding="utf-8")
    with pytest.raises(TurnbenchError, match="not well-formed"):
        load_eaf(broken)
    other = tmp_path / "other.eaf"
    other.write_text("<html/>", encoding="utf-8")
    with pytest.raises(TurnbenchError, match="not an ELAN"):
        load_eaf(other)


def test_pympi_failure_becomes_turnbench_error(tmp_path: Path) -> None:
    # Well-formed XML that pympi-ling cannot take (an annotation without ANNOTATION_VALUE).
    path = tmp_path / "odd.eaf"
    path.write_text(
        '<ANNOTATION_DOCUMENT VERSION="3.0" FORMAT="3.0" '
        'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
        'xsi:noNamespaceSchemaLocation="http://www.mpi.nl/tools/elan/EAFv3.0.xsd">'
        '<TIME_ORDER><TIME_SLOT TIME_SLOT_ID="ts1" TIME_VALUE="0"/>'
        '<TIME_SLOT TIME_SLOT_ID="ts2" TIME_VALUE="10"/></TIME_ORDER>'
        '<TIER TIER_ID="Turn" LINGUISTIC_TYPE_REF="x"><ANNOTATION>'
        '<ALIGNABLE_ANNOTATION ANNOTATION_ID="a1" TIME_SLOT_REF1="ts1" TIME_SLOT_REF2="ts2"/>'
        "</ANNOTATION></TIER></ANNOTATION_DOCUMENT>",
        encoding="utf-8",
    )
    with pytest.raises(TurnbenchError, match="pympi-ling could not read") as info:
        load_eaf(path)
    assert str(path) in str(info.value)


# ---------------------------------------------------------------------------------------
# Real ELAN exports (../shared/data/real-eaf)


def _xml_counts(path: Path) -> dict[str, int]:
    """Annotations per tier, counted with the standard library (independent of pympi)."""
    root = ET.parse(path).getroot()
    return {t.get("TIER_ID"): len(t.findall("ANNOTATION")) for t in root.iter("TIER")}


def test_real_folder_is_complete(real_eaf_dir: Path) -> None:
    assert sorted(p.name for p in real_eaf_dir.glob("*.eaf")) == REAL_FILES


@pytest.mark.parametrize("name", REAL_FILES)
def test_inspect_every_real_file(real_eaf_dir: Path, name: str) -> None:
    path = real_eaf_dir / name
    result = inspect_eaf(path)
    counts = _xml_counts(path)
    assert {t["tier"]: t["annotations"] for t in result["tiers"]} == counts
    # None of them holds turns, and inspect says so.
    assert result["turn_tiers"] == []
    assert any("no turn tiers" in n for n in result["notes"])
    # Privacy: no header fields unless asked.
    text = json.dumps(result)
    assert "MEDIA_URL" not in text and "header" not in result
    assert ".wav" not in text and ".mpg" not in text
    # No URL or path from inside the file (media, linked files, external vocabularies).
    assert "file:" not in text and "/Users/" not in text and "/home/" not in text
    # And no turn rows, without error.
    assert read_annotations(path).empty


def test_real_symbolic_child_of_time_aligned_child(real_eaf_dir: Path) -> None:
    # speach_test.eaf: the tier on which pympi's get_annotation_data_for_tier raises KeyError.
    path = real_eaf_dir / "speach_test.eaf"
    root = ET.parse(path).getroot()
    tiers = {t.get("TIER_ID"): t for t in root.iter("TIER")}
    ltypes = {lt.get("LINGUISTIC_TYPE_ID"): lt for lt in root.iter("LINGUISTIC_TYPE")}
    symbolic = [
        tid
        for tid, t in tiers.items()
        if ltypes[t.get("LINGUISTIC_TYPE_REF")].get("CONSTRAINTS") == "Symbolic_Association"
        and t.get("PARENT_REF")
        and ltypes[tiers[t.get("PARENT_REF")].get("LINGUISTIC_TYPE_REF")].get("CONSTRAINTS")
        in ("Included_In", "Time_Subdivision")
    ]
    assert symbolic, "the trap is in this file"
    eaf = load_eaf(path)
    with pytest.raises(KeyError):
        eaf.get_annotation_data_for_tier(symbolic[0])
    info = {t["tier"]: t for t in inspect_eaf(path)["tiers"]}
    child = info[symbolic[0]]
    parent = info[child["parent"]]
    assert child["constraint"] == "Symbolic_Association"
    assert child["annotations"] == parent["annotations"] > 0
    # A 1-1 association spans exactly its parents' time range.
    assert (child["start_s"], child["end_s"]) == (parent["start_s"], parent["end_s"])


def test_real_unaligned_time_slots(real_eaf_dir: Path) -> None:
    path = real_eaf_dir / "pympi_sample_2.8.eaf"
    root = ET.parse(path).getroot()
    unaligned_slots = {
        ts.get("TIME_SLOT_ID") for ts in root.iter("TIME_SLOT") if ts.get("TIME_VALUE") is None
    }
    tier = next(t for t in root.iter("TIER") if t.get("TIER_ID") == "words-timesub")
    expected = sum(
        1
        for a in tier.iter("ALIGNABLE_ANNOTATION")
        if a.get("TIME_SLOT_REF1") in unaligned_slots or a.get("TIME_SLOT_REF2") in unaligned_slots
    )
    info = {t["tier"]: t for t in inspect_eaf(path)["tiers"]}
    assert expected > 0
    assert info["words-timesub"]["unaligned"] == expected
    assert info["words-timesub"]["constraint"] == "Time_Subdivision"
    assert info["words-timesub"]["parent"] == "text"


def test_real_unknown_version_and_external_vocabulary(real_eaf_dir: Path) -> None:
    old = inspect_eaf(real_eaf_dir / "poio_example.eaf")
    assert old["format"] == "2.3"
    assert any("2.3" in n and "pympi-ling" in n for n in old["notes"])
    fables = real_eaf_dir / "speach_fables_01_03_aesop_64kb.eaf"
    root = ET.parse(fables).getroot()
    ext = {e.get("EXT_REF_ID"): e.get("VALUE") for e in root.iter("EXTERNAL_REF")}
    cv_ext = {c.get("CV_ID"): c.get("EXT_REF") for c in root.iter("CONTROLLED_VOCABULARY")}
    vocab = {v["id"]: v for v in inspect_eaf(fables)["vocabularies"]}
    assert vocab["MarkerType"]["external"] is True
    # The file's reference is file:/home/<a person>/Documents/ELAN/fables_cv.ecv: by default
    # only the file name is shown, the full path with keep_media_paths.
    full = ext[cv_ext["MarkerType"]]
    assert full.startswith("file:/home/") and full.endswith("/fables_cv.ecv")
    assert vocab["MarkerType"]["url"] == "fables_cv.ecv"
    assert "/home/" not in json.dumps(inspect_eaf(fables))
    kept = {v["id"]: v for v in inspect_eaf(fables, keep_media_paths=True)["vocabularies"]}
    assert kept["MarkerType"]["url"] == full
    assert vocab["MarkerType"]["entries"] == []
    assert vocab["Languages"]["external"] is False


def test_real_header_only_when_asked(real_eaf_dir: Path) -> None:
    path = real_eaf_dir / "pympi_sample_2.8.eaf"
    root = ET.parse(path).getroot()
    media = [m.get("MEDIA_URL") for m in root.iter("MEDIA_DESCRIPTOR")]
    kept = inspect_eaf(path, keep_media_paths=True)
    assert [m["MEDIA_URL"] for m in kept["header"]["media"]] == media
    assert media[0] not in json.dumps(inspect_eaf(path))


def test_real_one_tier_per_annotator_through_a_schema(real_eaf_dir: Path, tmp_path: Path) -> None:
    schema_path = tmp_path / "pygamma.toml"
    schema_path.write_text(
        "[turn]\n"
        "tier_regex = '^(?P<annotator>Maureen|Marvin|Robin)$'\n"
        'default_participant = "speaker"\n'
        "[aliases.turn_angle]\n"
        "S = 90\n",
        encoding="utf-8",
    )
    df = read_annotations(
        real_eaf_dir / "pygamma_MaureenMarvinRobin.eaf", schema=load_schema(schema_path)
    )
    # From the file: Maureen ts2-ts3, ts4-ts5; Marvin ts6-ts7; Robin ts8-ts9 (milliseconds).
    expected = pd.DataFrame(
        {
            "annotator": ["Maureen", "Maureen", "Marvin", "Robin"],
            "start_s": [1.006, 3.738, 2.401, 5.294],
            "end_s": [1.896, 4.926, 3.422, 5.781],
        }
    )
    pd.testing.assert_frame_equal(df[["annotator", "start_s", "end_s"]], expected)
    assert set(df["participant"]) == {"speaker"}
    assert set(df["angle_deg"]) == {90.0}
    assert set(df["value"]) == {"S"}


# ---------------------------------------------------------------------------------------
# The ELAN template (annotations/turn-remap.etf)

TEMPLATE = Path(__file__).resolve().parents[1] / "annotations" / "turn-remap.etf"
# The issue's controlled vocabularies, written out here rather than read from the schema.
ISSUE_ANGLES = ["90", "135", "180", "225", "270", "315", "360"]
ISSUE_SCENARIOS = ["scripted", "clinical", "free-living"]
# EAF 3.0 (EAFv3.0.xsd): the children of ANNOTATION_DOCUMENT come in this order.
EAF_ORDER = [
    "HEADER",
    "TIME_ORDER",
    "TIER",
    "LINGUISTIC_TYPE",
    "LOCALE",
    "LANGUAGE",
    "CONSTRAINT",
    "CONTROLLED_VOCABULARY",
    "LEXICON_REF",
    "REF_LINK_SET",
    "EXTERNAL_REF",
]


def test_template_is_an_elan_document_pympi_reads() -> None:
    root = ET.parse(TEMPLATE).getroot()
    assert root.tag == "ANNOTATION_DOCUMENT"
    # Attributes the EAF 3.0 schema requires.
    assert {"AUTHOR", "DATE", "VERSION"} <= set(root.attrib) and root.get("VERSION") == "3.0"
    order = [EAF_ORDER.index(child.tag) for child in root]
    assert order == sorted(order)
    eaf = load_eaf(TEMPLATE)  # pympi-ling, after the safety checks
    cvs = {
        cv_id: [values[0][0] for values, _ext in entries.values()]
        for cv_id, (_desc, entries, _ext_ref) in eaf.controlled_vocabularies.items()
    }
    assert cvs["turn_angle"] == ISSUE_ANGLES
    assert cvs["scenario"] == ISSUE_SCENARIOS
    assert cvs["location"]  # rooms: the issue names the vocabulary, not its values
    # Each tier's type picks its vocabulary, so ELAN offers the list while labelling.
    lt = {t: eaf.tiers[t][2]["LINGUISTIC_TYPE_REF"] for t in eaf.tiers}
    assert {t: eaf.linguistic_types[lt[t]]["CONTROLLED_VOCABULARY_REF"] for t in eaf.tiers} == {
        "Turn": "turn_angle",
        "Scenario": "scenario",
        "Location": "location",
    }
    assert all(eaf.linguistic_types[x]["TIME_ALIGNABLE"] == "true" for x in lt.values())


def test_session_started_from_the_template_parses(tmp_path: Path) -> None:
    import pympi.Elan

    # As saved before anything is labelled: no turns, no error, and inspect says why.
    blank = tmp_path / "blank.eaf"
    blank.write_bytes(TEMPLATE.read_bytes())
    assert read_annotations(blank).empty
    info = inspect_eaf(blank)
    assert info["turn_tiers"] == [{"tier": "Turn", "annotator": None, "participant": None}]
    assert any("names no rater" in n for n in info["notes"])
    assert {c["tier"] for k in ("location", "scenario") for c in info["context_tiers"][k]} == {
        "Location",
        "Scenario",
    }

    # Labelled as the README says: the template's Turn tier renamed and given its rater and
    # participant, a second rater's tier added with the type "turn", context spans marked;
    # values picked from the lists carry ELAN 3.0 CVE_REF links.
    eaf = pympi.Elan.Eaf(str(TEMPLATE))
    eaf.rename_tier("Turn", "Turn c1 PD01")
    eaf.tiers["Turn c1 PD01"][2].update(ANNOTATOR="c1", PARTICIPANT="PD01")
    eaf.add_tier("Turn c2 PD01", ling="turn", part="PD01", ann="c2")
    eaf.add_annotation("Turn c1 PD01", 2000, 3500, "180")
    eaf.add_annotation("Turn c2 PD01", 2100, 3400, "180")
    eaf.add_annotation("Turn c1 PD01", 8000, 9000, "90")
    eaf.add_annotation("Scenario", 0, 6000, "clinical")
    eaf.add_annotation("Scenario", 6000, 12000, "free-living")
    eaf.add_annotation("Location", 0, 12000, "hallway")
    # The template's own empty "Turn" tier is also kept in a copy that added tiers instead.
    eaf.add_tier("Turn", ling="turn")
    path = tmp_path / "pair01_day1.eaf"
    pympi.Elan.to_eaf(str(path), eaf)
    add_cve_refs(path, {"clinical": "scenario_clinical", "hallway": "location_hallway"})
    df = read_annotations(path)
    assert df[
        [
            "session",
            "tier",
            "annotator",
            "participant",
            "start_s",
            "end_s",
            "angle_deg",
            "scenario",
            "location",
        ]
    ].values.tolist() == [
        ["pair01_day1", "Turn c1 PD01", "c1", "PD01", 2.0, 3.5, 180.0, "clinical", "hallway"],
        ["pair01_day1", "Turn c1 PD01", "c1", "PD01", 8.0, 9.0, 90.0, "free-living", "hallway"],
        ["pair01_day1", "Turn c2 PD01", "c2", "PD01", 2.1, 3.4, 180.0, "clinical", "hallway"],
    ]
