"""The self-contained HTML report."""

from __future__ import annotations

import base64
import re
from html.parser import HTMLParser

import matplotlib
import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError
from pdmkit.experiments._report import Report

matplotlib.use("Agg")
import matplotlib.pyplot as plt


class _Collect(HTMLParser):
    """Collects tags, attributes and text of an HTML document (a strict-ish reader)."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict]] = []
        self.text: list[str] = []
        self.open: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag not in {"meta", "img", "br"}:
            self.open.append(tag)

    def handle_endtag(self, tag):
        assert self.open and self.open[-1] == tag, f"</{tag}> closes <{self.open[-1:]}>"
        self.open.pop()

    def handle_data(self, data):
        self.text.append(data)


def _parse(text: str) -> _Collect:
    parser = _Collect()
    parser.feed(text)
    parser.close()
    assert parser.open == [], f"unclosed tags {parser.open}"
    return parser


def _full_report() -> Report:
    rep = Report("Sensor study <rig 1>")
    rep.add_heading("Accuracy & cost")
    rep.add_text("Microphones are cheap.\n\nFlow sensors are <b>best</b>.")
    table = pd.DataFrame(
        {
            "sensor": ["Flow", "Mics", "<script>alert(1)</script>"],
            "accuracy": [0.97234, 0.95812, np.nan],
            "cost": [6000, 1500, 1000],
            "pareto": [True, True, False],
        }
    )
    rep.add_table(table, caption="Table 9.1", float_format="{:.3f}")
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    rep.add_figure(fig, caption="accuracy vs cost")
    rep.add_json(
        {"accuracy": 0.97234, "missing": float("nan"), "n": np.int64(3)}, "summary"
    )
    return rep


def test_written_report_holds_values_image_and_escaped_text(tmp_path):
    path = _full_report().write(tmp_path / "out" / "report.html")
    assert path == tmp_path / "out" / "report.html"
    text = path.read_text(encoding="utf-8")
    doc = _parse(text)
    visible = "".join(doc.text)
    for value in ("0.972", "0.958", "6000", "1500", "Flow", "Mics", "Table 9.1", "True"):
        assert value in visible
    assert "<script>" not in text and "&lt;script&gt;" in text
    assert "&lt;b&gt;best&lt;/b&gt;" in text
    assert "Sensor study &lt;rig 1&gt;" in text
    assert [t for t, _ in doc.tags].count("p") >= 2
    # the figure is an inline PNG
    assert '<img src="data:image/png;base64,' in text
    src = next(a["src"] for t, a in doc.tags if t == "img")
    png = base64.b64decode(src.split(",", 1)[1])
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    # JSON block: NaN written as null, numpy ints as numbers
    assert '"missing": null' in visible and '"n": 3' in visible
    # self-contained: nothing fetched from elsewhere, no scripts
    assert not any(t == "script" for t, _ in doc.tags)
    assert not re.search(r"(src|href)=\"(https?:)?//", text)


def test_failure_while_writing_keeps_the_existing_report(tmp_path, monkeypatch):
    path = tmp_path / "report.html"
    path.write_text("previous report")
    rep = _full_report()

    def broken(self):
        yield "<!DOCTYPE html><html><body><p>half"
        raise RuntimeError("disk full")

    monkeypatch.setattr(Report, "_render", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        rep.write(path)
    assert path.read_text() == "previous report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]


def test_failure_while_building_keeps_the_existing_report(tmp_path):
    path = tmp_path / "report.html"
    path.write_text("previous report")
    rep = Report("r")
    rep.add_text("fine")
    with pytest.raises(DataError, match="cannot write 'object' values to JSON"):
        rep.add_json({"x": object()}, caption="bad")
    with pytest.raises(TypeError, match="Figure or Axes"):
        rep.add_figure("not a figure")
    assert path.read_text() == "previous report"
    rep.write(path)
    assert "fine" in path.read_text()


def test_figures_are_closed(tmp_path):
    fig, ax = plt.subplots()
    rep = Report("r")
    rep.add_figure(ax)
    assert not plt.fignum_exists(fig.number)


def test_table_options():
    df = pd.DataFrame(
        {"x": [1.23456, np.nan], "n": [1, 2]}, index=pd.Index(["a", "b"], name="k")
    )
    rep = Report("r")
    rep.add_table(df, float_format="%.2f")
    html = rep.to_html()
    assert "1.23" in html and "1.235" not in html
    assert "<th>k</th>" in html and "<th>a</th>" in html  # a named index is shown
    assert "—" in html  # missing value
    rep = Report("r")
    rep.add_table(pd.DataFrame({"x": range(10)}), max_rows=3)
    assert "7 more rows not shown" in rep.to_html()
    with pytest.raises(ValueError, match="float_format"):
        Report("r").add_table(df, float_format=".2f")
    with pytest.raises(TypeError, match="DataFrame"):
        Report("r").add_table([1, 2])


def test_heading_levels():
    rep = Report("r")
    rep.add_heading("A", level=3)
    rep.add_heading("A", level=4)  # a repeated heading gets its own anchor
    html = rep.to_html()
    assert '<h3 id="a">A</h3>' in html and '<h4 id="a-2">A</h4>' in html
    with pytest.raises(ValueError, match="level"):
        rep.add_heading("B", level=1)
