"""Per-sensor fault classification on the twin with the seed's recipe (seed table 9.1).

Simulates a fault ensemble of the pneumatic twin (the 16 codes of ``fault_labels(2)``
by default, random load 0/1.25/5/6.25 kg and supply 5/6 bar of table 3.2, 10 s at
1 kHz), computes the seed's condition indicators of every signal (section 7.3.2:
whole-record statistics and Welch-spectrum indicators, groups ``stats`` and
``spectral``) and scores each sensor type of table 9.1 with the seed's recipe: the
sensor's indicators, Kruskal-Wallis top 5 chosen on the training part, fine kNN
(k = 1), on stratified 75/25 splits (``--splits`` of them, mean and spread reported).

The seed measured on its rig (20 labels, 4840 recordings; table 9.1): flow 97.2,
encoder 96.1, mics 95.8, strain 95.0, accelerometer 91.6, proximity 80.5, pressure
76.6 %. This benchmark measures how close the twin's sensors come to that, which is a
property of the twin's physics and sensor models, not of the classifier.

Usage::

    .venv/bin/python benchmarks/twin_sensor_fidelity.py [--members 480] [--seed 7]
        [--t-end 10] [--max-faults 2] [--splits 5] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from pdmkit.experiments.thesis import SEED_SENSOR_ACCURACY as SEED_TABLE_9_1


def seed_recipe_pipeline(top_k: int = 5):
    """Scaler, Kruskal-Wallis top-k (plain, no correlation filter), kNN with k = 1.

    Parameters
    ----------
    top_k : int
        Number of ranked indicators kept (5 in the seed, section 7.3.3).

    Returns
    -------
    sklearn.pipeline.Pipeline
        Unfitted pipeline.
    """
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    from pdmkit.features import SelectTopRanked

    return Pipeline(
        [
            ("scale", StandardScaler()),
            ("select", SelectTopRanked(k=top_k, method="kruskal")),
            ("model", KNeighborsClassifier(n_neighbors=1)),
        ]
    )


def sensor_accuracies(table, label: str, sensors: dict, splits: int, seed: int):
    """Held-out accuracy of the seed recipe per sensor over stratified splits.

    Parameters
    ----------
    table : pandas.DataFrame
        Feature table (``<signal>/<group>/<Feature>`` columns) with the label column.
    label : str
        Class column.
    sensors : dict of str to tuple of str
        Sensor type -> its signals.
    splits : int
        Number of stratified 75/25 splits.
    seed : int
        Seed of the splits.

    Returns
    -------
    dict
        Sensor -> {"mean", "std", "top": the indicators chosen on the first split}.
    """
    from sklearn.model_selection import StratifiedShuffleSplit

    y = table[label].astype(str).to_numpy()
    sss = StratifiedShuffleSplit(n_splits=splits, test_size=0.25, random_state=seed)
    folds = list(sss.split(np.zeros(len(y)), y))
    out = {}
    for name, signals in sensors.items():
        cols = [
            c
            for c in table.columns
            if "/" in str(c)
            and c.split("/")[0] in signals
            and c.split("/")[1] in ("stats", "spectral")
        ]
        x = table[cols].to_numpy(dtype=float)
        x = np.where(np.isfinite(x), x, 0.0)
        accs, top = [], []
        for k, (tr, te) in enumerate(folds):
            pipe = seed_recipe_pipeline().fit(x[tr], y[tr])
            accs.append(float(np.mean(pipe.predict(x[te]) == y[te])))
            if k == 0:
                top = [cols[i] for i in pipe.named_steps["select"].selected_]
        out[name] = {
            "mean": round(float(np.mean(accs)), 4),
            "std": round(float(np.std(accs)), 4),
            "top": top,
        }
    return out


def repeated_situations(
    n_members: int,
    repeats: int,
    jitter: float,
    *,
    max_faults: int,
    t_end: float,
    signals: list,
    seed: int,
    points=None,
):
    """An ensemble built like the seed's: fixed situations, each recorded repeatedly.

    The seed's 4840 recordings cover "almost 250 different condition situations"
    (section 3.3), about 20 recordings of each. Here ``n_members // repeats``
    situations (fault code, settings, operating point and unlabelled variation drawn
    as :func:`pdmkit.ensembles.simulate_fault_ensemble` draws them) are each simulated
    ``repeats`` times, with fresh sensor noise and a run-to-run variation of relative
    size ``jitter`` (standard deviation) of friction, valve delay and the supply
    pressure above ambient.

    Parameters
    ----------
    n_members : int
        Recordings in all.
    repeats : int
        Recordings per situation.
    jitter : float
        Relative run-to-run spread of the unlabelled parameters.
    max_faults : int
        Largest number of combined faults of a code.
    t_end : float
        Recording length, s.
    signals : list of str
        Sensor signals to record.
    seed : int
        Seed of every draw and of the sensor noise.
    points : dict, optional
        Operating points (``load_kg``, ``supply_bar``) to spread the situations over.

    Returns
    -------
    pdmkit.ensembles.Ensemble
        Conditions ``fault`` and ``situation``.
    """
    import pandas as pd

    from pdmkit.ensembles import Ensemble
    from pdmkit.ensembles import _pneumatic as ep

    rng = np.random.default_rng(seed)
    codes = ep.fault_labels(max_faults)
    n_sit = max(len(codes), n_members // repeats)
    labels = np.array([codes[i % len(codes)] for i in range(n_sit)])
    rng.shuffle(labels)
    cols = ep._operating_conditions(n_sit, rng)
    if points is not None:
        cols.update(ep._operating_points(points, n_sit, rng))
    cols.update(ep._fault_settings(labels, rng))
    idx = np.repeat(np.arange(n_sit), repeats)
    cols = {k: np.asarray(v)[idx] for k, v in cols.items()}
    n = len(idx)
    for k in ("friction_coulomb", "friction_viscous", "valve_delay"):
        cols[k] = cols[k] * (1.0 + jitter * rng.standard_normal(n)).clip(0.5, 1.5)
    gauge = (cols["p_supply"] - ep._P_AMBIENT) * (1.0 + jitter * rng.standard_normal(n))
    cols["p_supply"] = ep._P_AMBIENT + gauge
    data = ep._simulate_batches(
        cols,
        n,
        t_end=t_end,
        fs=1000.0,
        signals=signals,
        seed=seed,
        batch_size=500,
        desc="simulating repeated situations",
    )
    conditions = pd.DataFrame({"fault": labels[idx], "situation": idx})
    return Ensemble(data, fs=1000.0, conditions=conditions)


def main(argv: list[str] | None = None) -> dict:
    """Run the measurement; print the table and return the results.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    dict
        Members, seed, timing and the per-sensor accuracies.
    """
    from pdmkit.ensembles import PNEUMATIC_SENSORS, simulate_fault_ensemble
    from pdmkit.features import extract_ensemble

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=480)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--t-end", type=float, default=10.0)
    ap.add_argument("--max-faults", type=int, default=2)
    ap.add_argument("--splits", type=int, default=5)
    ap.add_argument(
        "--point",
        default=None,
        help="one operating point 'LOAD_KG,SUPPLY_BAR' instead of random ones",
    )
    ap.add_argument(
        "--repeats",
        type=int,
        default=0,
        help="seed-like design: recordings per fixed situation (0: every member new)",
    )
    ap.add_argument(
        "--jitter",
        type=float,
        default=0.02,
        help="run-to-run relative spread with --repeats (0.02)",
    )
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)

    sensors = {k: v for k, v in PNEUMATIC_SENSORS.items() if k in SEED_TABLE_9_1}
    signals = [s for sig in sensors.values() for s in sig]
    points = None
    if args.point:
        load, supply = (float(v) for v in args.point.split(","))
        points = {"load_kg": [load], "supply_bar": [supply]}
    t0 = time.perf_counter()
    if args.repeats > 0:
        ens = repeated_situations(
            args.members,
            args.repeats,
            args.jitter,
            max_faults=args.max_faults,
            t_end=args.t_end,
            signals=signals,
            seed=args.seed,
            points=points,
        )
    else:
        ens = simulate_fault_ensemble(
            args.members,
            max_faults=args.max_faults,
            t_end=args.t_end,
            signals=signals,
            seed=args.seed,
            operating_points=points,
        )
    t_sim = time.perf_counter() - t0
    table = extract_ensemble(ens, groups=("stats", "spectral"))
    t_ext = time.perf_counter() - t0 - t_sim
    acc = sensor_accuracies(table, "fault", sensors, args.splits, args.seed)
    t_all = time.perf_counter() - t0
    n_codes = ens.conditions["fault"].nunique()
    design = f"{args.repeats} repeats, jitter {args.jitter:g}, " if args.repeats else ""
    print(
        f"{args.members} members, {n_codes} codes, seed {args.seed}, "
        f"point {args.point or 'random'}, {design}"
        f"{args.t_end:g} s; simulate {t_sim:.0f} s, extract {t_ext:.0f} s, "
        f"total {t_all:.0f} s"
    )
    print(f"{'sensor':10s} {'twin %':>8s} {'+-':>5s} {'seed %':>7s}  top indicators")
    for name in sorted(sensors, key=lambda s: -SEED_TABLE_9_1[s]):
        a = acc[name]
        tops = ", ".join(t.split("/", 1)[1] for t in a["top"][:3])
        print(
            f"{name:10s} {100 * a['mean']:8.1f} {100 * a['std']:5.1f} "
            f"{SEED_TABLE_9_1[name]:7.1f}  {tops}"
        )
    result = {
        "members": args.members,
        "seed": args.seed,
        "t_end": args.t_end,
        "point": args.point,
        "repeats": args.repeats,
        "jitter": args.jitter if args.repeats else None,
        "codes": int(n_codes),
        "splits": args.splits,
        "seconds": {"simulate": t_sim, "extract": t_ext, "total": t_all},
        "accuracy": acc,
        "seed_table_9_1": SEED_TABLE_9_1,
    }
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
    return result


if __name__ == "__main__":
    sys.exit(main() and 0)
