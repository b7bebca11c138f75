"""The rig's whole mismatch discovery against the 120 s line (issue 29), beside a peer.

Runs, as a user would, ``pdmkit mismatch examples/pneumatic_rig/model_position.py
data11_1_1.csv --validation data11_1_2.csv data11_1_3.csv`` (estimate on one healthy
recording, validate on the other two) and, in the same run, the peer: the outside
reference fit of the same model's own parameters with scipy's ``least_squares``
(``examples/pneumatic_rig/reference_fit.py``, written without pdmkit). Each is a child
process; printed per run: wall and CPU seconds (the child's user + system), peak memory,
and for the discovery its stages (from the JSON's timings), verdict and validation RMSE;
then the medians, the ratio of the discovery to one outside fit, the target (120 s
wall, 1.5 GB) and the load average. numba's cache is warmed by a first discovery unless
``--cold``.

Usage::

    .venv/bin/python benchmarks/rig_discovery.py [--repeats 1] [--no-peer] [--cold]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("PDMKIT_DATA", ROOT.parent / "shared" / "data"))
DATA = DATA / "pneumatic_rig"
TARGET_S, TARGET_MB = 120.0, 1536.0
PEER_FILES = ("reference_fit.py", "sim.py", "model_thesis.py", "model_numpy.py")


def _child(cmd: list[str], cwd: Path) -> dict:
    """Wall, CPU (user + system) and peak memory of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu, "mb": after.ru_maxrss / 1024, "out": done.stdout}


def _discovery(work: Path) -> dict:
    exe = Path(sys.executable).with_name("pdmkit")
    cmd = [
        str(exe), "mismatch", str(ROOT / "examples/pneumatic_rig/model_position.py"),
        "data11_1_1.csv", "--validation", "data11_1_2.csv", "data11_1_3.csv",
        "--json", str(work / "rig.json"), "--out", str(work / "rig"),
    ]  # fmt: skip
    run = _child(cmd, DATA)
    res = json.loads((work / "rig.json").read_text())
    run["timings"] = res["diagnostics"]["timings"]
    v = res["verdict"]
    run["verdict"] = f"{v['effect']} on {v.get('target')}"
    run["rmse_mm"] = (res["fit"]["rmse_nominal"] * 1e3, res["fit"]["rmse_augmented"] * 1e3)
    return run


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--no-peer", action="store_true", help="skip the scipy reference fit")
    ap.add_argument("--cold", action="store_true", help="do not warm numba's cache first")
    a = ap.parse_args(argv)
    if not (DATA / "data11_1_1.csv").exists():
        sys.exit(f"the rig's recordings are not in {DATA} (set PDMKIT_DATA)")
    runs, peers = [], []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if not a.cold:
            _discovery(work)  # compiles the model's loops into numba's cache
        for _ in range(a.repeats):
            r = _discovery(work)
            t = r["timings"]
            print(
                f"discovery: {r['wall']:.1f} s wall, {r['cpu']:.1f} s CPU, "
                f"{r['mb']:.0f} MB; nominal {t['nominal_s']:.1f} s, screen and refit "
                f"{t['screen_refit_s']:.1f} s, data-driven terms {t['sparse_s']:.1f} s; "
                f"{r['verdict']}, validation {r['rmse_mm'][0]:.3f} -> "
                f"{r['rmse_mm'][1]:.3f} mm",
                flush=True,
            )
            runs.append(r)
            if not a.no_peer:  # a copy: it writes its fit_base.json beside itself
                for name in PEER_FILES:
                    src = ROOT / "examples/pneumatic_rig" / name
                    (work / name).write_text(src.read_text())
                p = _child([sys.executable, str(work / "reference_fit.py")], work)
                print(
                    f"peer (scipy least_squares, the file's own parameters): "
                    f"{p['wall']:.1f} s wall, {p['cpu']:.1f} s CPU",
                    flush=True,
                )
                peers.append(p)
    wall = statistics.median(r["wall"] for r in runs)
    cpu = statistics.median(r["cpu"] for r in runs)
    mb = max(r["mb"] for r in runs)
    line = f"median discovery {wall:.1f} s wall, {cpu:.1f} s CPU, peak {mb:.0f} MB"
    if peers:
        peer = statistics.median(p["wall"] for p in peers)
        line += f"; one outside fit {peer:.1f} s wall (ratio {wall / peer:.2f})"
    print(line)
    met = wall <= TARGET_S and mb <= TARGET_MB
    print(
        f"target <= {TARGET_S:.0f} s wall and <= {TARGET_MB:.0f} MB: "
        f"{'met' if met else 'NOT met'}; load average {os.getloadavg()[0]:.2f}"
    )
    return 0 if met else 1


if __name__ == "__main__":
    raise SystemExit(main())
