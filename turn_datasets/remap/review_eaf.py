"""ELAN review copies of an agreement audit: the disagreements as a tier of their own.

A reviewer opens the copy in ELAN and sees, beside each rater's turns, one annotation per
disagreement (a different angle, or a turn only one rater marked).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import defusedxml.ElementTree as safe_et
import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path
from turn_datasets.remap.matching import UNMATCHED
from turn_datasets.render.numbers import format_deg

__all__ = [
    "REVIEW_TIER",
    "REVIEW_ANNOTATOR",
    "write_review_eaf",
]


_XSI = "http://www.w3.org/2001/XMLSchema-instance"


REVIEW_TIER = "Disagreement"


REVIEW_ANNOTATOR = "turnbench"


#: Header properties that count annotation ids: ELAN writes ``lastUsedAnnotationId``,
#: pympi-ling ``lastUsedAnnotation``. The review copy keeps them past its new ids.
_ID_PROPERTIES = ("lastUsedAnnotationId", "lastUsedAnnotation")


_NEUTRAL_DATE = "1970-01-01T00:00:00+00:00"


def _review_spans(rows: pd.DataFrame, *, rater_a: str, rater_b: str) -> list[tuple[int, int, str]]:
    """(start_ms, end_ms, text) per disagreement of one participant, overlaps merged."""
    spans: list[tuple[int, int, str]] = []
    for r in rows.itertuples(index=False):
        starts = [t for t in (r.start_a_s, r.start_b_s) if np.isfinite(t)]
        ends = [t for t in (r.end_a_s, r.end_b_s) if np.isfinite(t)]
        va = "none" if not np.isfinite(r.angle_a_deg) else format_deg(r.angle_a_deg)
        vb = "none" if not np.isfinite(r.angle_b_deg) else format_deg(r.angle_b_deg)
        text = f"{rater_a}: {va} / {rater_b}: {vb}"
        if r.kind == UNMATCHED:
            text += " (unmatched)"
        spans.append((int(round(min(starts) * 1000)), int(round(max(ends) * 1000)), text))
    spans.sort()
    merged: list[list[Any]] = []
    for s0, s1, text in spans:
        # Annotations on one ELAN tier must not overlap: join overlapping disagreements.
        if merged and s0 < merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], s1)
            merged[-1][2] += "; " + text
        else:
            merged.append([s0, s1, text])
    return [(int(s0), int(s1), str(t)) for s0, s1, t in merged]


def _max_numeric_id(values: Iterable[str | None], prefix: str) -> int:
    best = 0
    for v in values:
        if v and v.startswith(prefix) and v[len(prefix) :].isdigit():
            best = max(best, int(v[len(prefix) :]))
    return best


def _strip_header(root: ET.Element, header: ET.Element | None) -> None:
    """What inspect shows only with --keep-media-paths goes: media and linked files, the
    author, the date, and header properties other than ELAN's annotation counter."""
    if header is not None:
        for tag in ("MEDIA_DESCRIPTOR", "LINKED_FILE_DESCRIPTOR"):
            for el in header.findall(tag):
                header.remove(el)
        for prop in header.findall("PROPERTY"):
            if prop.get("NAME") not in _ID_PROPERTIES:
                header.remove(prop)
        if header.get("MEDIA_FILE"):
            header.set("MEDIA_FILE", "")
    if "AUTHOR" in root.attrib:
        root.set("AUTHOR", "")
    if "DATE" in root.attrib:
        # ELAN requires a date; a fixed one says nothing about the recording.
        root.set("DATE", _NEUTRAL_DATE)


def _next_annotation_id(root: ET.Element, counters: list[ET.Element]) -> int:
    """Past every id in the file and past ELAN's counter, so no id is ever given twice."""
    ann_ids = [
        el.get("ANNOTATION_ID")
        for tag in ("ALIGNABLE_ANNOTATION", "REF_ANNOTATION")
        for el in root.iter(tag)
    ]
    in_counters = [int(p.text.strip()) for p in counters if p.text and p.text.strip().isdigit()]
    return max([_max_numeric_id(ann_ids, "a"), *in_counters]) + 1


class _Ids:
    """The next free time slot and annotation numbers of a file being extended."""

    def __init__(self, time_slot: int, annotation: int) -> None:
        self.time_slot, self.annotation = time_slot, annotation

    def slot(self, time_order: ET.Element, t_ms: int) -> str:
        slot_id = f"ts{self.time_slot}"
        slot = ET.SubElement(
            time_order, "TIME_SLOT", {"TIME_SLOT_ID": slot_id, "TIME_VALUE": str(t_ms)}
        )
        slot.tail = "\n\t\t"
        self.time_slot += 1
        return slot_id


def _review_tier(
    tier_id: str,
    lt_id: str,
    participant: str,
    spans: list[tuple[int, int, str]],
    time_order: ET.Element,
    ids: _Ids,
) -> ET.Element:
    """One review tier: an annotation per disagreement, over new time slots."""
    tier = ET.Element(
        "TIER",
        {
            "TIER_ID": tier_id,
            "LINGUISTIC_TYPE_REF": lt_id,
            "PARTICIPANT": participant,
            "ANNOTATOR": REVIEW_ANNOTATOR,
        },
    )
    for s0, s1, text in spans:
        ref1, ref2 = ids.slot(time_order, s0), ids.slot(time_order, s1)
        ann = ET.SubElement(tier, "ANNOTATION")
        al = ET.SubElement(
            ann,
            "ALIGNABLE_ANNOTATION",
            {"ANNOTATION_ID": f"a{ids.annotation}", "TIME_SLOT_REF1": ref1, "TIME_SLOT_REF2": ref2},
        )
        ids.annotation += 1
        ET.SubElement(al, "ANNOTATION_VALUE").text = text
    return tier


