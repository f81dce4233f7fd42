"""What an ELAN file holds, and what the schema takes from it (``turn-datasets remap inspect``).

:func:`inspect_eaf` lists a file's tiers, time slots and vocabularies as they are, however
unusual, so a clinician can see why a file yields no turns; :func:`inspect_markdown` prints the
listing. The file is loaded as safely as for reading labels (:mod:`turn_datasets.remap.eaf`,
which this module reads through its public tier-level functions).
"""

from __future__ import annotations

from collections.abc import Iterable
from os import PathLike
from pathlib import Path
from typing import Any

import pympi.Elan

from turn_datasets.errors import TurnbenchError
from turn_datasets.remap.eaf import (
    KNOWN_VERSIONS,
    Document,
    TierRole,
    Timed,
    annotation_times_ms,
    attr,
    classify_tiers,
    linguistic_type,
    load_document,
    parse_value,
    tier_annotations,
    tier_attrs,
    tiers_in_order,
)
from turn_datasets.remap.schema import Schema, load_schema
from turn_datasets.render.markdown import markdown_table
from turn_datasets.render.numbers import MISSING, fixed

__all__ = ["inspect_eaf", "inspect_markdown"]


def _url_name(url: str) -> str:
    """The last part of a URL or path (``file:/home/ann/cv/rooms.ecv`` -> ``rooms.ecv``)."""
    return url.replace("\\", "/").rstrip("/").rsplit("/", 1)[-1]


def _vocabularies(eaf: pympi.Elan.Eaf, *, keep_media_paths: bool) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for cv_id, (descriptions, entries, ext_ref) in eaf.controlled_vocabularies.items():
        description = next((str(d[1]).strip() for d in descriptions if d[1]), "")
        item: dict[str, Any] = {"id": cv_id, "description": description}
        if ext_ref:
            ref = eaf.external_refs.get(ext_ref)
            url = None if ref is None else str(ref[1])
            if url is not None and not keep_media_paths:
                # An external vocabulary is often a local file whose path names a person
                # (file:/home/<name>/...): its file name is enough to find it.
                url = _url_name(url)
            item.update(external=True, url=url, entries=[])
        else:
            texts = []
            for values, _ext in entries.values():
                text = next((str(v[0]).strip() for v in values if v[0] is not None), "")
                texts.append(text)
            item.update(external=False, url=None, entries=texts)
        out.append(item)
    return out


def _header(eaf: pympi.Elan.Eaf) -> dict[str, Any]:
    """Header fields that may identify people or places: only with ``keep_media_paths``."""
    return {
        "author": eaf.adocument.get("AUTHOR", ""),
        "date": eaf.adocument.get("DATE", ""),
        "media": [
            {k: v for k, v in m.items() if k in ("MEDIA_URL", "RELATIVE_MEDIA_URL", "MIME_TYPE")}
            for m in eaf.media_descriptors
        ],
        "linked_files": [
            {k: v for k, v in m.items() if k in ("LINK_URL", "RELATIVE_LINK_URL", "MIME_TYPE")}
            for m in eaf.linked_file_descriptors
        ],
    }


