"""Command-line plumbing shared by ``turn-datasets`` and ``turn-eval``.

stdout carries only the result; progress, warnings and "wrote ..." lines go to stderr.
Exit codes: 0 ok, 2 bad input (a :class:`TurnbenchError` or a usage error), 3 failed gate.
"""

from __future__ import annotations

import contextlib
import importlib
import math
import signal
import sys
import threading
import warnings
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import TypeVar

import click

from turn_datasets import limits
from turn_datasets.errors import GateFailed, TurnbenchError
from turn_datasets.fileio import check_not_input, check_owned, staged_dir
from turn_datasets.params import param_fields
from turn_datasets.render.numbers import counted
from turn_datasets.skeleton import LAYOUTS, UP_AXIS_CHOICES

__all__ = [
    "EXIT_OK",
    "EXIT_BAD_INPUT",
    "EXIT_GATE",
    "run_group",
    "Terminated",
    "sigterm_unwinds",
    "emit",
    "check_stdout",
    "info",
    "warn",
    "wrote",
    "progress",
    "format_option",
    "LazyGroup",
    "Number",
    "warn_below",
    "counted",
    "params_options",
    "params_from",
    "FILE",
    "file_option",
    "writing",
    "bootstrap_options",
    "DEFAULT_RESAMPLES",
    "check_out_dir",
    "one_run",
    "layout_option",
    "up_axis_option",
]

EXIT_OK = 0
EXIT_BAD_INPUT = 2
EXIT_GATE = 3

T = TypeVar("T")


class Terminated(BaseException):
    """SIGTERM arrived: unwinds like Ctrl-C, so every staging folder is removed on the way."""


def _raise_terminated(signum, frame) -> None:
    raise Terminated


@contextlib.contextmanager
def sigterm_unwinds() -> Iterator[None]:
    """SIGTERM raises :class:`Terminated` inside the block (in the main thread), so that
    ``finally`` blocks run as they do on Ctrl-C."""
    # `timeout`, systemd and CI stop a job with SIGTERM, whose default action kills at once
    # and left hidden staging folders with full copies of the output behind. Raising instead
    # runs the same `finally` blocks as SIGINT does. Signals can only be set in the main thread.
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def _library_warnings_silenced() -> Iterator[None]:
    # NumPy's arithmetic warnings (the mean of no values, 0/0) and matplotlib's note that a
    # "best" legend is slow say nothing to the person at the terminal: where a value is
    # undefined the result already says so (null, "–"). Our own warnings go through warn().
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        warnings.filterwarnings("ignore", message=r"Creating legend with loc=.best.")
        yield


def run_group(group: click.Group, prog_name: str, args: list[str] | None = None) -> int:
    """Run a click group, mapping turnbench errors to one line on stderr and an exit code."""
    with sigterm_unwinds(), _library_warnings_silenced():
        return _run_group(group, prog_name, args)


def _run_group(group: click.Group, prog_name: str, args: list[str] | None) -> int:
    try:
        rv = group.main(args=args, prog_name=prog_name, standalone_mode=False)
    except Terminated:
        click.echo(f"{prog_name}: terminated", err=True)
        return 128 + signal.SIGTERM
    except TurnbenchError as exc:
        click.echo(f"{prog_name}: error: {exc}", err=True)
        return EXIT_BAD_INPUT
    except GateFailed as exc:
        click.echo(f"{prog_name}: gate failed: {exc}", err=True)
        return EXIT_GATE
    except click.exceptions.Abort:
        click.echo(f"{prog_name}: aborted", err=True)
        return 130
    except click.UsageError as exc:
        # one line, like every other bad input, with where to read more
        path = exc.ctx.command_path if exc.ctx is not None else prog_name
        message = " ".join(exc.format_message().split())
        click.echo(f"{prog_name}: error: {message} (see '{path} --help')", err=True)
        return EXIT_BAD_INPUT
    except click.ClickException as exc:
        exc.show()
        return EXIT_BAD_INPUT if exc.exit_code not in (0, 1) else exc.exit_code
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except BrokenPipeError:
        # `| head` closed stdout: not an error of ours
        sys.stderr.close()
        return EXIT_OK
    except OSError as exc:
        # the machine said no (permission, no space, a file where a folder should be): the
        # user's to fix, so one line naming the path, not a traceback
        name = f"{exc.filename}: " if exc.filename else ""
        click.echo(f"{prog_name}: error: {name}{exc.strerror or exc}", err=True)
        return EXIT_BAD_INPUT
    return rv if isinstance(rv, int) else EXIT_OK


