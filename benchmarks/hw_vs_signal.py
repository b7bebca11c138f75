"""Hammerstein-Wiener coefficients vs signal indicators on the pneumatic twin.

Voronin's thesis (section 8.2.1) identified a Hammerstein-Wiener model for each
encoder-position recording of the pneumatic piston and classified the six primary fault
states from its coefficients; the accuracy "did not exceed 40 %". This script repeats the
experiment on the twin and puts the whole-recording signal indicators beside it, on the
same members and the same held-out split:

* ensemble: ``simulate_fault_ensemble`` with the six codes of ``fault_labels(1)``
  (healthy + five single faults), ``--members`` members of ``--seconds`` s, encoder
  position (``LeverPosition``) at 1 kHz;
* input: the valve command of the nominal cycle (``valve_command``, +-1; the controller
  knows it), output: the position, both decimated to ``--fs-model`` Hz;
* HW model: no input nonlinearity (a two-level input makes any static input map affine),
  linear block ``nb=2, nf=2, nk=10`` (0.1 s dead time: the chamber fills before the
  piston moves), output saturation (the end stops), fitted by
  :class:`pdmkit.models.ident.HammersteinWiener`; indicators: the 6 coefficients
  plus the fit percentage (``hw`` group of ``features._model_features``);
* signal indicators: ``stats`` + ``spectral`` of the position (``extract_ensemble``);
* classifiers: the seed's kNN on the top-5 Kruskal-Wallis indicators, and 30 bagged
  trees on all indicators (``pdmkit.experiments.classify``), 25 % held out, 5-fold CV.

Usage::

    .venv/bin/python benchmarks/hw_vs_signal.py [--members 200] [--seconds 4] [--seed 2027]

The structure (orders, dead time) was chosen on a development ensemble (seed 5) by the
fit percentage alone, never by classification accuracy.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from pdmkit.ensembles import fault_labels, simulate_fault_ensemble
from pdmkit.experiments import classify
from pdmkit.features import extract_ensemble
from pdmkit.features._model_features import hw_features
from pdmkit.models import PneumaticParams, valve_command


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--members", type=int, default=200)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--fs-model", type=float, default=100.0)
    ap.add_argument("--seed", type=int, default=2027)
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    ens = simulate_fault_ensemble(
        args.members,
        labels=fault_labels(1),
        t_end=args.seconds,
        signals=["LeverPosition"],
        seed=args.seed,
    )
    fs = ens.fs["LeverPosition"]
    pos, _ = ens.stack("LeverPosition")
    t = np.arange(pos.shape[1]) / fs
    u = np.asarray(valve_command(t, PneumaticParams()), dtype=float)
    t_sim = time.perf_counter() - t0

    t0 = time.perf_counter()
    step = round(fs / args.fs_model)
    nk = max(1, round(0.1 * args.fs_model))
    hw = hw_features(
        np.broadcast_to(u[::step], pos[:, ::step].shape),
        pos[:, ::step],
        args.fs_model,
        nk=nk,
    )
    hw.index = ens.member_ids
    t_hw = time.perf_counter() - t0

    t0 = time.perf_counter()
    sig = extract_ensemble(ens, groups=("stats", "spectral"), progress=False)
    t_sig = time.perf_counter() - t0
    cond = ens.conditions[["fault"]]
    hw_table = hw.add_prefix("LeverPosition/").join(cond)
    sig_table = sig if "fault" in sig.columns else sig.join(cond)

    results = {}
    for name, table in (("hw", hw_table), ("signal", sig_table)):
        for model, kw in (("knn", {}), ("bagged_trees", {"selection": None})):
            r = classify(table, "fault", model=model, random_state=args.seed, **kw)
            results[(name, model)] = (r.accuracy, r.cv_accuracy, r.cv_accuracy_std)

    print(
        f"members={args.members} seconds={args.seconds} classes={len(fault_labels(1))} "
        f"seed={args.seed}; simulate {t_sim:.1f} s, HW fits {t_hw:.1f} s, "
        f"signal indicators {t_sig:.1f} s"
    )
    print(
        f"HW fit percent: median {hw['hw/FitPercent'].median():.1f}, "
        f"10th pct {hw['hw/FitPercent'].quantile(0.1):.1f}"
    )
    print(f"{'indicators':<10} {'model':<13} {'held-out acc':>12} {'CV acc':>14}")
    for (name, model), (acc, cv, sd) in results.items():
        print(f"{name:<10} {model:<13} {acc:12.3f} {cv:8.3f} +-{sd:.3f}")
    return results


if __name__ == "__main__":
    main()
