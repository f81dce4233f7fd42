"""The annotation schema: which ELAN tiers hold turns, and which values they may take.

The paper's clinicians labelled each turn in ELAN with its angle from a controlled vocabulary
(90° to 360° in 45° steps, Cheng et al., Section 3.2); the scenario (scripted, clinical,
free-living, Table 2) and the room come from context tiers. The default convention is
described in ``annotations/README.md``; a TOML file (``--schema``) maps any other:

``[turn]``
    ``tier_regex`` picks turn tiers by TIER_ID (named groups ``annotator`` and
    ``participant`` may take those from the name), ``annotator_attribute`` and
    ``participant_attribute`` name the tier attributes used otherwise, ``default_participant``
    serves files with one unnamed subject, ``consensus_annotator`` names the adjudicating rater.
``[context]``
    ``location_tier_regex`` and ``scenario_tier_regex`` pick the context tiers.
``[vocabulary]`` and ``[aliases.<vocabulary>]``
    The values of ``turn_angle`` (degrees), ``scenario`` and ``location``, and other
    spellings that mean one of them.

Values are read forgivingly and checked strictly: case, surrounding spaces, runs of spaces,
``-`` and ``_`` never matter, an angle may carry a unit (``90°``, ``90 deg``, ``90 degrees``),
an alias maps a synonym; anything else is not in the vocabulary and :meth:`Vocabulary.parse`
returns ``None`` so the caller can report the file, tier and time.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from os import PathLike
from pathlib import Path
from typing import Any

from turn_datasets.errors import TurnbenchError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 reads TOML with the tomli backport
    import tomli as tomllib

__all__ = [
    "DEFAULT_SCHEMA_NAME",
    "Schema",
    "Vocabulary",
    "default_schema_text",
    "load_schema",
    "normalise_value",
]

#: File name of the default schema, shipped in ``turn_datasets/data`` (package data) and kept
#: identical in ``annotations/`` for clinicians (a test checks that they are the same).
DEFAULT_SCHEMA_NAME = "schema-default.toml"

_GROUPS = {"annotator", "participant"}
# "90", "90.0", "90°", "90 deg", "90 degrees", "90-degree" (case-folded, single-spaced).
_ANGLE_RE = re.compile(r"^(\d+(?:\.\d+)?)(?:\s*[°º]|\s*-?\s*(?:deg|degs|degree|degrees))?$")


def normalise_value(text: str) -> str:
    """The key two spellings of one value share: case-folded, ``-``/``_`` as spaces, single-spaced."""
    return " ".join(str(text).replace("-", " ").replace("_", " ").casefold().split())


def _format_angle(value: float) -> str:
    return f"{value:g}"


@dataclass(frozen=True)
class Vocabulary:
    """A controlled vocabulary with its aliases.

    Parameters
    ----------
    name
        ``turn_angle``, ``scenario`` or ``location``.
    values
        The canonical values in their display order (for ``turn_angle``, degrees as text).
    aliases
        Other spelling -> canonical value (keys as written; they are normalised).
    numeric
        Values are angles in degrees: :meth:`parse` returns a float and accepts units.
    """

    name: str
    values: tuple[str, ...]
    aliases: Mapping[str, str] = field(default_factory=dict)
    numeric: bool = False
    _lookup: dict[str, str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        lookup: dict[str, str] = {}
        for value in self.values:
            lookup[self._key(value)] = value
        for alias, target in self.aliases.items():
            lookup[self._key(alias)] = target
        object.__setattr__(self, "_lookup", lookup)

    def _key(self, text: str) -> str:
        if not self.numeric:
            return normalise_value(text)
        m = _ANGLE_RE.match(" ".join(str(text).casefold().split()))
        if m:
            return _format_angle(float(m.group(1)))
        key = normalise_value(text)
        # normalise_value turns "-90" into "90"; a number that only the normalisation made
        # look like an angle is not one, so give it a key no value has.
        return "\0" + key if _ANGLE_RE.match(key) else key

    def parse(self, raw: str | None) -> str | float | None:
        """The canonical value of ``raw``, or ``None`` when it is not in the vocabulary.

        Angles come back as ``float`` degrees, other values as their canonical text.
        """
        if raw is None:
            return None
        hit = self._lookup.get(self._key(raw))
        if hit is None:
            return None
        return float(hit) if self.numeric else hit

    def describe(self) -> str:
        """The values as a short list for error messages."""
        return ", ".join(self.values)


@dataclass(frozen=True)
class Schema:
    """How turns are read from ELAN files (see the module docstring for the TOML keys)."""

    turn_tier_regex: re.Pattern[str]
    annotator_attribute: str
    participant_attribute: str
    default_participant: str
    consensus_annotator: str
    location_tier_regex: re.Pattern[str]
    scenario_tier_regex: re.Pattern[str]
    turn_angle: Vocabulary
    scenario: Vocabulary
    location: Vocabulary
    source: str = "default"

    @property
    def angles_deg(self) -> tuple[float, ...]:
        """The turning angles of the vocabulary, in degrees, in order."""
        return tuple(float(v) for v in self.turn_angle.values)

    def is_consensus(self, annotator: str) -> bool:
        """Whether ``annotator`` is the adjudicating rater (case and spaces ignored)."""
        return normalise_value(annotator) == normalise_value(self.consensus_annotator)

    def vocabulary(self, name: str) -> Vocabulary:
        """The vocabulary called ``name`` (``turn_angle``, ``scenario`` or ``location``)."""
        if name not in ("turn_angle", "scenario", "location"):
            raise KeyError(name)
        return getattr(self, name)


# ---------------------------------------------------------------------------------------
# Loading

_TOP_KEYS = {"version", "turn", "context", "vocabulary", "aliases"}
_TURN_KEYS = {
    "tier_regex",
    "annotator_attribute",
    "participant_attribute",
    "default_participant",
    "consensus_annotator",
}
_CONTEXT_KEYS = {"location_tier_regex", "scenario_tier_regex"}
_VOCAB_KEYS = {"turn_angle", "scenario", "location"}


def default_schema_text() -> str:
    """The text of the default schema shipped with the package."""
    return (
        resources.files("turn_datasets")
        .joinpath("data")
        .joinpath(DEFAULT_SCHEMA_NAME)
        .read_text(encoding="utf-8")
    )


def _parse_toml(text: str, source: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise TurnbenchError(f"not a valid TOML schema: {exc}", file=source) from None


def _check_keys(table: Any, allowed: set[str], where: str, source: str) -> dict[str, Any]:
    if not isinstance(table, dict):
        raise TurnbenchError(f"[{where}] must be a table", file=source)
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise TurnbenchError(
            f"unknown key(s) {', '.join(unknown)} in [{where}]",
            file=source,
            hint=f"allowed: {', '.join(sorted(allowed))}",
        )
    return table


def _string(value: Any, key: str, source: str) -> str:
    if not isinstance(value, str):
        raise TurnbenchError(f"{key} must be a string, not {value!r}", file=source)
    return value


def _regex(value: Any, key: str, source: str, *, groups: set[str]) -> re.Pattern[str]:
    text = _string(value, key, source)
    try:
        pattern = re.compile(text)
    except re.error as exc:
        raise TurnbenchError(
            f"{key} is not a valid regular expression: {exc}", file=source
        ) from None
    extra = set(pattern.groupindex) - groups
    if extra:
        raise TurnbenchError(
            f"{key} has named group(s) {', '.join(sorted(extra))}; only "
            f"{', '.join(sorted(groups))} are understood",
            file=source,
        )
    return pattern


def _vocab_values(name: str, values: Any, source: str) -> tuple[str, ...]:
    if not isinstance(values, list) or not values:
        raise TurnbenchError(f"vocabulary {name} must be a non-empty list", file=source)
    out: list[str] = []
    for v in values:
        if name == "turn_angle":
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 3600:
                raise TurnbenchError(
                    f"vocabulary turn_angle must list angles in degrees (> 0), not {v!r}",
                    file=source,
                )
            out.append(_format_angle(float(v)))
        else:
            if not isinstance(v, str) or not v.strip():
                raise TurnbenchError(
                    f"vocabulary {name} must list non-empty strings, not {v!r}", file=source
                )
            out.append(v.strip())
    if len({normalise_value(v) for v in out}) != len(out):
        raise TurnbenchError(f"vocabulary {name} lists a value twice", file=source)
    return tuple(out)


def _build_vocabulary(name: str, values: tuple[str, ...], aliases: Any, source: str) -> Vocabulary:
    if not isinstance(aliases, dict):
        raise TurnbenchError(f"[aliases.{name}] must be a table", file=source)
    numeric = name == "turn_angle"
    plain = Vocabulary(name=name, values=values, numeric=numeric)
    resolved: dict[str, str] = {}
    for alias, target in aliases.items():
        if numeric and isinstance(target, (int, float)) and not isinstance(target, bool):
            target = _format_angle(float(target))
        if not isinstance(target, str):
            raise TurnbenchError(
                f"alias {alias!r} in [aliases.{name}] must map to a value", file=source
            )
        canonical = plain.parse(target)
        if canonical is None:
            raise TurnbenchError(
                f"alias {alias!r} in [aliases.{name}] maps to {target!r}, which is not in "
                f"the vocabulary ({plain.describe()})",
                file=source,
            )
        canonical_text = _format_angle(float(canonical)) if numeric else str(canonical)
        clash = plain.parse(alias)
        if clash is not None and clash != canonical:
            raise TurnbenchError(
                f"alias {alias!r} in [aliases.{name}] is itself the value {clash!r}",
                file=source,
            )
        resolved[alias] = canonical_text
    return Vocabulary(name=name, values=values, aliases=resolved, numeric=numeric)


def _schema_from_dict(data: dict[str, Any], source: str, base: dict[str, Any]) -> Schema:
    """Build a schema from ``data``, taking every missing key from ``base`` (the default)."""
    _check_keys(data, _TOP_KEYS, "top level", source)
    version = data.get("version", 1)
    if version != 1:
        raise TurnbenchError(
            f"schema version {version!r} is not supported (expected 1)", file=source
        )
    turn = {**base["turn"], **_check_keys(data.get("turn", {}), _TURN_KEYS, "turn", source)}
    context = {
        **base["context"],
        **_check_keys(data.get("context", {}), _CONTEXT_KEYS, "context", source),
    }
    vocab = {
        **base["vocabulary"],
        **_check_keys(data.get("vocabulary", {}), _VOCAB_KEYS, "vocabulary", source),
    }
    aliases_in = _check_keys(data.get("aliases", {}), _VOCAB_KEYS, "aliases", source)
    # A schema that redefines a vocabulary but not its aliases starts without aliases, since
    # the default's synonyms may point at values that are no longer there.
    aliases: dict[str, Any] = {}
    for name in _VOCAB_KEYS:
        if name in aliases_in:
            aliases[name] = aliases_in[name]
        elif name in data.get("vocabulary", {}):
            aliases[name] = {}
        else:
            aliases[name] = base.get("aliases", {}).get(name, {})

    values = {name: _vocab_values(name, vocab[name], source) for name in _VOCAB_KEYS}
    consensus = _string(turn["consensus_annotator"], "turn.consensus_annotator", source).strip()
    if not consensus:
        raise TurnbenchError("turn.consensus_annotator must not be empty", file=source)
    return Schema(
        turn_tier_regex=_regex(turn["tier_regex"], "turn.tier_regex", source, groups=_GROUPS),
        annotator_attribute=_string(
            turn["annotator_attribute"], "turn.annotator_attribute", source
        ),
        participant_attribute=_string(
            turn["participant_attribute"], "turn.participant_attribute", source
        ),
        default_participant=_string(
            turn["default_participant"], "turn.default_participant", source
        ).strip(),
        consensus_annotator=consensus,
        location_tier_regex=_regex(
            context["location_tier_regex"],
            "context.location_tier_regex",
            source,
            groups={"participant"},
        ),
        scenario_tier_regex=_regex(
            context["scenario_tier_regex"],
            "context.scenario_tier_regex",
            source,
            groups={"participant"},
        ),
        turn_angle=_build_vocabulary(
            "turn_angle", values["turn_angle"], aliases["turn_angle"], source
        ),
        scenario=_build_vocabulary("scenario", values["scenario"], aliases["scenario"], source),
        location=_build_vocabulary("location", values["location"], aliases["location"], source),
        source=source,
    )


def load_schema(path: str | PathLike[str] | None = None) -> Schema:
    """Read an annotation schema; ``None`` gives the default convention.

    Parameters
    ----------
    path
        A TOML file (see the module docstring). Keys it leaves out keep their default value.

    Raises
    ------
    TurnbenchError
        The file is missing, is not TOML, has unknown keys, a bad regular expression, or an
        alias that points outside its vocabulary; the message names the file.
    """
    base_text = default_schema_text()
    base = _parse_toml(base_text, DEFAULT_SCHEMA_NAME)
    if path is None:
        return _schema_from_dict(base, "default", base)
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise TurnbenchError("schema file not found", file=source) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"cannot read the schema: {exc}", file=source) from None
    return _schema_from_dict(_parse_toml(text, source), source, base)