def inspect_eaf(
    path: str | PathLike[str], *, schema: Schema | None = None, keep_media_paths: bool = False
) -> dict[str, Any]:
    """What an ELAN file holds, and what the schema takes from it.

    Never fails on a readable file: tiers, time slots and vocabularies are listed as they
    are, however unusual (symbolic children of time-aligned children, unaligned slots,
    external vocabularies, unknown format versions).

    Parameters
    ----------
    path
        The ELAN file.
    schema
        The convention used to name turn and context tiers (default schema if ``None``).
    keep_media_paths
        Also report the header (author, date, media and linked file paths) and the full
        location of external vocabularies. Off by default: outputs carry subject ids, never
        paths that may name people or places.

    Returns
    -------
    dict
        ``file, session, format, tiers`` (each ``tier, type, constraint, time_alignable,
        parent, annotator, participant, vocabulary, annotations, unaligned, start_s, end_s,
        role``), ``vocabularies`` (``id, description, external, url, entries``; the
        ``url`` of an external vocabulary is only its file name without ``keep_media_paths``),
        ``turn_tiers``, ``context_tiers`` (``location``, ``scenario``), ``notes``, and
        ``header`` with ``keep_media_paths``.
    """
    schema = schema if schema is not None else load_schema()
    doc = load_document(path)
    eaf = doc.eaf
    roles = {r.tier: r for r in classify_tiers(eaf, schema)}
    times = annotation_times_ms(eaf)
    notes: list[str] = []
    if doc.version not in KNOWN_VERSIONS:
        notes.append(
            f"EAF format {doc.version or '(none)'} is not one pympi-ling knows "
            f"({', '.join(KNOWN_VERSIONS)}); read anyway"
        )

    tiers: list[dict[str, Any]] = []
    for tier_id in tiers_in_order(eaf):
        attrs = tier_attrs(eaf, tier_id)
        lt = linguistic_type(eaf, tier_id)
        anns = tier_annotations(eaf, tier_id, times)
        starts = [a.start_ms for a in anns if a.start_ms is not None]
        ends = [a.end_ms for a in anns if a.end_ms is not None]
        unaligned = sum(1 for a in anns if a.start_ms is None or a.end_ms is None)
        role = roles.get(tier_id)
        if unaligned:
            notes.append(
                f"tier {tier_id!r}: {unaligned} of {len(anns)} annotations have an unaligned "
                "time slot (ELAN interpolates them)"
            )
        alignable = attr(lt, "TIME_ALIGNABLE")
        tiers.append(
            {
                "tier": tier_id,
                "type": attr(attrs, "LINGUISTIC_TYPE_REF"),
                "constraint": attr(lt, "CONSTRAINTS") or None,
                "time_alignable": None if not alignable else alignable.lower() == "true",
                "parent": attr(attrs, "PARENT_REF") or None,
                "annotator": attr(attrs, "ANNOTATOR") or None,
                "participant": attr(attrs, "PARTICIPANT") or None,
                "vocabulary": attr(lt, "CONTROLLED_VOCABULARY_REF") or None,
                "annotations": len(anns),
                "unaligned": unaligned,
                "start_s": min(starts) / 1000 if starts else None,
                "end_s": max(ends) / 1000 if ends else None,
                "role": None if role is None else role.role,
            }
        )

    n_disagree = _count_cve_disagreements(doc, roles, times, schema)
    if n_disagree:
        notes.append(
            f"{n_disagree} value(s) whose text disagrees with the vocabulary entry it links "
            "to (CVE_REF); labels and agreement read them as the entry and warn"
        )
    turn_tiers = [
        {"tier": r.tier, "annotator": r.annotator or None, "participant": r.participant or None}
        for r in roles.values()
        if r.role == "turn"
    ]
    for t in turn_tiers:
        if not t["annotator"]:
            notes.append(f"turn tier {t['tier']!r} names no rater ({schema.annotator_attribute})")
        if not t["participant"]:
            notes.append(
                f"turn tier {t['tier']!r} names no participant ({schema.participant_attribute})"
            )
    if not turn_tiers:
        notes.append(
            f"no turn tiers: no TIER_ID matches {schema.turn_tier_regex.pattern!r} "
            f"(schema {schema.source}); this file yields no turns"
        )
    context = {
        kind: [
            {"tier": r.tier, "participant": r.participant or None}
            for r in roles.values()
            if r.role == kind
        ]
        for kind in ("location", "scenario")
    }
    result: dict[str, Any] = {
        "file": str(doc.path),
        "session": doc.path.stem,
        "format": doc.version or None,
        "tiers": tiers,
        "vocabularies": _vocabularies(eaf, keep_media_paths=keep_media_paths),
        "turn_tiers": turn_tiers,
        "context_tiers": context,
        "cve_text_disagreements": n_disagree,
        "notes": notes,
    }
    if keep_media_paths:
        result["header"] = _header(eaf)
    return result


