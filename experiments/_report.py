"""Self-contained HTML reports: headings, text, tables, figures (PNG inline) and JSON.

A :class:`Report` collects blocks in order and writes one HTML file with no external
assets and no JavaScript, so it opens anywhere and can be mailed or archived as is.
Every piece of text is HTML-escaped; figures are embedded as base64 PNG.
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import os
import re
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._atomic import atomic_path
from pdmkit._outputs import to_jsonable
from pdmkit.errors import DataError

__all__ = ["Report"]

_CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif;
       max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222;
       line-height: 1.45; overflow-wrap: break-word; }
*, *::before, *::after { box-sizing: border-box; }
h1 { border-bottom: 2px solid #446; padding-bottom: .2em; }
h2, h3, h4 { color: #334; margin-top: 1.6em; }
p { margin: .6em 0; }
figure { margin: 1.2em 0; max-width: 100%; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption, .caption { color: #555; font-size: .92em; margin: .3em 0; }
.table-wrap { max-width: 100%; overflow-x: auto; margin: .3em 0 1em; }
table { border-collapse: collapse; font-size: .9em; }
th, td { border: 1px solid #ccc; padding: .25em .6em; vertical-align: top; }
th { background: #eef; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.long { overflow-wrap: anywhere; min-width: 18em; }
tbody tr:nth-child(even) { background: #f7f7fb; }
pre { background: #f5f5f5; border: 1px solid #ddd; padding: .8em; overflow-x: auto;
      font-size: .85em; white-space: pre-wrap; }
.summary { border: 2px solid #446; background: #f4f4fb; padding: .2em 1.2em;
           margin: 1.2em 0; }
.summary h2 { margin-top: .6em; }
.skipped { border-left: 4px solid #b80; background: #fff8e6; padding: .4em .8em;
           margin: .8em 0; }
footer { margin-top: 3em; color: #888; font-size: .8em; }
"""


def _readable_float(x: float) -> str:
    """About 4 significant digits, without an exponent between 1e-3 and 1e9.

    Examples
    --------
    >>> [_readable_float(v) for v in (0.97234, 25000.0, 1.0, 0.0012345, 3e-7)]
    ['0.9723', '25000', '1', '0.001234', '3e-07']
    """
    if not math.isfinite(x) or x == 0:
        return "0" if x == 0 else str(x)
    a = abs(x)
    if not 1e-3 <= a < 1e9:
        return f"{x:.4g}"
    decimals = max(0, 3 - math.floor(math.log10(a)))
    text = f"{x:.{decimals}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def _float_formatter(
    float_format: str | Callable[[float], str] | None,
) -> Callable[[float], str]:
    """The function formatting a table's floats, from ``add_table``'s ``float_format``."""
    if float_format is None:
        return _readable_float
    if callable(float_format):
        return float_format
    if not isinstance(float_format, str):
        raise TypeError(
            f"float_format must be a format string such as '{{:.4g}}' or '%.3f', or a "
            f"callable; got {type(float_format).__name__}"
        )
    if "{" in float_format:
        fmt = float_format.format
    elif "%" in float_format:

        def fmt(x: float) -> str:
            return float_format % x

    else:
        raise ValueError(
            f"float_format {float_format!r} is neither a str.format pattern ('{{:.3f}}') "
            "nor a %-pattern ('%.3f')"
        )
    try:
        fmt(1.5)
    except (ValueError, TypeError, IndexError, KeyError) as exc:
        raise ValueError(
            f"float_format {float_format!r} cannot format a float: {exc}"
        ) from None
    return fmt


def _table_cell(value: Any, fmt: Callable[[float], str]) -> tuple[str, bool]:
    """A table cell's text (unescaped), and whether it is a number (right-aligned)."""
    if isinstance(value, list | tuple | np.ndarray):
        return ", ".join(str(v) for v in value), False
    if value is None or (pd.api.types.is_scalar(value) and pd.isna(value)):
        return "—", False
    if isinstance(value, bool | np.bool_):
        return str(bool(value)), False
    if isinstance(value, float | np.floating):
        return fmt(float(value)), True
    if isinstance(value, int | np.integer):
        return str(int(value)), True
    return str(value), False


