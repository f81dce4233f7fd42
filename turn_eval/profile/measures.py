"""Per-participant turning measures (``profile.csv``) and turns hour by hour (``by_hour.csv``).

The measures are those turning studies at home report as candidate digital biomarkers of
Parkinson's disease: how often (turns per hour), how far (mean angle), how long (median
duration), how fast (mean and peak angular speed), with how many steps and of which type, and
how variable (coefficient of variation). El-Gohary et al. (2014, Gait & Posture 39:444) and
Mancini et al. (2015, Parkinsonism Relat. Disord. 21:1097) found that at home people with PD
turned through smaller angles, more slowly, with more steps and more variably than controls;
Shah et al. (2020, J Neurol 267:1188) found turn angle separated PD from controls over a week.

Definitions (one row per participant; every turn of every session of the participant):

- ``recorded_h``: the sum of the sessions' ``duration_s`` / 3600; ``turns``: detections;
  ``turns_per_hour``: turns / recorded_h;
- ``mean_angle_deg``: the mean of |angle_deg|; ``median_duration_s``: the median of
  end_s - start_s; ``mean_speed_deg_s``: the mean over turns of |angle_deg| / (end_s - start_s)
  (each turn counts once, however long);
- where the detections carry them: ``peak_speed_deg_s`` (mean over turns of each turn's peak
  heading rate), ``mean_steps``, ``pivot_share`` (pivot turns / turns with a type); turns
  without a value are left out of these;
- ``share_bin_45`` ... ``share_bin_225``: the share of turns in each 45° bin (DESIGN.md's
  nearest-multiple rule); the first bin also holds anything smaller, the last anything larger;
- ``cv_angle``, ``cv_duration``, ``cv_speed``: the coefficient of variation (standard deviation
  with ddof=1 over the mean) of each turn's angle, duration and speed;
- ``cv_days_angle``, ``cv_days_duration``, ``cv_days_speed``: the coefficient of variation
  across days (a day is the local date a turn starts on) of the day's mean angle, mean
  duration and mean speed; needs two days with turns and a known ``start_time``.

A participant with fewer than ``min_turns`` turns keeps ``recorded_h`` and ``turns`` but gets
every measure blank: a profile is clinical data and a measure from three turns is noise.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame
from turn_eval.events.contract import TURN_TYPES
from turn_eval.profile.inputs import ProfileInputs

__all__ = [
    "BIN_EDGES_DEG",
    "MEASURES",
    "OPTIONAL_MEASURES",
    "BY_HOUR_COLUMNS",
    "profile_table",
    "by_hour_table",
    "turn_values",
]

#: The 45° bins reported, by their centres (DESIGN.md: nearest multiple of 45).
BIN_EDGES_DEG = (45, 90, 135, 180, 225)
#: The measures every profile has, in column order.
MEASURES = ("turns_per_hour", "mean_angle_deg", "median_duration_s", "mean_speed_deg_s")
#: The measures a profile has when the detections carry the column named beside each.
OPTIONAL_MEASURES = {
    "peak_speed_deg_s": "peak_speed_deg_s",
    "mean_steps": "steps",
    "pivot_share": "turn_type",
}
_SHARES = tuple(f"share_bin_{b}" for b in BIN_EDGES_DEG)
_CVS = ("cv_angle", "cv_duration", "cv_speed", "cv_days_angle", "cv_days_duration", "cv_days_speed")
#: ``by_hour.csv``.
BY_HOUR_COLUMNS = {
    "subject": "str",
    "date": "str",
    "hour": "int64",
    "turns": "int64",
    "recorded_min": "float64",
}
_DAY_S = 86400.0
_HOUR_S = 3600.0


def turn_values(detections: pd.DataFrame) -> dict[str, np.ndarray]:
    """Each turn's angle (magnitude), duration and mean speed, and the optional columns as
    numbers (``pivot``: 1 for a pivot turn, 0 for a step turn, NaN without a type)."""
    start = detections["start_s"].to_numpy(dtype=np.float64)
    duration = detections["end_s"].to_numpy(dtype=np.float64) - start
    angle = np.abs(detections["angle_deg"].to_numpy(dtype=np.float64))
    out = {"angle": angle, "duration": duration, "speed": angle / duration, "start": start}
    if "peak_speed_deg_s" in detections:
        out["peak"] = detections["peak_speed_deg_s"].to_numpy(dtype=np.float64)
    if "steps" in detections:
        out["steps"] = detections["steps"].to_numpy(dtype=np.float64)
    if "turn_type" in detections:
        # through the few distinct values, not a string comparison per turn
        codes, kinds = pd.factorize(detections["turn_type"].to_numpy(dtype=object))
        value = {TURN_TYPES[0]: 1.0, TURN_TYPES[1]: 0.0}  # pivot, step
        lookup = np.array([value.get(str(k), np.nan) for k in kinds] + [np.nan])
        out["pivot"] = lookup[codes]
    return out


def _group_mean(
    code: np.ndarray, values: np.ndarray, n: int, count: np.ndarray | None = None
) -> np.ndarray:
    """The mean of ``values`` per group, NaN values left out (NaN for a group with none);
    ``count``: each group's rows, as float64, if already counted."""
    ok = np.isfinite(values)
    if ok.all():  # the usual case: no copy of the codes
        if count is None:
            count = np.bincount(code, minlength=n).astype(np.float64)
        total = np.bincount(code, weights=values, minlength=n)
    else:
        count = np.bincount(code[ok], minlength=n).astype(np.float64)
        total = np.bincount(code[ok], weights=values[ok], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _group_cv(
    code: np.ndarray,
    values: np.ndarray,
    n: int,
    count: np.ndarray | None = None,
    mean: np.ndarray | None = None,
) -> np.ndarray:
    """Per group, the standard deviation (ddof=1) over the mean, computed in two passes
    (deviations from the group's mean: no cancellation); NaN below two values or at mean 0.
    ``count`` (float64) and ``mean``: the groups' rows and :func:`_group_mean`, if known."""
    if count is None:
        count = np.bincount(code, minlength=n).astype(np.float64)
    if mean is None:
        mean = _group_mean(code, values, n, count)
    dev = values - mean[code]
    ss = np.bincount(code, weights=dev * dev, minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        sd = np.sqrt(ss / (count - 1))
        return np.where((count >= 2) & (mean != 0), sd / mean, np.nan)


def _group_median(code: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """The median per group (the mean of the two middle values of an even count; pandas'
    grouped median, which selects instead of sorting)."""
    medians = pd.Series(values).groupby(code, sort=True).median()
    out = np.full(n, np.nan)
    out[medians.index.to_numpy()] = medians.to_numpy()
    return out


def _day_cvs(
    code: np.ndarray, day: np.ndarray, values: dict[str, np.ndarray], n: int
) -> dict[str, np.ndarray]:
    """Across-day CVs of the day's mean angle, duration and speed, per participant."""
    known = np.isfinite(day)
    out = {name: np.full(n, np.nan) for name in _CVS[3:]}
    if not known.any():
        return out
    every = bool(known.all())
    days = (day if every else day[known]).astype(np.int64)
    first = int(days.min())
    span = int(days.max()) - first + 1
    # One cell per (participant, day) of the recording's span: indexed, not sorted.
    cell = (code if every else code[known]) * span + (days - first)
    count = np.bincount(cell, minlength=n * span)
    used = np.flatnonzero(count)
    owner = used // span
    for name, key in zip(_CVS[3:], ("angle", "duration", "speed"), strict=True):
        v = values[key] if every else values[key][known]
        daily = np.bincount(cell, weights=v, minlength=n * span)[used] / count[used]
        out[name] = _group_cv(owner, daily, n)
    return out


def profile_table(inputs: ProfileInputs, *, min_turns: int = 5) -> pd.DataFrame:
    """``profile.csv``: one row per participant (module docstring), in natural order."""
    subjects = inputs.subjects
    n = len(subjects)
    index = {s: i for i, s in enumerate(subjects)}
    sessions = inputs.sessions
    session_code = np.array([index[s] for s in sessions["subject"]], dtype=np.int64)
    seconds = np.bincount(session_code, weights=sessions["duration_s"].to_numpy(), minlength=n)
    recorded_h = seconds / _HOUR_S
    det = inputs.detections
    unit = det["unit"].to_numpy(dtype=np.int64)
    code = session_code[unit]
    values = turn_values(det)
    turns = np.bincount(code, minlength=n)
    # Counted and averaged once, for the means and again for the CVs.
    count = turns.astype(np.float64)
    means = {key: _group_mean(code, values[key], n, count) for key in ("angle", "speed")}
    columns: dict[str, Sequence[object] | np.ndarray] = {
        "subject": subjects,
        inputs.by: inputs.groups,
        "recorded_h": recorded_h,
        "turns": turns,
        "turns_per_hour": turns / recorded_h,
        "mean_angle_deg": means["angle"],
        "median_duration_s": _group_median(code, values["duration"], n),
        "mean_speed_deg_s": means["speed"],
    }
    for name, key in (
        ("peak_speed_deg_s", "peak"),
        ("mean_steps", "steps"),
        ("pivot_share", "pivot"),
    ):
        if key in values:
            columns[name] = _group_mean(code, values[key], n, count)
    # Each turn's bin (0 for the first bin and below ... 4 for the last and above), then one
    # count of turns per (participant, bin).
    k = len(BIN_EDGES_DEG)
    which = np.clip(np.floor(values["angle"] / 45.0 + 0.5).astype(np.int64) - 1, 0, k - 1)
    per_bin = np.bincount(code * k + which, minlength=n * k).reshape(n, k)
    with np.errstate(invalid="ignore", divide="ignore"):
        shares = per_bin / turns[:, None]
    for j, name in enumerate(_SHARES):
        columns[name] = np.where(turns > 0, shares[:, j], np.nan)
    columns["cv_angle"] = _group_cv(code, values["angle"], n, count, means["angle"])
    columns["cv_duration"] = _group_cv(code, values["duration"], n, count)
    columns["cv_speed"] = _group_cv(code, values["speed"], n, count, means["speed"])
    local = sessions["local_start_s"].to_numpy(dtype=np.float64)[unit] + values["start"]
    columns.update(_day_cvs(code, np.floor(local / _DAY_S), values, n))
    table = pd.DataFrame(columns)
    small = turns < min_turns
    measures = [c for c in table.columns if c not in ("subject", inputs.by, "recorded_h", "turns")]
    table.loc[small, measures] = np.nan
    dtypes = {c: "float64" for c in table.columns}
    dtypes.update({"subject": "str", inputs.by: "str", "turns": "int64"})
    return typed_frame(table, dtypes)


def _hour_cells(
    local_start: np.ndarray, duration: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sessions cut at local hour boundaries: each piece's session, hour (hours since the
    epoch, local) and seconds recorded in it."""
    first = np.floor(local_start / _HOUR_S).astype(np.int64)
    last = np.ceil((local_start + duration) / _HOUR_S).astype(np.int64) - 1
    last = np.maximum(last, first)
    count = last - first + 1
    session = np.repeat(np.arange(local_start.shape[0]), count)
    offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    hour = first[session] + offset
    lo = np.maximum(local_start[session], hour * _HOUR_S)
    hi = np.minimum(local_start[session] + duration[session], (hour + 1) * _HOUR_S)
    return session, hour, np.maximum(hi - lo, 0.0)


def by_hour_table(inputs: ProfileInputs, *, keep: np.ndarray | None = None) -> pd.DataFrame:
    """``by_hour.csv``: turns and recorded minutes per participant, local date and hour.

    A session crossing an hour is split there; a turn counts in the hour it starts. Sessions
    without a ``start_time`` are left out, and so are participants not in ``keep`` (a boolean
    per :attr:`ProfileInputs.subjects`; the suppressed ones). Rows in natural subject order,
    then date and hour.
    """
    subjects = inputs.subjects
    index = {s: i for i, s in enumerate(subjects)}
    sessions = inputs.sessions
    subject_of = np.array([index[s] for s in sessions["subject"]], dtype=np.int64)
    local = sessions["local_start_s"].to_numpy(dtype=np.float64)
    wanted = np.isfinite(local)
    if keep is not None:
        wanted &= np.asarray(keep, dtype=bool)[subject_of]
    rows = np.flatnonzero(wanted)
    session, hour, seconds = _hour_cells(local[rows], sessions["duration_s"].to_numpy()[rows])
    piece_subject = subject_of[rows][session]
    unit = inputs.detections["unit"].to_numpy(dtype=np.int64)
    turn_ok = wanted[unit]
    turn_local = local[unit[turn_ok]] + inputs.detections["start_s"].to_numpy()[turn_ok]
    turn_hour = np.floor(turn_local / _HOUR_S).astype(np.int64)
    turn_subject = subject_of[unit[turn_ok]]
    all_subject = np.concatenate([piece_subject, turn_subject])
    all_hour = np.concatenate([hour, turn_hour])
    if all_hour.size == 0:
        return typed_frame(pd.DataFrame({c: [] for c in BY_HOUR_COLUMNS}), BY_HOUR_COLUMNS)
    low = int(all_hour.min())
    span = int(all_hour.max()) - low + 1
    # One cell per (participant, hour) of the recording's span: indexed, not sorted.
    key = all_subject * span + (all_hour - low)
    n_pieces = hour.shape[0]
    size = len(subjects) * span
    minutes = np.bincount(key[:n_pieces], weights=seconds / 60.0, minlength=size)
    turns = np.bincount(key[n_pieces:], minlength=size)
    cells = np.flatnonzero((minutes > 0) | (turns > 0))
    minutes, turns = minutes[cells], turns[cells]
    cell_subject = cells // span
    cell_hour = cells % span + low
    day = cell_hour // 24
    dates = (np.datetime64("1970-01-01", "D") + day.astype("timedelta64[D]")).astype(str)
    table = pd.DataFrame(
        {
            "subject": np.asarray(subjects, dtype=object)[cell_subject],
            "date": dates.astype(object),
            "hour": cell_hour % 24,
            "turns": turns,
            "recorded_min": minutes,
        }
    )
    return typed_frame(table, BY_HOUR_COLUMNS)
