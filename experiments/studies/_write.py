"""What every study does around its own work: the output run, the timing, the files."""

from __future__ import annotations

import os
import time
from collections.abc import Callable

from threadpoolctl import threadpool_limits

from pdmkit._outputs import OutputRun, to_jsonable
from pdmkit.experiments._report import Report

__all__ = ["write_study"]


def write_study(
    out_dir: str | os.PathLike,
    json_path: str | os.PathLike | None,
    compute: Callable[[], tuple[dict, Callable[[dict], Report]]],
) -> dict:
    """Run a study's ``compute`` and write its ``summary.json`` and ``report.html``.

    ``compute()`` returns the summary and a function building the report from the
    summary (as written: with ``wall_s`` and ``cpu_s`` of the whole study added). The
    output folder is checked before any work and written all at once
    (:class:`pdmkit._outputs.OutputRun`, command ``study``). The studies' matrices are
    small: BLAS runs single-threaded, which on a busy machine is many times faster than
    threads fighting for cores.

    Examples
    --------
    >>> import tempfile
    >>> from pdmkit.experiments import Report
    >>> def compute():
    ...     return {"answer": 42}, lambda summary: Report("demo")
    >>> summary = write_study(tempfile.mkdtemp(), None, compute)
    >>> summary["answer"], sorted(summary)
    (42, ['answer', 'cpu_s', 'run_id', 'wall_s', 'warnings'])
    """
    started = time.perf_counter(), time.process_time()
    with (
        OutputRun(out_dir, "study", json_path=json_path) as run,
        threadpool_limits(1, user_api="blas"),
    ):
        summary, report = compute()
        summary["wall_s"] = round(time.perf_counter() - started[0], 2)
        summary["cpu_s"] = round(time.process_time() - started[1], 2)
        summary = to_jsonable(summary)
        run.add_json("summary.json", summary)
        run.add_report("report.html", report(summary))
        run.commit()
    return summary
