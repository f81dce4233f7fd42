"""A synthetic Turn-REMAP: ELAN sessions with known turns, two raters and their mistakes.

The real Turn-REMAP videos and labels are private (Cheng et al., Section 3.2: 1386 turns of
24 people, 12 with PD and 12 healthy controls, labelled in ELAN by two clinicians, about half
of the turns by both, Cohen's kappa 0.96). This module writes look-alike ``.eaf`` files in the
project's default convention (``annotations/README.md``) so that the parser, the labels and
the agreement audit can be tested and demonstrated end to end, with a ground truth to check
them against:

- one ``.eaf`` per session (a pair of participants, a PD participant and their companion, on
  one recording day); session id = file stem;
- turn tiers ``Turn <rater> <subject>`` with ``ANNOTATOR`` and ``PARTICIPANT`` attributes and
  the controlled vocabulary ``turn_angle`` (90 to 360 in 45° steps);
- a ``Scenario`` context tier (scripted, clinical, free-living segments, in that order) and a
  ``Location <subject>`` tier per participant (rooms, restricted by ``PARTICIPANT``);
- about half of the sessions double-annotated: both raters label every turn, boundaries
  jittered by a few hundred milliseconds, with planted angle disagreements (one bin apart,
  sometimes two), turns one rater missed and, optionally, pairs shifted too far to match;
  a ``consensus`` rater adjudicates the angle disagreements and the shifted pairs;
- the other sessions labelled by one rater (alternately);
- ``participants.csv`` (``subject, cohort, pair, sex, age, years_since_diagnosis``).

The angle and scenario mix follow the shape of the paper's Table 2 (mostly 90° and 180°,
few large angles; scripted, clinical and free-living recordings); the exact proportions are
this module's own and are parameters.

Everything is drawn from ``numpy.random.default_rng(seed)``: the same seed and parameters give
byte-identical files.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pympi.Elan as pympi_elan

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, typed_frame, write_csv
from turn_datasets.remap.eaf import ANNOTATION_COLUMNS, START_TIME_PROPERTY

__all__ = [
    "ANGLES_DEG",
    "ANGLE_MIX",
    "SCENARIO_MIX",
    "LOCATION_MIX",
    "TRUTH_COLUMNS",
    "WRITTEN_COLUMNS",
    "PARTICIPANT_COLUMNS",
    "Raters",
    "SyntheticRemap",
    "write_sessions",
    "session_start_time",
]

#: The paper's angle vocabulary (Section 3.2): 90° to 360° in 45° steps.
ANGLES_DEG = (90, 135, 180, 225, 270, 315, 360)
#: Share of each angle among the planted turns (Table 2's shape: mostly 90° and 180°).
ANGLE_MIX: Mapping[int, float] = {
    90: 0.45,
    135: 0.12,
    180: 0.30,
    225: 0.05,
    270: 0.04,
    315: 0.02,
    360: 0.02,
}
#: Share of turns per scenario; each session records the three in this order.
SCENARIO_MIX: Mapping[str, float] = {"scripted": 0.40, "clinical": 0.15, "free-living": 0.45}
#: Rooms the turns happen in (all in the default schema's location vocabulary).
LOCATION_MIX: Mapping[str, float] = {
    "living room": 0.30,
    "kitchen": 0.25,
    "hallway": 0.20,
    "dining room": 0.10,
    "bedroom": 0.10,
    "staircase": 0.05,
}

#: One row per planted turn. ``a_*`` are what ``raters[0]`` wrote, ``b_*`` what ``raters[1]``
#: wrote (NaN where that rater did not label the turn); ``ratio_ab`` is the overlap of the two
#: written intervals over the longer one (NaN unless both labelled it); ``consensus_angle_deg``
#: is the adjudicated angle where a consensus annotation was written.
TRUTH_COLUMNS = {
    "turn_id": "str",
    "session": "str",
    "file": "str",
    "subject": "str",
    "cohort": "str",
    "pair": "str",
    "scenario": "str",
    "location": "str",
    "start_s": "float64",
    "end_s": "float64",
    "angle_deg": "float64",
    "double_annotated": "bool",
    "kind": "str",
    "a_start_s": "float64",
    "a_end_s": "float64",
    "a_angle_deg": "float64",
    "b_start_s": "float64",
    "b_end_s": "float64",
    "b_angle_deg": "float64",
    "ratio_ab": "float64",
    "consensus_angle_deg": "float64",
}
#: One row per annotation written on a turn tier (the columns of ``eaf.read_annotations``
#: plus the planted ``turn_id``).
WRITTEN_COLUMNS = {**ANNOTATION_COLUMNS, "turn_id": "str"}
PARTICIPANT_COLUMNS = {
    "subject": "str",
    "cohort": "str",
    "pair": "str",
    "sex": "str",
    "age": "int64",
    "years_since_diagnosis": "float64",
}

#: Kinds of planted turns (``truth.kind``).
KINDS = ("agree", "disagree", "missed_a", "missed_b", "shifted", "single")

# Boundaries of the two raters are redrawn until their overlap ratio is at least this, so a
# planted agreement is always matched at the audit's default --min-overlap 0.6 (and at
# anything up to this value); shifted pairs are planted below 0.5.
_MIN_MATCH_RATIO = 0.7
_SHIFTED_RATIO_RANGE = (0.30, 0.50)
_MIN_GAP_S = 2.0
_MAX_GAP_S = 20.0


def session_start_time(seed: int, session: str, day: int) -> str:
    """When a synthetic session's recording started, ISO 8601 with its UTC offset: on ``day``
    (1, 2, ...) of March 2024 between 08:00 and 17:59, +01:00, drawn from ``seed`` and the
    session's name alone (so the other draws do not change)."""
    code = zlib.crc32(f"{seed}/{session}/start_time".encode())
    return f"2024-03-{day:02d}T{8 + code % 10:02d}:{code // 10 % 60:02d}:00+01:00"