def _count_cve_disagreements(
    doc: Document,
    roles: dict[str, TierRole],
    times: dict[str, tuple[int | None, int | None]],
    schema: Schema,
) -> int:
    """How many values of the schema's tiers :func:`read_annotations` would read as their
    vocabulary entry although their text says otherwise (inspect never fails on a value)."""
    for tier_id, role in roles.items():
        vocab = schema.turn_angle if role.role == "turn" else schema.vocabulary(role.role)
        for a in tier_annotations(doc.eaf, tier_id, times):
            if a.aid not in doc.cve_refs or a.start_ms is None:
                continue
            try:
                parse_value(doc, tier_id, Timed(a.aid, a.start_ms, a.end_ms or 0, a.value), vocab)
            except TurnbenchError:
                pass  # a value outside the vocabulary: labels refuses it, inspect lists tiers
    return len(doc.cve_disagreements)


def _cell(value: Any) -> Any:
    if value is None or value == "":
        return MISSING
    if isinstance(value, float):
        return fixed(value, 3)
    return value


def _md_table(header: list[str], rows: list[list[Any]]) -> list[str]:
    return markdown_table(header, [[_cell(v) for v in row] for row in rows])


def inspect_markdown(results: Iterable[dict[str, Any]]) -> str:
    """Markdown of :func:`inspect_eaf` results, one section per file."""
    out: list[str] = []
    for r in results:
        out += [f"## {Path(r['file']).name}", ""]
        out += [
            f"Session `{r['session']}`, EAF format {r['format'] or 'unknown'}, "
            f"{len(r['tiers'])} tier(s).",
            "",
        ]
        out += _md_table(
            [
                "tier",
                "type",
                "parent",
                "annotator",
                "participant",
                "vocabulary",
                "annotations",
                "from (s)",
                "to (s)",
                "role",
            ],
            [
                [
                    t["tier"],
                    t["type"] + (f" ({t['constraint']})" if t["constraint"] else ""),
                    t["parent"],
                    t["annotator"],
                    t["participant"],
                    t["vocabulary"],
                    str(t["annotations"]),
                    t["start_s"],
                    t["end_s"],
                    t["role"],
                ]
                for t in r["tiers"]
            ],
        )
        out.append("")
        if r["vocabularies"]:
            out += _md_table(
                ["vocabulary", "entries"],
                [
                    [
                        v["id"],
                        f"external: {v['url'] or '(no URL)'}"
                        if v["external"]
                        else ", ".join(v["entries"]) or "(empty)",
                    ]
                    for v in r["vocabularies"]
                ],
            )
        else:
            out.append("No controlled vocabularies.")
        out.append("")
        if r["turn_tiers"]:
            out.append(
                "Turn tiers: "
                + "; ".join(
                    f"`{t['tier']}` (rater {t['annotator'] or '?'}, "
                    f"participant {t['participant'] or '?'})"
                    for t in r["turn_tiers"]
                )
            )
        else:
            out.append("Turn tiers: **none**.")
        context = [
            f"{kind}: "
            + ", ".join(
                f"`{c['tier']}`"
                + (f" (participant {c['participant']})" if c["participant"] else "")
                for c in tiers
            )
            for kind, tiers in r["context_tiers"].items()
            if tiers
        ]
        out.append("Context tiers: " + ("; ".join(context) if context else "none") + ".")
        if "header" in r:
            h = r["header"]
            media = ", ".join(m.get("MEDIA_URL", "") for m in h["media"]) or "none"
            out.append(
                f"Header: author {h['author'] or '–'}, date {h['date'] or '–'}, media {media}."
            )
        if r["notes"]:
            out += ["", "Notes:"] + [f"- {n}" for n in r["notes"]]
        out.append("")
    return "\n".join(out).rstrip("\n") + "\n"
