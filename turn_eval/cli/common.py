"""Options shared by turn-eval's commands that read skeleton streams (``predict``, ``detect``).

The generic options every console script shares live in :mod:`turn_datasets.cli.common`; this
module adds the one block that is turn_eval's own: whose files the skeletons are.
"""

from __future__ import annotations

import click

from turn_datasets.cli.common import layout_option, up_axis_option
from turn_eval.estimate.formats import FORMAT_CHOICES


def skeleton_source_options(*, from_help: str, layout_help: str, up_axis_help: str):
    """Decorator: ``--from`` (whose files), ``--layout`` and ``--up-axis``, in that order.

    ``--from`` is ``arrays`` (generic arrays: the layout and the up axis given) or an
    estimator's output by name (:data:`turn_eval.estimate.formats.FORMAT_CHOICES`); the command
    receives ``source_format``, ``layout_name`` and ``up_axis`` (``None`` when not given, so it
    can tell a missing ``--layout`` from the default).
    """

    def decorator(f):
        # click collects options bottom-up: apply the last one first so --help keeps this order
        f = up_axis_option(default=None, help=up_axis_help)(f)
        f = layout_option(dest="layout_name", default=None, help=layout_help)(f)
        return click.option(
            "--from",
            "source_format",
            type=click.Choice(FORMAT_CHOICES),
            default="arrays",
            show_default=True,
            help=from_help,
        )(f)

    return decorator
