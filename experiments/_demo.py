"""``pdmkit demo``: the whole workbench on the simulated pneumatic piston.

The seed thesis (001, chapters 7-8) runs the predictive-maintenance workflow on a
measured pneumatic piston; its recordings are not public, so the demo runs the same
workflow on pdmkit's digital twin of that rig:

1. simulate a labelled fault ensemble (throttle valves, small and large dampers) at
   random operating points;
2. extract statistical and spectral indicators from all fifteen sensor signals and
   rank them (Kruskal-Wallis);
3. train and evaluate fault classifiers (kNN and bagged trees on the top-5 indicators);
4. compare the eight sensor types by accuracy and cost (seed table 9.1);
5. classify from residuals against the nominal model (seed 8.3) next to the raw
   encoder signal;
6. classify simulated sensor faults (seed 8.1).

It writes ``summary.json`` (machine-readable) and ``report.html`` into the output
folder.
"""

from __future__ import annotations

import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

__all__ = ["run_demo"]


def _step(message: str) -> Callable[[], float]:
    """Print a progress line; return a function giving the seconds since."""
    print(f"pdmkit demo: {message} ...", file=sys.stderr, flush=True)
    start = time.perf_counter()
    return lambda: time.perf_counter() - start


def _feature_columns(table, prefix: str | tuple[str, ...]) -> list[str]:
    """Indicator columns of the given signals that are finite for every member.

    A spectrum with fewer than five peaks leaves ``PeakAmp5`` undefined (NaN): such
    columns cannot feed a classifier and are left out.
    """
    columns = [c for c in table.columns if "/" in str(c) and str(c).startswith(prefix)]
    finite = np.isfinite(table[columns].to_numpy(dtype=float)).all(axis=0)
    return [c for c, ok in zip(columns, finite, strict=True) if ok]


