"""Every numeric option of every command is finite and in a sensible range (issue 10, #1, #14).

The check lives in one place (:class:`turn_datasets.cli.common.Number`); these tests walk
both command-line tools so that a new option with click's bare ``float`` (which lets ``nan``
and ``inf`` through) fails here.
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
import pytest
from conftest import run_cli as _run

from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT, Number
from turn_eval.cli import cli as eval_cli

REFERENCE = "clip_id,angle_deg,duration_s\na,90,1.0\nb,180,2.0\nc,45,0.5\nd,135,1.5\n"
PREDICTIONS = "clip_id,angle_deg\na,92.5\nb,170\nc,40\nd,100\n"


def _commands(group: click.Group, ctx: click.Context):
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        if isinstance(cmd, click.Group):
            yield from _commands(cmd, click.Context(cmd, parent=ctx, info_name=name))
        else:
            yield f"{ctx.command_path} {name}", cmd


def _all_commands():
    for group, prog in ((datasets_cli, "turn-datasets"), (eval_cli, "turn-eval")):
        yield from _commands(group, click.Context(group, info_name=prog))


def _numeric_params():
    numeric = (click.types.FloatParamType, click.types.IntParamType, Number)
    for path, cmd in _all_commands():
        for p in cmd.params:
            if isinstance(p.type, numeric):
                yield path, p


def test_every_numeric_option_uses_the_one_checked_type():
    params = list(_numeric_params())
    assert len(params) >= 15  # mine alone has 8; score, compare, agreement, predict, export
    loose = [f"{path} {p.opts[0]}" for path, p in params if not isinstance(p.type, Number)]
    assert loose == []


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e308", "-1e308"])
def test_no_numeric_option_accepts_a_non_finite_or_absurd_value(value):
    for path, p in _numeric_params():
        if p.type.kind is int and value in ("nan", "inf", "-inf"):
            with pytest.raises(click.BadParameter):
                p.type.convert(value, p, None)
            continue
        if p.type.kind is int:
            value = str(int(float(value)))
        with pytest.raises(click.BadParameter):
            p.type.convert(value, p, None)
            pytest.fail(f"{path} {p.opts[0]} accepted {value}")


@pytest.fixture()
def score_files(tmp_path: Path) -> tuple[Path, Path]:
    ref = tmp_path / "ref.csv"
    ref.write_text(REFERENCE)
    pred = tmp_path / "pred.csv"
    pred.write_text(PREDICTIONS)
    return pred, ref


@pytest.mark.parametrize("value", ["nan", "inf", "0", "-45", "361"])
def test_score_refuses_a_bin_width_that_would_make_every_clip_right(score_files, capsys, value):
    pred, ref = score_files
    code, out, err = _run(
        eval_cli, "turn-eval", ["score", pred, "-r", ref, "--bin-width-deg", value], capsys
    )
    assert code == EXIT_BAD_INPUT and out == ""
    assert "--bin-width-deg" in err and len(err.strip().splitlines()) == 1


def test_bootstrap_has_an_upper_bound_with_a_message_not_a_memory_error(score_files, capsys):
    pred, ref = score_files
    code, out, err = _run(
        eval_cli, "turn-eval", ["score", pred, "-r", ref, "--bootstrap", "100000000"], capsys
    )
    assert code == EXIT_BAD_INPUT and out == ""
    assert "--bootstrap" in err and "100000" in err and "1000 to 10000 is usual" in err


def test_bootstrap_at_its_bound_is_accepted():
    params = {f"{path} {p.opts[0]}": p for path, p in _numeric_params()}
    p = params["turn-eval score --bootstrap"]
    assert p.type.convert("100000", p, None) == 100_000


def test_predict_fps_nan_and_huge_are_refused_by_the_option_not_the_file(tmp_path, capsys):
    arr = tmp_path / "clip.npy"
    np.save(arr, np.zeros((10, 17, 3)))
    for value in ("nan", "1e400", "1e308"):
        code, out, err = _run(
            eval_cli,
            "turn-eval",
            ["predict", arr, "--layout", "h36m17", "--fps", value, "--out", tmp_path / "p.csv"],
            capsys,
        )
        assert code == EXIT_BAD_INPUT, err
        assert "--fps" in err and str(arr) not in err


@pytest.mark.parametrize(
    "option, value", [("--fps", "1e308"), ("--max-gap-s", "1e308"), ("--smooth-s", "inf")]
)
def test_mine_huge_fps_or_gap_is_one_line_not_a_traceback(tmp_path, capsys, option, value):
    arr = tmp_path / "x.npy"
    np.save(arr, np.zeros((100, 17, 3)))
    args = ["h36m", "mine", arr, "--layout", "h36m17", "--fps", "50", "--out", tmp_path / "o.csv"]
    code, out, err = _run(datasets_cli, "turn-datasets", [*args, option, value], capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert "Traceback" not in err and option in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.csv").exists()


def test_min_kappa_below_zero_warns_but_runs():
    params = {f"{path} {p.opts[0]}": p for path, p in _numeric_params()}
    p = params["turn-datasets remap agreement --min-kappa"]
    with pytest.raises(click.BadParameter):
        p.type.convert("-1.5", p, None)
    assert p.type.convert("-0.5", p, None) == -0.5


def test_min_kappa_below_zero_warns_on_stderr(capsys):
    cmd = datasets_cli.get_command(click.Context(datasets_cli), "remap")
    agreement = cmd.get_command(click.Context(cmd), "agreement")
    p = next(p for p in agreement.params if p.name == "min_kappa")
    ctx = click.Context(agreement)
    assert p.process_value(ctx, -0.5) == -0.5
    err = capsys.readouterr().err
    assert "--min-kappa -0.5 is below 0" in err and err.startswith("warning:")
    assert p.process_value(ctx, 0.2) == 0.2
    assert capsys.readouterr().err == ""