def _unique(name: str, taken: set) -> str:
    candidate, k = name, 2
    while candidate in taken:
        candidate, k = f"{name} {k}", k + 1
    taken.add(candidate)
    return candidate


def write_review_eaf(
    source: str | os.PathLike[str],
    target: str | os.PathLike[str],
    rows: pd.DataFrame,
    *,
    rater_a: str,
    rater_b: str,
    tier_per_participant: bool = False,
    keep_media_paths: bool = False,
) -> Path:
    """Copy an ``.eaf`` with a "Disagreement" tier marking ``rows``, to open in ELAN.

    The copy is the source's XML with added time slots, one linguistic type and one tier
    per participant with disagreements (``Disagreement``, or ``Disagreement <participant>``
    with ``tier_per_participant``; ``PARTICIPANT`` set), whose
    annotations span both raters' intervals and read ``A: 90 / B: 135``. Everything else is
    kept as written (XML is edited directly: pympi-ling would drop ELAN 3.0 ``CVE_REF`` links
    when writing the file back), and ELAN's annotation counter (``lastUsedAnnotationId``) is
    moved past the new ids. Without ``keep_media_paths`` the header goes, as from every
    turnbench output: media and linked-file descriptors, ``MEDIA_FILE``, the author, the
    date (set to 1970-01-01) and every header property but the counter. The source is only
    read.

    Parameters
    ----------
    source, target
        The original ``.eaf`` and the copy to write (atomically).
    rows
        :data:`DISAGREEMENT_COLUMNS` rows of this session.
    rater_a, rater_b
        Names used in the annotation texts.
    tier_per_participant
        Name the tiers after their participant (for sessions with several participants,
        even if only one of them has disagreements, so the names do not depend on that).
    keep_media_paths
        Keep the header as it is (media paths, author, date, properties).
    """
    src = Path(source)
    if Path(target).resolve() == src.resolve():
        raise TurnbenchError("the review copy would overwrite its source", file=str(src))
    try:
        tree = safe_et.parse(str(src), forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except Exception as exc:  # the file was read once already; a change since is the user's
        raise TurnbenchError(
            f"cannot read the file again for the review copy ({exc})", file=str(src)
        ) from None
    root = tree.getroot()
    ET.register_namespace("xsi", _XSI)

    header = root.find("HEADER")
    if not keep_media_paths:
        _strip_header(root, header)
    time_order = root.find("TIME_ORDER")
    if time_order is None:
        time_order = ET.Element("TIME_ORDER")
        root.insert(1 if header is not None else 0, time_order)
    counters = [
        prop
        for prop in (header.findall("PROPERTY") if header is not None else [])
        if prop.get("NAME") in _ID_PROPERTIES
    ]
    ids = _Ids(
        _max_numeric_id((el.get("TIME_SLOT_ID") for el in root.iter("TIME_SLOT")), "ts") + 1,
        _next_annotation_id(root, counters),
    )

    children = list(root)
    tier_ids = {el.get("TIER_ID") for el in root.findall("TIER")}
    lt_ids = {el.get("LINGUISTIC_TYPE_ID") for el in root.findall("LINGUISTIC_TYPE")}
    lt_id = "turnbench-disagreement"
    while lt_id in lt_ids:
        lt_id += "-"
    last_tier = max((children.index(el) for el in root.findall("TIER")), default=None)
    insert_at = (last_tier + 1) if last_tier is not None else children.index(time_order) + 1

    participants = sorted({str(p) for p in rows["participant"]})
    several = tier_per_participant or len(participants) > 1
    new_tiers: list[ET.Element] = []
    for participant in participants:
        tier_id = _unique(f"{REVIEW_TIER} {participant}" if several else REVIEW_TIER, tier_ids)
        spans = _review_spans(
            rows[rows["participant"] == participant], rater_a=rater_a, rater_b=rater_b
        )
        new_tiers.append(_review_tier(tier_id, lt_id, participant, spans, time_order, ids))
    for offset, tier in enumerate(new_tiers):
        ET.indent(tier, space="\t", level=1)  # laid out like ELAN's own files
        tier.tail = "\n\t"
        root.insert(insert_at + offset, tier)

    children = list(root)
    last_lt = max((children.index(el) for el in root.findall("LINGUISTIC_TYPE")), default=None)
    lt = ET.Element(
        "LINGUISTIC_TYPE",
        {"LINGUISTIC_TYPE_ID": lt_id, "TIME_ALIGNABLE": "true", "GRAPHIC_REFERENCES": "false"},
    )
    lt.tail = "\n\t"
    root.insert((last_lt if last_lt is not None else insert_at + len(new_tiers) - 1) + 1, lt)

    for prop in counters:
        # ELAN numbers new annotations after this one.
        prop.text = str(ids.annotation - 1)

    with atomic_path(target) as tmp:
        tree.write(str(tmp), encoding="UTF-8", xml_declaration=True)
    return Path(target)
