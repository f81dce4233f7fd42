"""Options shared by turn-eval's commands that read skeleton streams (``predict``, ``detect``).

The generic options every console script shares live in :mod:`turn_datasets.cli.common`; this
module adds the one block that is turn_eval's own: whose files the skeletons are.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import click

from turn_datasets.cli.common import layout_option, up_axis_option
from turn_datasets.errors import TurnbenchError
from turn_datasets.skeleton import AUTO, Layout, get_layout
from turn_eval.estimate.formats import FORMAT_CHOICES


@dataclass(frozen=True)
class SkeletonSource:
    """What ``--from``, ``--layout`` and ``--up-axis`` say about the skeleton files.

    ``format`` is ``arrays`` (generic arrays) or an estimator's name
    (:data:`turn_eval.estimate.formats.FORMAT_CHOICES`); ``layout_name`` and ``up_axis`` are
    None when not given, so a missing ``--layout`` can be told from the default.
    """

    format: str
    layout_name: str | None
    up_axis: str | None

    def layout(self) -> Layout:
        """The joint layout, once the options are known to fit together.

        Generic arrays need ``--layout`` (their vertical axis, unless given, is inferred:
        ``--up-axis auto``); an estimator's files are in the h36m17 layout.
        """
        if self.format == "arrays":
            if self.layout_name is None:
                raise TurnbenchError(
                    "generic arrays need --layout",
                    hint="or name the estimator that wrote them with --from",
                )
        elif self.layout_name not in (None, "h36m17"):
            raise TurnbenchError(f"--from {self.format} files are in the h36m17 layout")
        return get_layout(self.layout_name or "h36m17")

    @property
    def up_axis_option(self) -> str | None:
        """The axis to read with: the one given, else ``auto`` for generic arrays (they do
        not state theirs), else None (a named format's own)."""
        if self.up_axis is not None:
            return self.up_axis
        return AUTO if self.format == "arrays" else None


def skeleton_source_options(*, from_help: str, layout_help: str, up_axis_help: str):
    """Decorator: ``--from`` (whose files), ``--layout`` and ``--up-axis``, in that order.

    The command receives them as one ``source`` (:class:`SkeletonSource`).
    """

    def decorator(f):
        @functools.wraps(f)
        def command(*args, source_format: str, layout_name: str | None, up_axis: str | None, **kw):
            return f(*args, source=SkeletonSource(source_format, layout_name, up_axis), **kw)

        # click collects options bottom-up: apply the last one first so --help keeps this order
        command = up_axis_option(default=None, help=up_axis_help)(command)
        command = layout_option(dest="layout_name", default=None, help=layout_help)(command)
        return click.option(
            "--from",
            "source_format",
            type=click.Choice(FORMAT_CHOICES),
            default="arrays",
            show_default=True,
            help=from_help,
        )(command)

    return decorator
