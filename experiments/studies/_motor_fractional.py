"""``pdmkit study motor-fractional``: fractional-order diagnosis, end to end.

The source paper (condition-based diagnosis of mechatronic systems
with fractional calculus) estimates the transfer function from the output-bearing
accelerometer to the motor current of a DC motor + gearbox (its "empirical estimation
of the transfer function", EETF, eq. 7, 100-1000 rad/s) in four conditions (normal;
a broken tooth in gear 2, 3 or 4), fits ``G(s) = 1 / (a s^alpha + b s^beta + c)``
(eq. 8) to each condition with the simplex method on ``|G_EETF - G|`` (eqs. 6, 9;
20 data sets to tune, 10 to evaluate), compares it with the integer model ``alpha =
2, beta = 1`` (table 1), and classifies 240 new records (60 per condition) by k-nearest
neighbours (k = 3) on their mean square distances to the four condition models, in
ten folds (table 2: 220 of 240 right, 91.7 %).

This study runs that protocol on :class:`~pdmkit.models.rigs.MotorGearboxRig` with
:func:`~pdmkit.models.frequency.fit_fractional_simplex`, puts its table 1, table 2 and
figure 6 beside the seed's, repeats the classification with the EETF read literally
(one 1-s window per data set), and fits the same model to a real recorded input-output
pair (the Silverbox, an electronic mass-spring-damper, whose true orders are 2 and 1).
"""

from __future__ import annotations

import os
import time

import numpy as np
import pandas as pd

from pdmkit._config import data_dir
from pdmkit._outputs import to_jsonable
from pdmkit._progress import progress
from pdmkit.ensembles import load_silverbox
from pdmkit.experiments.studies._motor_report import build_report
from pdmkit.experiments.studies._write import write_study
from pdmkit.models.frequency import fit_fractional_simplex, frf_estimate, model_distance
from pdmkit.models.rigs import MOTOR_CONDITIONS, MotorGearboxRig

__all__ = ["run_motor_fractional"]

#: the paper's table 1: (train FOM, train IOM, test FOM, test IOM), each (mean, std)
SEED_TABLE1 = {
    "normal": ((1.84, 0.15), (3.23, 0.18), (2.06, 0.23), (3.47, 0.27)),
    "gear2": ((1.12, 0.05), (2.26, 0.05), (1.05, 0.02), (2.17, 0.03)),
    "gear3": ((1.44, 0.34), (2.43, 0.38), (1.41, 0.09), (2.37, 0.10)),
    "gear4": ((0.74, 0.05), (1.36, 0.06), (0.89, 0.07), (1.51, 0.07)),
}
#: the paper's table 2: rows actual case 1-4, columns estimated case 1-4 (k = 3)
SEED_TABLE2 = np.array([[56, 4, 0, 0], [0, 48, 12, 0], [0, 0, 60, 0], [0, 4, 0, 56]])
N_TUNE, N_EVAL, N_CLASSIFY = 20, 10, 60  # the paper's sections 4.2, 5.1
IOM = {"alpha": 2.0, "beta": 1.0}


def _records(rig, n, rng, seconds):
    """``n`` records of every condition: each condition's ETFEs (h1 and ratio)."""
    out = {}
    for name in MOTOR_CONDITIONS:
        h1, ratio = [], []
        for _ in range(n):
            rec = rig.simulate(name, duration=seconds, rng=rng)
            f, H = rec.etfe(method="h1")
            h1.append(H)
            ratio.append(rec.etfe(method="ratio")[1])
        out[name] = {"h1": np.array(h1), "ratio": np.array(ratio)}
    return f, out


