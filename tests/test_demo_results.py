"""The README's demo results are the full demo's own output, in every supported environment.

The full demo (``make demo``'s corpus and settings) runs once here, so the suite checks
what the README claims: the scores table, the untrimmed stage's detections and the
agreement audit, as :mod:`turn_eval.demo.results` writes them. ``make test`` runs this in
``.venv`` (NumPy 2.x) and in ``.venv-video`` (NumPy 1.26): both must give the README's
block, so the two environments give the same detections. They did not: 1358 turns against
1359, a tie in the synthetic streams broken by the last bit of NumPy's trigonometry; then 6
of 1390 turns with other boundaries, a stride's valid-pair count of exactly its threshold
that the two versions' FFTs put on either side of it (``test_miner`` pins it). The angles'
last digits still differ: the two versions vectorise ``arctan2`` differently (1 ulp in a
third of the frames); the C library's ``atan2`` element by element would make them equal
at a tenth of ``detect``'s time, so what is held equal is every decision: the block
carries the fingerprint of each turn's stream, frames, direction, angle to 0.01°, steps and
type (``decisions_fingerprint``), and both environments must print it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from turn_datasets.errors import TurnbenchError
from turn_eval.demo import run as demo
from turn_eval.demo.results import END, START, readme_block, replace_block, results_block

README = Path(__file__).resolve().parents[1] / "README.md"


@pytest.fixture(scope="module")
def full_demo(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("full") / "demo-output"
    capture = pytest.MonkeyPatch()
    capture.setattr(demo, "_say", lambda text="": None)
    try:
        demo.run_demo(out)  # make demo's corpus, seed and bootstrap
    finally:
        capture.undo()
    return out


def test_the_readme_shows_what_the_full_demo_prints(full_demo: Path) -> None:
    block = results_block(full_demo)
    assert readme_block(README.read_text(encoding="utf-8")) == block, (
        "README.md's demo results differ from the demo's output: run make demo, then "
        ".venv/bin/python -m turn_eval.demo.results demo-output README.md"
    )


def test_the_untrimmed_stage_finds_the_same_turns_in_every_environment(full_demo: Path) -> None:
    """The detections' count and the matched turns, against the README's (one figure for
    both NumPy versions), read from the detections file itself."""
    import pandas as pd

    detections = pd.read_csv(full_demo / "untrimmed" / "detections.csv")
    text = readme_block(README.read_text(encoding="utf-8"))
    found = text.split("`detect` finds ", 1)[1]
    tp = int(found.split(" of ", 1)[0])
    fp = int(found.split(" with ", 1)[1].split(" false", 1)[0])
    assert len(detections) == tp + fp


def _readme_words() -> str:
    """The README with every run of white space one blank (its lines wrap anywhere)."""
    return " ".join(README.read_text(encoding="utf-8").split())


def test_the_readmes_miner_check_is_the_full_demos(full_demo: Path) -> None:
    """The README's planted range (step 1) and its miner figures on the demo corpus (the
    miner's rule section), from the full demo's planted turns, clip index and matches."""
    import numpy as np
    import pandas as pd

    from turn_datasets.render.numbers import fixed

    planted = pd.read_csv(full_demo / "corpus" / "h36m" / "planted.csv")
    matched = pd.read_csv(full_demo / "h36m" / "miner-check.csv")
    index = pd.read_csv(full_demo / "h36m" / "turn-h36m.csv")
    found = matched[matched["found"]]
    big = found[found["angle_deg"] >= 60.0]
    assert len(matched) == len(planted)
    # the README says "100% (all N)" of both: a turn missed or a spurious clip changes it
    assert len(found) == len(matched)
    assert set(index["clip_id"]) <= set(found["clip_id"])

    def median(frame: pd.DataFrame, column: str) -> str:
        return fixed(np.median(np.abs(frame[column])), 2)

    angle = fixed(np.median(np.abs(found["mined_angle_deg"] - found["angle_deg"])), 1)
    low, high = (fixed(v, 0) for v in (planted["angle_deg"].min(), planted["angle_deg"].max()))
    text = _readme_words()
    for claim in (
        f"Turns with heading changes of {low}° to {high}° are planted",
        f"Measured on the demo corpus ({len(planted)} planted turns,",
        f"recall of the planted turns: 100% (all {len(planted)});",
        "mined clips that cover a planted turn: 100%;",
        f"median angle error against the planted heading change: {angle}°;",
        f"median boundary error: {median(found, 'start_error_s')} s at the start and "
        f"{median(found, 'end_error_s')} s at the end ({median(big, 'start_error_s')} s and "
        f"{median(big, 'end_error_s')} s for turns of 60° or more).",
    ):
        assert claim in text, claim


def test_the_readmes_remap_open_and_untrimmed_figures_are_the_full_demos(full_demo: Path) -> None:
    """The README's REMAP Open figures (step 8 and "What to expect against the paper": turns,
    participants, the net method's scores) and the untrimmed stage's hours of streams and
    timelines, from the full demo's own files."""
    import json

    import pandas as pd

    from turn_datasets.render.numbers import fixed

    labels = pd.read_csv(full_demo / "remap-open" / "data" / "labels.csv")
    scores = json.loads((full_demo / "remap-open" / "scores" / "scores.json").read_text())
    overall = scores["overall"]
    turns, people = len(labels), labels["subject"].nunique()
    assert overall["n"] == turns
    recorded = pd.read_csv(full_demo / "untrimmed" / "recorded_sessions.csv")
    hours = fixed(recorded["duration_s"].sum() / 3600.0, 1)
    timelines = len(list((full_demo / "untrimmed" / "events" / "timelines").glob("*.png")))
    text = _readme_words()
    for claim in (
        f"{people} participants, {turns} turns, an `.xlsx` rater spreadsheet",
        f"({turns} turns of {people} participants, clean synthetic",
        f"the net method scores {fixed(100 * overall['accuracy'], 1)}% accuracy, "
        f"{fixed(overall['mae_deg'], 1)}° MAE and {fixed(100 * overall['wprec'], 1)}% WPrec",
        f"for its {turns} turns)",
        f"writes and scores {hours} hours of streams with {timelines} timelines",
    ):
        assert claim in text, claim


