"""One self-contained HTML page of results, for a reader without Python.

The page (``report.html``) carries everything inline: the style sheet in a ``<style>`` block,
every figure as a base64 ``data:image/png`` URI, every table as HTML. It loads no script, no
font and no image from anywhere, so a clinician can open it from a USB stick or an e-mail
attachment, and a reviewer can archive it as one file.

Tables come from the results the commands wrote: the scores JSON of ``turn-eval score``
(DESIGN.md, "Scores"), laid out as the paper's Tables 4 and 5 (metrics as rows, groups as
columns, then "Avg." and "# Turns"); Markdown tables as ``--format md`` prints them; CSV files;
and flat JSON documents (the agreement audit, a comparison) as key/value tables.

Every piece of text taken from a result (a subject id, a room name, a file name, a caption)
is HTML-escaped: labels come from other people's ELAN files and must not become markup.

Same inputs give the same bytes: no timestamp, no random ids.

Example
-------
>>> report = Report("Turn-H3.6M on my estimator")                    # doctest: +SKIP
>>> sec = report.section("Scores")                                   # doctest: +SKIP
>>> sec.scores(json.load(open("scores/scores.json")), caption="...")   # doctest: +SKIP
>>> sec.figure("scores/confusion.png", caption="Confusion matrix")   # doctest: +SKIP
>>> report.write("report.html")                                      # doctest: +SKIP
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import write_text
from turn_datasets.render.labels import METRIC_LABELS
from turn_datasets.render.numbers import (
    MISSING,
    column_words,
    fixed,
    format_metric,
    is_missing,
)

__all__ = [
    "METRICS",
    "Report",
    "Section",
    "format_metric",
    "load_json",
    "markdown_to_html",
    "overall_rows",
    "scores_table_html",
    "table_html",
]

#: The metrics of a scores JSON in the paper's row order: (key, row label, kind), from the
#: one label table (:data:`turn_datasets.render.labels.METRIC_LABELS`).
METRICS: tuple[tuple[str, str, str], ...] = tuple(
    (key, label.short, label.kind) for key, label in METRIC_LABELS.items()
)

_CSS = """
body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:0;color:#1d232a;
background:#f6f7f9;line-height:1.45}
main{max-width:1080px;margin:0 auto;padding:24px 28px 60px;background:#fff;
box-shadow:0 0 12px rgba(0,0,0,.06)}
h1{font-size:1.7em;margin:.2em 0 .1em}h2{font-size:1.3em;margin-top:2em;padding-bottom:.2em;
border-bottom:2px solid #d6dde6}h3{font-size:1.08em;margin-top:1.4em}
p.sub{color:#56606b;margin-top:0}
nav ol{columns:2;padding-left:1.2em}nav a{color:#1f5fa8;text-decoration:none}
table{border-collapse:collapse;margin:.5em 0 1.2em;font-size:.92em}
caption{caption-side:top;text-align:left;font-weight:600;padding:.3em 0;color:#2b3540}
th,td{border:1px solid #d6dde6;padding:.25em .6em;vertical-align:top}
th{background:#eef2f6;text-align:left}td.num{text-align:right;font-variant-numeric:tabular-nums}
tr.avg td,tr.avg th{background:#f8f3e6}tr.count td,tr.count th{color:#56606b}
.wrap{overflow-x:auto}
td,th{overflow-wrap:anywhere}
figure{margin:1em 0 1.6em;display:inline-block;max-width:100%;vertical-align:top}
figure img{max-width:100%;height:auto;border:1px solid #e3e8ee}
figure a.open img{cursor:zoom-in}
figure .close{display:none}
figure:target{position:fixed;inset:0;z-index:10;margin:0;padding:1em;overflow:auto;
background:#fff;max-width:none}
figure:target img{max-width:none}
figure:target .close{display:inline-block;position:sticky;top:0;left:0;background:#1f5fa8;
color:#fff;padding:.2em .8em;text-decoration:none}
figcaption{font-size:.9em;color:#44505c;max-width:640px}
@media print{main{max-width:none;box-shadow:none;padding:0}.wrap{overflow:visible}
table{font-size:.78em}figure{break-inside:avoid}nav{display:none}}
pre{background:#f3f5f7;padding:.6em .8em;overflow-x:auto;font-size:.88em}
code{background:#f3f5f7;padding:0 .2em}
.note{background:#eef6ee;border-left:4px solid #5a9a5a;padding:.5em .9em}
.warn{background:#fbf1e6;border-left:4px solid #d08a2a;padding:.5em .9em}
footer{margin-top:3em;color:#6b7580;font-size:.85em}
"""


def _esc(value: object) -> str:
    return html.escape(str(value), quote=True)


def _format_ci(key: str, ci: object) -> str:
    if not isinstance(ci, Sequence) or isinstance(ci, str) or len(ci) != 2:
        return ""
    lo, hi = ci
    if is_missing(lo) or is_missing(hi):
        return ""
    return f"{format_metric(key, lo)}–{format_metric(key, hi)}"


def table_html(
    header: Sequence[object],
    rows: Iterable[Sequence[object]],
    *,
    caption: str = "",
    row_classes: Sequence[str] | None = None,
    first_column_header: bool = True,
) -> str:
    """An HTML table; every cell escaped, numeric-looking cells right-aligned."""
    out = ['<div class="wrap"><table>']
    if caption:
        out.append(f"<caption>{_esc(caption)}</caption>")
    out.append("<thead><tr>" + "".join(f"<th>{_esc(h)}</th>" for h in header) + "</tr></thead>")
    out.append("<tbody>")
    for i, row in enumerate(rows):
        cls = row_classes[i] if row_classes and i < len(row_classes) and row_classes[i] else ""
        cells = []
        for j, cell in enumerate(row):
            text = MISSING if is_missing(cell) else str(cell)
            if j == 0 and first_column_header:
                cells.append(f"<th>{_esc(text)}</th>")
            elif _looks_numeric(text):
                cells.append(f'<td class="num">{_esc(text)}</td>')
            else:
                cells.append(f"<td>{_esc(text)}</td>")
        tr = f'<tr class="{_esc(cls)}">' if cls else "<tr>"
        out.append(tr + "".join(cells) + "</tr>")
    out.append("</tbody></table></div>")
    return "".join(out)


_NUMERIC_RE = re.compile(
    r"^[-+−]?\d[\d,]*(\.\d+)?%?(\s*\(.*\))?$|^[-+−]?\d[\d,]*(\.\d+)?[–-][-+−]?\d"
)


def _looks_numeric(text: str) -> bool:
    return bool(_NUMERIC_RE.match(text.strip()))


#: Beyond this many groups a scores table puts the groups in rows (24 subjects as columns
#: ran off the page at PD06 and lost 13 columns in print).
MAX_GROUP_COLUMNS = 10

#: Why the "by bin" tables leave WPrec out: a bin holds one reference class, so every
#: prediction's weight is that class and the weighted precision is 100% by construction.
BIN_WPREC_NOTE = (
    "WPrec is left out by bin: each bin holds one reference class, so its weighted "
    "precision is 100% by construction."
)


def scores_table_html(
    scores: Mapping[str, Any],
    grouping: str,
    *,
    caption: str = "",
    metrics: Sequence[tuple[str, str, str]] = METRICS,
) -> str:
    """One grouping of a scores JSON laid out as the paper's Tables 4 and 5.

    Rows are the metrics (accuracy, MAE, WPrec, MAE of angular speed, as present), columns
    the groups in the order the scores list them, then ``Avg.`` (the unweighted mean over
    groups, as computed by ``turn-eval score``) and the last row ``# Turns`` per group with
    their ``Total`` (a count is summed, not averaged). Over :data:`MAX_GROUP_COLUMNS` groups
    the table is turned: groups in rows. By ``bin_deg`` WPrec is left out
    (:data:`BIN_WPREC_NOTE`).
    """
    by = scores.get("by", {})
    if grouping not in by:
        raise TurnbenchError(
            f"the scores have no grouping {grouping!r}; they have {sorted(by)}", item="scores"
        )
    block = by[grouping]
    groups: Mapping[str, Mapping[str, Any]] = block.get("groups", {})
    avg: Mapping[str, Any] = block.get("avg", {})
    names = list(groups)
    present = [m for m in metrics if any(not is_missing(g.get(m[0])) for g in groups.values())]
    if grouping == "bin_deg":
        present = [m for m in present if m[0] != "wprec"]
    counts = [groups[n].get("n") for n in names]
    total = 0
    for c in counts:
        if c is not None and not is_missing(c):
            total += int(c)
    rows = []
    for key, label, _ in present:
        rows.append(
            [
                label,
                *(format_metric(key, groups[n].get(key)) for n in names),
                format_metric(key, avg.get(key)),
            ]
        )
    rows.append(["# Turns", *(format_metric("n", c) for c in counts), f"Total {total}"])
    classes = [""] * len(present) + ["count"]
    header = [column_words(grouping), *names, "Avg."]
    note = f'<p class="sub">{_esc(BIN_WPREC_NOTE)}</p>' if grouping == "bin_deg" else ""
    if len(names) > MAX_GROUP_COLUMNS:
        turned = [[header[j], *(row[j] for row in rows)] for j in range(1, len(header))]
        turned[-1][-1] = str(total)  # the Avg. row's "# Turns": the total
        turned[-1][0] = "Avg. (# Turns: total)"
        head = [column_words(grouping), *(row[0] for row in rows)]
        classes = [""] * len(names) + ["avg"]
        return table_html(head, turned, caption=caption, row_classes=classes) + note
    return table_html(header, rows, caption=caption, row_classes=classes) + note


def overall_rows(
    labelled_scores: Mapping[str, Mapping[str, Any]],
    *,
    metrics: Sequence[tuple[str, str, str]] = METRICS,
) -> tuple[list[str], list[list[str]]]:
    """Header and rows of a summary table: one row per labelled scores JSON, overall metrics
    with their bootstrap 95% CI in brackets where the scores carry one."""
    kappa = any(_kappa(s.get("overall", {})) is not None for s in labelled_scores.values())
    header = ["", "n"] + [label for _, label, _ in metrics]
    header += ["κ (quadratic)"] if kappa else []
    rows = []
    for name, scores in labelled_scores.items():
        overall = scores.get("overall", {})
        ci = overall.get("ci95", {}) or {}
        row = [name, format_metric("n", overall.get("n"))]
        for key, _, _ in metrics:
            cell = format_metric(key, overall.get(key))
            interval = _format_ci(key, ci.get(key))
            row.append(f"{cell} ({interval})" if interval and cell != MISSING else cell)
        if kappa:
            value = _kappa(overall)
            row.append(MISSING if value is None else fixed(value, 3))
        rows.append(row)
    return header, rows


def _kappa(overall: Mapping[str, Any]) -> float | None:
    """The quadratic-weighted kappa ``turn-eval score`` prints (``kappa`` in its JSON: a
    number, or a block with ``quadratic``)."""
    value = overall.get("kappa")
    if isinstance(value, Mapping):
        value = value.get("quadratic", value.get("value"))
    return None if is_missing(value) or not isinstance(value, (int, float)) else float(value)


_SEPARATOR_RE = re.compile(r"^\s*\|?\s*:?-{2,}:?\s*(\|\s*:?-{2,}:?\s*)*\|?\s*$")


def _split_row(line: str) -> list[str]:
    body = line.strip()
    if body.startswith("|"):
        body = body[1:]
    if body.endswith("|") and not body.endswith("\\|"):
        body = body[:-1]
    cells = re.split(r"(?<!\\)\|", body)
    # Markdown's entities read as the characters they stand for (the commands write "<" as
    # "&lt;"), to be escaped once, on the way out
    return [_plain_cell(html.unescape(c.strip().replace("\\|", "|"))) for c in cells]


def _plain_cell(text: str) -> str:
    # A table cell is escaped text: drop the Markdown emphasis the commands put on a
    # "**Total**" row (the row is styled instead) and the backticks of `code`.
    match = re.fullmatch(r"\*\*(.*)\*\*|`(.*)`", text)
    return next(g for g in match.groups() if g is not None) if match else text


def _inline(text: str) -> str:
    # Escape first (entities as the characters they stand for, as Markdown shows them),
    # then the only inline markup we honour: `code` and **bold**.
    out = _esc(html.unescape(text))
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    return re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", out)


def markdown_to_html(text: str, *, caption: str = "") -> str:
    """The subset of Markdown the commands print: pipe tables, ``#`` headings, paragraphs,
    fenced code. Everything is escaped; nothing else is interpreted.

    ``caption`` goes on the first table.
    """
    lines = text.splitlines()
    out: list[str] = []
    para: list[str] = []
    i = 0

    def flush() -> None:
        if para:
            out.append("<p>" + _inline(" ".join(para)) + "</p>")
            para.clear()

    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        if stripped.startswith("```"):
            flush()
            j = i + 1
            while j < len(lines) and not lines[j].strip().startswith("```"):
                j += 1
            out.append("<pre>" + _esc("\n".join(lines[i + 1 : j])) + "</pre>")
            i = j + 1
            continue
        if stripped.startswith("|") and i + 1 < len(lines) and _SEPARATOR_RE.match(lines[i + 1]):
            flush()
            header = _split_row(stripped)
            rows = []
            j = i + 2
            while j < len(lines) and lines[j].strip().startswith("|"):
                rows.append(_split_row(lines[j]))
                j += 1
            classes = [
                "avg" if r and r[0].strip("* ").lower() in ("avg.", "avg", "total") else ""
                for r in rows
            ]
            out.append(table_html(header, rows, caption=caption, row_classes=classes))
            caption = ""
            i = j
            continue
        heading = re.match(r"^(#{1,6})\s+(.*)$", stripped)
        if heading:
            flush()
            out.append(f"<h4>{_inline(heading.group(2))}</h4>")
        elif not stripped:
            flush()
        else:
            para.append(stripped)
        i += 1
    flush()
    return "\n".join(out)


def _png_data_uri(path: Path) -> str:
    data = path.read_bytes()
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        raise TurnbenchError("not a PNG image", file=str(path))
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _flatten(mapping: Mapping[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    items: list[tuple[str, Any]] = []
    for key, value in mapping.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            items.extend(_flatten(value, prefix=f"{name}."))
        elif (
            isinstance(value, list)
            and len(value) == 2
            and all(isinstance(v, (int, float)) or v is None for v in value)
        ):
            items.append(
                (
                    name,
                    MISSING
                    if any(is_missing(v) for v in value)
                    else f"[{_fmt_plain(value[0])}, {_fmt_plain(value[1])}]",
                )
            )
        elif isinstance(value, list):
            items.append((name, ", ".join(_fmt_plain(v) for v in value)))
        else:
            items.append((name, value))
    return items


def _fmt_plain(value: object) -> str:
    if is_missing(value):
        return MISSING
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


@dataclass
class Section:
    """A titled part of the report: its blocks of HTML in the order they were added."""

    title: str
    anchor: str
    blocks: list[str] = field(default_factory=list)
    n_figures: int = 0

    def paragraph(self, text: str, *, kind: str = "") -> Section:
        """A paragraph of plain text (escaped; `code` and **bold** honoured); ``kind`` is
        ``note`` or ``warn`` for a highlighted box."""
        cls = f' class="{_esc(kind)}"' if kind in ("note", "warn") else ""
        self.blocks.append(f"<p{cls}>{_inline(text)}</p>")
        return self

    def heading(self, text: str) -> Section:
        self.blocks.append(f"<h3>{_esc(text)}</h3>")
        return self

    def markdown(self, text: str, *, caption: str = "") -> Section:
        """Markdown as the commands print it (tables, headings, paragraphs)."""
        self.blocks.append(markdown_to_html(text, caption=caption))
        return self

    def markdown_file(self, path: str | os.PathLike[str], *, caption: str = "") -> Section:
        return self.markdown(Path(path).read_text(encoding="utf-8"), caption=caption)

    def frame(self, df: pd.DataFrame, *, caption: str = "", float_digits: int = 1) -> Section:
        """A DataFrame as a table, floats rounded to ``float_digits``."""
        rows = []
        for record in df.itertuples(index=False, name=None):
            rows.append(
                [
                    (fixed(v, float_digits) if isinstance(v, float) and math.isfinite(v) else v)
                    for v in record
                ]
            )
        self.blocks.append(
            table_html(
                [column_words(str(c)) for c in df.columns],
                rows,
                caption=caption,
                first_column_header=True,
            )
        )
        return self

    def csv_file(
        self,
        path: str | os.PathLike[str],
        *,
        caption: str = "",
        max_rows: int = 200,
        float_digits: int = 1,
    ) -> Section:
        """A CSV file as a table (at most ``max_rows`` rows, with a note of how many more)."""
        df = pd.read_csv(path, keep_default_na=False, na_values=[""])
        self.frame(df.head(max_rows), caption=caption, float_digits=float_digits)
        if len(df) > max_rows:
            self.paragraph(f"… and {len(df) - max_rows} more rows in `{Path(path).name}`.")
        return self

    def key_values(self, mapping: Mapping[str, Any], *, caption: str = "") -> Section:
        """A JSON document as a two-column table; nested keys joined with dots."""
        rows = [[k, _fmt_plain(v) if not isinstance(v, str) else v] for k, v in _flatten(mapping)]
        self.blocks.append(table_html(["item", "value"], rows, caption=caption))
        return self

    def scores(
        self,
        scores: Mapping[str, Any],
        *,
        groupings: Sequence[str] | None = None,
        caption: str = "",
    ) -> Section:
        """Tables of a scores JSON: one per grouping (default: every one the scores have)."""
        names = list(scores.get("by", {})) if groupings is None else list(groupings)
        for name in names:
            label = f"{caption} by {column_words(name)}" if caption else f"by {column_words(name)}"
            self.blocks.append(scores_table_html(scores, name, caption=label))
        return self

    def summary(
        self, labelled_scores: Mapping[str, Mapping[str, Any]], *, caption: str = ""
    ) -> Section:
        """One row per scores JSON with its overall metrics and bootstrap 95% CIs."""
        header, rows = overall_rows(labelled_scores)
        self.blocks.append(table_html(header, rows, caption=caption))
        return self

    def _figure_html(self, path: str | os.PathLike[str], caption: str) -> str:
        """A PNG at its natural size, never wider than the page; a click on it shows it
        whole (the figure becomes the ``:target`` of its own link: no script, no copy)."""
        p = Path(path)
        self.n_figures += 1
        anchor = f"{self.anchor}-f{self.n_figures}"
        alt = caption or p.stem.replace("_", " ")
        return (
            f'<figure id="{_esc(anchor)}"><a class="close" href="#{_esc(self.anchor)}">'
            "close full size</a>"
            f'<a class="open" href="#{_esc(anchor)}" title="open full size">'
            f'<img src="{_png_data_uri(p)}" alt="{_esc(alt)}"></a>'
            f"<figcaption>{_inline(caption or p.name)} "
            f'<a href="#{_esc(anchor)}">(full size)</a></figcaption></figure>'
        )

    def figure(self, path: str | os.PathLike[str], *, caption: str = "") -> Section:
        """A PNG embedded as a data URI, with its caption (:meth:`_figure_html`)."""
        self.blocks.append(self._figure_html(path, caption))
        return self

    def figures(
        self,
        paths: Iterable[str | os.PathLike[str]],
        *,
        captions: Mapping[str, str] | None = None,
    ) -> Section:
        """Several PNGs one after another, each at its natural size up to the page width;
        ``captions`` maps file names to captions."""
        for path in paths:
            name = Path(path).name
            self.figure(path, caption=(captions or {}).get(name, name))
        return self

    def files(
        self, paths: Mapping[str, str], *, caption: str = "Files", link: bool = False
    ) -> Section:
        """Where each result is: a table of description -> relative path; with ``link``, each
        path is a link to the file beside the page (paths separated by ", " are linked one
        by one; a path with ``{a,b}`` stays text, and so do the words of a parenthesis: in
        "events/ (scores, timelines)" only ``events/`` is a path)."""
        rows = []
        for what, where in paths.items():
            links = []
            for part in re.split(r"(, (?![^{(]*[})]))", where):
                plain = re.match(r"^([\w./-]+)(.*)$", part)
                if not link or part == ", " or plain is None or "{" in part:
                    links.append(_esc(part))
                else:
                    target, rest = plain.group(1), plain.group(2)
                    links.append(f'<a href="{_esc(target)}">{_esc(target)}</a>{_esc(rest)}')
            rows.append(f"<tr><th>{_esc(what)}</th><td>{''.join(links)}</td></tr>")
        self.blocks.append(
            '<div class="wrap"><table>'
            + (f"<caption>{_esc(caption)}</caption>" if caption else "")
            + "<thead><tr><th>result</th><th>file</th></tr></thead><tbody>"
            + "".join(rows)
            + "</tbody></table></div>"
        )
        return self

    def code(self, text: str) -> Section:
        self.blocks.append(f"<pre>{_esc(text)}</pre>")
        return self

    def raw_html(self) -> str:
        return (
            f'<section id="{_esc(self.anchor)}"><h2>{_esc(self.title)}</h2>\n'
            + "\n".join(self.blocks)
            + "\n</section>"
        )


class Report:
    """A self-contained HTML report: a title, an optional lead paragraph and sections."""

    def __init__(self, title: str, *, subtitle: str = "") -> None:
        self.title = title
        self.subtitle = subtitle
        self.sections: list[Section] = []

    def section(self, title: str) -> Section:
        """Add a section and return it (sections get stable anchors ``s1``, ``s2``, ...)."""
        sec = Section(title=title, anchor=f"s{len(self.sections) + 1}")
        self.sections.append(sec)
        return sec

    def render(self) -> str:
        """The whole page as text."""
        toc = "".join(
            f'<li><a href="#{_esc(s.anchor)}">{_esc(s.title)}</a></li>' for s in self.sections
        )
        parts = [
            "<!DOCTYPE html>",
            '<html lang="en"><head><meta charset="utf-8">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>{_esc(self.title)}</title>",
            f"<style>{_CSS}</style></head><body><main>",
            f"<h1>{_esc(self.title)}</h1>",
        ]
        if self.subtitle:
            parts.append(f'<p class="sub">{_inline(self.subtitle)}</p>')
        if len(self.sections) > 1:
            parts.append(f"<nav><ol>{toc}</ol></nav>")
        parts.extend(s.raw_html() for s in self.sections)
        parts.append(
            f"<footer>Written by turnbench {_esc(__version__)} (turn_eval.report). "
            "Self-contained: no scripts, fonts or images are loaded from elsewhere.</footer>"
        )
        parts.append("</main></body></html>")
        return "\n".join(parts) + "\n"

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the page atomically."""
        return write_text(path, self.render())


def load_json(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a JSON result, with a clear error naming the file if it is not JSON."""
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except json.JSONDecodeError as exc:
        raise TurnbenchError(f"not valid JSON: {exc.msg}", file=str(path), row=exc.lineno) from None