# A fixed document date: pympi would stamp the current time, breaking byte-identity.
_DOC_DATE = "2024-01-01T00:00:00+00:00"


@dataclass(frozen=True)
class SyntheticRemap:
    """What :func:`write_sessions` wrote, and the truth behind it.

    Attributes
    ----------
    paths
        The ``.eaf`` files, sorted by session.
    participants_path
        ``participants.csv`` beside them.
    participants
        The participants table (:data:`PARTICIPANT_COLUMNS`).
    truth
        One row per planted turn (:data:`TRUTH_COLUMNS`).
    written
        One row per annotation written on a turn tier (:data:`WRITTEN_COLUMNS`).
    raters
        The two raters; ``a_*`` columns of ``truth`` are ``raters[0]``, ``b_*`` ``raters[1]``.
    consensus
        The adjudicating rater's name.
    """

    paths: tuple[Path, ...]
    participants_path: Path
    participants: pd.DataFrame
    truth: pd.DataFrame
    written: pd.DataFrame
    raters: tuple[str, str]
    consensus: str


def _choice(rng: np.random.Generator, mix: Mapping, size: int) -> list:
    keys = list(mix)
    p = np.array([mix[k] for k in keys], dtype=float)
    picks = rng.choice(len(keys), size=size, p=p / p.sum())
    return [keys[i] for i in picks]


def _ms(t_s: float) -> int:
    return int(round(t_s * 1000.0))


def _ratio(a0: int, a1: int, b0: int, b1: int) -> float:
    overlap = min(a1, b1) - max(a0, b0)
    return max(overlap, 0) / max(a1 - a0, b1 - b0)


def _jittered(
    rng: np.random.Generator, start_ms: int, end_ms: int, *, jitter_s: float
) -> tuple[tuple[int, int], tuple[int, int]]:
    """Two raters' boundaries around a turn, redrawn until they overlap enough to match."""
    limit = 2.0 * jitter_s
    for _ in range(1000):
        d = np.clip(rng.normal(0.0, jitter_s, size=4), -limit, limit)
        a = (start_ms + _ms(d[0]), end_ms + _ms(d[1]))
        b = (start_ms + _ms(d[2]), end_ms + _ms(d[3]))
        if a[1] > a[0] and b[1] > b[0] and _ratio(*a, *b) >= _MIN_MATCH_RATIO:
            return a, b
    raise TurnbenchError(f"jitter_s={jitter_s} is too large for turns this short", item="jitter_s")


