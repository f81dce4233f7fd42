"""Reading ELAN (``.eaf``) files safely: turn annotations of every rater, and what a file holds.

In the paper (Cheng et al., Section 3.2) clinicians labelled each turn of the Turn-REMAP
videos in ELAN with its start, end and angle. :func:`read_annotations` turns such files into
one table with a row per annotation of every rater. The tier-level functions (loading a
document, its tiers in order, their attributes, annotations and resolved times, the schema's
role of each tier) are public for :mod:`turn_datasets.remap.inspect`, which lists what any
ELAN file holds.

EAF files are XML written by other people's tools. Before pympi-ling sees a file, it is
parsed with ``defusedxml`` and refused if it declares a DOCTYPE or an entity (billion laughs,
external entities); ELAN never writes either. pympi-ling is then used only through what it
stores (tiers, time slots, vocabularies), never through the accessors that fail on real
exports: ``get_annotation_data_for_tier`` raises ``KeyError`` on a symbolic child of a
time-aligned child tier, and time slots without a value come back as ``None``. Times of
reference annotations are resolved here through their parents, and a tier that is not
needed can never stop the parse.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any
from xml.etree.ElementTree import Element, ParseError

import defusedxml.ElementTree as safe_et
import pandas as pd
import pympi.Elan
from defusedxml.common import DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden

from turn_datasets.errors import TurnbenchError, Where
from turn_datasets.fileio import typed_frame, walk_files
from turn_datasets.remap.schema import Schema, Vocabulary, load_schema
from turn_datasets.render.numbers import counted
from turn_datasets.usertable import Problems

__all__ = [
    "ANNOTATION_COLUMNS",
    "KNOWN_VERSIONS",
    "Document",
    "Timed",
    "TierRole",
    "annotation_times_ms",
    "attr",
    "classify_tiers",
    "expand_eaf_paths",
    "linguistic_type",
    "load_document",
    "load_eaf",
    "parse_value",
    "tier_annotations",
    "tier_attrs",
    "tiers_in_order",
    "read_annotations",
    "read_annotations_and_context",
    "FileContext",
]

#: Column contract of :func:`read_annotations` (``annotations.csv``).
ANNOTATION_COLUMNS = {
    "session": "str",
    "file": "str",
    "tier": "str",
    "annotator": "str",
    "participant": "str",
    "start_s": "float64",
    "end_s": "float64",
    "angle_deg": "float64",
    "scenario": "str",
    "location": "str",
    "value": "str",
}

#: EAF format versions pympi-ling 1.71 knows; others are read, with a note in ``inspect``.
KNOWN_VERSIONS = ("2.7", "2.8", "3.0")


# ---------------------------------------------------------------------------------------
# Loading


@dataclass
class Document:
    """A loaded file: pympi's object plus what pympi drops (CVE_REF links, the version), and
    the values whose text disagrees with their linked vocabulary entry (read as the entry)."""

    path: Path
    eaf: pympi.Elan.Eaf
    cve_refs: dict[str, str]
    version: str
    cve_disagreements: list[str] = field(default_factory=list)


#: The attribute pympi-ling requires on the root (it deletes it unchecked); older tools and
#: hand edits leave it out, and ELAN itself reads such files.
_XSI_LOCATION = "{http://www.w3.org/2001/XMLSchema-instance}noNamespaceSchemaLocation"


class _VettedTree:
    """Stands in for ElementTree inside ``pympi.Elan.parse_eaf``, which only calls
    ``etree.parse(path).getroot()``: pympi then reads the tree defusedxml already parsed and
    vetted (not the file a second time, unchecked), with any repair made in memory only."""

    ParseError = ParseError

    def __init__(self, root: Element) -> None:
        self._root = root

    def parse(self, source: object) -> _VettedTree:
        return self

    def getroot(self) -> Element:
        return self._root


def _pympi_eaf(path: Path, root: Element) -> pympi.Elan.Eaf:
    if _XSI_LOCATION not in root.attrib:
        root.set(_XSI_LOCATION, "")  # in memory: the file is never modified
    saved = pympi.Elan.etree
    pympi.Elan.etree = _VettedTree(root)
    try:
        with warnings.catch_warnings():
            # The version is reported by `inspect`; pympi's generic warning adds nothing.
            warnings.simplefilter("ignore")
            return pympi.Elan.Eaf(str(path), suppress_version_warning=True)
    finally:
        pympi.Elan.etree = saved


def _safe_root(path: Path) -> Element:
    """Parse ``path`` with defusedxml, refusing DOCTYPE and entity declarations."""
    name = str(path)
    try:
        tree = safe_et.parse(name, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DTDForbidden:
        raise TurnbenchError(
            "refused: the file declares a DOCTYPE (its entities could expand without bound "
            "or read other files); ELAN never writes one",
            file=name,
        ) from None
    except EntitiesForbidden:
        raise TurnbenchError(
            "refused: the file declares XML entities (billion laughs); ELAN never writes them",
            file=name,
        ) from None
    except ExternalReferenceForbidden:
        raise TurnbenchError(
            "refused: the file refers to an external XML entity or DTD", file=name
        ) from None
    except ParseError as exc:
        raise TurnbenchError(f"not well-formed XML ({exc})", file=name) from None
    except FileNotFoundError:
        raise TurnbenchError("file not found", file=name) from None
    except IsADirectoryError:
        raise TurnbenchError("is a folder, not an .eaf file", file=name) from None
    except OSError as exc:
        raise TurnbenchError(f"cannot read the file: {exc.strerror or exc}", file=name) from None
    root = tree.getroot()
    if root.tag != "ANNOTATION_DOCUMENT":
        raise TurnbenchError(
            f"not an ELAN annotation document (root element <{root.tag}>)", file=name
        )
    return root


def load_document(path: str | PathLike[str]) -> Document:
    p = Path(path)
    root = _safe_root(p)
    cve_refs: dict[str, str] = {}
    for tag in ("ALIGNABLE_ANNOTATION", "REF_ANNOTATION"):
        for el in root.iter(tag):
            ref, aid = el.get("CVE_REF"), el.get("ANNOTATION_ID")
            if ref and aid:
                cve_refs[aid] = ref
    version = str(root.get("VERSION", ""))
    try:
        eaf = _pympi_eaf(p, root)
    except Exception as exc:  # pympi raises bare Exception/KeyError/IndexError on odd files
        raise TurnbenchError(
            f"pympi-ling could not read this ELAN file ({type(exc).__name__}: {exc})",
            file=str(p),
        ) from None
    return Document(path=p, eaf=eaf, cve_refs=cve_refs, version=version)


def load_eaf(path: str | PathLike[str]) -> pympi.Elan.Eaf:
    """Read an ELAN file with pympi-ling after checking that its XML is safe.

    Parameters
    ----------
    path
        The ``.eaf`` (or ``.etf`` template) file.

    Returns
    -------
    pympi.Elan.Eaf
        The parsed file. Use it through its stored attributes (``tiers``, ``timeslots``,
        ``controlled_vocabularies``); see :func:`read_annotations` for turn rows.

    Raises
    ------
    TurnbenchError
        Naming the file: it declares a DOCTYPE or entities (refused before pympi sees it),
        is not well-formed XML, is not an ELAN document, or pympi-ling cannot read it.
    """
    return load_document(path).eaf


def expand_eaf_paths(
    paths_or_dirs: str | PathLike[str] | Iterable[str | PathLike[str]],
) -> list[Path]:
    """Files given, and the ``.eaf`` files in folders given and their subfolders.

    A folder's files are sorted by their path inside it (``day1/s1.eaf`` before
    ``day2/s2.eaf``), subfolders reached through symbolic links included, as ``h36m mine``
    walks a dataset. Hidden files and folders (names starting with ``.``) are skipped; a file
    named on its own is always taken.

    Raises
    ------
    TurnbenchError
        A path does not exist, a folder (or a subfolder) cannot be read, a folder holds no
        ``.eaf`` file, or nothing was given.
    """
    if isinstance(paths_or_dirs, (str, os.PathLike)):
        items: list[str | PathLike[str]] = [paths_or_dirs]
    else:
        items = list(paths_or_dirs)
    if not items:
        raise TurnbenchError("no .eaf file or folder given")
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            # Hidden files are skipped: macOS leaves "._name.eaf" resource forks (binary, not
            # ELAN) beside every file copied to a shared drive.
            found = [c for c in walk_files(p) if c.suffix.lower() == ".eaf" and c.is_file()]
            if not found:
                raise TurnbenchError("folder holds no .eaf file", file=str(p))
            out.extend(found)
        elif p.exists():
            out.append(p)
        else:
            raise TurnbenchError("file not found", file=str(p))
    return out


# ---------------------------------------------------------------------------------------
# Tiers, times and vocabularies as stored by pympi


def tier_attrs(eaf: pympi.Elan.Eaf, tier_id: str) -> dict[str, Any]:
    return eaf.tiers[tier_id][2]


def tiers_in_order(eaf: pympi.Elan.Eaf) -> list[str]:
    return [t for t, _ in sorted(eaf.tiers.items(), key=lambda kv: kv[1][3])]


def attr(attrs: dict[str, Any], key: str) -> str:
    value = attrs.get(key)
    return "" if value is None else str(value).strip()


def annotation_times_ms(eaf: pympi.Elan.Eaf) -> dict[str, tuple[int | None, int | None]]:
    """Start and end (ms, ``None`` when unaligned) of every annotation, symbolic ones included.

    A reference annotation takes the times of the aligned annotation it hangs from, followed
    up the chain of ``ANNOTATION_REF`` (pympi's own accessor fails on such chains).
    """
    times: dict[str, tuple[int | None, int | None]] = {}
    parent: dict[str, str] = {}
    for aligned, refs, _attrs, _ord in eaf.tiers.values():
        for aid, (ts1, ts2, _value, _svg) in aligned.items():
            times[aid] = (eaf.timeslots.get(ts1), eaf.timeslots.get(ts2))
        for aid, (ref, _value, _prev, _svg) in refs.items():
            parent[aid] = ref
    for aid in parent:
        chain = [aid]
        cur = aid
        # Follow the chain to an aligned annotation; a broken or cyclic chain has no time.
        while cur in parent and cur not in times and len(chain) <= len(parent) + 1:
            cur = parent[cur]
            chain.append(cur)
        found = times.get(cur, (None, None))
        for c in chain:
            times.setdefault(c, found)
    return times


@dataclass(frozen=True)
class _Ann:
    aid: str
    start_ms: int | None
    end_ms: int | None
    value: str


def tier_annotations(
    eaf: pympi.Elan.Eaf, tier_id: str, times: dict[str, tuple[int | None, int | None]]
) -> list[_Ann]:
    aligned, refs, _attrs, _ord = eaf.tiers[tier_id]
    anns = [
        _Ann(aid, *times.get(aid, (None, None)), value="" if v[2] is None else str(v[2]))
        for aid, v in aligned.items()
    ]
    anns += [
        _Ann(aid, *times.get(aid, (None, None)), value="" if v[1] is None else str(v[1]))
        for aid, v in refs.items()
    ]

    def key(a: _Ann) -> tuple[int, int, str]:
        big = 1 << 62
        return (
            big if a.start_ms is None else a.start_ms,
            big if a.end_ms is None else a.end_ms,
            a.aid,
        )

    return sorted(anns, key=key)


def linguistic_type(eaf: pympi.Elan.Eaf, tier_id: str) -> dict[str, Any]:
    lt = attr(tier_attrs(eaf, tier_id), "LINGUISTIC_TYPE_REF")
    return eaf.linguistic_types.get(lt, {}) or {}


def _tier_cv(eaf: pympi.Elan.Eaf, tier_id: str) -> str:
    return attr(linguistic_type(eaf, tier_id), "CONTROLLED_VOCABULARY_REF")


def _cve_texts(eaf: pympi.Elan.Eaf, cv_id: str, cve_id: str) -> list[str]:
    """The texts (every language) of vocabulary entry ``cve_id`` of ``cv_id``; [] if unknown."""
    cv = eaf.controlled_vocabularies.get(cv_id)
    if not cv:
        return []
    entry = cv[1].get(cve_id)
    if not entry:
        return []
    return [str(text) for text, _lang, _desc in entry[0] if text is not None and str(text).strip()]


# ---------------------------------------------------------------------------------------
# Which tiers the schema takes


@dataclass(frozen=True)
class TierRole:
    tier: str
    role: str  # "turn", "location", "scenario"
    annotator: str
    participant: str


def classify_tiers(eaf: pympi.Elan.Eaf, schema: Schema) -> list[TierRole]:
    roles: list[TierRole] = []
    for tier_id in tiers_in_order(eaf):
        attrs = tier_attrs(eaf, tier_id)
        # A stray space before "Turn" in a tier name must not hide the tier.
        m = schema.turn_tier_regex.search(tier_id.strip())
        if m:
            groups = m.groupdict()
            annotator = (groups.get("annotator") or "").strip() or attr(
                attrs, schema.annotator_attribute
            )
            participant = (
                (groups.get("participant") or "").strip()
                or attr(attrs, schema.participant_attribute)
                or schema.default_participant
            )
            if schema.is_consensus(annotator):
                annotator = schema.consensus_annotator
            roles.append(TierRole(tier_id, "turn", annotator, participant))
            continue
        for role, regex in (
            ("location", schema.location_tier_regex),
            ("scenario", schema.scenario_tier_regex),
        ):
            m = regex.search(tier_id.strip())
            if m:
                participant = (m.groupdict().get("participant") or "").strip() or attr(
                    attrs, schema.participant_attribute
                )
                roles.append(TierRole(tier_id, role, "", participant))
                break
    return roles


# ---------------------------------------------------------------------------------------
# Turn annotations


def _fmt_s(ms: int | None) -> str:
    return "?" if ms is None else f"{ms / 1000:.3f} s"


@dataclass(frozen=True)
class Timed:
    """An annotation whose start and end are known and in order."""

    aid: str
    start_ms: int
    end_ms: int
    value: str


def _refuse(
    problems: Problems | None,
    exc: TurnbenchError,
    kind: str,
    *,
    detail: str | None = None,
    unit: str = "annotation",
) -> None:
    """Raise ``exc``, or with ``problems`` add it there as ``kind`` and go on."""
    if problems is None:
        raise exc
    problems.record(exc, kind=kind, detail=detail, unit=unit)


def _checked_intervals(
    doc: Document,
    tier: str,
    anns: list[_Ann],
    *,
    allow_overlap: bool,
    problems: Problems | None = None,
) -> list[Timed]:
    """Aligned, positive-length annotations of one tier, in time order (errors otherwise;
    with ``problems``, each added there and the annotation left out)."""
    file = str(doc.path)
    out: list[Timed] = []
    for a in anns:
        item = f"annotation {a.aid}"
        shown = f"{a.value.strip()!r}"
        if a.start_ms is None or a.end_ms is None:
            known = a.start_ms if a.start_ms is not None else a.end_ms
            span = f"start {_fmt_s(a.start_ms)}, end {_fmt_s(a.end_ms)}"
            exc = TurnbenchError(
                f"annotation {shown} has an unaligned time slot ({span}); align it in ELAN",
                file=file,
                item=item,
                tier=tier,
                time_s=None if known is None else known / 1000,
            )
            _refuse(
                problems,
                exc,
                "annotation with an unaligned time slot (align it in ELAN)",
                detail=f"{shown}, {span}",
            )
            continue
        if a.end_ms <= a.start_ms:
            exc = TurnbenchError(
                f"annotation {shown} ends ({a.end_ms / 1000:.3f} s) not after it starts",
                file=file,
                item=item,
                tier=tier,
                time_s=a.start_ms / 1000,
            )
            _refuse(
                problems,
                exc,
                "annotation ends not after it starts",
                detail=f"{shown}, ends at {a.end_ms / 1000:.3f} s",
            )
            continue
        if not allow_overlap and out and a.start_ms < out[-1].end_ms:
            prev = out[-1]
            span = f"{prev.start_ms / 1000:.3f} to {prev.end_ms / 1000:.3f} s"
            exc = TurnbenchError(
                f"turn {shown} overlaps the previous turn on this tier ({span})",
                file=file,
                item=item,
                tier=tier,
                time_s=a.start_ms / 1000,
            )
            _refuse(
                problems,
                exc,
                "turn overlaps the previous turn on its tier",
                detail=f"{shown}, the previous {span}",
            )
            continue
        out.append(Timed(a.aid, a.start_ms, a.end_ms, a.value))
    return out


def parse_value(doc: Document, tier: str, a: Timed, vocab: Vocabulary) -> str | float:
    """The canonical value of annotation ``a`` (CVE_REF first, then its text), or an error."""
    candidates: list[str] = []
    ref = doc.cve_refs.get(a.aid)
    if ref:
        # ELAN 3.0 links a value to its vocabulary entry; the entry is the truth (the text
        # may be another language's, or stale after the vocabulary was edited).
        candidates += _cve_texts(doc.eaf, _tier_cv(doc.eaf, tier), ref)
    candidates.append(a.value)
    for i, text in enumerate(candidates):
        parsed = vocab.parse(text)
        if parsed is not None:
            if i < len(candidates) - 1 and a.value.strip() and vocab.parse(a.value) != parsed:
                # Read as the entry, but never without a word: the text is what the rater
                # saw last, and "100°" read as 90 is a disagreement someone must look at.
                where = Where(file=str(doc.path), tier=tier, time_s=a.start_ms / 1000)
                doc.cve_disagreements.append(
                    f"{where}: text {a.value!r} disagrees with its vocabulary entry "
                    f"{text!r} (CVE_REF {ref}); read as the entry"
                )
            return parsed
    raise TurnbenchError(
        f"value {a.value!r} is not in the {vocab.name} vocabulary ({vocab.describe()})",
        file=str(doc.path),
        item=f"annotation {a.aid}",
        tier=tier,
        time_s=a.start_ms / 1000,
        hint=VOCABULARY_HINT,
    )


#: How to mend a value outside its vocabulary.
VOCABULARY_HINT = "fix it in ELAN, or add an alias to the schema (--schema)"


def _parsed_or_none(
    doc: Document, tier: str, a: Timed, vocab: Vocabulary, problems: Problems | None
) -> str | float | None:
    """:func:`parse_value`; with ``problems``, a value outside the vocabulary is added there
    (and None returned)."""
    try:
        return parse_value(doc, tier, a, vocab)
    except TurnbenchError as exc:
        _refuse(
            problems,
            exc,
            f"value not in the {vocab.name} vocabulary ({vocab.describe()})",
            detail=repr(a.value),
        )
        return None


@dataclass(frozen=True)
class _Context:
    participant: str
    start_ms: int
    end_ms: int
    value: str


def _context_value(contexts: list[_Context], participant: str, start_ms: int, end_ms: int) -> str:
    """The context value overlapping the turn most; a subject's own tiers before shared ones."""
    for pool in (
        [c for c in contexts if c.participant and c.participant == participant],
        [c for c in contexts if not c.participant],
    ):
        best, best_overlap = "", 0
        for c in pool:  # in time order, so a tie goes to the earlier annotation
            overlap = min(end_ms, c.end_ms) - max(start_ms, c.start_ms)
            if overlap > best_overlap:
                best, best_overlap = c.value, overlap
        if best_overlap > 0:
            return best
    return ""


#: The ELAN header property (``<PROPERTY NAME="start_time">``) that records when a session's
#: recording started: ISO 8601 with its UTC offset. ELAN keeps header properties as they are;
#: ``remap labels`` copies it into ``sessions.csv``'s ``start_time`` for hour-of-day profiles.
START_TIME_PROPERTY = "start_time"


@dataclass(frozen=True)
class FileContext:
    """What one session's file says about its context, for untrimmed scoring.

    Attributes
    ----------
    session
        The session id (the file stem).
    participants
        Participants with turn annotations, in order of first appearance.
    contexts
        ``"scenario"`` and ``"location"``: the context tiers' annotations (participant
        ``""`` for a tier shared by everyone), in time order.
    last_time_ms
        The file's last aligned time slot (ms), 0 when it has none.
    start_time
        When the recording started, from the header's :data:`START_TIME_PROPERTY` property
        (ISO 8601 with its UTC offset, as written), empty when the file does not say.
    """

    session: str
    participants: tuple[str, ...]
    contexts: dict[str, list[_Context]]
    last_time_ms: int
    start_time: str = ""


def _file_contexts(
    doc: Document, schema: Schema, roles: list[TierRole], times, problems: Problems
) -> dict[str, list[_Context]]:
    """The context tiers' annotations of a file, by role, in time order (problems added to
    ``problems``, the annotation left out)."""
    eaf = doc.eaf
    contexts: dict[str, list[_Context]] = {"location": [], "scenario": []}
    for r in roles:
        if r.role == "turn":
            continue
        vocab = schema.vocabulary(r.role)
        anns = _checked_intervals(
            doc, r.tier, tier_annotations(eaf, r.tier, times), allow_overlap=True, problems=problems
        )
        for a in anns:
            if not a.value.strip() and a.aid not in doc.cve_refs:
                continue  # an empty context annotation says nothing
            value = _parsed_or_none(doc, r.tier, a, vocab, problems)
            if value is not None:
                contexts[r.role].append(_Context(r.participant, a.start_ms, a.end_ms, str(value)))
    for pool in contexts.values():
        pool.sort(key=lambda c: (c.start_ms, c.end_ms))
    return contexts


def _turn_tier_named(
    r: TierRole, schema: Schema, file: str, seen: dict[tuple[str, str], str], problems: Problems
) -> bool:
    """Whether turn tier ``r`` names its rater and participant, and is the first of that
    rater for that participant (each problem added to ``problems``)."""
    named = True
    for value, what, hint in (
        (
            r.annotator,
            "rater",
            f"set the tier's {schema.annotator_attribute} attribute "
            "in ELAN (Tier > Change Tier Attributes)",
        ),
        (
            r.participant,
            "participant",
            f"set the tier's {schema.participant_attribute} "
            "attribute in ELAN, or turn.default_participant in the schema",
        ),
    ):
        if not value:
            exc = TurnbenchError(f"turn tier names no {what}", file=file, tier=r.tier, hint=hint)
            problems.record(exc, unit="tier")
            named = False
    if not named:
        return False
    key = (r.annotator.casefold(), r.participant)
    if key in seen:
        first = f"rater {r.annotator!r} and participant {r.participant!r}"
        problems.record(
            TurnbenchError(
                f"a second turn tier for {first} (the first is {seen[key]!r})",
                file=file,
                tier=r.tier,
            ),
            kind="a second turn tier for one rater and participant",
            detail=f"{first}, the first is {seen[key]!r}",
            unit="tier",
        )
        return False
    seen[key] = r.tier
    return True


def _file_rows(
    doc: Document, schema: Schema, problems: Problems
) -> tuple[list[dict[str, Any]], FileContext]:
    """One file's turn rows and context; each problem is added to ``problems`` and what it
    concerns (an annotation, a tier) left out."""
    eaf = doc.eaf
    file = str(doc.path)
    roles = classify_tiers(eaf, schema)
    times = annotation_times_ms(eaf)
    contexts = _file_contexts(doc, schema, roles, times, problems)

    rows: list[dict[str, Any]] = []
    seen: dict[tuple[str, str], str] = {}
    for r in roles:
        if r.role != "turn":
            continue
        tier_anns = tier_annotations(eaf, r.tier, times)
        if not tier_anns:
            # An empty turn tier holds no turn to attribute: the template's "Turn" tier, left
            # without rater and participant beside the tiers a clinician did fill, must not
            # stop the parse (inspect still notes it).
            continue
        if not _turn_tier_named(r, schema, file, seen, problems):
            continue
        anns = _checked_intervals(doc, r.tier, tier_anns, allow_overlap=False, problems=problems)
        for a in anns:
            angle = _parsed_or_none(doc, r.tier, a, schema.turn_angle, problems)
            if angle is None:
                continue
            rows.append(
                {
                    "session": doc.path.stem,
                    "file": file,
                    "tier": r.tier,
                    "annotator": r.annotator,
                    "participant": r.participant,
                    "start_s": a.start_ms / 1000,
                    "end_s": a.end_ms / 1000,
                    "angle_deg": float(angle),
                    "scenario": _context_value(
                        contexts["scenario"], r.participant, a.start_ms, a.end_ms
                    ),
                    "location": _context_value(
                        contexts["location"], r.participant, a.start_ms, a.end_ms
                    ),
                    "value": a.value,
                }
            )
    participants = tuple(dict.fromkeys(str(r["participant"]) for r in rows))
    slots = [t for t in eaf.timeslots.values() if t is not None]
    return rows, FileContext(
        session=doc.path.stem,
        participants=participants,
        contexts=contexts,
        last_time_ms=int(max(slots)) if slots else 0,
        start_time=next(
            (str(v or "").strip() for k, v in eaf.properties if k == START_TIME_PROPERTY), ""
        ),
    )


def read_annotations_and_context(
    paths_or_dirs: str | PathLike[str] | Iterable[str | PathLike[str]],
    *,
    schema: Schema | None = None,
    iterate: Callable[[list[Path]], Iterable[Path]] | None = None,
    warn: Callable[[str], None] | None = None,
    require_turn_tier: bool = False,
) -> tuple[pd.DataFrame, list[FileContext]]:
    """Every turn annotation of every rater in ELAN files, one row each, and each file's
    context (:class:`FileContext`, for ``context.csv`` and ``sessions.csv``).

    Parameters
    ----------
    paths_or_dirs
        ``.eaf`` files, or folders whose ``.eaf`` files are read (not recursively). One file
        is one recording session; its stem is the session id and must be unique.
    schema
        Which tiers hold turns and context, and the vocabularies (default:
        :func:`turn_datasets.remap.schema.load_schema`).
    iterate
        Wraps the list of files while they are read (the command line passes a progress bar).
    warn
        Called with one line (file, tier, time) per value whose text disagrees with the
        vocabulary entry it links to (``CVE_REF``): it is read as the entry.
    require_turn_tier
        Refuse a file without a turn tier among files with turns (the commands, which read
        a folder of sessions: such a file is in another convention, or stray); else it adds
        no rows.

    Returns
    -------
    pandas.DataFrame
        :data:`ANNOTATION_COLUMNS`: ``session, file, tier, annotator, participant, start_s,
        end_s, angle_deg, scenario, location, value`` in file, tier and time order.
        ``angle_deg`` is the vocabulary angle (the paper's 90° to 360° in 45° steps),
        ``scenario`` and ``location`` come from the context annotation overlapping the turn
        most (a participant's own context tiers before shared ones; empty if none overlaps),
        ``value`` is the annotation's text as written. An empty turn tier adds no rows (such
        as the template's ``Turn`` tier left unnamed), and so does a file without turn tiers
        (unless ``require_turn_tier``).

    Raises
    ------
    TurnbenchError
        Every problem of every file at once, grouped by kind (the first few places of each
        named by file, annotation, tier and time, and counted), after reading them all; a
        lone problem as its own one-line error: a value outside the vocabulary, overlapping
        turns on one tier, an end not after its start, an unaligned annotation, a turn tier
        with annotations but without rater or participant, two tiers of one rater for one
        participant, two files of one session, a file :func:`load_eaf` refuses, and with
        ``require_turn_tier`` a file without a turn tier among files with turns.
    """
    schema = schema if schema is not None else load_schema()
    rows: list[dict[str, Any]] = []
    contexts: list[FileContext] = []
    sessions: dict[str, Path] = {}
    paths = expand_eaf_paths(paths_or_dirs)
    problems = Problems(None)
    without_turn_tier: list[Path] = []
    for path in iterate(paths) if iterate is not None else paths:
        if path.stem in sessions:
            other = sessions[path.stem]
            exc = TurnbenchError(
                f"session {path.stem!r} comes from two files (the other is {other})",
                file=str(path),
                hint="one .eaf per session: the file stem is the session id",
            )
            problems.record(
                exc,
                kind="a session comes from two files",
                detail=f"the other is {other}",
                unit="file",
            )
        sessions.setdefault(path.stem, path)
        try:
            doc = load_document(path)
        except TurnbenchError as exc:
            problems.record(
                exc, kind="not readable as an ELAN file", detail=exc.message, unit="file"
            )
            continue
        if require_turn_tier and not any(r.role == "turn" for r in classify_tiers(doc.eaf, schema)):
            without_turn_tier.append(path)
        file_rows, context = _file_rows(doc, schema, problems)
        rows.extend(file_rows)
        contexts.append(context)
        if warn is not None:
            for message in doc.cve_disagreements:
                warn(message)
    if rows or problems:
        # Beside files with turns, a file without a turn tier is another convention or a
        # stray file, never a session to pass over in silence.
        for path in without_turn_tier:
            problems.record(
                TurnbenchError(
                    f"no turn tier: no tier name matches {schema.turn_tier_regex.pattern!r}",
                    file=str(path),
                    hint="see `turn-datasets remap inspect`, or map the tiers with --schema",
                ),
                unit="file",
            )
    problems.raise_if_any("nothing read", scope=f" in {counted(len(paths), 'ELAN file')}")
    frame = pd.DataFrame(rows, columns=list(ANNOTATION_COLUMNS))
    return typed_frame(frame, ANNOTATION_COLUMNS), contexts


def read_annotations(
    paths_or_dirs: str | PathLike[str] | Iterable[str | PathLike[str]],
    *,
    schema: Schema | None = None,
    iterate: Callable[[list[Path]], Iterable[Path]] | None = None,
    warn: Callable[[str], None] | None = None,
    require_turn_tier: bool = False,
) -> pd.DataFrame:
    """Every turn annotation of every rater in ELAN files, one row each (the first part of
    :func:`read_annotations_and_context`, whose documentation says it all)."""
    return read_annotations_and_context(
        paths_or_dirs,
        schema=schema,
        iterate=iterate,
        warn=warn,
        require_turn_tier=require_turn_tier,
    )[0]
