"""``turn-eval server init|add-team|add-baseline|close-phase|list|verify-receipt``: set up
and run a challenge with a hidden reference (:mod:`turn_eval.server`).

Thin: parse, call :mod:`turn_eval.server.service`, print. The commands need the ``server``
extra; without it they say so in one line (exit 2).
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path
from types import ModuleType

import click

from turn_datasets.cli.common import (
    CONTEXT_SETTINGS,
    bootstrap_options,
    emit,
    info,
    params_from,
    params_options,
)
from turn_datasets.errors import GateFailed, TurnbenchError
from turn_datasets.fileio import to_json_text
from turn_datasets.render.markdown import markdown_cell
from turn_eval.cli import cli
from turn_eval.server import EXTRA_HINT
from turn_eval.server.datadir import ChallengeParams, open_challenge
from turn_eval.server.receipts import verify_receipt

__all__ = ["server", "needs_extra"]


def needs_extra(module: str) -> ModuleType:
    """Import a module of the server that needs the ``server`` extra, or say how to get it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise TurnbenchError(
            f"{exc.name or 'a server package'} is not installed; {EXTRA_HINT}"
        ) from None


DATA_DIR = click.Path(file_okay=False, path_type=Path)


@cli.group("server", context_settings=CONTEXT_SETTINGS)
def server() -> None:
    """Set up a challenge with a hidden reference for `turn-eval serve`.

    \b
    Example:
      turn-eval server init challenge/ --reference labels.csv --name "Turn-REMAP" --by cohort
      turn-eval server add-team challenge/ "Team A" > team-a.token
      turn-eval serve challenge/ --port 8000
    """


@server.command("init", context_settings=CONTEXT_SETTINGS)
@click.argument("root", metavar="DIR", type=DATA_DIR)
@click.option(
    "--reference",
    "-r",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="The hidden reference: labels or a clip index (clip_id, angle_deg, ...).",
)
@click.option("--name", required=True, help="The challenge's title, shown on the page.")
@click.option(
    "--by",
    multiple=True,
    metavar="COL",
    help="A reference column the board shows per group (repeatable); nothing else of the "
    "reference is ever shown.",
)
@params_options(ChallengeParams)
@bootstrap_options(
    "Bootstrap resamples of the intervals and of the rank tests.",
    seed_help="Seed of the public/private split and of every bootstrap.",
    min_resamples=1,
)
@click.option(
    "--db",
    "database",
    metavar="URL",
    help="A SQLAlchemy database URL (postgresql+psycopg://user@host/db); default: a SQLite "
    "file in DIR.",
)
def init(root: Path, reference: Path, name: str, by: tuple[str, ...], **options) -> None:
    """Make a challenge's data directory DIR (a new or empty folder).

    It holds the settings, a private copy of the reference, the public/private split (by
    participant where the reference has a subject column, else by clip; seeded and
    recorded), the receipts' secret and, unless --db names another, the SQLite database.

    \b
    Example:
      turn-eval server init challenge/ -r labels.csv --name "Turn-REMAP" --by cohort \\
          --by scenario --daily-quota 5 --total-quota 100 --private-fraction 0.5 --seed 0
    """
    params = params_from(ChallengeParams, options)
    service = needs_extra("turn_eval.server.service")
    challenge = service.init_challenge(
        root,
        reference=reference,
        name=name,
        params=params,
        by=by,
        seed=options["seed"],
        n_resamples=options["n_resamples"],
        database=options["database"],
    )
    split = challenge.split
    emit(to_json_text(challenge.as_json()))
    info(
        f"made challenge {challenge.name!r} in {root}: {split['n_clips_public']} public and "
        f"{split['n_clips_private']} private clips (split by {split['unit']})"
    )


def _open(root: Path):
    service = needs_extra("turn_eval.server.service")
    challenge = open_challenge(root)
    return service, challenge, service.open_store(challenge)


@server.command("add-team", context_settings=CONTEXT_SETTINGS)
@click.argument("root", metavar="DIR", type=DATA_DIR)
@click.argument("name")
def add_team(root: Path, name: str) -> None:
    """Add a team; print its token, once (only its hash is kept).

    \b
    Example:
      turn-eval server add-team challenge/ "Team A" > team-a.token
    """
    service, _, store = _open(root)
    token = service.add_team(store, name)
    emit(token)
    info(f"added team {name.strip()!r}; its token is shown once, above")


@server.command("add-baseline", context_settings=CONTEXT_SETTINGS)
@click.argument("root", metavar="DIR", type=DATA_DIR)
@click.argument("name")
@click.argument("predictions", type=click.Path(dir_okay=False, path_type=Path))
def add_baseline(root: Path, name: str, predictions: Path) -> None:
    """Add a baseline (shown with a badge): a team with one submission, scored now.

    \b
    Example:
      turn-eval server add-baseline challenge/ "constant 90°" constant90.csv
    """
    service, challenge, store = _open(root)
    submission_id = service.add_baseline(challenge, store, name, predictions)
    emit(submission_id)
    info(f"added baseline {name.strip()!r}, scored as submission {submission_id}")


@server.command("close-phase", context_settings=CONTEXT_SETTINGS)
@click.argument("root", metavar="DIR", type=DATA_DIR)
def close_phase(root: Path) -> None:
    """Close the phase: the board ranks on the private clips and shows their scores.

    \b
    Example:
      turn-eval server close-phase challenge/
    """
    import time

    _, _, store = _open(root)
    closed = store.close_phase(time.time())
    emit(to_json_text({"phase": "closed"}))
    info("closed the phase" if closed else "the phase was already closed")


@server.command("list", context_settings=CONTEXT_SETTINGS)
@click.argument("root", metavar="DIR", type=DATA_DIR)
@click.option("--format", "fmt", type=click.Choice(["md", "json"]), default="md", show_default=True)
def list_challenge(root: Path, fmt: str) -> None:
    """List the challenge's teams and their submissions by status.

    \b
    Example:
      turn-eval server list challenge/ --format json
    """
    service, challenge, store = _open(root)
    summary = service.challenge_summary(challenge, store)
    if fmt == "json":
        emit(to_json_text(summary))
        return
    columns = ["team", "baseline", "submissions", "queued", "scoring", "scored", "failed"]
    lines = [
        f"{summary['challenge']} ({summary['phase']})",
        "",
        "| " + " | ".join(columns) + " |",
        "|" + "---|" * len(columns),
    ]
    for team in summary["teams"]:
        lines.append("| " + " | ".join(markdown_cell(str(team[c])) for c in columns) + " |")
    emit("\n".join(lines))
    info(f"{len(summary['teams'])} team(s)")


@server.command("verify-receipt", context_settings=CONTEXT_SETTINGS)
@click.argument("root", metavar="DIR", type=DATA_DIR)
@click.argument("receipt", type=click.Path(dir_okay=False, path_type=Path))
def verify(root: Path, receipt: Path) -> None:
    """Check a receipt's signature with the challenge's secret (exit 3 if it fails).

    \b
    Example:
      turn-eval server verify-receipt challenge/ receipt.json
    """
    challenge = open_challenge(root)
    try:
        doc = json.loads(receipt.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise TurnbenchError(f"not a receipt (unreadable JSON: {exc})", file=str(receipt)) from None
    if not isinstance(doc, dict):
        raise TurnbenchError("not a receipt (not a JSON object)", file=str(receipt))
    ok, why = verify_receipt(challenge.secret(), doc)
    if not ok:
        raise GateFailed(f"{receipt}: {why}")
    emit(to_json_text({"valid": True, "submission": doc["submission"], "team": doc["team"]}))
    info(f"{receipt}: {why}")