def _wrong_angle(rng: np.random.Generator, angle: int, *, far: bool) -> int:
    """An angle one bin (or, if ``far``, two bins) away from ``angle``, inside the vocabulary."""
    i = ANGLES_DEG.index(angle)
    step = 2 if far else 1
    options = [j for j in (i - step, i + step) if 0 <= j < len(ANGLES_DEG)]
    return ANGLES_DEG[options[int(rng.integers(len(options)))]]


def _participants(rng: np.random.Generator, n_pairs: int) -> pd.DataFrame:
    rows = []
    for p in range(1, n_pairs + 1):
        pair = f"pair{p:02d}"
        for cohort in ("PD", "HC"):
            rows.append(
                {
                    "subject": f"{cohort}{p:02d}",
                    "cohort": cohort,
                    "pair": pair,
                    "sex": "F" if rng.random() < 0.45 else "M",
                    "age": int(rng.integers(55, 81)),
                    "years_since_diagnosis": (
                        round(float(rng.uniform(1.0, 15.0)), 1) if cohort == "PD" else np.nan
                    ),
                }
            )
    return typed_frame(pd.DataFrame(rows), PARTICIPANT_COLUMNS)


def _new_eaf(session: str, start_time: str = "") -> pympi_elan.Eaf:
    eaf = pympi_elan.Eaf(author="turnbench synth_eaf")
    eaf.adocument["DATE"] = _DOC_DATE
    if start_time:
        eaf.add_property(START_TIME_PROPERTY, start_time)
    eaf.remove_tier("default")
    # A media path like a clinician's, so privacy handling downstream has something to drop.
    eaf.add_linked_file(
        f"file:///home/clinician/remap/video/{session}.mp4",
        relpath=f"video/{session}.mp4",
        mimetype="video/mp4",
    )
    eaf.add_language("eng", "http://cdb.iso.org/lg/CDB-00138502-001", "English (eng)")
    vocabularies = {
        "turn_angle": [str(a) for a in ANGLES_DEG],
        "scenario": list(SCENARIO_MIX),
        "location": list(LOCATION_MIX),
    }
    for cv_id, values in vocabularies.items():
        eaf.add_controlled_vocabulary(cv_id)
        for k, value in enumerate(values):
            eaf.add_cv_entry(cv_id, f"cveid_{cv_id}_{k}", [(value, "eng", None)])
    for ling, cv_id in (("turn", "turn_angle"), ("scenario", "scenario"), ("location", "location")):
        eaf.add_linguistic_type(
            ling,
            param_dict={
                "LINGUISTIC_TYPE_ID": ling,
                "TIME_ALIGNABLE": "true",
                "GRAPHIC_REFERENCES": "false",
                "CONTROLLED_VOCABULARY_REF": cv_id,
            },
        )
    return eaf


def _write_eaf(eaf: pympi_elan.Eaf, path: Path) -> None:
    # Not pympi_elan.to_eaf: it renames an existing target to .bak, which would leave the
    # atomic writer's temporary file behind.
    # ELAN numbers new annotations from lastUsedAnnotation: keep it past our ids.
    ids = [
        int(aid[1:])
        for aligned, refs, _, _ in eaf.tiers.values()
        for aid in (*aligned, *refs)
        if aid[1:].isdigit()
    ]
    eaf.properties = [
        (k, max(ids, default=0) if k == "lastUsedAnnotation" else v) for k, v in eaf.properties
    ]
    root = pympi_elan.to_adocument(eaf, pretty=True)
    with atomic_path(path) as tmp:
        ET.ElementTree(root).write(str(tmp), xml_declaration=True, encoding="UTF-8")


