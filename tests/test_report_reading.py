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
    ax = fig.axes[0]
    return [(t.get_text(), t.get_window_extent(renderer)) for t in ax.texts]


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