def check_stdout() -> None:
    """Refuse to "print" into a closed stdout: Python then has no sys.stdout and click would
    print nothing and exit 0, as if the result had been shown (``cat`` fails there too)."""
    if sys.stdout is None or sys.stdout.closed:
        raise TurnbenchError(
            "standard output is closed, so the result cannot be printed",
            hint="redirect it to a file (> result.txt)",
        )


def emit(text: str) -> None:
    """Print the command's result on stdout (ends with exactly one newline)."""
    check_stdout()
    click.echo(text.rstrip("\n"))


def info(message: str) -> None:
    """A line for the person at the terminal, on stderr."""
    click.echo(message, err=True)


def warn(message: str) -> None:
    """A warning on stderr."""
    click.echo(f"warning: {message}", err=True)


def wrote(*paths: str | Path, what: str = "") -> None:
    """The one-line summary of what a command wrote, on stderr."""
    names = ", ".join(str(p) for p in paths)
    info(f"wrote {what + ' ' if what else ''}{names}")


def progress(items: Iterable[T], *, label: str, length: int | None = None) -> Iterator[T]:
    """Iterate with a progress bar on stderr (only the label when stderr is not a terminal)."""
    with click.progressbar(
        items, label=label, length=length, file=sys.stderr, show_pos=True
    ) as bar:
        yield from bar


def bootstrap_progress(chunks: Iterable[T], n_chunks: int) -> Iterator[T]:
    """The bootstrap's progress bar (the ``progress`` callback of the scoring functions)."""
    return progress(chunks, label="bootstrap", length=n_chunks)


def format_option(default: str = "md", choices: tuple[str, ...] = ("md", "json", "csv")):
    """The ``--format`` option every result-printing command takes."""
    return click.option(
        "--format",
        "fmt",
        type=click.Choice(choices),
        default=default,
        show_default=True,
        help="How to print the result on stdout.",
    )


class Number(click.ParamType):
    """A numeric option: finite and within sensible bounds, checked here for every command.

    click's ``float`` lets ``nan`` and ``inf`` through (every comparison with NaN is false,
    so even a ``FloatRange`` passes it), and a bin width of NaN scored everything correct.
    Every numeric option of ``turn-datasets`` and ``turn-eval`` uses this type, with bounds
    from :mod:`turn_datasets.limits`, so a bad value is one line and exit 2 before any work.

    Parameters
    ----------
    kind
        ``float`` or ``int``.
    min, max
        The bounds (``None``: unbounded on that side; always finite).
    min_open, max_open
        Exclude the bound itself.
    why
        Appended to the message when a value is above ``max`` (say what the limit protects).
    """

    def __init__(
        self,
        kind: type = float,
        *,
        min: float | None = None,
        max: float | None = None,
        min_open: bool = False,
        max_open: bool = False,
        why: str = "",
    ) -> None:
        self.kind = kind
        self.name = "integer" if kind is int else "float"
        self.min, self.max = min, max
        self.min_open, self.max_open = min_open, max_open
        self.why = why

    def _range(self) -> str:
        lo = "" if self.min is None else f"{self.min:g}{' <' if self.min_open else ' <='} "
        hi = "" if self.max is None else f" {'<' if self.max_open else '<='} {self.max:g}"
        return f"{lo}x{hi}"

    def convert(self, value, param, ctx):
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            x = value
        else:
            text = str(value).strip()
            try:
                x = int(text) if self.kind is int else float(text)
            except ValueError:
                what = "an integer" if self.kind is int else "a number"
                self.fail(f"{value!r} is not {what}", param, ctx)
        if self.kind is float:
            x = float(x)
            if math.isnan(x):
                self.fail(f"must be a number, not {value}", param, ctx)
            if not math.isfinite(x):
                self.fail(f"must be a finite number, not {value}", param, ctx)
        if self.min is not None and (x < self.min or (self.min_open and x == self.min)):
            self.fail(f"{value} is not in the range {self._range()}", param, ctx)
        if self.max is not None and (x > self.max or (self.max_open and x == self.max)):
            why = f" ({self.why})" if self.why else ""
            self.fail(f"{value} is not in the range {self._range()}{why}", param, ctx)
        return x


def warn_below(threshold: float, why: str):
    """A click callback that warns on stderr when an option's value is below ``threshold``
    (legal, but almost surely a mistake: ``--min-kappa -1`` passes every audit)."""

    def callback(ctx: click.Context, param: click.Parameter, value: float | None):
        if value is not None and value < threshold:
            warn(f"{param.opts[0]} {value:g} is below {threshold:g}: {why}")
        return value

    return callback


