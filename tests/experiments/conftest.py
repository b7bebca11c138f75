"""Shared fixtures of the workflow tests: one quick demo run for every test that reads it.

``pdmkit demo`` is the slowest command; ``test_demo.py`` checks what it writes and
``test_report_screens.py`` how its report reads in a browser. Both take the same run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pytest

from pdmkit._outputs import OUTPUTS
from pdmkit.experiments._cli import main
from pdmkit.experiments._report import Report


@dataclass
class DemoRun:
    """A finished quick demo: its folders, exit code and the axis labels of its figures."""

    tmp: Path
    out: Path
    code: int
    axis_labels: list[str] = field(default_factory=list)


def figure_axis_labels(fig_or_ax) -> list[str]:
    """The non-empty x and y labels of every axes of a figure (or an axes' figure)."""
    fig = getattr(fig_or_ax, "figure", fig_or_ax)
    while getattr(fig, "figure", None) is not None and fig.figure is not fig:
        fig = fig.figure
    return [
        label
        for ax in fig.axes
        for label in (ax.get_xlabel(), ax.get_ylabel())
        if label.strip()
    ]


def recording_labels(monkeypatch: pytest.MonkeyPatch, labels: list[str]) -> None:
    """Make :meth:`Report.add_figure` note each figure's axis labels in ``labels``."""
    add_figure = Report.add_figure

    def add(self, fig_or_ax, *args, **kwargs):
        labels.extend(figure_axis_labels(fig_or_ax))
        return add_figure(self, fig_or_ax, *args, **kwargs)

    monkeypatch.setattr(Report, "add_figure", add)


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory) -> DemoRun:
    """``pdmkit demo`` at its smallest (80 recordings of 2.5 s), run once per session.

    The output folder holds the user's files and a stale run's: the demo must replace
    its own files and leave the user's byte for byte (the demo's case of
    tests/security/test_output_folders.py, set up here to run the demo once).
    """
    tmp = tmp_path_factory.mktemp("demo_run")
    out = tmp / "demo"
    (out / "rul").mkdir(parents=True)
    (out / "notes.txt").write_text("mine\n")
    (out / "rul" / "mine.csv").write_text("a,b\n1,2\n")
    for name in OUTPUTS["demo"]:
        (out / name).write_text("stale\n")
    argv = ["demo", "--out", str(out), "--n-members", "80", "--seed", "2"]
    argv += ["--recording-s", "2.5", "--json", str(tmp / "copy.json")]
    run = DemoRun(tmp, out, code=-1)
    with pytest.MonkeyPatch.context() as mp:
        recording_labels(mp, run.axis_labels)
        run.code = main(argv)
    return run


@pytest.fixture(scope="session")
def label_recorder():
    """:func:`recording_labels`, for tests that build reports themselves."""
    return recording_labels
