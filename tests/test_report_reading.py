"""report.html and its figures, read as a submitter and a clinician would: every bin on the
confusion matrix's axes, no empty rows; figures at their natural size, openable full size;
tables that fit; numbers that mean what they say (each check fails without its fix)."""

from __future__ import annotations

import numpy as np
import pytest

from turn_eval import plots


@pytest.fixture()
def drawn(monkeypatch):
    """The figures as drawn (axes kept), instead of only their PNG bytes."""
    figures = {}

    def keep(fig, path):
        figures[path.name] = fig
        return path

    monkeypatch.setattr(plots, "_save", keep)
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