def run_demo(
    out_dir: str | Path = "results/demo",
    *,
    members: int | None = None,
    seed: int = 0,
    recording_s: float = 10.0,
) -> dict:
    """Run the demo workflow and write ``summary.json`` and ``report.html``.

    Parameters
    ----------
    out_dir : str or Path
        Output folder (created when missing).
    members : int, optional
        Size of the simulated fault ensemble (default 480: 80 recordings of each of
        the six fault codes).
    seed : int, default 0
        Seed of the simulation and of the data splits.
    recording_s : float, default 10.0
        Length of each simulated recording in s (the seed's are 10 s; shorter runs
        are for quick checks).

    Returns
    -------
    dict
        The summary written to ``summary.json``.

    Examples
    --------
    >>> import tempfile
    >>> from pdmkit.experiments._demo import run_demo
    >>> summary = run_demo(tempfile.mkdtemp(), members=24, seed=1)  # doctest: +SKIP
    >>> sorted(summary)  # doctest: +SKIP
    ['classification', 'residuals', 'sensor_faults', 'sensors', 'timing_s', ...]
    """
    from pdmkit.ensembles import (
        PNEUMATIC_SENSORS,
        pneumatic_residuals,
        simulate_fault_ensemble,
        simulate_sensor_fault_ensemble,
    )
    from pdmkit.experiments._classify import classify
    from pdmkit.experiments._cli import write_json, write_parquet
    from pdmkit.experiments._report import Report
    from pdmkit.experiments._sensors import compare_sensors
    from pdmkit.features import extract_ensemble, rank_features

    out = Path(out_dir)
    n_members = int(members) if members is not None else 480
    timing: dict[str, float] = {}
    report = Report("pdmkit demo: predictive maintenance of a pneumatic piston (simulated)")
    report.add_text(
        "The workflow of the seed thesis (Predictive maintenance of pneumatic pistons, "
        "chapters 7-8) on pdmkit's digital twin of its rig: a double-acting vertical "
        "piston with throttle valves, adjustable small end dampers, static large dampers, "
        "load masses of 0-6.25 kg and 5 or 6 bar supply, recorded 10 s at 1 kHz by the "
        "fifteen sensors of the seed's table 3.1. All data on this page are simulated."
    )

    # 1. fault ensemble --------------------------------------------------------------
    elapsed = _step(
        f"simulating {n_members} recordings of the twin ({recording_s:g} s, 15 sensors)"
    )
    ensemble = simulate_fault_ensemble(n_members, seed=seed, t_end=recording_s)
    timing["simulate"] = elapsed()
    counts = ensemble.conditions["fault"].value_counts().sort_index()

    # 2. indicators and ranking --------------------------------------------------------
    elapsed = _step("extracting condition indicators")
    table = extract_ensemble(ensemble, groups=("stats", "spectral"))
    write_parquet(table, out / "features.parquet")
    features = _feature_columns(table, tuple(ensemble.signal_names))
    ranking = rank_features(table, table["fault"], method="kruskal", features=features)
    timing["features"] = elapsed()

    report.add_heading("1. Simulated fault ensemble")
    report.add_table(
        counts.rename("recordings").to_frame(), caption="Recordings per fault code"
    )
    report.add_figure(_example_figure(ensemble), caption="One recording per fault code")
    report.add_heading("2. Condition indicators, ranked")
    report.add_text(
        f"{len(features)} indicators (statistics and Welch-spectrum features of each "
        "signal), ranked by the Kruskal-Wallis statistic against the fault code."
    )
    report.add_figure(ranking.plot(k=20), caption="Top 20 indicators (Kruskal-Wallis)")

    # 3. classifiers -------------------------------------------------------------------
    elapsed = _step("training fault classifiers")
    classification = {}
    for model in ("knn", "bagged_trees"):
        result = classify(
            table, "fault", features=features, model=model, top_k=5, random_state=seed
        )
        classification[model] = result.summary()
        report.add_figure(
            result.plot(),
            caption=f"{model}: held-out accuracy {result.summary()['accuracy']:.3f} "
            f"on the top-5 indicators {', '.join(result.summary()['features'])}",
        )
    timing["classify"] = elapsed()

    # 4. sensors ------------------------------------------------------------------------
    elapsed = _step("comparing the eight sensor types")
    comparison = compare_sensors(
        table[[*features, "fault"]],
        "fault",
        PNEUMATIC_SENSORS,
        model="knn",
        top_k=5,
        random_state=seed,
    )
    timing["sensors"] = elapsed()
    report.add_heading("3. Sensors by accuracy and cost")
    report.add_text(
        "Each sensor type is scored on its own indicators (kNN, top-5 Kruskal-Wallis, "
        "5-fold cross-validation). Costs are the seed's table 9.1 (CZK); the "
        "temperature sensors have no cost there."
    )
    report.add_figure(comparison.plot(), caption="Accuracy against cost; Pareto front")
    report.add_table(comparison.to_pandas(), caption="Sensor comparison")

    # 5. residuals against the nominal model --------------------------------------------
    elapsed = _step("classifying from residuals against the nominal model")
    residuals = pneumatic_residuals(ensemble, ["LeverPosition"])
    res_table = extract_ensemble(residuals, groups=("stats", "spectral"))
    res_result = classify(
        res_table,
        "fault",
        features=_feature_columns(res_table, "Lever"),
        model="knn",
        top_k=5,
        random_state=seed,
    )
    raw_result = classify(
        table,
        "fault",
        features=_feature_columns(table, "LeverPosition/"),
        model="knn",
        top_k=5,
        random_state=seed,
    )
    timing["residuals"] = elapsed()
    residual_summary = {
        "signal": "LeverPosition",
        "accuracy_residual": res_result.summary()["accuracy"],
        "accuracy_signal": raw_result.summary()["accuracy"],
        "features_residual": res_result.summary()["features"],
    }
    report.add_heading("4. Residuals against the nominal model (seed 8.3)")
    report.add_text(
        "Encoder position minus the healthy twin simulated at the member's load and "
        f"supply: held-out accuracy {residual_summary['accuracy_residual']:.3f} from "
        f"residual indicators against {residual_summary['accuracy_signal']:.3f} from the "
        "raw position signal (kNN, top 5)."
    )
    report.add_figure(_residual_figure(residuals), caption="Position residuals by fault")

    # 6. sensor faults ------------------------------------------------------------------
    elapsed = _step("classifying simulated sensor faults")
    sensor_faults = simulate_sensor_fault_ensemble(
        max(50, n_members // 4), seed=seed + 7, t_end=recording_s
    )
    sf_table = extract_ensemble(sensor_faults, groups=("stats",))
    sf_result = classify(sf_table, "sensor_fault", model="knn", top_k=5, random_state=seed)
    timing["sensor_faults"] = elapsed()
    report.add_heading("5. Sensor faults (seed 8.1)")
    report.add_figure(
        sf_result.plot(),
        caption=f"Flow sensor healthy / noisy / offset / drifting / lost: held-out "
        f"accuracy {sf_result.summary()['accuracy']:.3f}",
    )

    summary = {
        "members": n_members,
        "recording_s": recording_s,
        "labels": sorted(counts.index.tolist()),
        "n_features": len(features),
        "top_features": ranking.top(5),
        "classification": classification,
        "sensors": comparison.summary()["sensors"],
        "residuals": residual_summary,
        "sensor_faults": sf_result.summary(),
        "timing_s": {k: round(v, 2) for k, v in timing.items()},
        "environment": {"python": platform.python_version(), "seed": seed},
    }
    summary["timing_s"]["total"] = round(sum(timing.values()), 2)
    report.add_heading("Summary")
    report.add_json(summary["timing_s"], caption="Time per step (s)")
    write_json(summary, out / "summary.json")
    report.write(out / "report.html")
    return summary


def _example_figure(ensemble):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    faults = ensemble.conditions["fault"]
    fs = ensemble.fs["LeverPosition"]
    for code in sorted(faults.unique()):
        i = int(np.flatnonzero(faults.to_numpy() == code)[0])
        x = ensemble.signal("LeverPosition")[i]
        q = ensemble.signal("FlowExtrusion")[i]
        t = np.arange(x.size) / fs
        axes[0].plot(t, x * 1e3, lw=0.8, label=code)
        axes[1].plot(t, q, lw=0.8)
    axes[0].set_ylabel("position (mm)")
    axes[1].set_ylabel("flow into A (l/min)")
    axes[1].set_xlabel("time (s)")
    axes[0].legend(fontsize=7, ncol=3)
    fig.tight_layout()
    return fig


def _residual_figure(residuals):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 3))
    faults = residuals.conditions["fault"].to_numpy()
    fs = residuals.fs["LeverPosition_res"]
    for code in sorted(set(faults)):
        i = int(np.flatnonzero(faults == code)[0])
        e = residuals.signal("LeverPosition_res")[i]
        ax.plot(np.arange(e.size) / fs, e * 1e3, lw=0.8, label=code)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("residual (mm)")
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    return fig
