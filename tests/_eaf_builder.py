"""Build small ELAN files with pympi-ling for the label tests (values known by construction),
and name the real ELAN exports the tests read."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pympi.Elan

#: The real ELAN exports in ../shared/data/real-eaf (SOURCE.md there says where each is from).
REAL_FILES = [
    "poio_example.eaf",
    "poio_turkish.eaf",
    "pygamma_MaureenMarvinRobin.eaf",
    "pympi_sample_2.7.eaf",
    "pympi_sample_2.8.eaf",
    "pympi_sample_3.0.eaf",
    "speach_fables_01_03_aesop_64kb.eaf",
    "speach_test.eaf",
    "speach_test2.eaf",
]


@dataclass
class Tier:
    """A tier to write: annotations are ``(start_ms, end_ms, value)``."""

    tier_id: str
    annotations: Sequence[tuple[int, int, str]] = ()
    annotator: str | None = None
    participant: str | None = None
    ling: str = "default-lt"
    # Annotations written without pympi's checks (end before start, zero length).
    raw: Sequence[tuple[int | None, int | None, str]] = field(default_factory=tuple)


def write_eaf(
    path: Path,
    tiers: Sequence[Tier],
    *,
    vocabularies: dict[str, dict[str, str]] | None = None,
    ling_cv: dict[str, str] | None = None,
) -> Path:
    """Write an EAF with these tiers.

    ``vocabularies`` maps a CV id to ``{cve_id: value}``; ``ling_cv`` maps a linguistic type
    (created if needed) to the CV it uses.
    """
    eaf = pympi.Elan.Eaf()
    eaf.remove_tier("default")
    eaf.add_language("eng", "http://cdb.iso.org/lg/CDB-00138502-001", "English (eng)")
    for cv_id, entries in (vocabularies or {}).items():
        eaf.add_controlled_vocabulary(cv_id)
        eaf.add_cv_description(cv_id, "eng", cv_id)
        for cve_id, value in entries.items():
            eaf.add_cv_entry(cv_id, cve_id, [(value, "eng", None)])
    for ling, cv_id in (ling_cv or {}).items():
        eaf.add_linguistic_type(ling)
        eaf.linguistic_types[ling]["CONTROLLED_VOCABULARY_REF"] = cv_id
    for t in tiers:
        if t.ling not in eaf.linguistic_types:
            eaf.add_linguistic_type(t.ling)
        eaf.add_tier(t.tier_id, ling=t.ling, part=t.participant, ann=t.annotator)
        for start, end, value in t.annotations:
            eaf.add_annotation(t.tier_id, start, end, value)
        for start, end, value in t.raw:
            ts1 = eaf.generate_ts_id(start)
            ts2 = eaf.generate_ts_id(end)
            aid = eaf.generate_annotation_id()
            eaf.annotations[aid] = t.tier_id
            eaf.tiers[t.tier_id][0][aid] = (ts1, ts2, value, None)
    pympi.Elan.to_eaf(str(path), eaf)
    return path


Annotation = tuple[int, int, str]


def two_raters(
    path: Path,
    alice: Sequence[Annotation],
    bob: Sequence[Annotation],
    *more: Tier,
    participant: str = "PD01",
) -> Path:
    """A session two raters labelled: tiers ``Turn alice`` and ``Turn bob`` (each its rater's
    ``(start_ms, end_ms, value)`` turns of ``participant``), then ``more`` tiers."""
    raters = [
        Tier(f"Turn {name}", annotator=name, participant=participant, annotations=turns)
        for name, turns in (("alice", alice), ("bob", bob))
    ]
    return write_eaf(path, [*raters, *more])


def add_cve_refs(path: Path, refs: dict[str, str]) -> Path:
    """Give annotations whose text is a key of ``refs`` the attribute CVE_REF (ELAN 3.0)."""
    text = path.read_text(encoding="utf-8")
    for value, cve in refs.items():
        pattern = re.compile(
            r"(<ALIGNABLE_ANNOTATION [^>]*?)(>\s*<ANNOTATION_VALUE>" + re.escape(value) + "<)"
        )
        text, n = pattern.subn(rf'\1 CVE_REF="{cve}"\2', text)
        assert n, f"no annotation with value {value!r}"
    path.write_text(text, encoding="utf-8")
    return path