def _fit_table(freq, data, method, n_starts):
    """Seed table 1: FOM and IOM fitted on 20 records, errors on them and on 10 more."""
    rows, models, fits = [], {}, {}
    w = 2 * np.pi * freq
    for name in MOTOR_CONDITIONS:
        H = data[name][method]
        train, test = H[:N_TUNE], H[N_TUNE : N_TUNE + N_EVAL]
        fom = fit_fractional_simplex(freq, train, n_starts=n_starts)
        iom = fit_fractional_simplex(freq, train, fixed_orders=IOM, n_starts=n_starts)
        models[name], fits[name] = fom.model, {"FOM": fom, "IOM": iom}

        def err(fit, X):
            e = np.mean(np.abs(X - fit.model.frequency_response(w)), axis=1)
            return float(e.mean()), float(e.std(ddof=1))

        tr_f, tr_i, te_f, te_i = (
            err(fom, train),
            err(iom, train),
            err(fom, test),
            err(iom, test),
        )
        seed = SEED_TABLE1[name]
        rows.append(
            {
                "case": MOTOR_CONDITIONS[name][2],
                "train FOM": tr_f[0],
                "train FOM sd": tr_f[1],
                "train IOM": tr_i[0],
                "train IOM sd": tr_i[1],
                "test FOM": te_f[0],
                "test FOM sd": te_f[1],
                "test IOM": te_i[0],
                "test IOM sd": te_i[1],
                "ratio FOM/IOM (test)": te_f[0] / te_i[0],
                "seed ratio (test)": seed[2][0] / seed[3][0],
                "seed train FOM / IOM": f"{seed[0][0]} / {seed[1][0]}",
                "seed test FOM / IOM": f"{seed[2][0]} / {seed[3][0]}",
            }
        )
    return pd.DataFrame(rows), models, fits


def _features(freq, X, models):
    """The paper's failure indices: mean square distance to each condition model."""
    return np.column_stack(
        [np.log10(model_distance(X, models[c], freq)) for c in MOTOR_CONDITIONS]
    )


def _classify(freq, data, models, method, seed, ks=(1, 3, 5, 7, 9, 11, 15)):
    """Classify by kNN on the failure indices of 60 new records per condition."""
    from sklearn.metrics import confusion_matrix, roc_auc_score
    from sklearn.model_selection import StratifiedKFold, cross_val_predict
    from sklearn.neighbors import KNeighborsClassifier

    start = N_TUNE + N_EVAL
    X = np.vstack([data[c][method][start : start + N_CLASSIFY] for c in MOTOR_CONDITIONS])
    y = np.repeat(np.arange(len(MOTOR_CONDITIONS)), N_CLASSIFY)
    F = _features(freq, X, models)
    cv = StratifiedKFold(10, shuffle=True, random_state=seed)
    per_k = []
    for k in ks:
        proba = cross_val_predict(
            KNeighborsClassifier(k), F, y, cv=cv, method="predict_proba"
        )
        pred = proba.argmax(axis=1)
        per_k.append(
            {
                "k": k,
                "accuracy": float(np.mean(pred == y)),
                "AUC (one vs rest)": float(roc_auc_score(y, proba, multi_class="ovr")),
            }
        )
        if k == 3:
            cm = confusion_matrix(y, pred)
    return {"confusion": cm, "per_k": pd.DataFrame(per_k), "features": F, "labels": y}


def _silverbox(quick: bool) -> dict | None:
    """The seed's fit on a real input-output pair whose orders are known (2 and 1)."""
    if not data_dir("silverbox").is_dir():
        return None
    sb = load_silverbox()
    u, y, fs = sb["V1"][40650:], sb["V2"][40650:], sb["fs"]
    frf = frf_estimate(
        u - u.mean(), y - y.mean(), fs, nperseg=1024 if quick else 4096, fmin=5, fmax=150
    )
    ok = frf.coherence > 0.9
    fom = fit_fractional_simplex(frf.freq[ok], frf.H[ok])
    iom = fit_fractional_simplex(frf.freq[ok], frf.H[ok], fixed_orders=IOM)
    peak = float(frf.freq[ok][np.argmax(np.abs(frf.H[ok]))])
    return {
        "fom": fom,
        "iom": iom,
        "frf": frf,
        "band_hz": (5.0, 150.0),
        "n_freq": int(ok.sum()),
        "peak_hz": peak,
        "fom_resonance_hz": float((fom.c / fom.a) ** (1 / fom.alpha) / (2 * np.pi)),
    }


