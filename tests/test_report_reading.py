"""report.html and its figures, read as a submitter and a clinician would: every bin on the
confusion matrix's axes, no empty rows; figures at their natural size, openable full size;
tables that fit; numbers that mean what they say (each check fails without its fix)."""

from __future__ import annotations

import numpy as np
import pytest

from turn_eval.clips import plots


@pytest.fixture()
def drawn(monkeypatch):
    """The figures as drawn (axes kept), instead of only their PNG bytes."""
    figures = {}

    def keep(fig, path):
        figures[path.name] = fig
        return path

    monkeypatch.setattr(plots, "save_figure", keep)
    return figures


def test_confusion_axes_are_every_bin_and_rows_only_the_references(tmp_path, drawn) -> None:
    # reference: 4 bins (90..225); predictions spread over 33 bins (45..1485), every one a
    # column (the old matrix labelled every other tick past 30, and showed 29 empty rows)
    ref = np.repeat([90.0, 135.0, 180.0, 225.0], 9)[:33]
    pred = 45.0 * np.arange(1, 34)
    plots.write_plots(pred, ref, tmp_path)
    ax = drawn["confusion_matrix.png"].axes[0]
    columns = [t.get_text() for t in ax.get_xticklabels()]
    rows = [t.get_text() for t in ax.get_yticklabels()]
    assert columns == [str(45 * k) for k in range(1, 34)]
    assert rows == ["90", "135", "180", "225"]
    # each row's counts are the reference bin's clips
    image = ax.get_images()[0].get_array()
    assert image.shape == (4, 33)
    assert np.allclose(np.asarray(image).sum(axis=1), 1.0)


@pytest.fixture()
def drawn_events(monkeypatch):
    from turn_eval.events import plots as event_plots

    figures = {}

    def keep(fig, path):
        figures[path.name] = fig
        return path

    monkeypatch.setattr(event_plots, "save_figure", keep)
    return event_plots, figures