def test_results_block_by_hand(tmp_path: Path) -> None:
    """The block's figures from hand-made result files: percentages with one decimal, the
    speed MAE blank where absent, the untrimmed counts and both kappas."""
    import json

    def scores(folder: str, method: str, acc: float, mae: float, wprec: float, speed) -> None:
        p = tmp_path / folder / f"scores-{method}" / "scores.json"
        p.parent.mkdir(parents=True)
        overall = {"n": 10, "accuracy": acc, "mae_deg": mae, "wprec": wprec}
        p.write_text(json.dumps({"overall": {**overall, "mae_speed_deg_s": speed}}))

    scores("h36m", "paper", 0.6034, 17.25, 0.6421, 15.04)
    scores("h36m", "net", 0.7, 10.0, 0.75, None)
    scores("remap", "paper", 0.5, 20.0, 0.7, 9.95)
    scores("remap", "net", 0.8, 12.0, 0.9, 6.0)
    ev = tmp_path / "untrimmed" / "events" / "event_scores.json"
    ev.parent.mkdir(parents=True)
    ev.write_text(
        json.dumps(
            {
                "overall": {
                    "tp": 9,
                    "fp": 1,
                    "fn": 1,
                    "f1": 0.9,
                    "matched": {"accuracy": 1.0, "mae_deg": 2.25},
                }
            }
        )
    )
    (tmp_path / "untrimmed" / "detections.csv").write_text(
        "session,subject,start_s,end_s,angle_deg,direction,steps,turn_type\n"
        "s1,P1,1.0,2.5,90.004,left,,\n",
        encoding="utf-8",
    )
    ag = tmp_path / "remap" / "agreement" / "agreement.json"
    ag.parent.mkdir(parents=True)
    ag.write_text(
        json.dumps(
            {
                "kappa": 0.9684,
                "kappa_ci95": [0.95, 0.98],
                "matched": 674,
                "kappa_with_unmatched": 0.925,
            }
        )
    )
    block = results_block(tmp_path)
    assert (
        "| Turn-H3.6M-like | 10 | paper (eq. 3 as printed) | 60.3% | 17.3° | 64.2% | 15.0°/s |"
        in block
    )
    assert "| Turn-H3.6M-like | 10 | net | 70.0% | 10.0° | 75.0% | – |" in block
    assert "finds 9 of the 10 labelled turns with 1 false detections (F1 90.0%)" in block
    assert "kappa 0.968 (95% CI 0.950 to 0.980) over 674 matched turns, and 0.925" in block
    import hashlib

    print_ = hashlib.sha256(b"s1|P1|30|75|left|90.00||").hexdigest()[:12]
    assert f"have the fingerprint `{print_}` in every supported environment." in block
    readme = f"intro\n{START}\nold\n{END}\nrest\n"
    assert replace_block(readme, block) == f"intro\n{START}\n{block}{END}\nrest\n"
    with pytest.raises(TurnbenchError, match="no demo-results markers"):
        readme_block("no markers here")


def test_the_decisions_fingerprint_names_decisions_not_last_digits(tmp_path: Path) -> None:
    import hashlib

    from turn_eval.demo.results import decisions_fingerprint

    head = "session,subject,start_s,end_s,angle_deg,direction,steps,turn_type\n"
    a = tmp_path / "a.csv"
    a.write_text(
        head + "s1,P1,18.166666666666668,20.833333333333332,177.01782050972915,left,3.0,step\n",
        encoding="utf-8",
    )
    # the same turn, its angle one ulp away and its times as another writer prints them
    b = tmp_path / "b.csv"
    b.write_text(
        head + "s1,P1,18.16666666666667,20.83333333333333,177.01782050972912,left,3.0,step\n",
        encoding="utf-8",
    )
    # one frame later
    c = tmp_path / "c.csv"
    c.write_text(
        head + "s1,P1,18.2,20.833333333333332,177.01782050972915,left,3.0,step\n", encoding="utf-8"
    )
    want = hashlib.sha256(b"s1|P1|545|625|left|177.02|3.0|step").hexdigest()[:12]
    assert decisions_fingerprint(a) == decisions_fingerprint(b) == want
    assert decisions_fingerprint(c) != want