#: The numeric option types the commands share (one bound, one message, everywhere).
FPS_HZ = Number(float, min=0, min_open=True, max=limits.MAX_FPS_HZ)
DURATION_S = Number(float, min=0, max=limits.MAX_DURATION_S)
POSITIVE_DURATION_S = Number(float, min=0, min_open=True, max=limits.MAX_DURATION_S)
ANGLE_DEG = Number(float, min=0, min_open=True, max=limits.MAX_ANGLE_DEG)
SPEED_DEG_S = Number(float, min=0, max=limits.MAX_SPEED_DEG_S)
FRACTION = Number(float, min=0, min_open=True, max=1)
KAPPA = Number(float, min=-1, max=1)
SEED = Number(int, min=0, max=limits.MAX_SEED)


@contextlib.contextmanager
def writing(what: str, path: str | Path) -> Iterator[None]:
    """Turn an ``OSError`` while writing ``what`` into one line and exit 2, as any bad input:
    a folder that cannot be made or written (a file in the way, no permission, a full disk).
    """
    try:
        yield
    except OSError as exc:
        detail = f"{exc.filename}: {exc.strerror}" if exc.filename else str(exc)
        raise TurnbenchError(f"cannot write {what}: {detail}", file=str(path)) from None


def check_out_dir(
    out_dir: Path,
    names: Iterable[str],
    inputs: Iterable[Path],
    *,
    folders: Iterable[str] = (),
    record: str | None = None,
) -> None:
    """Refuse an ``--out-dir`` that is a file, whose ``names`` would overwrite an input or
    exist and are not regular files, or that owns an input (:func:`check_owned`: ``folders``
    it fills, its run ``record`` and what the previous run's record lists). Called before
    any work."""
    inputs = list(inputs)
    if out_dir.exists() and not out_dir.is_dir():
        raise TurnbenchError("--out-dir is a file, not a folder", file=str(out_dir))
    for name in names:
        check_not_input(out_dir / name, inputs, option="--out-dir")
    check_owned(out_dir, inputs, names=names, folders=folders, record=record, option="--out-dir")


@contextlib.contextmanager
def one_run(out_dir: Path, *, what: str, record: str | None = None) -> Iterator[Path]:
    """Yield a staging folder whose files replace ``out_dir``'s together, or none at all.

    With ``record`` (a command that writes some files in one run and not in another), the
    folder holds one run: the run is recorded in ``out_dir/record`` and a file the previous
    run's record lists that this run did not write is removed, and said on stderr; one the
    user has changed since is kept, and said too (:func:`staged_dir`). Without, nothing is
    removed. A folder that cannot be written is one line and exit 2 (:func:`writing`).
    """
    removed: list[Path] = []
    kept: list[Path] = []
    with (
        writing(what, out_dir),
        staged_dir(out_dir, record=record, removed=removed, kept=kept) as stage,
    ):
        yield stage
    if removed:
        info(f"removed {len(removed)} file(s) of the previous run: " + ", ".join(map(str, removed)))
    if kept:
        warn(
            f"kept {len(kept)} file(s) of the previous run that were changed since it wrote "
            "them: " + ", ".join(map(str, kept))
        )


#: A path the user names that must be a file, never a folder (an input or an --out).
FILE = click.Path(dir_okay=False, path_type=Path)


def file_option(*names: str, help: str, **kwargs):
    """An option naming one file (``--out``, ``--reference``, ``--participants``, ...)."""
    return click.option(*names, type=FILE, help=help, **kwargs)


def layout_option(help: str, *, dest: str = "layout", **kwargs):
    """``--layout``: the joint layout of skeleton arrays (Human3.6M's 17 or 32 joints)."""
    return click.option("--layout", dest, type=click.Choice(sorted(LAYOUTS)), help=help, **kwargs)


def up_axis_option(help: str, **kwargs):
    """``--up-axis``: the vertical axis of skeleton arrays (converted to z up), or ``auto``
    (inferred per array from the trunk: :mod:`turn_datasets.up_axis`)."""
    return click.option("--up-axis", type=click.Choice(UP_AXIS_CHOICES), help=help, **kwargs)


def params_options(cls: type, *, prefix: str = "", defaults: object | None = None):
    """Decorator: one click option per field of a parameter dataclass, in field order.

    Each option is ``--<prefix><field-name>`` (underscores as dashes), of the field's type
    checked by :class:`Number` within the field's bounds, its default shown, its help the
    field's (:func:`turn_datasets.params.param`). So a parameter is declared once, in its
    dataclass; :func:`params_from` builds the dataclass back from the parsed options.
    ``defaults``, an instance of ``cls``, gives other defaults than the fields' (a command
    that runs the rule with its own settings, as ``turn-eval detect`` runs the miner's).
    """

    def decorator(f):
        # click collects options bottom-up: apply the last field first so --help lists them
        # in the order the dataclass declares them
        for fld in reversed(param_fields(cls)):
            meta = fld.metadata
            kind = (
                int if isinstance(fld.default, int) and not isinstance(fld.default, bool) else float
            )
            f = click.option(
                f"--{prefix}{fld.name}".replace("_", "-"),
                f"{prefix}{fld.name}",
                type=Number(kind, min=meta["min"], max=meta["max"], min_open=meta["min_open"]),
                default=fld.default if defaults is None else getattr(defaults, fld.name),
                show_default=True,
                help=meta["help"],
            )(f)
        return f

    return decorator


