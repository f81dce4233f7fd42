"""``turn-eval``: score, compare and produce turning-angle predictions.

This module only builds the command group; each command lives in a ``_cli_*`` module,
imported only when it is used.
"""

from __future__ import annotations

import sys

import click

from turn_datasets import __version__
from turn_datasets.cli.common import lazy_group, run_group


@lazy_group(
    {
        "score": "turn_eval.cli.score",
        "compare": "turn_eval.cli.compare",
        "predict": "turn_eval.cli.predict",
        "estimate": "turn_eval.cli.estimate",
        "score-events": "turn_eval.cli.score_events",
        "detect": "turn_eval.cli.detect",
        "server": "turn_eval.cli.server",
        "serve": "turn_eval.cli.serve",
        "profile": "turn_eval.cli.profile",
    }
)
@click.version_option(__version__, prog_name="turn-eval")
def cli() -> None:
    """Score turning-angle predictions against Turn-H3.6M or Turn-REMAP.

    \b
    Example:
      turn-eval score predictions.csv --reference turn-h36m.csv --format md
      turn-eval compare a.csv b.csv --reference turn-h36m.csv
      turn-eval predict skeletons.npz --layout h36m17 --out predictions.csv
      turn-eval estimate walk.mp4 --out walk.npz   (needs: pip install 'turnbench[video]')
      turn-eval detect streams/ --layout h36m17 --up-axis -y --fps 30 --out detections.csv
      turn-eval score-events detections.csv --reference labels.csv
      turn-eval server init challenge/ -r labels.csv --name NAME  (needs the server extra)
      turn-eval serve challenge/ --port 8000
      turn-eval profile detections.csv --sessions sessions.csv --participants p.csv --out-dir prof
    """


# Each command registers itself on the group when its module is imported (LazyGroup).


def main(args: list[str] | None = None) -> None:
    """Console-script entry point."""
    sys.exit(run_group(cli, "turn-eval", args))
