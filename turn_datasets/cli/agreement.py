"""``turn-datasets remap agreement``: the inter-rater agreement audit of turn labels.

Parses options, reads the annotations, calls :mod:`turn_datasets.remap.agreement` and prints;
every file of ``--out-dir`` is staged and moved in only when all are written.
"""

from __future__ import annotations

from pathlib import Path

import click

from turn_datasets import __version__
from turn_datasets.cli import CONTEXT_SETTINGS, remap
from turn_datasets.cli.common import (
    KAPPA,
    bootstrap_options,
    check_out_dir,
    check_stdout,
    counted,
    format_option,
    info,
    one_run,
    progress,
    warn,
    warn_below,
    wrote,
)
from turn_datasets.cli.labels import min_overlap_option, no_turns_error, schema_option
from turn_datasets.errors import GateFailed
from turn_datasets.fileio import (
    to_json_text,
    write_files,
)
from turn_datasets.remap.agreement import AgreementAudit, audit_agreement
from turn_datasets.remap.agreement_report import agreement_markdown, write_confusion_png
from turn_datasets.remap.eaf import expand_eaf_paths, read_annotations
from turn_datasets.remap.gate import GATE_ON, check_gate
from turn_datasets.remap.review_eaf import write_review_eaf
from turn_datasets.remap.schema import load_schema

#: Files written into --out-dir (review copies go to its ``review/`` folder).
OUT_FILES = (
    "agreement.json",
    "agreement.md",
    "pairs.csv",
    "disagreements.csv",
    "confusion.csv",
    "confusion.png",
    "by_session.csv",
    "by_rater_pair.csv",
)
REVIEW_DIR = "review"
#: The run record of --out-dir: the next run removes only the review copies listed there.
AGREEMENT_RECORD = "agreement.manifest.json"


@remap.command("agreement", context_settings=CONTEXT_SETTINGS)
@click.argument(
    "inputs", nargs=-1, required=True, metavar="EAF_OR_DIR...", type=click.Path(path_type=Path)
)
@schema_option
@click.option(
    "--raters",
    nargs=2,
    type=str,
    default=None,
    metavar="A B",
    help="The two raters to audit (default: the two present besides the consensus rater).",
)
@min_overlap_option
@click.option(
    "--min-kappa",
    type=KAPPA,
    default=None,
    callback=warn_below(0.0, "a gate below chance agreement passes almost any audit"),
    help="Gate: exit 3 after the report when Cohen's kappa is below this (or undefined): "
    "kappa over matched turns and kappa counting missed turns, both (see --gate-on).",
)
@click.option(
    "--gate-on",
    type=click.Choice(GATE_ON),
    default="both",
    show_default=True,
    help="Which kappas --min-kappa gates: both, or matched turns alone (a rater who misses "
    "turns then passes).",
)
@format_option(default="md", choices=("md", "json"))
@click.option(
    "--out-dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Also write the report, pairs, disagreements, confusion matrix (CSV, PNG) here.",
)
@click.option(
    "--review-eaf",
    is_flag=True,
    help="Write a copy of each session with disagreements, with a 'Disagreement' tier, "
    "into OUT_DIR/review/ (needs --out-dir; the originals are never modified).",
)
@click.option(
    "--keep-media-paths",
    is_flag=True,
    help="Keep the header (media paths, author, date) in the review copies (emptied by default).",
)
@bootstrap_options("Bootstrap resamples of the matched pairs for the 95% CI (0: no CI).")
def agreement(
    inputs: tuple[Path, ...],
    schema_path: Path | None,
    raters: tuple[str, str] | None,
    min_overlap: float,
    min_kappa: float | None,
    gate_on: str,
    fmt: str,
    out_dir: Path | None,
    review_eaf: bool,
    keep_media_paths: bool,
    n_resamples: int,
    seed: int,
) -> None:
    """Audit inter-rater agreement of turn labels in ELAN files (EAF_OR_DIR...).

    Two raters' turns of the same participant are linked when their overlap divided by the
    longer duration is at least --min-overlap, greedily, highest first (as ELAN's own
    reliability check). Reports annotations, matched and unmatched turns per rater, percent
    agreement, Cohen's kappa (unweighted and linear, with a bootstrap 95% CI), kappa with
    "unmatched" as a category, the confusion matrix and median boundary differences,
    overall, per session and per pair of raters. Fractions in JSON, percentages in Markdown.
    Problems in the ELAN files (as `remap labels` finds them) are all reported in one run,
    grouped by kind, with exit 2 and nothing written.

    \b
    Example:
      turn-datasets remap agreement eaf/ --min-kappa 0.8
      turn-datasets remap agreement eaf/ --format json > agreement.json
      turn-datasets remap agreement eaf/ --out-dir audit/ --review-eaf
      turn-datasets remap agreement other.eaf --schema mine.toml --raters Ann Bob
    """
    if review_eaf and out_dir is None:
        raise click.UsageError("--review-eaf writes into --out-dir; give one")
    schema = load_schema(schema_path)
    paths = expand_eaf_paths(inputs)
    if out_dir is not None:
        # Before any reading: no input may lie among what the folder owns (its review copies
        # are replaced or removed by the run).
        check_out_dir(
            out_dir, OUT_FILES, [*inputs, *paths], folders=(REVIEW_DIR,), record=AGREEMENT_RECORD
        )
    annotations = read_annotations(
        list(progress(paths, label="reading ELAN files")),
        schema=schema,
        warn=warn,
        require_turn_tier=True,
    )
    if annotations.empty:
        raise no_turns_error(paths, schema)
    audit = audit_agreement(
        annotations,
        raters=raters,
        labels_deg=schema.angles_deg,
        consensus_annotator=schema.consensus_annotator,
        min_overlap=min_overlap,
        n_bootstrap=n_resamples,
        seed=seed,
    )
    info(f"read {counted(len(paths), 'ELAN file')}")
    if not len(audit.items):
        warn(
            f"no session and participant was labelled by both {audit.raters[0]!r} and "
            f"{audit.raters[1]!r}: nothing to compare"
        )
    document = audit.to_dict()
    document["settings"]["version"] = __version__
    gate = check_gate(audit.overall, min_kappa, gate_on) if min_kappa is not None else None
    if gate is not None:
        document["gate"] = gate.to_dict()

    markdown = agreement_markdown(audit)
    if gate is not None:
        markdown += f"\n{gate.line()}\n"
        info(gate.line())

    if out_dir is not None:
        participants = annotations.groupby("session")["participant"].nunique().to_dict()
        _write_outputs(
            out_dir,
            audit,
            document,
            markdown,
            paths=paths,
            review_eaf=review_eaf,
            keep_media_paths=keep_media_paths,
            participants_per_session=participants,
        )

    check_stdout()
    click.echo(to_json_text(document) if fmt == "json" else markdown, nl=False)

    if gate is not None and not gate.passed:
        raise GateFailed(gate.failure())


