"""Start-up time of the ``pdmkit`` command (issue 15: ``pdmkit --version`` <= 1 s median).

Runs ``pdmkit --version`` and, for comparison, ``pdmkit --help`` (which builds the whole
command-line interface) ``--repeats`` times each in fresh processes and prints the
median and spread of the wall time, the CPU time of the children and the load average.

Usage::

    .venv/bin/python benchmarks/cli_startup.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path


def _command() -> list[str]:
    script = Path(sys.executable).with_name("pdmkit")
    if script.exists():
        return [str(script)]
    found = shutil.which("pdmkit")
    return [found] if found else [sys.executable, "-m", "pdmkit"]


def _time(args: list[str], repeats: int) -> tuple[list[float], float]:
    walls = []
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
        walls.append(time.perf_counter() - start)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime) / repeats
    return walls, cpu


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7, help="runs per command (7)")
    a = ap.parse_args(argv)
    base = _command()
    ok = True
    for extra, target in ((["--version"], 1.0), (["--help"], 1.0)):
        walls, cpu = _time([*base, *extra], a.repeats)
        median = statistics.median(walls)
        verdict = ""
        if target is not None:
            ok = ok and median <= target
            met = "met" if median <= target else "NOT met"
            verdict = f"  (target <= {target:g} s: {met})"
        print(
            f"pdmkit {' '.join(extra):10s} median {median:.3f} s wall "
            f"(min {min(walls):.3f}, max {max(walls):.3f}), {cpu:.3f} s CPU{verdict}"
        )
    print(f"load average {os.getloadavg()[0]:.2f}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
