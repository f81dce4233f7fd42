"""Small things a careless input still showed (issue 10, #18): library warnings on stderr,
Markdown broken or made live by a group's name, an empty output path, "1 clips", counts
printed as 235.0, and a closed stdout taken for success."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import click
import matplotlib.axes
import numpy as np
import pytest
from conftest import run_cli as _run

from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_eval.cli import cli as eval_cli

REFERENCE = (
    "clip_id,angle_deg,duration_s,location\n"
    'a,90,1.0,"<script>alert(1)</script>"\n'
    'b,180,2.0,"hall|way\nupstairs"\n'
    "c,45,0.5,kitchen\n"
)
PREDICTIONS = "clip_id,angle_deg\na,92.5\nb,170\nc,40\n"


@pytest.fixture()
def files(tmp_path: Path) -> tuple[Path, Path]:
    ref = tmp_path / "ref.csv"
    ref.write_text(REFERENCE)
    pred = tmp_path / "pred.csv"
    pred.write_text(PREDICTIONS)
    return pred, ref


def test_library_warnings_do_not_reach_stderr(capsys):
    @click.group()
    def group() -> None:
        pass

    @group.command()
    def noisy() -> None:
        np.mean(np.array([]))  # numpy: "Mean of empty slice"
        warnings.warn(
            'Creating legend with loc="best" can be slow with large amounts of data.', stacklevel=2
        )
        click.echo("done")

    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")  # as Python shows them on stderr, each time
        code, out, err = _run(group, "x", ["noisy"], capsys)
    assert code == 0 and out == "done\n"
    assert [str(w.message) for w in shown] == []
    assert "Warning" not in err and "slice" not in err and "legend" not in err


def test_every_figure_legend_has_a_fixed_place(files, tmp_path, capsys, monkeypatch):
    calls: list[dict] = []
    real = matplotlib.axes.Axes.legend

    def legend(self, *args, **kwargs):
        calls.append(kwargs)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.axes.Axes, "legend", legend)
    pred, ref = files
    code, _, err = _run(
        eval_cli,
        "turn-eval",
        ["score", pred, "-r", ref, "--bootstrap", "0", "--out-dir", tmp_path / "o", "--plots"],
        capsys,
    )
    assert code == 0, err
    assert calls and all(c.get("loc", "best") != "best" for c in calls)


def test_group_names_cannot_break_or_script_the_markdown(files, capsys):
    pred, ref = files
    code, out, err = _run(
        eval_cli,
        "turn-eval",
        ["score", pred, "-r", ref, "--bootstrap", "0", "--by", "location"],
        capsys,
    )
    assert code == 0, err
    assert "<script>" not in out and "&lt;script>alert(1)&lt;/script>" in out
    header = next(line for line in out.splitlines() if line.startswith("| location |"))
    assert " | hall\\|way upstairs | " in header
    # every row of a table has as many cells as its header (no cell broke the row)
    tables: list[list[str]] = [[]]
    for line in out.splitlines():
        if line.startswith("|"):
            tables[-1].append(line)
        elif tables[-1]:
            tables.append([])
    for table in filter(None, tables):
        assert len({line.replace("\\|", "").count("|") for line in table}) == 1, table


@pytest.mark.parametrize(
    "group, prog, args",
    [
        (eval_cli, "turn-eval", ["score", "{pred}", "-r", "{ref}", "--out-dir", ""]),
        (eval_cli, "turn-eval", ["predict", "{pred}", "--layout", "h36m17", "--out", ""]),
        (datasets_cli, "turn-datasets", ["remap", "agreement", "{pred}", "--out-dir", ""]),
    ],
)
def test_an_empty_output_path_is_refused_not_the_working_folder(
    files, capsys, monkeypatch, tmp_path, group, prog, args
):
    pred, ref = files
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    args = [a.format(pred=pred, ref=ref) for a in args]
    code, _, err = _run(group, prog, args, capsys)
    assert code == EXIT_BAD_INPUT and "is empty" in err
    assert list(work.iterdir()) == []


def test_one_clip_is_one_clip(tmp_path, capsys):
    from turn_datasets.synthetic import mocap as sm

    segs = [sm.Segment.stand(1.0), sm.Segment.walk(2.0, 1.2), sm.Segment.pivot_turn(90.0, 1.4)]
    segs += [sm.Segment.walk(2.0, 1.2), sm.Segment.stand(1.0)]
    arr = tmp_path / "walk.npy"
    np.save(arr, sm.generate_sequence(seed=1, segments=segs, noise_mm=5.0).positions)
    code, _, err = _run(
        datasets_cli,
        "turn-datasets",
        [
            "h36m",
            "mine",
            arr,
            "--layout",
            "h36m32",
            "--fps",
            "50",
            "--up-axis",
            "z",
            "--units",
            "mm",
            "--out",
            tmp_path / "o.csv",
        ],
        capsys,
    )
    assert code == 0, err
    assert "wrote 1 clip from 1 sequence to" in err and "(1 file read)" in err


def test_csv_prints_counts_as_integers(files, tmp_path, capsys):
    pred, ref = files
    code, out, err = _run(
        eval_cli,
        "turn-eval",
        [
            "score",
            pred,
            "-r",
            ref,
            "--bootstrap",
            "0",
            "--by",
            "location",
            "--format",
            "csv",
            "--out-dir",
            tmp_path / "o",
        ],
        capsys,
    )
    assert code == 0, err
    lines = out.splitlines()
    assert lines[1].startswith("overall,all,3,")
    assert (tmp_path / "o" / "scores.csv").read_text().splitlines()[1].startswith("overall,all,3,")
    assert any(line.startswith("location,avg,1,") for line in lines)  # 3 groups of 1: mean 1


def test_a_closed_stdout_is_an_error_not_silence(files):
    pred, ref = files
    proc = subprocess.run(
        [sys.executable, "-m", "turn_eval", "score", str(pred), "-r", str(ref), "--bootstrap", "0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        # fd 1 closed in the child, as `>&-` does in a shell
        preexec_fn=lambda: __import__("os").close(1),
    )
    assert proc.returncode == EXIT_BAD_INPUT
    assert "standard output is closed" in proc.stderr
