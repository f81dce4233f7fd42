"""The demo's untrimmed stage on a small label table: streams, detect, score-events, report."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from turn_datasets.cli.common import run_group
from turn_datasets.synthetic.untrimmed import write_untrimmed_corpus
from turn_eval.cli import cli
from turn_eval.demo.untrimmed import UNTRIMMED_DIR, run_untrimmed_stage, untrimmed_section
from turn_eval.report import Report


def test_stage_plants_the_labels_detects_scores_and_reports(tmp_path: Path) -> None:
    corpus = tmp_path / "corpus"
    write_untrimmed_corpus(corpus, seed=4, n_pairs=2, duration_s=90.0)
    ran: list[list[str]] = []

    def run_eval(args):
        ran.append(list(args))
        assert run_group(cli, "turn-eval", list(args)) == 0
        return ""

    res = run_untrimmed_stage(
        tmp_path / "demo",
        labels=corpus / "labels.csv",
        context=corpus / "context.csv",
        sessions=corpus / "sessions.csv",
        seed=1,
        run_eval=run_eval,
        max_sessions=1,
    )
    assert [a[0] for a in ran] == ["detect", "score-events"]
    assert "--min-turn-deg" in ran[0] and ran[0][ran[0].index("--min-turn-deg") + 1] == "67.5"
    assert res.folder == tmp_path / "demo" / UNTRIMMED_DIR
    # --quick's cut: one session's two people, scored against that session's labels only
    assert sorted(p.name for p in res.streams.glob("*.npz")) == ["home01.npz"]
    labels = pd.read_csv(corpus / "labels.csv")
    n_home01 = int((labels.session == "home01").sum())
    overall = res.scores["overall"]
    assert overall["tp"] + overall["fn"] == n_home01
    assert overall["f1"] >= 0.85
    report = Report("demo")
    untrimmed_section(report, res)
    html = report.render()
    assert "<h2" in html and "Untrimmed sessions" in html
    assert html.count("data:image/png;base64") == 3  # a timeline, F1 per group, PR curve
