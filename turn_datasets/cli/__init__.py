"""``turn-datasets``: curate Turn-H3.6M (``h36m ...``) and Turn-REMAP (``remap ...``).

This module only builds the command groups; each command lives in a ``_cli_*`` module that
parses its options, calls the library and prints, and is imported only when it is used.
"""

from __future__ import annotations

import sys

import click

from turn_datasets import __version__
from turn_datasets.cli.common import CONTEXT_SETTINGS, lazy_group, run_group


@click.group(context_settings=CONTEXT_SETTINGS)
@click.version_option(__version__, prog_name="turn-datasets")
def cli() -> None:
    """Curate the Turn-H3.6M and Turn-REMAP turning benchmarks.

    \b
    Example:
      turn-datasets h36m mine /data/human36m --out turn-h36m.csv
      turn-datasets remap labels eaf/ --participants participants.csv --out labels.csv
    """


@lazy_group(
    {
        "mine": "turn_datasets.cli.mine",
        "stats": "turn_datasets.cli.mine",
        "export-clips": "turn_datasets.cli.export",
    },
    parent=cli,
)
def h36m() -> None:
    """Turn-H3.6M: mine turning clips from motion capture, curate and summarise them.

    \b
    Example:
      turn-datasets h36m mine /data/human36m --out turn-h36m.csv
      turn-datasets h36m stats turn-h36m.csv
    """


@lazy_group(
    {
        "inspect": "turn_datasets.cli.labels",
        "labels": "turn_datasets.cli.labels",
        "stats": "turn_datasets.cli.labels",
        "agreement": "turn_datasets.cli.agreement",
        "open": "turn_datasets.cli.remap_open",
    },
    parent=cli,
)
def remap() -> None:
    """Turn-REMAP: labels from ELAN exports, the inter-rater agreement audit, the REMAP Open release.

    \b
    Example:
      turn-datasets remap inspect session01.eaf
      turn-datasets remap agreement eaf/ --min-kappa 0.8
      turn-datasets remap open Open_dataset_REMAP --out-dir remap-open/
    """


# Each command registers itself on its group when its module is imported (LazyGroup).


def main(args: list[str] | None = None) -> None:
    """Console-script entry point."""
    sys.exit(run_group(cli, "turn-datasets", args))