def run_motor_fractional(
    out_dir: str | os.PathLike,
    *,
    json_path: str | os.PathLike | None = None,
    seed: int = 0,
    quick: bool = False,
) -> dict:
    """Run the fractional motor-diagnosis study; write the summary and report.

    Parameters
    ----------
    out_dir : path
        Output folder (see :mod:`pdmkit._outputs`).
    json_path : path, optional
        Also write the summary here.
    seed : int, default 0
        Seed of the rig's records.
    quick : bool, default False
        2-s records instead of 4 s and a coarser Silverbox FRF (for tests and a first
        look); the seed's protocol (20 + 10 + 60 records per condition) is kept.

    Returns
    -------
    dict
        ``table1`` (FOM and IOM errors per case), ``ratio``, ``confusion`` (k = 3),
        ``accuracy``, ``per_k``, ``literal_etfe`` (the same with one window),
        ``real_data`` (Silverbox), ``timings`` and the seed's numbers.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from pdmkit.experiments.studies import run_study
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> s = run_study("motor-fractional", out, quick=True)   # doctest: +SKIP
    """

    def compute():
        summary, parts = _study(seed, quick)
        return summary, lambda written: build_report(written, parts)

    return write_study(out_dir, json_path, compute)


def _study(seed: int, quick: bool):
    """(summary, parts for the report) of :func:`run_motor_fractional`."""
    t0 = time.perf_counter()
    rig = MotorGearboxRig()
    rng = np.random.default_rng(seed)
    bar = iter(progress(range(4), desc="motor-fractional study", total=4))
    next(bar, None)
    freq, data = _records(rig, N_TUNE + N_EVAL + N_CLASSIFY, rng, 2.0 if quick else 4.0)
    t_sim = time.perf_counter() - t0
    next(bar, None)
    variants = {}
    for method in ("h1", "ratio"):
        table, models, fits = _fit_table(freq, data, method, 2 if quick else 4)
        variants[method] = {
            "table1": table,
            "models": models,
            "fits": fits,
            "classification": _classify(freq, data, models, method, seed),
        }
    t_fit = time.perf_counter() - t0 - t_sim
    next(bar, None)
    real = _silverbox(quick)
    next(bar, None)
    summary = _summary(variants, real, quick, seed)
    summary["timings"] = {
        "simulation_s": t_sim,
        "fits_and_classification_s": t_fit,
        "total_s": time.perf_counter() - t0,
    }
    parts = {
        "rig": rig,
        "freq": freq,
        "data": data,
        "variants": variants,
        "real": real,
        "seconds": 2.0 if quick else 4.0,
    }
    return to_jsonable(summary), parts


def _summary(variants, real, quick, seed) -> dict:
    out = {
        "study": "motor-fractional",
        "seed_document": "004_d897e6553e80b52a.txt (fractional calculus diagnosis)",
        "quick": bool(quick),
        "seed": int(seed),
    }
    for method, key in (("h1", "main"), ("ratio", "literal_etfe")):
        v = variants[method]
        t = v["table1"]
        cl = v["classification"]
        cm = cl["confusion"]
        out[key] = {
            "etfe": "H1, 1-s Hann windows averaged" if method == "h1" else "one 1-s window",
            "table1": t.to_dict(orient="records"),
            "ratio_test_mean": float(t["ratio FOM/IOM (test)"].mean()),
            "ratio_test_max": float(t["ratio FOM/IOM (test)"].max()),
            "fom_params": {c: v["fits"][c]["FOM"].params for c in MOTOR_CONDITIONS},
            "confusion_k3": cm.tolist(),
            "accuracy_k3": float(np.trace(cm) / cm.sum()),
            "per_k": cl["per_k"].to_dict(orient="records"),
        }
    seed_ratios = [v[2][0] / v[3][0] for v in SEED_TABLE1.values()]
    out["seed_numbers"] = {
        "table1": {k: [list(x) for x in v] for k, v in SEED_TABLE1.items()},
        "ratio_test_mean": float(np.mean(seed_ratios)),
        "table2": SEED_TABLE2.tolist(),
        "accuracy_k3": float(np.trace(SEED_TABLE2) / SEED_TABLE2.sum()),
    }
    if real is not None:
        out["real_data"] = {
            "dataset": "Silverbox (SNLS80mV multisines), V1 -> V2, H1 with coherence > 0.9",
            "fom": real["fom"].params,
            "fom_error": real["fom"].error,
            "iom": real["iom"].params,
            "iom_error": real["iom"].error,
            "ratio": real["fom"].error / real["iom"].error,
            "peak_hz": real["peak_hz"],
            "fom_resonance_hz": real["fom_resonance_hz"],
        }
    else:
        out["real_data"] = None
    return out