@dataclass(frozen=True)
class Raters:
    """Who annotates the synthetic sessions, and how they err.

    Attributes
    ----------
    names
        The two raters' names (``ANNOTATOR`` attribute and tier names).
    consensus
        Name of the adjudicating rater, who writes the true angle of every planted angle
        disagreement and shifted pair; ``None`` writes no consensus tiers.
    disagreement_rate, missed_rate, shifted_rate
        Per double-annotated turn, the chance of an angle disagreement (one rater writes a
        neighbouring bin; two bins away with ``far_disagreement_fraction``), of one rater
        missing the turn, and of the second rater's interval being shifted so far (overlap
        ratio 0.3 to 0.5) that the audit cannot match it at 0.6.
    jitter_s
        Standard deviation of each rater's boundary error, seconds (clipped at twice this).

    Raises
    ------
    TurnbenchError
        Not two different raters, a consensus rater among them, or rates adding up to more
        than 1.
    """

    names: tuple[str, ...] = ("clinician1", "clinician2")
    consensus: str | None = "consensus"
    disagreement_rate: float = 0.025
    far_disagreement_fraction: float = 0.25
    missed_rate: float = 0.03
    shifted_rate: float = 0.0
    jitter_s: float = 0.15

    def __post_init__(self) -> None:
        object.__setattr__(self, "names", tuple(self.names))
        if len(self.names) != 2 or self.names[0] == self.names[1]:
            raise TurnbenchError(f"need two different raters, got {self.names!r}", item="names")
        if self.consensus is not None and self.consensus in self.names:
            raise TurnbenchError(
                "the consensus rater must differ from the two raters", item="consensus"
            )
        if self.disagreement_rate + self.missed_rate + self.shifted_rate > 1.0:
            raise TurnbenchError(
                "disagreement, missed and shifted rates add up to more than 1",
                item="disagreement_rate",
            )


def _check_session_args(
    n_pairs: int, sessions_per_pair: int, turns_per_subject: int, angle_mix
) -> None:
    if n_pairs < 1 or sessions_per_pair < 1 or turns_per_subject < 0:
        raise TurnbenchError(
            "n_pairs and sessions_per_pair must be >= 1, turns_per_subject >= 0",
            item="n_pairs",
        )
    unknown = set(angle_mix) - set(ANGLES_DEG)
    if unknown:
        raise TurnbenchError(
            f"angle_mix has angles outside the vocabulary: {sorted(unknown)}", item="angle_mix"
        )


def _kinds(rng: np.random.Generator, n: int, *, is_double: bool, raters: Raters) -> list[str]:
    """What happens to each of ``n`` turns: one rater only, both agree, or a planted error."""
    kinds = []
    for x in rng.random(n):
        if not is_double:
            kinds.append("single")
        elif x < raters.disagreement_rate:
            kinds.append("disagree")
        elif x < raters.disagreement_rate + raters.missed_rate:
            kinds.append("missed_a" if rng.random() < 0.5 else "missed_b")
        elif x < raters.disagreement_rate + raters.missed_rate + raters.shifted_rate:
            kinds.append("shifted")
        else:
            kinds.append("agree")
    return kinds


def _lay_out(
    rng: np.random.Generator,
    eaf: pympi_elan.Eaf,
    per_subject: dict[str, list[dict]],
    scenario_mix: Mapping[str, float],
) -> tuple[dict[str, list[tuple[int, int, int, dict]]], int, int]:
    """Times of every turn: the scenarios one after the other (annotated on ``Scenario``);
    both subjects turn independently inside each (their turns may overlap in time: they are
    different people). Returns (start, end, end of anything written for the turn, turn) per
    subject, and the session's first and last time."""
    t0_ms = _ms(float(rng.uniform(5.0, 30.0)))
    segment_start_ms = t0_ms
    timeline: dict[str, list[tuple[int, int, int, dict]]] = {s: [] for s in per_subject}
    for scenario in scenario_mix:
        segment_end_ms = segment_start_ms
        for subject, turns in per_subject.items():
            t_ms = segment_start_ms + _ms(float(rng.uniform(_MIN_GAP_S, _MAX_GAP_S)))
            for turn in (t for t in turns if t["scenario"] == scenario):
                # PD turns are slower; bigger turns take longer (about 1.6 s to 6 s).
                slow = 1.3 if turn["cohort"] == "PD" else 1.0
                dur_s = slow * (1.0 + turn["angle"] / 90.0 * float(rng.uniform(0.6, 1.0)))
                start_ms, end_ms = t_ms, t_ms + _ms(dur_s)
                # A shifted second rater reaches up to 0.7 of the duration past the end.
                extent_ms = end_ms + (_ms(0.7 * dur_s) if turn["kind"] == "shifted" else 0)
                timeline[subject].append((start_ms, end_ms, extent_ms, turn))
                t_ms = extent_ms + _ms(float(rng.uniform(_MIN_GAP_S, _MAX_GAP_S)))
            segment_end_ms = max(segment_end_ms, t_ms)
        if segment_end_ms > segment_start_ms:
            eaf.add_annotation("Scenario", segment_start_ms, segment_end_ms, scenario)
        segment_start_ms = segment_end_ms
    return timeline, t0_ms, segment_start_ms


