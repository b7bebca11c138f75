"""Benchmark: feature extraction over an on-disk ensemble in-process and on Dask.

A synthetic ensemble the size of the seed's recordings (4840 members x 13 signals x
10000 samples at 1 kHz: 5.0 GB of float64 samples) is generated to disk in chunks of
128 members (:func:`pdmkit.ensembles._parquet.write_parquet_batches`: no process ever
holds it whole), then ``extract_ensemble(path, groups=("stats", "spectral"))`` runs

- in-process (streaming batches of ``--batch-size`` members, threads over chunks),
- on a Dask ``LocalCluster`` with 1 worker process (1 thread),
- on a Dask ``LocalCluster`` with 2 worker processes (1 thread each),

each in a fresh subprocess. The script prints the time, the throughput (members/s
and MB/s of samples), the peak resident memory of the process that extracts
(Linux VmHWM, reset after imports; for Dask: the driver and every worker), and checks
that the three feature tables are identical.

The target of issue 7: in-process peak memory < 2 GB and < 2 minutes on the 2-core
machine. Note that the machine may be shared: times vary with other load.

Usage::

    .venv/bin/python benchmarks/scale.py                # seed size (needs ~5 GB disk)
    .venv/bin/python benchmarks/scale.py --quick        # 240 members: a few seconds
    .venv/bin/python benchmarks/scale.py --json results/scale.json --keep
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

FS = 1000.0
GROUPS = ("stats", "spectral")
CHUNK = 128


# --------------------------------------------------------------------------- memory
def _hwm_bytes() -> int:
    """Peak resident set size of this process (Linux VmHWM)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return 0


