"""The foundation: one error type, atomic writes, CLI exit codes and help."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import click
import pandas as pd
import pytest

from turn_datasets.cli.common import EXIT_BAD_INPUT, EXIT_GATE, run_group
from turn_datasets.errors import GateFailed, TurnbenchError
from turn_datasets.fileio import (
    atomic_path,
    check_not_input,
    staged_dir,
    to_json_text,
    typed_frame,
    write_csv,
)

BIN = Path(sys.executable).parent


def test_error_message_names_where():
    err = TurnbenchError("angle is not a number", file="pred.csv", row=7, hint="use degrees")
    assert str(err) == "pred.csv:7: angle is not a number (hint: use degrees)"
    err = TurnbenchError(
        "value '100' outside the vocabulary", file="s1.eaf", tier="Turn_A", time_s=12.5
    )
    assert str(err) == "s1.eaf, tier 'Turn_A', at 12.500 s: value '100' outside the vocabulary"
    assert err.where.tier == "Turn_A"


def test_atomic_path_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_staged_dir_moves_all_or_nothing(tmp_path):
    out = tmp_path / "results"
    with pytest.raises(RuntimeError):
        with staged_dir(out) as tmp:
            (tmp / "a.json").write_text("{}")
            raise RuntimeError("boom")
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []
    with staged_dir(out) as tmp:
        (tmp / "a.json").write_text("{}")
        (tmp / "plots").mkdir()
        (tmp / "plots" / "b.png").write_bytes(b"x")
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()) == [
        "a.json",
        "plots/b.png",
    ]


def test_csv_and_json_are_reproducible(tmp_path):
    df = pd.DataFrame({"clip_id": ["a", "b"], "angle_deg": [90.5, float("nan")]})
    write_csv(df, tmp_path / "x.csv")
    assert (tmp_path / "x.csv").read_bytes() == b"clip_id,angle_deg\na,90.5\nb,\n"
    assert json.loads(to_json_text({"kappa": float("nan"), "n": 3})) == {"kappa": None, "n": 3}


def test_check_not_input_and_typed_frame(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("x\n")
    with pytest.raises(TurnbenchError, match="overwrite this input"):
        check_not_input(tmp_path / "." / "in.csv", [src])
    out = typed_frame(
        pd.DataFrame({"b": [1.0], "a": ["1"], "c": [0]}), {"a": "string", "b": "int64"}
    )
    assert list(out.columns) == ["a", "b"] and str(out["b"].dtype) == "int64"


def test_run_group_maps_errors_to_exit_codes(capsys):
    @click.group()
    def g():
        pass

    @g.command()
    def bad():
        raise TurnbenchError("no such column 'angle_deg'", file="p.csv", row=1)

    @g.command()
    def gate():
        raise GateFailed("kappa 0.41 is below --min-kappa 0.8")

    assert run_group(g, "tb", ["bad"]) == EXIT_BAD_INPUT
    assert capsys.readouterr().err == "tb: error: p.csv:1: no such column 'angle_deg'\n"
    assert run_group(g, "tb", ["gate"]) == EXIT_GATE
    assert run_group(g, "tb", ["nosuch"]) == EXIT_BAD_INPUT
    assert run_group(g, "tb", ["--help"]) == 0


@pytest.mark.parametrize("script", ["turn-datasets", "turn-eval"])
def test_console_scripts_have_version_and_help_with_example(script):
    out = subprocess.run([BIN / script, "--version"], capture_output=True, text=True, check=True)
    assert "0." in out.stdout
    out = subprocess.run([BIN / script, "--help"], capture_output=True, text=True, check=True)
    assert "Example:" in out.stdout


def _all_commands(group: click.Group, prefix=()):
    ctx = click.Context(group)
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        assert cmd is not None, (
            f"{' '.join(prefix + (name,))} is listed but its module defines no such command"
        )
        assert cmd.name == name
        if isinstance(cmd, click.Group):
            yield from _all_commands(cmd, prefix + (name,))
        else:
            yield prefix + (name,), cmd


def test_every_command_help_has_an_example():
    from turn_datasets.cli import cli as datasets_cli
    from turn_eval.cli import cli as eval_cli

    seen = []
    for group in (datasets_cli, eval_cli):
        for path, cmd in _all_commands(group):
            seen.append(path)
            assert "Example" in (cmd.help or ""), f"{' '.join(path)} --help lacks an example"
    assert seen, "no commands registered"


def test_outputs_get_the_umask_permissions_not_owner_only(tmp_path):
    import os

    old = os.umask(0o022)
    try:
        write_csv(pd.DataFrame({"a": [1]}), tmp_path / "x.csv")
        with staged_dir(tmp_path / "d") as tmp:
            (tmp / "y.json").write_text("{}")
            os.chmod(tmp / "y.json", 0o600)
    finally:
        os.umask(old)
    assert (tmp_path / "x.csv").stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "d" / "y.json").stat().st_mode & 0o777 == 0o644


@pytest.mark.parametrize("pkg", ["turn_datasets", "turn_eval"])
def test_python_dash_m_runs_the_same_commands(pkg):
    out = subprocess.run(
        [sys.executable, "-m", pkg, "--help"], capture_output=True, text=True, check=True
    )
    assert "Commands:" in out.stdout and ("score" in out.stdout or "h36m" in out.stdout)


def test_lazy_command_maps_name_every_registered_command():
    """A command module registering a name its group's map lacks would be unreachable."""
    import importlib

    from turn_datasets.cli import h36m, remap
    from turn_datasets.cli.common import LazyGroup
    from turn_eval.cli import cli as eval_cli

    for group in (h36m, remap, eval_cli):
        assert isinstance(group, LazyGroup)
        for module in set(group.lazy_commands.values()):
            importlib.import_module(module)
        assert sorted(group.commands) == sorted(group.lazy_commands), group.name


def test_a_command_loads_only_its_own_module():
    code = (
        "import sys; from turn_datasets.cli import main\n"
        "try:\n    main(['h36m', 'mine', '--help'])\nexcept SystemExit:\n    pass\n"
        "print('LOADED', sorted(m for m in sys.modules if m.startswith(('sklearn', 'pympi', 'turn_datasets.cli.'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = out.stdout.split("LOADED", 1)[1]
    assert "turn_datasets.cli.mine" in loaded
    assert "sklearn" not in loaded and "pympi" not in loaded and "cli.agreement" not in loaded


def test_usage_and_os_errors_are_one_line_exit_2(capsys, tmp_path):
    @click.group()
    def g():
        pass

    @g.command()
    @click.argument("src", type=click.Path(exists=True))
    def read(src):
        pass

    @g.command()
    def write():
        (tmp_path / "blocker").write_text("x")
        with open(tmp_path / "blocker" / "out.csv", "w"):  # a file where a folder should be
            pass

    assert run_group(g, "tb", ["read", str(tmp_path / "nope.csv")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tb: error: ") and "nope.csv" in err
    assert "(see 'tb read --help')" in err
    assert run_group(g, "tb", ["write"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err == f"tb: error: {tmp_path / 'blocker' / 'out.csv'}: Not a directory\n"
