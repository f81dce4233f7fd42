"""``turn-datasets remap inspect | labels | stats``: ELAN files to Turn-REMAP labels.

Parses options, calls :mod:`turn_datasets.remap.eaf` and :mod:`turn_datasets.remap.labels`, prints.
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd

from turn_datasets.cli import CONTEXT_SETTINGS, remap
from turn_datasets.cli.common import (
    FILE,
    FRACTION,
    counted,
    emit,
    file_option,
    format_option,
    info,
    progress,
    warn,
    wrote,
)
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import check_not_input, staged_dir, to_json_text, write_csv
from turn_datasets.remap.context import context_table, sessions_table
from turn_datasets.remap.eaf import expand_eaf_paths, read_annotations_and_context
from turn_datasets.remap.inspect import inspect_eaf, inspect_markdown
from turn_datasets.remap.labels import RESOLVE_CHOICES, make_labels
from turn_datasets.remap.participants import read_participants
from turn_datasets.remap.schema import Schema, load_schema
from turn_datasets.remap.stats import (
    read_labels,
    stats_csv,
    stats_dict,
    stats_markdown,
    table1,
    table2,
    turns_per_location,
)

#: The raw per-rater rows are written beside the labels under this name (DESIGN.md).
ANNOTATIONS_NAME = "annotations.csv"
#: For untrimmed scoring, beside the labels too: the context intervals and the annotated
#: duration per session and participant (:mod:`turn_datasets.remap.context`).
CONTEXT_NAME = "context.csv"
SESSIONS_NAME = "sessions.csv"
#: Every file ``labels`` writes beside ``--out``.
BESIDE_NAMES = (ANNOTATIONS_NAME, CONTEXT_NAME, SESSIONS_NAME)

schema_option = click.option(
    "--schema",
    "schema_path",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Annotation schema TOML for files in another convention (default: the shipped one).",
)


#: ``--min-overlap`` of ``labels`` and ``agreement``: one matching rule for both.
min_overlap_option = click.option(
    "--min-overlap",
    type=FRACTION,
    default=0.6,
    show_default=True,
    help="Two raters' turns are one when overlap / longer duration is at least this (as "
    "ELAN's reliability check).",
)


def no_turns_error(paths: list[Path], schema: Schema) -> TurnbenchError:
    """The error for files that yield no turn at all (``labels`` and ``agreement``)."""
    return TurnbenchError(
        f"no turn annotations in {len(paths)} file(s): no tier whose name matches "
        f"{schema.turn_tier_regex.pattern!r} holds an annotation",
        file=str(paths[0]) if len(paths) == 1 else None,
        hint="see `turn-datasets remap inspect`, or map the tiers with --schema",
    )


@remap.command("inspect", context_settings=CONTEXT_SETTINGS)
@click.argument(
    "files", nargs=-1, required=True, metavar="FILE...", type=click.Path(path_type=Path)
)
@schema_option
@format_option(default="md", choices=("md", "json"))
@click.option(
    "--keep-media-paths",
    is_flag=True,
    help="Also show the header: author, date, media and linked file paths (may identify "
    "people or places; off by default).",
)
def inspect_cmd(
    files: tuple[Path, ...], schema_path: Path | None, fmt: str, keep_media_paths: bool
) -> None:
    """List what ELAN files hold and which tiers the schema takes as turn and context tiers.

    Per file: each tier with its linguistic type and constraint, parent, annotator,
    participant, vocabulary, annotation count and time range; the controlled vocabularies
    (external ones with their URL); the turn and context tiers, or a clear note that there
    are none. FILES may be .eaf files or folders of them. Any readable ELAN file works,
    whatever its version or tier structure; files declaring XML entities are refused.

    \b
    Example:
      turn-datasets remap inspect session01.eaf
      turn-datasets remap inspect eaf/ --format json > inventory.json
      turn-datasets remap inspect other.eaf --schema mine.toml
    """
    schema = load_schema(schema_path)
    paths = expand_eaf_paths(files)
    results = [
        inspect_eaf(p, schema=schema, keep_media_paths=keep_media_paths)
        for p in progress(paths, label="reading ELAN files")
    ]
    info(f"read {counted(len(paths), 'ELAN file')}")
    if fmt == "json":
        emit(to_json_text({"schema": schema.source, "files": results}))
    else:
        emit(inspect_markdown(results))


@remap.command("labels", context_settings=CONTEXT_SETTINGS)
@click.argument(
    "inputs", nargs=-1, required=True, metavar="EAF_OR_DIR...", type=click.Path(path_type=Path)
)
@file_option(
    "--participants",
    "participants_path",
    required=True,
    help="CSV: subject, cohort (PD or HC), pair, sex, age, years_since_diagnosis.",
)
@schema_option
@min_overlap_option
@click.option(
    "--resolve",
    type=click.Choice(RESOLVE_CHOICES),
    default="consensus",
    show_default=True,
    help="Who decides where two raters disagree: the consensus tier (else exit 2), or the "
    "rater whose tier comes first in the file.",
)
@file_option(
    "--out",
    required=True,
    help=f"Labels CSV to write; {ANNOTATIONS_NAME} (every rater's raw rows), {CONTEXT_NAME} "
    f"and {SESSIONS_NAME} (for score-events) go beside it.",
)
def labels_cmd(
    inputs: tuple[Path, ...],
    participants_path: Path,
    schema_path: Path | None,
    min_overlap: float,
    resolve: str,
    out: Path,
) -> None:
    """Write the Turn-REMAP labels: one row per turn after adjudication.

    Reads every turn annotation of every rater from the ELAN files (EAF_OR_DIR: files or
    folders of .eaf files), makes one turn of two raters' matched annotations, lets the
    consensus rater decide where they disagree, and adds each subject's cohort from the
    participants table. Columns: clip_id, session, subject, cohort, annotator, start_s,
    end_s, duration_s, angle_deg, scenario, location, double_annotated, source; clip_id is
    {session}_{subject}_{start_ms}-{end_ms}. annotations.csv beside --out holds every raw
    row; context.csv the context tiers' intervals per session and participant (session,
    subject, start_s, end_s, scenario, location) and sessions.csv each participant's
    annotated duration (session, subject, duration_s), for `turn-eval score-events`. All
    four are written together or not at all.

    Exit 2, naming file, annotation, tier and time: a value outside the vocabulary,
    overlapping turns on one tier, an end not after its start, a file that is not ELAN or
    has no turn tier beside files that have one (every such problem of every file in one
    run, grouped by kind); a participant missing from the table; or disagreements without
    consensus (all listed first; --resolve first-rater takes the first rater's label
    instead).

    \b
    Example:
      turn-datasets remap labels eaf/ --participants participants.csv --out labels/labels.csv
      turn-datasets remap labels eaf/ --participants participants.csv \\
          --resolve first-rater --out labels.csv
    """
    beside = [out.parent / name for name in BESIDE_NAMES]
    if out.name in BESIDE_NAMES:
        raise click.UsageError(f"--out must not be named {out.name}: that file goes beside it")
    schema = load_schema(schema_path)
    paths = expand_eaf_paths(inputs)
    inputs_all = [*paths, participants_path, *([schema_path] if schema_path else [])]
    for path in (out, *beside):
        check_not_input(path, inputs_all)

    participants = read_participants(participants_path)
    annotations, file_contexts = read_annotations_and_context(
        paths,
        schema=schema,
        iterate=lambda ps: progress(ps, label="reading ELAN files"),
        warn=warn,
        require_turn_tier=True,
    )
    if annotations.empty:
        raise no_turns_error(paths, schema)

    def list_unresolved(pending: pd.DataFrame) -> None:
        # Every disagreement before the one-line error, so one review pass can fix them all.
        for r in pending.itertuples(index=False):
            info(
                f"unresolved: {r.file}, tier {r.tier!r}, participant {r.participant}, "
                f"{r.start_s:.3f}-{r.end_s:.3f} s: {r.values}"
            )

    labels = make_labels(
        annotations,
        participants,
        consensus_annotator=schema.consensus_annotator,
        min_overlap=min_overlap,
        resolve=resolve,
        on_unresolved=list_unresolved,
    )
    with staged_dir(out.parent) as stage:
        write_csv(labels, stage / out.name)
        write_csv(annotations, stage / ANNOTATIONS_NAME)
        write_csv(context_table(file_contexts), stage / CONTEXT_NAME)
        write_csv(sessions_table(file_contexts), stage / SESSIONS_NAME)
    n_double = int(labels["double_annotated"].sum())
    wrote(
        out,
        *beside,
        what=f"{len(labels)} turns ({n_double} double-annotated) from {len(annotations)} "
        f"annotations in {counted(len(paths), 'ELAN file')}:",
    )


@remap.command("stats", context_settings=CONTEXT_SETTINGS)
@click.argument("labels_csv", type=FILE)
@file_option(
    "--participants",
    "participants_path",
    default=None,
    help="Participants table, for mean ages and years since diagnosis.",
)
@click.option("--csv", "as_csv", is_flag=True, help="Same as --format csv.")
@format_option(default="md", choices=("md", "csv", "json"))
def stats_cmd(labels_csv: Path, participants_path: Path | None, as_csv: bool, fmt: str) -> None:
    """Summarise a label set as the paper's Table 1 and Table 2.

    Table 1: subjects, turns, mean age and years since diagnosis per cohort (PD, HC, all).
    Table 2: turns per scenario and angle, with totals. Then turns per location and cohort.
    Markdown by default; --csv prints one long CSV (table, row, column, value).

    \b
    Example:
      turn-datasets remap stats labels.csv --participants participants.csv
      turn-datasets remap stats labels.csv --csv > stats.csv
    """
    labels = read_labels(labels_csv)
    participants = read_participants(participants_path) if participants_path else None
    t1 = table1(labels, participants)
    t2 = table2(labels)
    locations = turns_per_location(labels)
    fmt = "csv" if as_csv else fmt
    if fmt == "csv":
        emit(stats_csv(t1, t2, locations))
    elif fmt == "json":
        emit(to_json_text(stats_dict(t1, t2, locations)))
    else:
        emit(stats_markdown(t1, t2, locations))
