"""``turn_eval.report``: one self-contained, escaped, deterministic HTML page.

The inputs are fixture files written here by hand (a scores JSON per DESIGN "Scores", a
Markdown table as ``--format md`` prints it, a CSV, a PNG), and the page is read back with
the standard library's HTML parser, so every check looks at what a browser would see.
"""

from __future__ import annotations

import base64
import json
from html.parser import HTMLParser
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from turn_datasets.errors import TurnbenchError  # noqa: E402
from turn_eval.report import (  # noqa: E402
    Report,
    format_metric,
    load_json,
    markdown_to_html,
    scores_table_html,
)

VOID = {"meta", "img", "br", "hr", "link", "input"}


class _Page(HTMLParser):
    """Collects tags, attributes, tables (as lists of cell texts) and checks nesting."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.tags: list[tuple[str, dict]] = []
        self.tables: list[dict] = []
        self._cell: list[str] | None = None
        self._row: list[str] | None = None
        self._caption: list[str] | None = None
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag not in VOID:
            self.stack.append(tag)
        if tag == "table":
            self.tables.append({"caption": "", "rows": []})
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "caption":
            self._caption = []

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unbalanced </{tag}> with open {self.stack[-3:]}")
            return
        self.stack.pop()
        if tag in ("td", "th") and self._row is not None and self._cell is not None:
            self._row.append("".join(self._cell).strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.tables[-1]["rows"].append(self._row)
            self._row = None
        elif tag == "caption" and self._caption is not None:
            self.tables[-1]["caption"] = "".join(self._caption).strip()
            self._caption = None

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)
        if self._caption is not None:
            self._caption.append(data)


def _parse(text: str) -> _Page:
    page = _Page()
    page.feed(text)
    page.close()
    assert page.errors == []
    assert page.stack == []
    return page


# A scores document shaped as DESIGN.md "Scores", with numbers chosen to check formatting by
# eye: accuracy 0.735 prints as 73.5, mae 18.46 as 18.5, wprec 0.8625 as 86.2 (100 * 0.8625
# is exactly 86.25, and Python's format rounds half to even) and a null speed as an en dash.
SCORES = {
    "overall": {
        "n": 4,
        "accuracy": 0.735,
        "mae_deg": 18.46,
        "wprec": 0.8625,
        "mae_speed_deg_s": None,
        "ci95": {"accuracy": [0.70, 0.77], "mae_deg": [12.0, 25.04]},
    },
    "by": {
        "subject": {
            "groups": {
                "S9": {"n": 3, "accuracy": 0.6667, "mae_deg": 10.0, "wprec": 0.5},
                "<b>S11</b> & co": {"n": 1, "accuracy": 1.0, "mae_deg": 30.0, "wprec": 1.0},
            },
            # the unweighted mean over the two groups, worked by hand: (0.6667 + 1) / 2,
            # (10 + 30) / 2, (0.5 + 1) / 2, (3 + 1) / 2
            "avg": {"n": 2.0, "accuracy": 0.83335, "mae_deg": 20.0, "wprec": 0.75},
        }
    },
    "settings": {"bin_width_deg": 45, "bootstrap": 1000, "seed": 0, "version": "0.1.0"},
}

TABLE3_MD = """\
| Bin (°) | Clips | Min (°) | Max (°) | Mean (°) |
|---:|---:|---:|---:|---:|
| 45 | 2 | 45.2 | 66.0 | 55.6 |
| 90 | 1 | 91.0 | 91.0 | 91.0 |
| a \\| b | 1 | 1 | 1 | 1 |
| **Total** | 4 | 45.2 | 91.0 | 67.1 |
"""


@pytest.fixture()
def png(tmp_path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(2, 2), dpi=40)
    ax.plot([0, 1], [0, 1])
    path = tmp_path / "fig.png"
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return path


def _build(tmp_path: Path, png: Path) -> Path:
    tmp_path.mkdir(parents=True, exist_ok=True)
    csv = tmp_path / "rows.csv"
    csv.write_text("clip_id,angle_deg,room\nS9_Walking_0-10,91.25,<kitchen>\n", encoding="utf-8")
    report = Report("Demo <report>", subtitle="seed `0` & friends")
    sec = report.section("Scores & tables")
    sec.summary({"paper": SCORES}, caption="Overall")
    sec.scores(SCORES, caption="Turn-H3.6M")
    sec.markdown(TABLE3_MD, caption="Table 3")
    sec.csv_file(csv, caption="Rows")
    sec.key_values({"kappa": 0.9612, "kappa_ci95": [0.9, 0.99], "raters": ["A", "B<"]})
    sec.figure(png, caption="A line")
    report.section("Files").files({"scores": "h36m/scores.json"})
    out = tmp_path / "report.html"
    report.write(out)
    return out


def test_page_is_self_contained_and_well_formed(tmp_path: Path, png: Path) -> None:
    text = _build(tmp_path, png).read_text(encoding="utf-8")
    page = _parse(text)
    # nothing is fetched from elsewhere: no script, no stylesheet link, no remote source
    names = [t for t, _ in page.tags]
    assert "script" not in names and "link" not in names and "iframe" not in names
    srcs = [a["src"] for t, a in page.tags if "src" in a]
    assert len(srcs) == 1 and srcs[0].startswith("data:image/png;base64,")
    # the figure is the very PNG we wrote, byte for byte
    assert base64.b64decode(srcs[0].split(",", 1)[1]) == png.read_bytes()
    assert "style" in names  # the CSS is inline
    hrefs = [a["href"] for t, a in page.tags if t == "a"]
    assert hrefs and all(h.startswith("#") for h in hrefs)


def test_everything_from_results_is_escaped(tmp_path: Path, png: Path) -> None:
    text = _build(tmp_path, png).read_text(encoding="utf-8")
    for raw in ("<b>S11</b>", "<kitchen>", "<report>", "B<"):
        assert raw not in text
    assert "&lt;b&gt;S11&lt;/b&gt; &amp; co" in text
    page = _parse(text)
    assert [t for t, _ in page.tags].count("b") == 0
    # ... and a reader sees the original text
    assert "<b>S11</b> & co" in "".join(page.text)
    assert page.tags[[t for t, _ in page.tags].index("title")][0] == "title"
    assert "Demo <report>" in "".join(page.text)


def test_scores_table_is_laid_out_as_the_papers_table_4(tmp_path: Path, png: Path) -> None:
    page = _parse(_build(tmp_path, png).read_text(encoding="utf-8"))
    table = next(t for t in page.tables if t["caption"] == "Turn-H3.6M by subject")
    rows = table["rows"]
    assert rows[0] == ["subject", "S9", "<b>S11</b> & co", "Avg."]
    # metrics as rows in the paper's order; speed is absent because no group has it
    assert rows[1] == ["Acc. (%)", "66.7", "100.0", "83.3"]
    assert rows[2] == ["MAE (°)", "10.0", "30.0", "20.0"]
    assert rows[3] == ["WPrec (%)", "50.0", "100.0", "75.0"]
    # a count is summed (3 + 1 turns), not averaged: the "Avg." column gives its Total
    assert rows[4] == ["# Turns", "3", "1", "Total 4"]
    assert len(rows) == 5


def test_summary_carries_the_bootstrap_intervals(tmp_path: Path, png: Path) -> None:
    page = _parse(_build(tmp_path, png).read_text(encoding="utf-8"))
    table = next(t for t in page.tables if t["caption"] == "Overall")
    assert table["rows"][0] == ["", "n", "Acc. (%)", "MAE (°)", "WPrec (%)", "MAE speed (°/s)"]
    # WPrec 0.8625 is 86.25%: half up, as scores.md prints it (it read 86.2 before the
    # report and scores.md shared one rounding rule)
    assert table["rows"][1] == ["paper", "4", "73.5 (70.0–77.0)", "18.5 (12.0–25.0)", "86.3", "–"]


def test_markdown_table_with_escaped_pipe_and_total_row(tmp_path: Path, png: Path) -> None:
    page = _parse(_build(tmp_path, png).read_text(encoding="utf-8"))
    table = next(t for t in page.tables if t["caption"] == "Table 3")
    assert table["rows"][0] == ["Bin (°)", "Clips", "Min (°)", "Max (°)", "Mean (°)"]
    assert table["rows"][3] == ["a | b", "1", "1", "1", "1"]
    assert table["rows"][4] == ["Total", "4", "45.2", "91.0", "67.1"]
    assert 'class="avg"' in markdown_to_html(TABLE3_MD)


def test_csv_and_key_values(tmp_path: Path, png: Path) -> None:
    page = _parse(_build(tmp_path, png).read_text(encoding="utf-8"))
    rows = next(t for t in page.tables if t["caption"] == "Rows")["rows"]
    # 91.25 rounds half up, as every table of turnbench (it read 91.2 before the one rule)
    # raw column names in words
    assert rows == [["clip", "angle (°)", "room"], ["S9_Walking_0-10", "91.3", "<kitchen>"]]
    kv = next(t for t in page.tables if t["rows"][0] == ["item", "value"])["rows"]
    assert ["kappa", "0.9612"] in kv
    assert ["kappa_ci95", "[0.9, 0.99]"] in kv
    assert ["raters", "A, B<"] in kv


def test_same_inputs_same_bytes(tmp_path: Path, png: Path) -> None:
    a = _build(tmp_path / "a", png).read_bytes()
    b = _build(tmp_path / "b", png).read_bytes()
    assert a == b


@pytest.mark.parametrize(
    ("key", "value", "text"),
    [
        ("accuracy", 0.735, "73.5"),
        ("wprec", 1.0, "100.0"),
        ("mae_deg", 18.46, "18.5"),
        ("mae_speed_deg_s", 15.54, "15.5"),
        ("mae_speed_deg_s", None, "–"),
        ("accuracy", float("nan"), "–"),
        ("n", 619, "619"),
        ("n", 88.4, "88.4"),  # an Avg. row's mean count is not an integer
        ("n", 33.42857, "33.4"),
        ("n", 46.0, "46"),
        ("kappa", 0.96123, "0.961"),
    ],
)
def test_format_metric(key, value, text) -> None:
    assert format_metric(key, value) == text


def test_errors_name_the_problem(tmp_path: Path) -> None:
    with pytest.raises(TurnbenchError, match="no grouping 'cohort'"):
        scores_table_html(SCORES, "cohort")
    fake = tmp_path / "fake.png"
    fake.write_bytes(b"GIF89a")
    with pytest.raises(TurnbenchError, match="fake.png: not a PNG"):
        Report("x").section("y").figure(fake)
    bad = tmp_path / "bad.json"
    bad.write_text('{"a": 1,\n}', encoding="utf-8")
    with pytest.raises(TurnbenchError, match="bad.json:2"):
        load_json(bad)


def test_failed_write_leaves_no_file(tmp_path: Path, png: Path) -> None:
    report = Report("x")
    report.section("y").figure(png)
    out = tmp_path / "report.html"
    report.sections[0].blocks.append(object())  # not text: rendering fails midway
    with pytest.raises(TypeError):
        report.write(out)
    assert list(tmp_path.iterdir()) == [png]
    json.dumps(SCORES)  # the fixture itself is plain JSON