def params_from(cls: type[T], options: dict, *, prefix: str = "") -> T:
    """The dataclass of :func:`params_options`' options, removed from ``options`` (a command's
    keyword arguments), so the command keeps only its own."""
    return cls(**{f.name: options.pop(f"{prefix}{f.name}") for f in param_fields(cls)})


def resamples(min_resamples: int = 0) -> Number:
    """Bootstrap or permutation counts: bounded, so 10^8 is a message, not a MemoryError."""
    return Number(
        int,
        min=min_resamples,
        max=limits.MAX_RESAMPLES,
        why="each resample recomputes every metric; 1000 to 10000 is usual",
    )


#: Resamples of every bootstrap unless ``--bootstrap`` says otherwise (sacrebleu's default).
DEFAULT_RESAMPLES = 1000


def bootstrap_options(resamples_help: str, *, seed_help: str = "Bootstrap seed.", min_resamples=0):
    """Decorator: ``--bootstrap`` (into ``n_resamples``) and ``--seed``, in that order.

    Declared once for every command that resamples: the default count
    (:data:`DEFAULT_RESAMPLES`), its bounds (:func:`resamples`) and seed 0; each command says
    in ``resamples_help`` what it resamples.
    """

    def decorator(f):
        # click collects options bottom-up: the last one first keeps this order in --help
        f = click.option("--seed", type=SEED, default=0, show_default=True, help=seed_help)(f)
        return click.option(
            "--bootstrap",
            "n_resamples",
            type=resamples(min_resamples),
            default=DEFAULT_RESAMPLES,
            show_default=True,
            help=resamples_help,
        )(f)

    return decorator


class _NonEmptyPath(click.Path):
    """click's Path, refusing the empty string: ``--out-dir ''`` became ``Path('')``, the
    working folder, and a command wrote its files there."""

    def convert(self, value, param, ctx):
        if isinstance(value, str) and not value.strip():
            self.fail("is empty; give a file or folder name", param, ctx)
        return super().convert(value, param, ctx)


def _refuse_empty_paths(command: click.Command) -> click.Command:
    # Done here, where every command is loaded, so no command (nor a new one) can miss it.
    for p in command.params:
        if isinstance(p.type, click.Path) and not isinstance(p.type, _NonEmptyPath):
            t = p.type
            p.type = _NonEmptyPath(
                exists=t.exists,
                file_okay=t.file_okay,
                dir_okay=t.dir_okay,
                writable=t.writable,
                readable=t.readable,
                resolve_path=t.resolve_path,
                allow_dash=t.allow_dash,
                path_type=t.type,
                executable=t.executable,
            )
    return command


#: click settings every command and group shares: ``-h`` as ``--help``, 100 columns of help.
CONTEXT_SETTINGS = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


def lazy_group(commands: Mapping[str, str], parent: click.Group | None = None):
    """Decorator: a :class:`LazyGroup` of ``commands`` (name -> module), under ``parent``.

    Without ``parent`` it makes a top-level group (a console script's own); every group gets
    :data:`CONTEXT_SETTINGS`.
    """
    make = click.group if parent is None else parent.group
    return make(cls=LazyGroup, context_settings=CONTEXT_SETTINGS, lazy_commands=commands)


class LazyGroup(click.Group):
    """A click group whose commands are imported only when one is asked for.

    ``lazy_commands`` maps a command name to the module that defines it; importing that
    module registers the command on this group (``@group.command(...)``). So
    ``turn-datasets h36m mine`` loads the miner but not scikit-learn or pympi, which only
    other commands need, and ``--version`` loads no command at all.
    """

    def __init__(self, *args, lazy_commands: Mapping[str, str] | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.lazy_commands = dict(lazy_commands or {})

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(super().list_commands(ctx)) | set(self.lazy_commands))

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self.commands and cmd_name in self.lazy_commands:
            importlib.import_module(self.lazy_commands[cmd_name])
        command = super().get_command(ctx, cmd_name)
        return None if command is None else _refuse_empty_paths(command)
