"""The annotation schema: defaults, forgiving values, strict checks of schema files."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.remap.schema import DEFAULT_SCHEMA_NAME, load_schema, normalise_value

REPO = Path(__file__).resolve().parents[1]


def test_packaged_default_equals_annotations_copy() -> None:
    packaged = REPO / "turn_datasets" / "data" / DEFAULT_SCHEMA_NAME
    shipped = REPO / "annotations" / DEFAULT_SCHEMA_NAME
    assert packaged.read_bytes() == shipped.read_bytes()
    # Loading the clinicians' copy by path gives the same schema as the default.
    a, b = load_schema(), load_schema(shipped)
    assert a.turn_angle.values == b.turn_angle.values
    assert a.scenario.values == b.scenario.values
    assert a.location.values == b.location.values


def test_default_vocabularies_are_the_papers() -> None:
    s = load_schema()
    # 90 to 360 in 45 degree steps (the paper, Section 3.2).
    assert s.angles_deg == (90.0, 135.0, 180.0, 225.0, 270.0, 315.0, 360.0)
    assert s.scenario.values == ("scripted", "clinical", "free-living")


def test_template_vocabularies_match_default_schema() -> None:
    root = ET.parse(REPO / "annotations" / "turn-remap.etf").getroot()
    cvs = {
        cv.get("CV_ID"): [v.text for v in cv.iter("CVE_VALUE")]
        for cv in root.iter("CONTROLLED_VOCABULARY")
    }
    s = load_schema()
    assert cvs["turn_angle"] == list(s.turn_angle.values)
    assert cvs["scenario"] == list(s.scenario.values)
    assert cvs["location"] == list(s.location.values)
    tiers = [t.get("TIER_ID") for t in root.iter("TIER")]
    assert any(s.turn_tier_regex.search(t) for t in tiers)
    assert any(s.location_tier_regex.search(t) for t in tiers)
    assert any(s.scenario_tier_regex.search(t) for t in tiers)


@pytest.mark.parametrize(
    "raw,expected",
    [
        ("90", 90.0),
        ("90°", 90.0),
        ("90 deg", 90.0),
        ("90 degrees", 90.0),
        (" 90 ", 90.0),
        ("90.0", 90.0),
        ("360", 360.0),
        ("135°", 135.0),
        ("90-degree", 90.0),
        ("90 DEG", 90.0),
        ("180 °", 180.0),
        ("+90", None),
        ("100", None),  # not a multiple of 45
        ("45", None),  # below the vocabulary
        ("-90", None),
        ("ninety", None),
        ("", None),
        ("90 rad", None),
    ],
)
def test_angle_parsing(raw: str, expected: float | None) -> None:
    assert load_schema().turn_angle.parse(raw) == expected


@pytest.mark.parametrize(
    "raw,expected",
    [
        ("scripted", "scripted"),
        ("loosely scripted", "scripted"),
        ("Loosely  Scripted", "scripted"),
        ("free living", "free-living"),
        ("Free_Living", "free-living"),
        (" clinical ", "clinical"),
        ("weekend", None),
    ],
)
def test_scenario_parsing(raw: str, expected: str | None) -> None:
    assert load_schema().scenario.parse(raw) == expected


def test_normalise_value() -> None:
    assert normalise_value("  Free_living-Room ") == "free living room"


def _schema_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_partial_schema_keeps_defaults(tmp_path: Path) -> None:
    path = _schema_file(
        tmp_path,
        "[turn]\ntier_regex = '^(?P<annotator>\\w+)-(?P<participant>P\\d+)$'\n"
        "[aliases.turn_angle]\nquarter = 90\n'half turn' = '180'\n",
    )
    s = load_schema(path)
    m = s.turn_tier_regex.search("alice-P07")
    assert m and m.group("annotator") == "alice" and m.group("participant") == "P07"
    assert s.turn_angle.parse("Quarter") == 90.0
    assert s.turn_angle.parse("half-turn") == 180.0
    # Untouched parts are the default's.
    assert s.scenario.parse("loosely scripted") == "scripted"
    assert s.consensus_annotator == "consensus"
    assert s.source == str(path)


def test_redefined_vocabulary_drops_default_aliases(tmp_path: Path) -> None:
    s = load_schema(_schema_file(tmp_path, "[vocabulary]\nscenario = ['lab', 'home']\n"))
    assert s.scenario.parse("home") == "home"
    assert s.scenario.parse("loosely scripted") is None


@pytest.mark.parametrize(
    "text,fragment",
    [
        ("[turn]\ntier_regx = 'x'\n", "tier_regx"),
        ("[turn]\ntier_regex = '(unclosed'\n", "regular expression"),
        ("[turn]\ntier_regex = '(?P<rater>x)'\n", "rater"),
        ("[aliases.scenario]\nweekend = 'holiday'\n", "holiday"),
        ("[aliases.turn_angle]\nbig = 400\n", "400"),
        ("[vocabulary]\nturn_angle = ['ninety']\n", "turn_angle"),
        ("[vocabulary]\nlocation = []\n", "non-empty"),
        ("version = 2\n", "version"),
        ("[turn\n", "TOML"),
        ("[aliases.scenario]\nclinical = 'scripted'\n", "itself the value"),
    ],
)
def test_bad_schema_files(tmp_path: Path, text: str, fragment: str) -> None:
    path = _schema_file(tmp_path, text)
    with pytest.raises(TurnbenchError) as info:
        load_schema(path)
    assert fragment in str(info.value)
    assert str(path) in str(info.value)


def test_missing_schema_file(tmp_path: Path) -> None:
    with pytest.raises(TurnbenchError, match="not found"):
        load_schema(tmp_path / "nope.toml")


def test_consensus_is_case_insensitive() -> None:
    s = load_schema()
    assert s.is_consensus("Consensus") and s.is_consensus(" CONSENSUS ")
    assert not s.is_consensus("alice")


def test_readme_schema_example_loads(tmp_path: Path) -> None:
    text = (REPO / "annotations" / "README.md").read_text(encoding="utf-8")
    block = text.split("```toml\n", 1)[1].split("```", 1)[0]
    s = load_schema(_schema_file(tmp_path, block))
    m = s.turn_tier_regex.search("Marvin")
    assert m and m.group("annotator") == "Marvin"
    assert s.default_participant == "P01"
    assert s.turn_angle.parse("S") == 90.0
