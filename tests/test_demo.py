"""``python -m turn_eval.demo``: every step runs through the real commands and lands where the
demo says, the gate passes, the report holds it all, and the demo's own outputs repeat.

The demo runs once per module on its ``--quick`` corpus (the full one is ``make demo``'s,
timed in the report to the lead, not here).
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import re
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pandas as pd
import pytest

from turn_datasets.cli.common import Terminated, run_group
from turn_datasets.fileio import write_run_record
from turn_datasets.synthetic.degrade import degrade_skeleton
from turn_datasets.synthetic.demo_corpus import (
    write_h36m_corpus,
    write_h36m_estimates,
    write_remap_corpus,
    write_remap_estimates,
)
from turn_eval import cli as eval_cli
from turn_eval.demo import run as demo
from turn_eval.demo.untrimmed import telling_timeline


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "demo-output"
    capture = pytest.MonkeyPatch()
    lines: list[str] = []
    capture.setattr(demo, "_say", lambda text="": lines.append(text))
    try:
        results = demo.run_demo(out, quick=True, bootstrap=100)
    finally:
        capture.undo()
    return out, results, "\n".join(lines)


def test_every_result_listed_exists(ran) -> None:
    out, results, printed = ran
    assert len(results) >= 20
    for what, path in results.items():
        assert Path(path).exists(), what
        assert out in Path(path).parents or Path(path) == out / "report.html"
    # the run ends by saying where each result is, the generated corpus included
    tail = printed[printed.index("Where each result is:") :]
    for path in results.values():
        assert str(path) in tail
    listed = set(results.values())
    for rel in (
        "corpus/h36m",
        "corpus/h36m/planted.csv",
        "corpus/remap/eaf",
        "corpus/remap/participants.csv",
        "h36m/compare.json",
        "remap/compare.json",
        "h36m/compare-figures",
        "remap/compare-figures",
    ):
        assert out / rel in listed, rel


def test_it_runs_the_commands_users_run(ran) -> None:
    _, _, printed = ran
    commands = [line[2:] for line in printed.splitlines() if line.startswith("$ ")]
    verbs = [
        " ".join(c.split()[:3]) if c.startswith("turn-datasets") else " ".join(c.split()[:2])
        for c in commands
    ]
    for expected in (
        "turn-datasets h36m mine",
        "turn-datasets h36m stats",
        "turn-datasets remap labels",
        "turn-datasets remap stats",
        "turn-datasets remap agreement",
        "turn-eval predict",
        "turn-eval score",
        "turn-eval compare",
        "turn-datasets remap open",
    ):
        assert expected in verbs, expected
    # both methods, both sets, and the REMAP Open stage's one of each
    assert sum(v == "turn-eval predict" for v in verbs) == 4 + 1
    assert sum(v == "turn-eval score" for v in verbs) == 4 + 1
    assert "Table 3: clips per angle bin" in printed
    assert "--min-kappa 0.8" in printed


def test_the_gate_passes_and_agrees_with_the_printed_line(ran) -> None:
    out, _, printed = ran
    audit = json.loads((out / "remap" / "agreement" / "agreement.json").read_text())
    assert audit["kappa"] >= demo.MIN_KAPPA
    assert f"Cohen's kappa {audit['kappa']:.3f}" in printed
    assert list((out / "remap" / "agreement" / "review").glob("*.eaf"))


def test_predictions_cover_every_reference_clip(ran) -> None:
    out, _, _ = ran
    for folder, reference in (("h36m", "turn-h36m.csv"), ("remap", "labels.csv")):
        ref = pd.read_csv(out / folder / reference)
        for method in demo.METHODS:
            pred = pd.read_csv(out / folder / f"predictions-{method}.csv")
            assert sorted(pred["clip_id"]) == sorted(ref["clip_id"])
            scores = json.loads((out / folder / f"scores-{method}" / "scores.json").read_text())
            assert scores["overall"]["n"] == len(ref)
            assert scores["settings"]["bootstrap"] == 100
            assert len(list((out / folder / f"scores-{method}").glob("*.png"))) >= 2
        assert (out / folder / "compare.md").read_text().count("signature:") == 1


def test_net_is_no_worse_than_equation_3_on_the_degraded_skeletons(ran) -> None:
    # equation 3 adds the magnitude of every frame-to-frame rotation, so on skeletons with
    # jitter it can only overshoot the net rotation (|sum of steps| <= sum of |steps|): its
    # predictions are never below net's, clip by clip
    out, _, _ = ran
    for folder in ("h36m", "remap"):
        paper = pd.read_csv(out / folder / "predictions-paper.csv").set_index("clip_id")
        net = pd.read_csv(out / folder / "predictions-net.csv").set_index("clip_id")
        assert (paper["angle_deg"] >= net.loc[paper.index, "angle_deg"] - 1e-6).all()


def test_report_is_one_self_contained_page_with_everything(ran) -> None:
    out, _, _ = ran
    text = (out / "report.html").read_text(encoding="utf-8")
    assert "<script" not in text.lower() and "<link" not in text.lower()
    sources = re.findall(r'src="([^"]+)"', text)
    # the figures on the page, byte for byte: `score --plots`' 4 figures once per set, the
    # two methods side by side on shared axes (`compare --plots-dir`: 2 x 4; each method's
    # own stay in its scores folder), the audit's confusion matrix (1)
    assert len(list(out.glob("*/scores-*/*.png"))) == 2 * 2 * 4
    pngs = sorted(out.glob(f"*/{demo.COMPARE_FIGURES}/*.png"))
    pngs += sorted(out.glob("remap/agreement/*.png"))
    assert len(pngs) == 2 * 4 + 1
    # and the untrimmed sessions' (issue 13): one session's timeline, F1 per group, PR curve
    events = out / "untrimmed" / "events"
    # the session shown is one with a false and a missed detection where there is one
    timeline = telling_timeline(events)
    assert timeline is not None
    pngs += [timeline]
    pngs += [events / "f1_by_group.png", events / "pr_curve.png"]
    # and the turning profile's (issue 22): the forest plot, the distributions, a heat map
    profile = out / "untrimmed" / "profile"
    pngs += [profile / "forest.png", profile / "distributions.png"]
    pngs += [sorted((profile / "heatmaps").glob("*.png"))[0]]
    assert len(sources) == len(pngs)
    embedded = set()
    for src in sources:
        assert src.startswith("data:image/png;base64,")
        embedded.add(base64.b64decode(src.split(",", 1)[1]))
    assert embedded == {p.read_bytes() for p in pngs}
    # nothing is fetched from elsewhere: no address at all outside the embedded images
    assert not re.search(r"(?:https?:|ftp:|file:|//)[^\s\"<]", re.sub(r"data:[^\"]+", "", text))
    assert "url(" not in text and "@import" not in text
    for needle in (
        "Table 3: clips per angle bin",
        "Table 1: subjects and turns per cohort",
        "Table 2: turns per scenario and angle",
        "Inter-rater agreement",
        "Turn-H3.6M scores",
        "Turn-REMAP scores",
        "McNemar",
        "Avg.",
        "# Turns",
    ):
        assert needle in text, needle
    # no absolute file paths from the disagreements table
    assert str(out / "corpus") not in text.split("Disagreements to review")[1].split("</table>")[0]


def test_miner_check_against_planted_turns(ran) -> None:
    out, _, _ = ran
    matched = pd.read_csv(out / "h36m" / "miner-check.csv")
    planted = pd.read_csv(out / "corpus" / "h36m" / "planted.csv")
    assert len(matched) == len(planted)
    # the target for the miner: at least 98% of planted turns of 60° or more found
    big = matched[matched["angle_deg"] >= 60.0]
    assert big["found"].mean() >= 0.98


def test_miner_check_names_the_planted_range(ran) -> None:
    # the first row's label is the range of the planted hip rotations, read from planted.csv
    out, _, _ = ran
    planted = pd.read_csv(out / "corpus" / "h36m" / "planted.csv")
    low, high = planted["angle_deg"].min(), planted["angle_deg"].max()
    rows = (out / "h36m" / "miner-check.md").read_text(encoding="utf-8").splitlines()
    assert rows[2].startswith(f"| all ({low:.0f}° to {high:.0f}°) | {len(planted)} |")


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict]] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))

    def handle_data(self, data):
        self.text.append(data)


def test_hostile_group_names_in_a_reference_stay_text(ran, tmp_path: Path) -> None:
    """A room or subject named like markup, scored by the real command, is text in the page."""
    out = tmp_path / "demo-output"
    shutil.copytree(ran[0], out)
    labels = pd.read_csv(out / "remap" / "labels.csv", keep_default_na=False)
    hostile_room = "<script>alert(1)</script>"
    hostile_subject = '"><img src=x onerror=alert(2)>'
    labels["location"] = [hostile_room if i % 2 else "kitchen" for i in range(len(labels))]
    labels["subject"] = [
        hostile_subject if i % 3 == 0 else s for i, s in enumerate(labels["subject"])
    ]
    labels.to_csv(out / "remap" / "labels.csv", index=False)
    for method in demo.METHODS:
        code = run_group(
            eval_cli.cli,
            "turn-eval",
            [
                "score",
                str(out / "remap" / f"predictions-{method}.csv"),
                "--reference",
                str(out / "remap" / "labels.csv"),
                "--out-dir",
                str(out / "remap" / f"scores-{method}"),
                "--plots",
                "--bootstrap",
                "20",
            ],
        )
        assert code == 0
    page_path = demo.write_report(demo.load_results(out), out / "report.html")
    text = page_path.read_text(encoding="utf-8")
    assert hostile_room not in text and "<img src=x" not in text
    page = _Tags()
    page.feed(text)
    names = [t for t, _ in page.tags]
    assert "script" not in names
    # every image is one of the embedded PNGs, none is the planted one
    for tag, attrs in page.tags:
        if tag == "img":
            assert attrs["src"].startswith("data:image/png;base64,")
        assert "onerror" not in attrs
    # ... and a reader sees the names as they are, as table headings
    seen = "".join(page.text)
    assert hostile_room in seen and hostile_subject in seen


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--seed", "-1"], "--seed: -1 is below 0"),
        (["--bootstrap", "0"], "--bootstrap: 0 is below 1"),
        (["--seed", "x"], "'x' is not a whole number"),
    ],
)
def test_bad_options_stop_before_any_work(tmp_path: Path, capsys, args, message) -> None:
    with pytest.raises(SystemExit) as exc:
        demo.main(["--out-dir", str(tmp_path / "out"), "--quick", *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_an_unwritable_out_dir_is_one_line_and_exit_2(tmp_path: Path, capsys) -> None:
    a_file = tmp_path / "taken"
    a_file.write_text("not a folder", encoding="utf-8")
    assert demo.main(["--out-dir", str(a_file), "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"error: {a_file}: --out-dir is a file, not a folder"]
    # a folder below a file cannot be made: the OS's error, in one line
    assert demo.main(["--out-dir", str(a_file / "below"), "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("demo failed:") and str(a_file) in err[0]
    assert a_file.read_text(encoding="utf-8") == "not a folder"


def test_disagreements_table_for_the_page(tmp_path: Path) -> None:
    path = tmp_path / "disagreements.csv"
    path.write_text(
        "session,participant,kind,angle_a_deg,angle_b_deg,file\n"
        "s1,NA,angle,135.0,180.0,/home/me/s1.eaf\n"
        "None,P2,unmatched,,90.0,/home/me/None.eaf\n",
        encoding="utf-8",
    )
    df = demo._disagreements_table(path)
    assert list(df.columns) == ["session", "participant", "kind", "angle_a_deg", "angle_b_deg"]
    assert df.to_dict("list") == {
        "session": ["s1", "None"],
        "participant": ["NA", "P2"],
        "kind": ["angle", "unmatched"],
        "angle_a_deg": ["135", "–"],
        "angle_b_deg": ["180", "90"],
    }


def _previous_run(out: Path, files: dict[str, str]) -> dict[str, str]:
    """A folder as an earlier demo run left it: ``files`` (path -> text) written and listed
    in its run record with their sha256 (worked out here with hashlib)."""
    for rel, text in files.items():
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text(text, encoding="utf-8")
    digests = {rel: hashlib.sha256(text.encode()).hexdigest() for rel, text in files.items()}
    doc = {"written_by": "turnbench", "files": digests}
    (out / demo.RECORD).write_text(json.dumps(doc), encoding="utf-8")
    return digests


def test_prepare_out_dir_removes_only_what_the_record_lists_as_written(tmp_path: Path) -> None:
    out = tmp_path / "demo-output"
    _previous_run(
        out,
        {
            "corpus/h36m/S1/old.cdf": "cdf",
            "h36m/turn-h36m.csv": "index",
            "h36m/table3.md": "table 3",
            "remap/eaf/x.eaf": "eaf",
            "report.html": "page",
        },
    )
    (out / "h36m" / "table3.md").write_text("table 3, annotated", encoding="utf-8")
    (out / "h36m" / "my-notes.txt").write_text("mine", encoding="utf-8")
    (out / "remap" / "eaf" / "fixed.eaf").write_text("my fix", encoding="utf-8")
    (out / "my-notes.txt").write_text("mine too", encoding="utf-8")
    removed = demo.prepare_out_dir(out)
    assert sorted(p.relative_to(out).as_posix() for p in removed) == [
        "corpus/h36m/S1/old.cdf",
        "h36m/turn-h36m.csv",
        "remap/eaf/x.eaf",
        "report.html",
    ]
    left = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    # the user's files, and the listed one the user changed since, are kept
    assert left == [
        demo.RECORD,
        "h36m/my-notes.txt",
        "h36m/table3.md",
        "my-notes.txt",
        "remap/eaf/fixed.eaf",
    ]
    assert (out / "h36m" / "table3.md").read_text(encoding="utf-8") == "table 3, annotated"
    assert json.loads((out / demo.RECORD).read_text(encoding="utf-8"))["files"] == {}
    # a new folder is made, with its (empty) record
    demo.prepare_out_dir(tmp_path / "new" / "deep")
    assert (tmp_path / "new" / "deep" / demo.RECORD).is_file()


def test_a_rerun_replaces_the_demos_files_and_keeps_the_users(tmp_path: Path, monkeypatch) -> None:
    # the steps replaced by two runs' worth of files: the first writes a larger corpus
    runs = iter(
        [
            {"corpus/h36m/S6/Walking.npz": "S6", "h36m/turn-h36m.csv": "first", "report.html": "1"},
            {"h36m/turn-h36m.csv": "second", "report.html": "2"},
        ]
    )

    def steps(out: Path, **kwargs) -> dict[str, Path]:
        for rel, text in next(runs).items():
            (out / rel).parent.mkdir(parents=True, exist_ok=True)
            (out / rel).write_text(text, encoding="utf-8")
        return {}

    monkeypatch.setattr(demo, "_run_steps", steps)
    out = tmp_path / "demo-output"
    demo.run_demo(out, quick=True)
    (out / "h36m" / "my-notes.txt").write_text("mine", encoding="utf-8")
    demo.run_demo(out, quick=True)
    assert (out / "h36m" / "my-notes.txt").read_text(encoding="utf-8") == "mine"
    assert (out / "h36m" / "turn-h36m.csv").read_text(encoding="utf-8") == "second"
    assert not (out / "corpus" / "h36m" / "S6" / "Walking.npz").exists()  # the first run's
    record = json.loads((out / demo.RECORD).read_text(encoding="utf-8"))["files"]
    assert record == {
        "h36m/turn-h36m.csv": hashlib.sha256(b"second").hexdigest(),
        "report.html": hashlib.sha256(b"2").hexdigest(),
    }


def test_a_stopped_run_is_recorded_so_the_next_one_removes_its_files(
    tmp_path: Path, monkeypatch
) -> None:
    def steps(out: Path, **kwargs) -> dict[str, Path]:
        (out / "corpus" / "h36m").mkdir(parents=True)
        (out / "corpus" / "h36m" / "half.cdf").write_text("half", encoding="utf-8")
        raise KeyboardInterrupt

    monkeypatch.setattr(demo, "_run_steps", steps)
    out = tmp_path / "demo-output"
    with pytest.raises(KeyboardInterrupt):
        demo.run_demo(out, quick=True)
    assert json.loads((out / demo.RECORD).read_text(encoding="utf-8"))["files"] == {
        "corpus/h36m/half.cdf": hashlib.sha256(b"half").hexdigest()
    }
    assert [p.name for p in demo.prepare_out_dir(out)] == ["half.cdf"]


def test_the_demo_records_every_file_it_wrote(ran) -> None:
    out, _, _ = ran
    record = json.loads((out / demo.RECORD).read_text(encoding="utf-8"))["files"]
    written = {
        p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in out.rglob("*")
        if p.is_file() and p.name != demo.RECORD
    }
    assert record == written
    assert any(name.startswith("corpus/h36m/") for name in record)


@pytest.mark.parametrize("kind", ["symlink", "fifo"])
def test_a_link_or_fifo_in_the_demos_folder_is_refused_in_one_line(
    tmp_path: Path, capsys, kind
) -> None:
    out = tmp_path / "demo-output"
    _previous_run(out, {"h36m/turn-h36m.csv": "index", "corpus/h36m/planted.csv": "subject\n"})
    node = out / "h36m" / ("elsewhere" if kind == "symlink" else "pipe")
    if kind == "symlink":
        node.symlink_to(tmp_path)
    else:
        os.mkfifo(node)
    assert demo.main(["--out-dir", str(out), "--quick"]) == 2
    what = f"a symbolic link to {tmp_path}" if kind == "symlink" else "a FIFO (named pipe)"
    assert capsys.readouterr().err.strip().splitlines() == [
        f"demo failed: {node}: is {what}, not a regular file: refusing to replace it "
        "(hint: choose another --out-dir)"
    ]
    assert os.path.lexists(node) and (node.is_symlink() == (kind == "symlink"))
    assert (out / "h36m" / "turn-h36m.csv").is_file()  # refused before any clean-up


def test_a_file_left_where_the_demo_reads_every_file_is_refused(tmp_path: Path, capsys) -> None:
    out = tmp_path / "demo-output"
    _previous_run(out, {"corpus/h36m/S1/Walking.cdf": "cdf", "report.html": "page"})
    (out / "corpus" / "h36m" / "S7").mkdir()
    (out / "corpus" / "h36m" / "S7" / "Walking.cdf").write_text("mine", encoding="utf-8")
    assert demo.main(["--out-dir", str(out), "--quick"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"demo failed: {out / 'corpus/h36m/S7/Walking.cdf'}: is in corpus, whose every file "
        "the demo reads, and is not a file of the previous demo run as it wrote it (1 such "
        "file there): move it out, or give another --out-dir"
    ]
    # nothing removed: the previous run's files and the user's are all there
    assert (out / "corpus/h36m/S1/Walking.cdf").is_file() and (out / "report.html").is_file()
    assert (out / "corpus/h36m/S7/Walking.cdf").read_text(encoding="utf-8") == "mine"


def test_a_demo_folder_from_before_the_record_is_refused_not_emptied(
    tmp_path: Path, capsys
) -> None:
    out = tmp_path / "demo-output"
    (out / "corpus" / "h36m").mkdir(parents=True)
    (out / "corpus" / "h36m" / "planted.csv").write_text("subject\n", encoding="utf-8")
    (out / demo.MARKER).write_text("", encoding="utf-8")
    assert demo.main(["--out-dir", str(out), "--quick"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"demo failed: {out}: --out-dir holds a demo run from before the demo kept a run "
        f"record ({demo.RECORD}): which of its files are the demo's is not known, and the "
        "demo reads every file in corpus; remove the folder, or give another --out-dir"
    ]
    assert (out / "corpus" / "h36m" / "planted.csv").is_file()


def test_a_folder_that_is_not_the_demos_is_refused(tmp_path: Path, capsys) -> None:
    (tmp_path / "h36m").mkdir()
    (tmp_path / "h36m" / "my-index.csv").write_text("clip_id\n", encoding="utf-8")
    assert demo.main(["--out-dir", str(tmp_path), "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"demo failed: {tmp_path}: --out-dir is not empty and holds no earlier demo run; "
        "give a new or empty folder"
    ]
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["h36m", "my-index.csv"]


def test_a_quick_run_over_a_larger_one_reads_only_its_own_corpus(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    # An earlier run left a larger corpus: more subjects' motion capture and more pairs'
    # sessions. The gate is set out of reach so the run stops after mining and labelling.
    out = tmp_path / "demo-output"
    (out).mkdir()
    write_h36m_corpus(
        out / "corpus" / "h36m", seed=1, subjects=("S6", "S7"), actions={"Walking": (1, 1)}
    )
    write_remap_corpus(out / "corpus" / "remap", seed=1, n_pairs=5)
    # as that run recorded them: every file it wrote, with its sha256
    earlier = sorted(p for p in (out / "corpus").rglob("*") if p.is_file())
    write_run_record(
        out,
        demo.RECORD,
        {
            p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in earlier
        },
    )
    monkeypatch.setattr(demo, "MIN_KAPPA", 0.999)
    assert demo.main(["--out-dir", str(out), "--quick", "--bootstrap", "10"]) == 1
    err = capsys.readouterr().err
    assert "remap agreement" in err and "code 3" in err  # mining and labels went through
    index = pd.read_csv(out / "h36m" / "turn-h36m.csv")
    assert set(index["subject"]) == set(demo.QUICK["subjects"])
    labels = pd.read_csv(out / "remap" / "labels.csv")
    assert labels["session"].str.slice(0, 6).isin(["pair01", "pair02", "pair03"]).all()


def test_match_planted_by_hand() -> None:
    planted = pd.DataFrame(
        {
            "subject": ["S9", "S9", "S9"],
            "action": ["Walking"] * 3,
            "subaction": ["", "", "1"],
            "start_frame": [100, 300, 100],
            "end_frame": [200, 400, 200],
            "angle_deg": [90.0, 60.0, 50.0],
            "direction": ["left", "right", "left"],
        }
    )
    index = pd.DataFrame(
        {
            "clip_id": ["a", "b", "c"],
            "subject": ["S9", "S9", "S9"],
            "action": ["Walking"] * 3,
            "subaction": ["", "", ""],
            # a covers 60 of turn 0's 100 frames (>= half): found, 10 frames late = 0.2 s;
            # b overlaps turn 1 by 40 frames only (< half); c turns the wrong way
            "start_frame": [110, 360, 300],
            "end_frame": [170, 420, 400],
            "angle_deg": [85.0, 61.0, 59.0],
            "direction": ["left", "right", "left"],
            "fps": [50.0, 50.0, 50.0],
        }
    )
    m = demo.match_planted(planted, index)
    assert m["found"].tolist() == [True, False, False]
    assert m.loc[0, "clip_id"] == "a"
    assert m.loc[0, "start_error_s"] == pytest.approx(0.2)
    assert m.loc[0, "end_error_s"] == pytest.approx(-0.6)
    assert m.loc[0, "mined_angle_deg"] == 85.0


def test_the_demos_own_outputs_repeat(ran, tmp_path: Path) -> None:
    """Corpus, estimator skeletons and report are byte-identical on a rerun (the commands'
    own outputs are checked for that by their tests)."""
    out, _, _ = ran
    seed = demo.DEMO_SEED
    h36m = write_h36m_corpus(
        tmp_path / "h36m", seed=seed, subjects=demo.QUICK["subjects"], actions=demo.QUICK["actions"]
    )
    for path in h36m.files:
        rel = path.relative_to(tmp_path / "h36m")
        assert path.read_bytes() == (out / "corpus" / "h36m" / rel).read_bytes(), rel
    remap = write_remap_corpus(tmp_path / "remap", seed=seed, n_pairs=demo.QUICK["n_pairs"])
    for path in remap.paths:
        assert path.read_bytes() == (out / "corpus" / "remap" / "eaf" / path.name).read_bytes()
    write_h36m_estimates(
        out / "h36m" / "turn-h36m.csv",
        [out / "corpus" / "h36m"],
        tmp_path / "h.npz",
        degrade=degrade_skeleton,
        seed=seed,
    )
    assert (tmp_path / "h.npz").read_bytes() == (out / "h36m" / "skeletons.npz").read_bytes()
    write_remap_estimates(
        out / "remap" / "labels.csv", tmp_path / "r.npz", degrade=degrade_skeleton, seed=seed
    )
    assert (tmp_path / "r.npz").read_bytes() == (out / "remap" / "skeletons.npz").read_bytes()
    before = (out / "report.html").read_bytes()
    demo.write_report(demo.load_results(out, seed=seed), out / "report.html")
    assert (out / "report.html").read_bytes() == before


def test_a_failed_step_stops_the_demo_with_exit_1(tmp_path: Path, monkeypatch, capsys) -> None:
    # a gate the quick corpus's labels cannot pass (its kappa is about 0.98, with planted
    # disagreements): the audit exits 3, the demo stops there and says so
    monkeypatch.setattr(demo, "MIN_KAPPA", 0.999)
    code = demo.main(["--out-dir", str(tmp_path / "out"), "--quick", "--bootstrap", "10"])
    assert code == 1
    err = capsys.readouterr().err
    assert "demo failed" in err and "remap agreement" in err and "code 3" in err
    assert not (tmp_path / "out" / "report.html").exists()
    assert not (tmp_path / "out" / "h36m" / "predictions-net.csv").exists()


def test_untrimmed_stage_plants_the_labels_and_finds_them(ran) -> None:
    # issue 13: streams of the first two REMAP-like sessions with the labels' own turns,
    # `detect --min-turn-deg 67.5`, `score-events --plots`, and the report's section
    out, _, said = ran
    folder = out / "untrimmed"
    labels = pd.read_csv(out / "remap" / "labels.csv", keep_default_na=False)
    first_two = sorted(set(labels.session))[:2]
    assert sorted(p.stem for p in (folder / "streams").glob("*.npz")) == first_two
    doc = json.loads((folder / "events" / "event_scores.json").read_text())
    o = doc["overall"]
    assert o["tp"] + o["fn"] == int(labels.session.isin(first_two).sum())
    assert o["f1"] >= 0.9 and o["matched"]["accuracy"] >= 0.9
    assert doc["settings"]["resamples"] == 100
    assert "--min-turn-deg 67.5" in said and "labelled turns found" in said
    text = (out / "report.html").read_text(encoding="utf-8")
    assert "Untrimmed sessions" in text


def test_remap_open_stage_scores_by_medication_and_turn_type_in_the_report(ran) -> None:
    from turn_eval.demo.remap_open import OPEN_DIR

    out, results, said = ran
    folder = out / OPEN_DIR
    assert results["REMAP Open: release, read data, predictions, scores"] == folder
    labels = pd.read_csv(folder / "data" / "labels.csv", keep_default_na=False, dtype=str)
    assert len(labels) == 16  # --quick: 2 + 2 participants, 4 turns each
    scores = json.loads((folder / "scores" / "scores.json").read_text())
    assert scores["overall"]["n"] == 16
    for col in ("medication", "dbs", "turn_type", "steps", "cohort", "scenario"):
        counts = labels[col].replace("", "(blank)").value_counts().to_dict()  # score's name
        assert {g: v["n"] for g, v in scores["by"][col]["groups"].items()} == counts, col
    manifest = json.loads((folder / "data" / "manifest.json").read_text())
    assert manifest["up_axis"]["found"] == {"-y": 16}  # camera axes, found from the trunk
    assert "$ turn-datasets remap open" in said
    text = (out / "report.html").read_text(encoding="utf-8")
    section = text.split("Turn-REMAP as released (REMAP Open)</h2>")[1].split("<h2")[0]
    # the captions name the columns in words (turn_type is "turn type")
    for caption in ("by medication", "by turn type", "by dbs", "by steps"):
        assert f"Turn-REMAP as released, net {caption}" in section, caption
    # the page's numbers are the scores file's: overall accuracy with one decimal
    accuracy = f"{100 * scores['overall']['accuracy']:.1f}"
    assert accuracy in section


def test_a_run_stopped_by_sigterm_is_recorded_and_said_in_one_line(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    def steps(out: Path, **kwargs) -> dict[str, Path]:
        (out / "h36m").mkdir(parents=True)
        (out / "h36m" / "turn-h36m.csv").write_text("half", encoding="utf-8")
        raise Terminated  # what SIGTERM raises inside sigterm_unwinds

    monkeypatch.setattr(demo, "_run_steps", steps)
    out = tmp_path / "demo-output"
    assert demo.main(["--out-dir", str(out), "--quick"]) == 143
    assert capsys.readouterr().err.strip().splitlines() == ["demo stopped: terminated"]
    assert json.loads((out / demo.RECORD).read_text(encoding="utf-8"))["files"] == {
        "h36m/turn-h36m.csv": hashlib.sha256(b"half").hexdigest()
    }
