"""Benchmark: pdmkit.features.extract against tsfresh on one synthetic ensemble.

Both libraries compute the matching condition indicators of the same members in the
same run; the script prints both times, the speed ratio and pdmkit's peak memory.

pdmkit: ``extract(x, fs, groups=("stats", "spectral"))`` - 11 statistics and 21 Welch-PSD
features per member (5 peak amplitudes and frequencies, total power, spectral centroid,
spread, kurtosis, entropy, flatness), default ``workers`` (one thread per core).

tsfresh: the closest calculators (tsfresh has no PSD peak finder):

=============================  ==================================================
tsfresh calculator             pdmkit feature
=============================  ==================================================
mean                           stats/Mean
standard_deviation             stats/Std (tsfresh divides by n, pdmkit by n - 1)
root_mean_square               stats/RMS
absolute_maximum               stats/PeakValue
maximum, minimum               stats/PeakToPeak
kurtosis                       stats/Kurtosis (tsfresh: pandas' excess, unbiased)
skewness                       stats/Skewness (tsfresh: pandas' unbiased)
spkt_welch_density coeff 2/5/8 spectral/PeakAmp* (Welch PSD values)
fft_aggregated centroid,       spectral/SpectralCentroid, SpectralSpread,
variance, skew, kurtosis       SpectralKurtosis (moments of the spectrum)
=============================  ==================================================

tsfresh runs once with ``n_jobs=2`` (its fastest setting on a 2-core machine; it uses
worker processes) and ``disable_progressbar=True``; its time covers
``extract_features`` only, not building its long-format input table. pdmkit's time is
the median of ``--repeats`` runs. pdmkit's peak memory is measured in a fresh
subprocess: the peak resident set size while ``extract`` runs (Linux
``/proc/self/status`` VmHWM, reset after the data are generated; it includes the
interpreter and the input array), and the peak of Python-tracked allocations made by
``extract`` itself (tracemalloc; numpy reports its buffers to it).

Usage::

    .venv/bin/python benchmarks/features_vs_tsfresh.py                 # 2000 x 10000
    .venv/bin/python benchmarks/features_vs_tsfresh.py --members 200 --samples 4096
    .venv/bin/python benchmarks/features_vs_tsfresh.py --json results/bench.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

FS = 10_000.0
GROUPS = ("stats", "spectral")

TSFRESH_PARAMETERS = {
    "mean": None,
    "standard_deviation": None,
    "root_mean_square": None,
    "absolute_maximum": None,
    "maximum": None,
    "minimum": None,
    "kurtosis": None,
    "skewness": None,
    "spkt_welch_density": [{"coeff": c} for c in (2, 5, 8)],
    "fft_aggregated": [
        {"aggtype": a} for a in ("centroid", "variance", "skew", "kurtosis")
    ],
}

CLASSES = ("normal", "imbalance", "bearing", "gear")


def make_ensemble(members: int, samples: int, fs: float = FS, seed: int = 0):
    """Synthetic vibration members of four fault-like classes, float64.

    normal: shaft tone + broadband noise; imbalance: a strong 1x shaft tone;
    bearing: impacts at a defect rate ringing a 3 kHz resonance; gear: a mesh tone with
    harmonics and shaft sidebands. Shaft speed, amplitudes and noise vary by member.
    Generated in blocks into one preallocated array (no full-size temporaries).
    """
    rng = np.random.default_rng(seed)
    labels = np.array(CLASSES)[np.arange(members) % len(CLASSES)]
    x = np.empty((members, samples))
    t = np.arange(samples) / fs
    block = 256
    for start in range(0, members, block):
        stop = min(start + block, members)
        m = stop - start
        lab = labels[start:stop]
        shaft = rng.uniform(20.0, 40.0, (m, 1))
        phase = rng.uniform(0, 2 * np.pi, (m, 1))
        out = x[start:stop]
        out[:] = rng.normal(size=(m, samples))
        out *= rng.uniform(0.2, 0.5, (m, 1))
        out += 0.3 * np.sin(2 * np.pi * shaft * t + phase)
        imb = lab == "imbalance"
        if imb.any():
            out[imb] += rng.uniform(1.0, 2.0, (imb.sum(), 1)) * np.sin(
                2 * np.pi * shaft[imb] * t + phase[imb]
            )
        brg = lab == "bearing"
        if brg.any():
            rate = 5.4 * shaft[brg]
            since = (t + rng.uniform(0, 0.05, (brg.sum(), 1))) % (1.0 / rate)
            out[brg] += (
                rng.uniform(1.0, 3.0, (brg.sum(), 1))
                * np.exp(-2000.0 * since)
                * np.sin(2 * np.pi * 3000.0 * since)
            )
        gear = lab == "gear"
        if gear.any():
            mesh = 27 * shaft[gear]
            for h, a in ((1, 0.8), (2, 0.4), (3, 0.2)):
                out[gear] += a * np.sin(2 * np.pi * h * mesh * t)
            out[gear] += 0.2 * np.sin(2 * np.pi * (mesh + shaft[gear]) * t)
    return x, labels


def run_pdmkit(x: np.ndarray, fs: float, repeats: int):
    import pdmkit.features as pf

    pf.extract(x[: min(len(x), 8)], fs, groups=GROUPS)  # warm up imports and caches
    times = []
    table = None
    for _ in range(repeats):
        start = time.perf_counter()
        table = pf.extract(x, fs, groups=GROUPS)
        times.append(time.perf_counter() - start)
    return statistics.median(times), times, table


def run_tsfresh(x: np.ndarray, fs: float, n_jobs: int):
    import pandas as pd
    from tsfresh import extract_features

    members, samples = x.shape
    long = pd.DataFrame(
        {"id": np.repeat(np.arange(members), samples), "value": x.reshape(-1)}
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.perf_counter()
        table = extract_features(
            long,
            column_id="id",
            column_value="value",
            default_fc_parameters=TSFRESH_PARAMETERS,
            n_jobs=n_jobs,
            disable_progressbar=True,
        )
        elapsed = time.perf_counter() - start
    return elapsed, table


def _status_kib(field: str) -> int | None:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def memory_probe(members: int, samples: int, fs: float) -> dict:
    """Run in a fresh process: generate the data, then measure one extract call."""
    import resource
    import tracemalloc

    import pdmkit.features as pf

    x, _ = make_ensemble(members, samples, fs)
    pf.extract(x[:4], fs, groups=GROUPS)  # imports and first-call setup outside the peak
    reset = False
    try:  # reset the resident-set high-water mark (Linux >= 4.0)
        Path("/proc/self/clear_refs").write_text("5")
        reset = True
    except OSError:
        pass
    before_kib = _status_kib("VmRSS")
    tracemalloc.start()
    pf.extract(x, fs, groups=GROUPS)
    _, traced_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    hwm = _status_kib("VmHWM") if reset else None
    if hwm is None:
        hwm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return {
        "peak_rss_mb": hwm / 1024.0,
        "rss_before_mb": (before_kib or 0) / 1024.0,
        "extract_alloc_peak_mb": traced_peak / 2**20,
        "input_mb": x.nbytes / 2**20,
        "hwm_reset": reset,
    }


def measure_memory(members: int, samples: int, fs: float) -> dict:
    proc = subprocess.run(
        [
            sys.executable,
            __file__,
            "--_memory-probe",
            "--members",
            str(members),
            "--samples",
            str(samples),
            "--fs",
            str(fs),
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(proc.stdout.strip().splitlines()[-1])


def cross_check(pdm, tsf) -> dict:
    """Largest differences of the features both libraries define the same way."""
    pairs = {
        "Mean": ("stats/Mean", "value__mean"),
        "RMS": ("stats/RMS", "value__root_mean_square"),
        "PeakValue": ("stats/PeakValue", "value__absolute_maximum"),
    }
    out = {}
    for name, (a, b) in pairs.items():
        ours = pdm[a].to_numpy()
        theirs = tsf[b].sort_index().to_numpy()
        out[name] = float(np.max(np.abs(ours - theirs)))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--members", type=int, default=2000)
    parser.add_argument("--samples", type=int, default=10_000)
    parser.add_argument("--fs", type=float, default=FS)
    parser.add_argument("--repeats", type=int, default=5, help="pdmkit runs (median)")
    parser.add_argument("--tsfresh-jobs", type=int, default=2, help="tsfresh n_jobs")
    parser.add_argument("--skip-tsfresh", action="store_true")
    parser.add_argument("--json", type=Path, help="write the results here")
    parser.add_argument("--_memory-probe", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args._memory_probe:
        print(json.dumps(memory_probe(args.members, args.samples, args.fs)))
        return 0

    print(
        f"synthetic ensemble: {args.members} members x {args.samples} samples, float64, "
        f"{len(CLASSES)} classes, fs={args.fs:g} Hz; {os.cpu_count()} CPU(s)"
    )
    x, _ = make_ensemble(args.members, args.samples, args.fs)
    pdm_s, pdm_times, pdm_table = run_pdmkit(x, args.fs, args.repeats)
    print(
        f"pdmkit  extract(groups={GROUPS}): {pdm_s:.3f} s median of {args.repeats} "
        f"({', '.join(f'{t:.3f}' for t in pdm_times)}); {pdm_table.shape[1]} features"
    )
    memory = measure_memory(args.members, args.samples, args.fs)
    print(
        f"pdmkit  peak memory: {memory['peak_rss_mb']:.0f} MB resident (process peak "
        f"during extract, incl. the {memory['input_mb']:.0f} MB input; "
        f"{memory['rss_before_mb']:.0f} MB before), "
        f"{memory['extract_alloc_peak_mb']:.0f} MB allocated by extract"
    )
    result = {
        "pdmkit_s": pdm_s,
        "tsfresh_s": None,
        "speed_ratio": None,
        "pdmkit_peak_mb": memory["peak_rss_mb"],
        "pdmkit_extract_alloc_peak_mb": memory["extract_alloc_peak_mb"],
        "members": args.members,
        "samples": args.samples,
        "pdmkit_times_s": pdm_times,
        "tsfresh_n_jobs": args.tsfresh_jobs,
        "cpu_count": os.cpu_count(),
    }
    if not args.skip_tsfresh:
        ts_s, ts_table = run_tsfresh(x, args.fs, args.tsfresh_jobs)
        print(
            f"tsfresh extract_features (n_jobs={args.tsfresh_jobs}, one run): "
            f"{ts_s:.3f} s; {ts_table.shape[1]} features"
        )
        checks = cross_check(pdm_table, ts_table)
        print(
            "same quantities agree (max |pdmkit - tsfresh|): "
            + ", ".join(f"{k} {v:.1e}" for k, v in checks.items())
        )
        result.update(tsfresh_s=ts_s, speed_ratio=ts_s / pdm_s, cross_check=checks)
        print(f"speed ratio tsfresh / pdmkit: {ts_s / pdm_s:.1f}x")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