def _write_outputs(
    out_dir: Path,
    audit: AgreementAudit,
    document: dict,
    markdown: str,
    *,
    paths: list[Path],
    review_eaf: bool,
    keep_media_paths: bool,
    participants_per_session: dict,
) -> None:
    """Every file of --out-dir, staged; nothing lands unless all are written."""
    sessions_to_review = sorted(audit.disagreements["session"].unique()) if review_eaf else []
    files = dict(zip(audit.items["session"], audit.items["file"], strict=True))
    review_names = [f"{REVIEW_DIR}/{s}.eaf" for s in sessions_to_review]
    check_out_dir(
        out_dir, [*OUT_FILES, *review_names], paths, folders=(REVIEW_DIR,), record=AGREEMENT_RECORD
    )
    # The folder holds one run: review copies of sessions that agree now are removed.
    with one_run(out_dir, what="the agreement report", record=AGREEMENT_RECORD) as stage:
        tables = {
            "agreement.json": document,
            "agreement.md": markdown,
            "pairs.csv": audit.items,
            "disagreements.csv": audit.disagreements,
            "confusion.csv": audit.confusion_table(),
            "by_session.csv": audit.summary_table("session"),
            "by_rater_pair.csv": audit.summary_table("rater_pair"),
        }
        write_files(stage, tables)
        write_confusion_png(audit, stage / "confusion.png")
        for session in sessions_to_review:
            rows = audit.disagreements[audit.disagreements["session"] == session]
            write_review_eaf(
                files[session],
                stage / REVIEW_DIR / f"{session}.eaf",
                rows,
                rater_a=audit.raters[0],
                rater_b=audit.raters[1],
                tier_per_participant=participants_per_session.get(session, 1) > 1,
                keep_media_paths=keep_media_paths,
            )
    what = f"agreement report ({len(OUT_FILES)} files"
    if review_eaf:
        what += f", {len(review_names)} review copies in {out_dir / REVIEW_DIR}"
    wrote(out_dir, what=what + ") to")
    if review_eaf and not review_names:
        info("no disagreements: no review copies written")