def _annotate_locations(
    eaf: pympi_elan.Eaf,
    subject: str,
    spans: list[tuple[int, int, int, dict]],
    first_ms: int,
    last_ms: int,
) -> None:
    """Each turn's room from halfway after the previous turn to halfway before the next;
    neighbours in the same room share one annotation."""
    bounds = [first_ms]
    for prev, nxt in zip(spans[:-1], spans[1:], strict=True):
        bounds.append((prev[2] + nxt[0]) // 2)
    bounds.append(last_ms)
    segments: list[list] = []
    for i, (_, _, _, turn) in enumerate(spans):
        if segments and segments[-1][2] == turn["location"]:
            segments[-1][1] = bounds[i + 1]
        else:
            segments.append([bounds[i], bounds[i + 1], turn["location"]])
    for s0, s1, room in segments:
        eaf.add_annotation(f"Location {subject}", s0, s1, room)


def _rater_spans(
    rng: np.random.Generator,
    kind: str,
    start_ms: int,
    end_ms: int,
    angle: int,
    *,
    raters: Raters,
    single_rater: str,
) -> dict[str, tuple[int, int, int]]:
    """What each rater writes for one turn: rater -> (start ms, end ms, angle)."""
    names, consensus = raters.names, raters.consensus
    wrote: dict[str, tuple[int, int, int]] = {}
    if kind == "single":
        a, _ = _jittered(rng, start_ms, end_ms, jitter_s=raters.jitter_s)
        wrote[single_rater] = (a[0], a[1], angle)
        return wrote
    a, b = _jittered(rng, start_ms, end_ms, jitter_s=raters.jitter_s)
    angle_a = angle_b = angle
    if kind == "disagree":
        wrong = _wrong_angle(rng, angle, far=bool(rng.random() < raters.far_disagreement_fraction))
        if rng.random() < 0.5:
            angle_a = wrong
        else:
            angle_b = wrong
    if kind == "shifted":
        # b starts so late that it overlaps only `target` of the longer one.
        lo, hi = _SHIFTED_RATIO_RANGE
        target = float(rng.uniform(lo, hi))
        dur_b = b[1] - b[0]
        longer = max(a[1] - a[0], dur_b)
        b0 = a[1] - int(target * longer)
        b = (b0, b0 + dur_b)
        while _ratio(*a, *b) >= hi:  # ms rounding
            b = (b[0] + 10, b[1] + 10)
    if kind != "missed_a":
        wrote[names[0]] = (a[0], a[1], angle_a)
    if kind != "missed_b":
        wrote[names[1]] = (b[0], b[1], angle_b)
    if kind in ("disagree", "shifted") and consensus:
        # a shifted pair is two overlapping turns of one person, which the labels refuse
        # without an adjudicated one
        wrote[consensus] = (start_ms, end_ms, angle)
    return wrote


def _truth_row(
    turn: dict, wrote: dict[str, tuple[int, int, int]], raters: Raters, **known: Any
) -> dict[str, Any]:
    """One row of :data:`TRUTH_COLUMNS`: the planted turn and what each rater wrote of it."""
    wa, wb = wrote.get(raters.names[0]), wrote.get(raters.names[1])
    wc = wrote.get(raters.consensus) if raters.consensus else None
    nan = float("nan")
    return {
        **known,
        "cohort": turn["cohort"],
        "scenario": turn["scenario"],
        "location": turn["location"],
        "a_start_s": wa[0] / 1000.0 if wa else nan,
        "a_end_s": wa[1] / 1000.0 if wa else nan,
        "a_angle_deg": float(wa[2]) if wa else nan,
        "b_start_s": wb[0] / 1000.0 if wb else nan,
        "b_end_s": wb[1] / 1000.0 if wb else nan,
        "b_angle_deg": float(wb[2]) if wb else nan,
        "ratio_ab": _ratio(wa[0], wa[1], wb[0], wb[1]) if wa and wb else nan,
        "consensus_angle_deg": float(wc[2]) if wc else nan,
    }


def _assign_sessions(
    rng: np.random.Generator,
    n_pairs: int,
    sessions_per_pair: int,
    double_annotated_fraction: float,
    names: Sequence[str],
) -> tuple[list[tuple[str, str]], set[str], dict[str, str]]:
    """(pair, session) in order, the double-annotated sessions (drawn), and the rater of
    each single-annotated one (the two alternately, in session order)."""
    sessions = [
        (f"pair{p:02d}", f"pair{p:02d}_day{k}")
        for p in range(1, n_pairs + 1)
        for k in range(1, sessions_per_pair + 1)
    ]
    n_double = int(round(double_annotated_fraction * len(sessions)))
    order = rng.permutation(len(sessions))
    double = {sessions[i][1] for i in order[:n_double]}
    single_sessions = [s for _, s in sessions if s not in double]
    return sessions, double, {s: names[i % 2] for i, s in enumerate(single_sessions)}


def _write_session(
    rng: np.random.Generator,
    out: Path,
    pair: str,
    session: str,
    subjects: pd.DataFrame,
    *,
    turns_this_session: int,
    is_double: bool,
    single_rater: str,
    raters: Raters,
    mixes: tuple[Mapping, Mapping, Mapping],
    truth_rows: list[dict],
    written_rows: list[dict],
    start_time: str = "",
) -> Path:
    """Plant, lay out and annotate one session's turns, and write its ``.eaf``."""
    file_name = f"{session}.eaf"
    angle_mix, scenario_mix, location_mix = mixes
    eaf = _new_eaf(session, start_time)
    names, consensus = raters.names, raters.consensus
    tier_raters = names if is_double else (single_rater,)
    tier_names: dict[tuple[str, str], str] = {}
    for subject in subjects["subject"]:
        for rater in tier_raters + ((consensus,) if is_double and consensus else ()):
            tier = f"Turn {rater} {subject}"
            eaf.add_tier(tier, ling="turn", part=subject, ann=rater)
            tier_names[(rater, subject)] = tier
        eaf.add_tier(f"Location {subject}", ling="location", part=subject)
    eaf.add_tier("Scenario", ling="scenario")

    # Each subject's share of turns in this session, then per scenario.
    per_subject: dict[str, list[dict]] = {}
    for subject, cohort in subjects.itertuples(index=False):
        n = turns_this_session
        angles = _choice(rng, angle_mix, n)
        scenarios = _choice(rng, scenario_mix, n)
        rooms = _choice(rng, location_mix, n)
        kinds = _kinds(rng, n, is_double=is_double, raters=raters)
        per_subject[subject] = [
            {"cohort": cohort, "angle": a, "scenario": s, "location": r, "kind": kd}
            for a, s, r, kd in zip(angles, scenarios, rooms, kinds, strict=True)
        ]
    timeline, first_ms, last_ms = _lay_out(rng, eaf, per_subject, scenario_mix)

    for subject, spans in timeline.items():
        _annotate_locations(eaf, subject, spans, first_ms, last_ms)
        for i, (start_ms, end_ms, _, turn) in enumerate(spans):
            turn_id = f"{session}_{subject}_{i:03d}"
            angle = int(turn["angle"])
            wrote = _rater_spans(
                rng,
                turn["kind"],
                start_ms,
                end_ms,
                angle,
                raters=raters,
                single_rater=single_rater,
            )
            for rater, (w0, w1, value) in wrote.items():
                eaf.add_annotation(tier_names[(rater, subject)], w0, w1, str(value))
                written_rows.append(
                    {
                        "session": session,
                        "file": file_name,
                        "tier": tier_names[(rater, subject)],
                        "annotator": rater,
                        "participant": subject,
                        "start_s": w0 / 1000.0,
                        "end_s": w1 / 1000.0,
                        "angle_deg": float(value),
                        "scenario": turn["scenario"],
                        "location": turn["location"],
                        "value": str(value),
                        "turn_id": turn_id,
                    }
                )
            truth_rows.append(
                _truth_row(
                    turn,
                    wrote,
                    raters,
                    turn_id=turn_id,
                    session=session,
                    file=file_name,
                    subject=subject,
                    pair=pair,
                    start_s=start_ms / 1000.0,
                    end_s=end_ms / 1000.0,
                    angle_deg=float(angle),
                    double_annotated=is_double,
                    kind=turn["kind"],
                )
            )
    path = out / file_name
    _write_eaf(eaf, path)
    return path


def write_sessions(
    out_dir: str | os.PathLike[str],
    *,
    seed: int,
    n_pairs: int = 12,
    sessions_per_pair: int = 2,
    turns_per_subject: int = 58,
    double_annotated_fraction: float = 0.5,
    raters: Raters = Raters(),
    angle_mix: Mapping[int, float] = ANGLE_MIX,
    scenario_mix: Mapping[str, float] = SCENARIO_MIX,
    location_mix: Mapping[str, float] = LOCATION_MIX,
    start_times: bool = False,
) -> SyntheticRemap:
    """Write synthetic Turn-REMAP ELAN sessions and ``participants.csv`` into ``out_dir``.

    Parameters
    ----------
    out_dir
        Folder to write into (created if needed); existing files of the same names are
        replaced atomically.
    seed
        Seed of every random draw.
    n_pairs
        Pairs of participants (one PD, one HC each); the paper has 12 (24 people).
    sessions_per_pair
        Recording sessions (``.eaf`` files) per pair.
    turns_per_subject
        Planted turns per participant over all their sessions (the paper: 1386 / 24 ≈ 58).
    double_annotated_fraction
        Share of sessions labelled by both raters (the paper: about half of the turns).
    raters
        Who annotates and how they err (:class:`Raters`).
    angle_mix, scenario_mix, location_mix
        Shares of the planted angles, scenarios and rooms.
    start_times
        Record each session's start in its header (:data:`START_TIME_PROPERTY`,
        :func:`session_start_time`), as a recording tool would; ``remap labels`` copies it
        into ``sessions.csv``.

    Returns
    -------
    SyntheticRemap
        The files written and the ground truth.
    """
    _check_session_args(n_pairs, sessions_per_pair, turns_per_subject, angle_mix)
    names = raters.names

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    participants = _participants(rng, n_pairs)

    sessions, double, single_rater = _assign_sessions(
        rng, n_pairs, sessions_per_pair, double_annotated_fraction, names
    )

    truth_rows: list[dict] = []
    written_rows: list[dict] = []
    paths: list[Path] = []
    for pair, session in sessions:
        k = int(session.rsplit("day", 1)[1]) - 1
        paths.append(
            _write_session(
                rng,
                out,
                pair,
                session,
                participants.loc[participants["pair"] == pair, ["subject", "cohort"]],
                turns_this_session=turns_per_subject // sessions_per_pair
                + (1 if k < turns_per_subject % sessions_per_pair else 0),
                is_double=session in double,
                single_rater=single_rater.get(session, ""),
                raters=raters,
                mixes=(angle_mix, scenario_mix, location_mix),
                truth_rows=truth_rows,
                written_rows=written_rows,
                start_time=session_start_time(seed, session, k + 1) if start_times else "",
            )
        )

    participants_path = write_csv(participants, out / "participants.csv")
    truth = typed_frame(pd.DataFrame(truth_rows, columns=list(TRUTH_COLUMNS)), TRUTH_COLUMNS)
    written = typed_frame(
        pd.DataFrame(written_rows, columns=list(WRITTEN_COLUMNS)), WRITTEN_COLUMNS
    )
    return SyntheticRemap(
        paths=tuple(paths),
        participants_path=participants_path,
        participants=participants,
        truth=truth,
        written=written,
        raters=(names[0], names[1]),
        consensus=raters.consensus or "",
    )
