"""How workflows speak and finish: one line on stderr, and the run's two files."""

from __future__ import annotations

import sys

from pdmkit._outputs import OutputRun

__all__ = ["finish", "say"]


def say(message: str) -> None:
    """Print ``pdmkit: message`` on stderr (progress and results people read).

    Examples
    --------
    >>> say("hello")  # on stderr
    """
    print(f"pdmkit: {message}", file=sys.stderr, flush=True)


def finish(run: OutputRun, summary: dict, report, then=None) -> None:
    """Register ``summary.json`` and ``report.html`` with the run and commit it."""
    run.add_json("summary.json", summary)
    run.add_report("report.html", report)
    run.commit(then)
    say(f"wrote {run.path('summary.json')} and {run.path('report.html')}")