def _reset_hwm() -> None:
    """Reset VmHWM to the current RSS (Linux >= 4.0)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


# --------------------------------------------------------------------------- data
def generate(path: Path, members: int, signals: int, samples: int, seed: int = 0) -> Path:
    """Write the synthetic ensemble in chunks; reuse it when already there."""
    from pdmkit.ensembles import Ensemble
    from pdmkit.ensembles._parquet import read_manifest, write_parquet_batches
    from pdmkit.errors import DataError

    try:
        m = read_manifest(path)
        if m["n_members"] == members and len(m["signals"]) == signals:
            print(f"reusing {path} ({members} members)", flush=True)
            return path
    except DataError:
        pass
    names = [f"S{j:02d}" for j in range(signals)]
    t = np.arange(samples) / FS
    faults = np.array(["healthy", "leak", "clog", "wear"])

    def chunks():
        rng = np.random.default_rng(seed)
        for start in range(0, members, CHUNK):
            n = min(CHUNK, members - start)
            f0 = rng.uniform(1.0, 50.0, size=(n, 1))
            data = {}
            for j, name in enumerate(names):
                tone = np.sin(2 * np.pi * (f0 * (j + 1)) * t)
                data[name] = tone + 0.3 * rng.standard_normal((n, samples))
            yield Ensemble(
                data,
                fs=FS,
                conditions={"fault": faults[(np.arange(start, start + n)) % 4]},
                member_ids=[f"m{i:05d}" for i in range(start, start + n)],
            )

    start = time.perf_counter()
    write_parquet_batches(chunks(), path)
    size = sum(p.stat().st_size for p in path.iterdir())
    print(
        f"generated {members} x {signals} x {samples} in {time.perf_counter() - start:.0f}"
        f" s ({size / 1e9:.2f} GB on disk)",
        flush=True,
    )
    return path


# --------------------------------------------------------------------------- child
def _warm() -> None:
    """Import pdmkit and run a tiny extraction (imports, FFT plans)."""
    from pdmkit.ensembles import Ensemble
    from pdmkit.features import extract_ensemble

    extract_ensemble(Ensemble({"x": np.zeros((2, 2048))}, fs=FS), groups=GROUPS)


def child(mode: str, path: str, out: str, batch_size: int) -> dict:
    """Run one extraction in this (fresh) process; return its measurements."""
    from pdmkit.ensembles._distributed import dask_client
    from pdmkit.features import extract_ensemble

    _warm()
    workers = {"inprocess": None, "dask1": 1, "dask2": 2}[mode]
    with dask_client(workers) as client:
        if client is not None:
            client.run(_warm)  # each worker imports pdmkit before the clock starts
            client.run(_reset_hwm)
        _reset_hwm()
        start = time.perf_counter()
        table = extract_ensemble(path, groups=GROUPS, batch_size=batch_size, client=client)
        elapsed = time.perf_counter() - start
        driver = _hwm_bytes()
        per_worker = list(client.run(_hwm_bytes).values()) if client is not None else []
    table.to_parquet(out)
    return {
        "mode": mode,
        "seconds": elapsed,
        "members": len(table),
        "peak_driver_bytes": driver,
        "peak_worker_bytes": per_worker,
    }


# --------------------------------------------------------------------------- main
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--members", type=int, default=4840)
    parser.add_argument("--signals", type=int, default=13)
    parser.add_argument("--samples", type=int, default=10_000)
    parser.add_argument(
        "--quick", action="store_true", help="240 members, batches of 32 (smoke run)"
    )
    parser.add_argument(
        "--batch-size", type=int, help="members per batch / task (256; --quick: 32)"
    )
    parser.add_argument("--modes", nargs="+", default=["inprocess", "dask1", "dask2"])
    parser.add_argument("--dir", type=Path, help="where to write the ensemble")
    parser.add_argument("--keep", action="store_true", help="keep the generated ensemble")
    parser.add_argument("--json", type=Path, help="write the results here")
    parser.add_argument(
        "--child", nargs=3, metavar=("MODE", "PATH", "OUT"), help=argparse.SUPPRESS
    )
    args = parser.parse_args(argv)
    if args.batch_size is None:
        args.batch_size = 32 if args.quick else 256
    if args.child:
        result = child(*args.child, batch_size=args.batch_size)
        print("RESULT " + json.dumps(result), flush=True)
        return 0
    if args.quick:
        args.members = 240
    root = args.dir or Path(tempfile.mkdtemp(prefix="pdmkit-scale-"))
    root.mkdir(parents=True, exist_ok=True)
    path = generate(root / "ensemble", args.members, args.signals, args.samples)
    data_bytes = args.members * args.signals * args.samples * 8
    results = []
    try:
        for mode in args.modes:
            out = root / f"features-{mode}.parquet"
            cmd = [sys.executable, __file__, "--batch-size", str(args.batch_size)]
            cmd += ["--child", mode, str(path), str(out)]
            proc = subprocess.run(cmd, capture_output=True, text=True)
            lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
            if proc.returncode or not lines:
                print(proc.stdout[-2000:], proc.stderr[-4000:], file=sys.stderr)
                return 1
            r = json.loads(lines[-1][len("RESULT ") :])
            r["members_per_s"] = r["members"] / r["seconds"]
            r["mb_per_s"] = data_bytes / 1e6 / r["seconds"]
            results.append(r)
            workers = ", ".join(f"{b / 2**30:.2f}" for b in r["peak_worker_bytes"])
            driver = r["peak_driver_bytes"] / 2**30
            print(
                f"{mode:10s} {r['seconds']:7.1f} s  {r['members_per_s']:7.1f} members/s  "
                f"{r['mb_per_s']:6.0f} MB/s  peak driver {driver:.2f} GiB"
                + (f", workers [{workers}] GiB" if workers else ""),
                flush=True,
            )
        import pandas as pd

        tables = [pd.read_parquet(root / f"features-{m}.parquet") for m in args.modes]
        for t in tables[1:]:
            pd.testing.assert_frame_equal(t, tables[0], check_exact=True)
        print(f"feature tables identical across {', '.join(args.modes)}", flush=True)
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    summary = {
        "members": args.members,
        "signals": args.signals,
        "samples": args.samples,
        "data_bytes": data_bytes,
        "groups": list(GROUPS),
        "batch_size": args.batch_size,
        "results": results,
    }
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(summary, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