def _cell_class(text: str, numeric: bool) -> str:
    """The CSS class of a cell: ``num`` (right-aligned), ``long`` (a word that may wrap).

    Indicator names (``AccelerometerMoving_axisZ/cycle/S2_Decay``) are single words a
    browser will not wrap; a ``long`` cell (a word over 30 letters) may break them, so
    its column wraps them instead of pushing the table wider than the page.

    Examples
    --------
    >>> _cell_class("0.97", True)
    ' class="num"'
    >>> _cell_class("AccelerometerMoving_axisZ/cycle/S2_Decay; Strain/stats/Std", False)
    ' class="long"'
    >>> _cell_class("healthy", False)
    ''
    """
    if numeric:
        return ' class="num"'
    if any(len(word) > 30 for word in text.split()):
        return ' class="long"'
    return ""


def _plain_index(index: pd.Index) -> bool:
    """Whether an index is pandas' bookkeeping, not data: unnamed integers."""
    return index.name is None and pd.api.types.is_integer_dtype(index.dtype)


def _table_rows(df: pd.DataFrame, index: bool, fmt: Callable[[float], str]) -> list[str]:
    """The head and body of an HTML table, every cell escaped."""
    head = ([html.escape(str(df.index.name or ""))] if index else []) + [
        html.escape(str(c)) for c in df.columns
    ]
    out = ["<thead><tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr></thead>"]
    out.append("<tbody>")
    for idx, row in zip(df.index, df.itertuples(index=False, name=None), strict=True):
        cells = []
        if index:
            text = _table_cell(idx, fmt)[0]
            cells.append(f"<th{_cell_class(text, False)}>{html.escape(text)}</th>")
        for value in row:
            text, numeric = _table_cell(value, fmt)
            cells.append(f"<td{_cell_class(text, numeric)}>{html.escape(text)}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    return out


class Report:
    """A self-contained HTML report built block by block.

    Parameters
    ----------
    title : str
        Shown as the page title and the top heading.

    Notes
    -----
    Blocks are rendered to HTML when they are added, so a bad input fails at the
    ``add_*`` call that brought it. :meth:`write` writes through
    :func:`pdmkit._atomic.atomic_path`: an existing report is replaced only once the
    new one is complete.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import pandas as pd
    >>> rep = Report("Bearing faults")
    >>> rep.add_heading("Results")
    >>> rep.add_text("Accuracy <on test set> is high.")
    >>> rep.add_table(pd.DataFrame({"model": ["knn"], "accuracy": [0.98765]}),
    ...               caption="Models", float_format="{:.3f}")
    >>> rep.add_json({"accuracy": 0.98765}, caption="Summary")
    >>> path = rep.write(pathlib.Path(tempfile.mkdtemp()) / "report.html")
    >>> text = path.read_text()
    >>> "0.988" in text and "&lt;on test set&gt;" in text
    True
    """

    def __init__(self, title: str):
        self.title = str(title)
        self._blocks: list[str] = []
        self._anchors: set[str] = set()
        #: Id of the run that writes the report (set by :mod:`pdmkit._outputs`); shown
        #: in the footer and in ``<meta name="pdmkit-run">`` so a report can be matched
        #: with the run's JSON summary.
        self.run_id: str | None = None

    def __repr__(self) -> str:
        return f"Report({self.title!r}, blocks={len(self._blocks)})"

    def __len__(self) -> int:
        return len(self._blocks)

    # ------------------------------------------------------------------ blocks
    def add_heading(self, text: str, level: int = 2) -> None:
        """Add a section heading.

        Parameters
        ----------
        text : str
            Heading text (escaped).
        level : int, default 2
            HTML heading level, 2 to 4 (level 1 is the report title).

        Examples
        --------
        >>> rep = Report("r")
        >>> rep.add_heading("Sensors")
        >>> '<h2 id="sensors">Sensors</h2>' in rep.to_html()
        True
        """
        if level not in (2, 3, 4):
            raise ValueError(f"heading level must be 2, 3 or 4; got {level!r}")
        anchor = self.anchor(text)
        self._anchors.add(anchor)
        self._blocks.append(f'<h{level} id="{anchor}">{html.escape(str(text))}</h{level}>')

    def anchor(self, heading: str) -> str:
        """The link target a heading gets (``#`` + this), unique within the report.

        Lower-case words of the heading joined by ``-``; a repeated heading gets a
        ``-2``, ``-3``, ... suffix, so call this before :meth:`add_heading` to know the
        anchor of the heading about to be added.

        Examples
        --------
        >>> rep = Report("r")
        >>> rep.anchor("3. Sensors by accuracy & cost")
        '3-sensors-by-accuracy-cost'
        """
        words = re.findall(r"[a-z0-9]+", str(heading).lower())
        base = "-".join(words) or "section"
        anchor, n = base, 1
        while anchor in self._anchors:
            n += 1
            anchor = f"{base}-{n}"
        return anchor

    def add_summary_box(
        self, rows: Sequence[tuple[str, str, str | None]], title: str = "Summary"
    ) -> None:
        """Put a summary box at the top of the report (before every other block).

        Parameters
        ----------
        rows : sequence of (label, text, anchor)
            One line each: a bold label, a sentence, and the anchor of the section
            that tells more (from :meth:`anchor`; None for no link).
        title : str
            The box's heading.

        Examples
        --------
        >>> rep = Report("r")
        >>> rep.add_heading("Sensors")
        >>> rep.add_summary_box([("Best sensor", "encoder, 0.97", "sensors")])
        >>> html = rep.to_html()
        >>> html.index('class="summary"') < html.index('<h2 id="sensors">')
        True
        >>> '<a href="#sensors">' in html
        True
        """
        items = []
        for label, text, anchor in rows:
            more = f' <a href="#{html.escape(anchor)}">more</a>' if anchor else ""
            items.append(
                f"<li><strong>{html.escape(str(label))}</strong>: "
                f"{html.escape(str(text))}{more}</li>"
            )
        self._blocks.insert(
            0,
            f'<div class="summary"><h2>{html.escape(str(title))}</h2>\n<ul>\n'
            + "\n".join(items)
            + "\n</ul></div>",
        )

    def add_text(self, paragraph: str) -> None:
        """Add a paragraph of plain text (escaped; blank lines start new paragraphs).

        Examples
        --------
        >>> rep = Report("r")
        >>> rep.add_text("a < b")
        >>> "<p>a &lt; b</p>" in rep.to_html()
        True
        """
        parts = [p.strip() for p in str(paragraph).split("\n\n") if p.strip()]
        for part in parts:
            self._blocks.append(f"<p>{html.escape(part)}</p>")

    def add_skipped(self, what: str, reason: str) -> None:
        """Say that a part of the report was skipped, and why.

        A report that promises a section must not leave it out silently: this adds a
        marked line ``<what>: skipped: <reason>`` where the section would stand.

        Parameters
        ----------
        what : str
            The part left out (a section's title).
        reason : str
            Why, e.g. ``"../shared/data/cascaded_tanks not found"``.

        Examples
        --------
        >>> rep = Report("r")
        >>> rep.add_skipped("Cascaded Tanks", "../shared/data/cascaded_tanks not found")
        >>> "Cascaded Tanks: skipped: ../shared/data/cascaded_tanks not found" in (
        ...     rep.to_html().replace("<strong>", "").replace("</strong>", ""))
        True
        """
        self._blocks.append(
            f'<p class="skipped"><strong>{html.escape(str(what))}</strong>: skipped: '
            f"{html.escape(str(reason))}</p>"
        )

    def add_table(
        self,
        df: pd.DataFrame | pd.Series,
        caption: str | None = None,
        float_format: str | Callable[[float], str] | None = None,
        *,
        index: bool | None = None,
        max_rows: int | None = 500,
    ) -> None:
        """Add a table, in a box of its own that scrolls sideways when it is too wide.

        The caption stands above the table across the page's column; a cell with a
        long word (an indicator name, a fault code) may wrap it.

        Parameters
        ----------
        df : pandas.DataFrame or pandas.Series
            The table. Cells are converted with ``str`` and escaped; floats use
            ``float_format``; missing values show as an em dash.
        caption : str, optional
            Shown above the table.
        float_format : str or callable, optional
            A ``str.format`` pattern (``"{:.3f}"``), a %-pattern (``"%.3f"``) or a
            function ``float -> str``; default: about 4 significant digits, with no
            exponent for costs and counts (``25000``, ``0.9723``).
        index : bool, optional
            Show the index; default: unless it is unnamed integers (pandas'
            row numbers, not data).
        max_rows : int or None, default 500
            Show at most this many rows (a note says how many were left out).

        Examples
        --------
        >>> import pandas as pd
        >>> rep = Report("r")
        >>> rep.add_table(pd.DataFrame({"x": [1.23456]}), float_format="%.2f")
        >>> "1.23" in rep.to_html() and "1.234" not in rep.to_html()
        True
        """
        if isinstance(df, pd.Series):
            df = df.to_frame()
        if not isinstance(df, pd.DataFrame):
            raise TypeError(
                f"add_table expects a pandas DataFrame; got {type(df).__name__}"
            )
        fmt = _float_formatter(float_format)
        if index is None:
            index = not _plain_index(df.index)
        omitted = 0
        if max_rows is not None and len(df) > max_rows:
            omitted = len(df) - max_rows
            df = df.iloc[:max_rows]
        out = []
        if caption:
            out.append(f'<p class="caption">{html.escape(str(caption))}</p>')
        out.append('<div class="table-wrap"><table>')
        out += _table_rows(df, index, fmt)
        out.append("</div>")
        if omitted:
            out.append(f"<p><em>{omitted} more rows not shown.</em></p>")
        self._blocks.append("\n".join(out))

    def add_figure(
        self, fig_or_ax: Any, caption: str | None = None, *, dpi: int = 110
    ) -> None:
        """Add a matplotlib figure (or the figure of an axes) as an inline PNG.

        The figure is closed afterwards, so building long reports does not pile up
        open figures.

        Parameters
        ----------
        fig_or_ax : matplotlib.figure.Figure or matplotlib.axes.Axes
            What to embed.
        caption : str, optional
            Shown under the figure.
        dpi : int, default 110
            Resolution of the PNG.

        Examples
        --------
        >>> import matplotlib
        >>> matplotlib.use("Agg")
        >>> import matplotlib.pyplot as plt
        >>> fig, ax = plt.subplots()
        >>> _ = ax.plot([0, 1], [0, 1])
        >>> rep = Report("r")
        >>> rep.add_figure(ax, caption="a line")
        >>> '<img src="data:image/png;base64,' in rep.to_html()
        True
        >>> plt.fignum_exists(fig.number)
        False
        """
        from matplotlib.axes import Axes
        from matplotlib.figure import Figure, SubFigure

        if isinstance(fig_or_ax, Axes):
            fig = fig_or_ax.figure
        elif isinstance(fig_or_ax, Figure | SubFigure):
            fig = fig_or_ax
        else:
            raise TypeError(
                "add_figure expects a matplotlib Figure or Axes (for example what a "
                f"result's .plot() returns); got {type(fig_or_ax).__name__}"
            )
        while isinstance(fig, SubFigure):
            fig = fig.figure
        buffer = io.BytesIO()
        try:
            fig.savefig(buffer, format="png", dpi=dpi, bbox_inches="tight")
        finally:
            import matplotlib.pyplot as plt

            plt.close(fig)
        data = base64.b64encode(buffer.getvalue()).decode("ascii")
        alt = html.escape(str(caption) if caption else "figure", quote=True)
        block = f'<figure><img src="data:image/png;base64,{data}" alt="{alt}">'
        if caption:
            block += f"<figcaption>{html.escape(str(caption))}</figcaption>"
        self._blocks.append(block + "</figure>")

    def add_json(self, data: Any, caption: str | None = None) -> None:
        """Add a dictionary (or list) as pretty-printed JSON.

        NaN and infinities are shown as ``null``, numpy values as plain numbers.

        Examples
        --------
        >>> rep = Report("r")
        >>> rep.add_json({"accuracy": float("nan")}, caption="summary")
        >>> '&quot;accuracy&quot;: null' in rep.to_html()
        True
        """
        try:
            text = json.dumps(to_jsonable(data), indent=2, allow_nan=False)
        except TypeError as exc:
            raise DataError(f"add_json({caption or 'data'}): {exc}") from None
        block = ""
        if caption:
            block += f'<p class="caption"><strong>{html.escape(str(caption))}</strong></p>'
        self._blocks.append(block + f"<pre>{html.escape(text)}</pre>")

    # ------------------------------------------------------------------ output
    def _render(self) -> Iterator[str]:
        from pdmkit import __version__

        title = html.escape(self.title)
        run = html.escape(str(self.run_id)) if self.run_id else ""
        meta = f'<meta name="pdmkit-run" content="{run}">\n' if run else ""
        yield (
            '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"{meta}<title>{title}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
            f"<h1>{title}</h1>\n"
        )
        for block in self._blocks:
            yield block + "\n"
        footer = f"Generated by pdmkit {html.escape(__version__)}"
        footer += f", run {run}." if run else "."
        yield f"<footer>{footer}</footer>\n"
        yield "</body>\n</html>\n"

    def to_html(self) -> str:
        """Return the whole report as one HTML string.

        Examples
        --------
        >>> Report("T & C").to_html().count("T &amp; C")
        2
        """
        return "".join(self._render())

    def write(self, path: str | os.PathLike) -> Path:
        """Write the report to ``path`` atomically and return the path.

        An existing file at ``path`` is replaced only after the new report has been
        written completely; if anything fails on the way it keeps its content.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> p = Report("empty").write(pathlib.Path(tempfile.mkdtemp()) / "r.html")
        >>> p.read_text().startswith("<!DOCTYPE html>")
        True
        """
        path = Path(path)
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as handle:
            for chunk in self._render():
                handle.write(chunk)
        return path