def _extents(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    return [(t.get_text(), t.get_window_extent(renderer)) for ax in fig.axes for t in ax.texts]


def test_timeline_angles_have_one_decimal_and_do_not_overlap(tmp_path, drawn_events) -> None:
    import pandas as pd

    event_plots, figures = drawn_events
    nan = float("nan")
    # two detections 1 s apart in a 500 s session (the "97.384157.9946°")
    events = pd.DataFrame(
        {
            "kind": ["TP", "FP", "FN"],
            "ref_start_s": [100.0, nan, 400.0],
            "ref_end_s": [102.0, nan, 402.0],
            "ref_angle_deg": [90.0, nan, 180.0],
            "det_start_s": [100.2, 101.2, nan],
            "det_end_s": [101.0, 102.0, nan],
            "det_angle_deg": [97.38416, 157.99461, nan],
        }
    )
    event_plots._timeline(events, tmp_path / "t.png", "s1", "P1")
    texts = _extents(figures["t.png"])
    assert sorted(t for t, _ in texts) == ["158.0°", "180.0°", "90.0°", "97.4°"]
    boxes = [b for _, b in texts]
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            assert not boxes[i].overlaps(boxes[j]), (texts[i][0], texts[j][0])
    # 100 s to 402 s: three rows of 120 s, each readable at a page's width (12 in)
    fig = figures["t.png"]
    assert len(fig.axes) == 3 and fig.get_figwidth() <= 12.0
    assert [round(ax.get_xlim()[0] + 0.02 * 120, 6) for ax in fig.axes] == [100.0, 220.0, 340.0]


def test_f1_axis_shows_the_differences_between_groups(tmp_path, drawn_events) -> None:
    event_plots, figures = drawn_events
    group = {"f1": 0.95, "ci95": {"f1": [0.93, 0.97]}}
    doc = {
        "by": {
            "cohort": {
                "groups": {"HC": group, "PD": {"f1": 0.99, "ci95": {"f1": [0.98, 1.0]}}},
                "avg": {"f1": 0.97},
            }
        }
    }
    event_plots._f1_by_group(doc, tmp_path / "f1.png")
    ax = figures["f1.png"].axes[0]
    bottom, top = ax.get_ylim()
    assert bottom == 90.0 and top == 101  # 93 - 3, down to a multiple of 5
    assert "axis from 90" in ax.get_ylabel()


# --- the page -----------------------------------------------------------------------------


def _scores(names: list[str], *, wprec: float = 1.0) -> dict:
    groups = {
        n: {"n": 10 + k, "accuracy": 0.5, "mae_deg": 10.0, "wprec": wprec}
        for k, n in enumerate(names)
    }
    return {"by": {"g": {"groups": groups, "avg": {"n": 99.9, "accuracy": 0.5, "mae_deg": 10.0}}}}


def test_counts_get_a_total_and_bins_leave_wprec_out_with_the_reason() -> None:
    from turn_eval.report import BIN_WPREC_NOTE, scores_table_html

    doc = _scores(["90", "135"])
    doc["by"]["bin_deg"] = doc["by"].pop("g")
    html = scores_table_html(doc, "bin_deg", caption="by bin")
    assert "WPrec" not in html.split("</table>")[0] and BIN_WPREC_NOTE in html
    # 10 + 11 turns: a Total, never the Avg. of counts (99.9 in the JSON)
    assert "<td>Total 21</td>" in html and "99.9" not in html
    assert "<th>bin (°)</th>" in html  # the column's name in words


def test_many_groups_go_in_rows() -> None:
    from turn_eval.report import MAX_GROUP_COLUMNS, scores_table_html

    names = [f"PD{k:02d}" for k in range(1, 25)]
    assert len(names) > MAX_GROUP_COLUMNS
    html = scores_table_html(_scores(names), "g")
    header = html.split("</thead>")[0]
    assert "PD06" not in header and "Acc. (%)" in header  # metrics are the columns
    body = html.split("<tbody>")[1]
    assert body.count("<tr") == 25  # 24 subjects and the Avg. row
    assert "<th>PD24</th>" in body and ">516<" in body  # 10 + 11 + ... + 33 = 516 turns


def test_figures_at_natural_size_and_openable_full_size(tmp_path) -> None:
    import re

    from turn_eval.report import Report

    png = tmp_path / "wide.png"
    plots.write_plots(np.array([90.0, 180.0]), np.array([90.0, 135.0]), tmp_path)
    png = tmp_path / "confusion_matrix.png"
    report = Report("t")
    sec = report.section("figures")
    sec.figure(png, caption="a matrix")
    text = report.render()
    assert "width:480px" not in text and 'style="width' not in text
    (fig_id,) = re.findall(r'<figure id="([^"]+)">', text)
    # the figure links to itself: its :target rule shows it whole, with a way back
    assert f'href="#{fig_id}"' in text and "figure:target img{max-width:none}" in text
    assert 'class="close" href="#s1"' in text
    assert "@media print" in text


def test_p_values_at_the_resampling_resolution_print_as_a_bound() -> None:
    from turn_datasets.render.numbers import format_p

    assert format_p(1 / 1001) == "< 0.001"
    assert format_p(0.00799) == "0.008" and format_p(0.25) == "0.250"


def test_the_overall_table_gives_the_quadratic_kappa_score_prints() -> None:
    from turn_eval.report import overall_rows

    header, rows = overall_rows({"paper": {"overall": {"n": 4, "accuracy": 0.5, "kappa": 0.81746}}})
    assert header[-1] == "κ (quadratic)" and rows[0][-1] == "0.817"


def test_disagreement_times_as_elan_shows_them(tmp_path) -> None:
    from turn_eval.demo.run import _disagreements_table

    path = tmp_path / "d.csv"
    path.write_text(
        "session,participant,kind,start_a_s,end_a_s,angle_a_deg,file\n"
        "s1,P1,angle,3725.5,3727.25,90.0,/abs/s1.eaf\n"
    )
    df = _disagreements_table(path)
    assert list(df["start_a_s"]) == ["1:02:05.500 (3725.500 s)"]
    assert list(df["end_a_s"]) == ["1:02:07.250 (3727.250 s)"] and "file" not in df.columns


def test_a_zero_width_kappa_interval_says_its_n() -> None:
    from turn_datasets.remap.agreement_report import _k_ci

    assert _k_ci(1.0, (1.0, 1.0), 53) == "1.000 (1.000 to 1.000; n = 53)"
    assert _k_ci(0.974, (0.92, 1.0), 56) == "0.974 (0.920 to 1.000)"


def test_the_files_section_links(tmp_path) -> None:
    from turn_eval.report import Report

    report = Report("t")
    report.section("Files").files(
        {"labels": "remap/labels.csv", "scores": "h36m/scores-{paper,net}/"}, link=True
    )
    text = report.render()
    assert '<a href="remap/labels.csv">remap/labels.csv</a>' in text
    assert "h36m/scores-{paper,net}/" in text and 'href="h36m/scores-{' not in text
    # the words of a parenthesis are not paths beside the page
    report = Report("t")
    report.section("Files").files(
        {"events": "untrimmed/events/ (event scores, timelines, PR curve), untrimmed/x.csv"},
        link=True,
    )
    text = report.render()
    assert '<a href="untrimmed/events/">untrimmed/events/</a> (event scores, timelines' in text
    assert '<a href="untrimmed/x.csv">' in text
    assert 'href="timelines"' not in text and 'href="PR"' not in text


def test_the_timeline_shown_has_a_false_and_a_missed_detection(tmp_path) -> None:
    from turn_eval.demo.untrimmed import telling_timeline

    (tmp_path / "timelines").mkdir()
    for name in ("0000_s1_P1.png", "0001_s1_P2.png", "0002_s2_P1.png"):
        (tmp_path / "timelines" / name).write_bytes(b"")
    (tmp_path / "events.csv").write_text("unit,kind\n0,TP\n0,TP\n1,TP\n1,FP\n2,TP\n2,FN\n2,FP\n")
    assert telling_timeline(tmp_path).name == "0002_s2_P1.png"


# --- paper and net on shared axes -----------------------------------------------------------

#: Ten clips, two reference bins. "paper" is far off on three (errors up to 200°, predicted
#: bins 90 to 270); "net" is within 10° everywhere (predicted bins 90 and 180 only).
_REF = np.array([90.0] * 5 + [180.0] * 5)
_PAPER = _REF + np.array([0, 10, -10, 120, 200, 0, 10, -10, 40, -30])
_NET = _REF + np.array([5, -5, 0, 10, -10, 5, -5, 0, 10, -10])


@pytest.mark.parametrize("name", plots.PLOT_FILES)
def test_paper_and_net_share_axes_side_by_side(name) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plots.side_by_side(name, {"paper": (_PAPER, _REF), "net": (_NET, _REF)})
    FigureCanvasAgg(fig).draw()
    paper, net = [ax for ax in fig.axes if ax.get_title() in ("paper", "net")]
    assert (paper.get_title(), net.get_title()) == ("paper", "net")
    # one row: net to the right of paper, at the same height
    assert paper.get_position().x1 <= net.get_position().x0
    assert paper.get_position().y0 == pytest.approx(net.get_position().y0)
    assert paper.get_ylim() == net.get_ylim() and paper.get_xlim() == net.get_xlim()

    def ticks(labels) -> list[str]:
        return [t.get_text() for t in labels]

    assert ticks(paper.get_yticklabels()) == ticks(net.get_yticklabels())
    assert ticks(paper.get_xticklabels()) == ticks(net.get_xticklabels())
    if name == "abs_error.png":
        # the same 5° bars in both, up to paper's largest error (200°): 40 bars each
        edges = [[p.get_x() for p in ax.patches] for ax in (paper, net)]
        assert edges[0] == edges[1] == [5.0 * k for k in range(40)]
    elif name == "confusion_matrix.png":
        # rows: the reference's bins; columns: every bin either predicts, in both panels
        assert ticks(paper.get_yticklabels()) == ["90", "180"]
        assert ticks(net.get_xticklabels()) == ["90", "135", "180", "225", "270"]
    elif name == "predicted_by_bin.png":
        # net's panel reaches paper's 290° (90 + 200) too: the heights compare directly
        assert net.get_ylim()[1] >= 290.0
    else:
        # paper's +200° difference sets both panels' top
        assert net.get_ylim()[1] >= 200.0


def test_a_p_value_bound_from_a_markdown_table_shows_once_escaped() -> None:
    # `compare` writes "< 0.001" in its Markdown as "&lt; 0.001" (a name like "<script>" is
    # shown, not run, where Markdown is rendered); the page showed "&lt; 0.001" literally
    from turn_datasets.render.markdown import markdown_table
    from turn_eval.report import markdown_to_html

    text = "\n".join(markdown_table(["metric", "p"], [["MAE (°)", "< 0.001"]], align="lr"))
    html = markdown_to_html(text + "\n\nsubject <script>alert(1)</script>\n")
    assert "<td>&lt; 0.001</td>" in html and "&amp;lt;" not in html
    assert "<script>" not in html and "&lt;script&gt;" in html


def test_side_by_side_of_a_submission_in_the_wrong_unit_stays_bounded(tmp_path) -> None:
    # Centidegrees beside degrees: ~200 bins; the matrices merge them into at most 40 runs
    # and no figure grows past a single figure's 14 + 1.2 inches at 110 dpi (1672 px)
    rng = np.random.default_rng(0)
    ref = rng.uniform(45, 360, 300)
    written = plots.write_side_by_side({"cdeg": (ref * 100, ref), "deg": (ref, ref)}, tmp_path)
    assert [p.name for p in written] == list(plots.PLOT_FILES)
    for path in written:
        data = path.read_bytes()
        width = int.from_bytes(data[16:20], "big")
        height = int.from_bytes(data[20:24], "big")
        assert width <= 1672 and height <= 1672, (path.name, width, height)
