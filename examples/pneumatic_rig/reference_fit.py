# ruff: noqa  (an independent outside reference, kept as its author wrote it)
"""Reference fit of the thesis's pneumatic-rig model (scipy only).

  python reference_fit.py                 # nominal + base fit on data11_1_1, validate _2/_3
  python reference_fit.py deadtime        # same, with an extra effect (see sim.py)
  python reference_fit.py spool deadtime  # several effects together
  python reference_fit.py nominal         # nominal simulations only

Fit: scipy.optimize.least_squares (trf) on the LeverPosition of data11_1_1
decimated to 100 Hz; FREE parameters of the model (+ the effect's own
parameters), positive ones in log space. Validation: the same parameters on the
full 1 kHz data11_1_2 and data11_1_3. A run with effects starts from the base
fit (fit_base.json). Results are also written to fit_<tag>.json.
"""

import json
import os
import sys
import time

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import model_thesis as MT  # noqa: E402
import sim  # noqa: E402

RECS = ["data11_1_1", "data11_1_2", "data11_1_3"]
LINEAR = {"F_C": 10.0, "tau": 0.01}  # fitted linearly with this scale (can be 0)
EFFECT_PARAMS = {
    "deadtime": {"tau": 0.01},
    "spool": {"T_sp": 0.02},
    "supply": {},
    "polytropic": {"n_poly": 1.4},
    "deadvol": {"V0A": MT.PARAMS["V0A"], "V0B": MT.PARAMS["V0B"]},
    "linevol": {"V0A": MT.PARAMS["V0A"], "V0B": MT.PARAMS["V0B"]},
}
# "linevol" = "deadvol" started from 20 cm^3 per side (tubes + flow sensor + valve
# ports between the 5/2 valve and the cylinder), not from the cylinder's own 4-5 cm^3
EFFECT_START = {"linevol": {"V0A": 2e-5, "V0B": 2e-5}}


def to_params(theta, names, base):
    p = dict(base)
    for th, k in zip(theta, names):
        p[k] = LINEAR[k] * th if k in LINEAR else base_nom[k] * np.exp(th)
    return p


def from_params(p, names):
    return np.array(
        [p[k] / LINEAR[k] if k in LINEAR else np.log(p[k] / base_nom[k]) for k in names]
    )


def evaluate(p, recs, effects, label):
    res = {}
    for name in RECS:
        rec = recs[name]
        t0 = time.time()
        o = sim.simulate(p, rec, rec["time"], effects)
        wt = time.time() - t0
        r = {
            "pos_rmse_mm": 1e3 * sim.rmse(o["LeverPosition"], rec["LeverPosition"]),
            "flowExt_rmse_lmin": sim.rmse(o["FlowExtrusion"], rec["FlowExtrusion"]),
            "flowCon_rmse_lmin": sim.rmse(o["FlowContraction"], rec["FlowContraction"]),
            "flowExt_range_meas": [
                float(rec["FlowExtrusion"].min()),
                float(rec["FlowExtrusion"].max()),
            ],
            "flowCon_range_meas": [
                float(rec["FlowContraction"].min()),
                float(rec["FlowContraction"].max()),
            ],
            "flowExt_range_sim": [
                float(np.nanmin(o["FlowExtrusion"])),
                float(np.nanmax(o["FlowExtrusion"])),
            ],
            "flowCon_range_sim": [
                float(np.nanmin(o["FlowContraction"])),
                float(np.nanmax(o["FlowContraction"])),
            ],
            "sim_wall_s": wt,
        }
        # split of the position error: up stroke (1-6 s) and down stroke (6-10 s)
        t = rec["time"]
        for lab, m in [("up", (t >= 1) & (t < 6)), ("down", t >= 6)]:
            r["pos_rmse_mm_" + lab] = 1e3 * sim.rmse(
                o["LeverPosition"][m], rec["LeverPosition"][m]
            )
        res[name] = r
        print(
            f"  [{label}] {name}: LeverPosition RMSE {r['pos_rmse_mm']:.3f} mm "
            f"(up {r['pos_rmse_mm_up']:.2f}, down {r['pos_rmse_mm_down']:.2f}); "
            f"FlowExtrusion RMSE {r['flowExt_rmse_lmin']:.2f} l/min "
            f"(meas {r['flowExt_range_meas'][0]:.1f}..{r['flowExt_range_meas'][1]:.1f}, "
            f"sim {r['flowExt_range_sim'][0]:.1f}..{r['flowExt_range_sim'][1]:.1f}); "
            f"FlowContraction RMSE {r['flowCon_rmse_lmin']:.2f} l/min "
            f"(meas {r['flowCon_range_meas'][0]:.1f}..{r['flowCon_range_meas'][1]:.1f}, "
            f"sim {r['flowCon_range_sim'][0]:.1f}..{r['flowCon_range_sim'][1]:.1f}); "
            f"sim {wt:.2f} s",
            flush=True,
        )
    return res


def author_reference():
    a = pd.read_csv(sim.DATA + "author_model_health.csv")
    out = {}
    for k in ["LeverPosition", "FlowExtrusion", "FlowContraction", "LeverVelocity"]:
        out[k] = sim.rmse(a[k + "_sim"].to_numpy(), a[k + "_measured"].to_numpy())
    t = a["time"].to_numpy()
    for lab, m in [("up", (t >= 1) & (t < 6)), ("down", t >= 6)]:
        out["LeverPosition_" + lab] = sim.rmse(
            a["LeverPosition_sim"].to_numpy()[m], a["LeverPosition_measured"].to_numpy()[m]
        )
    same = np.array_equal(
        a["LeverPosition_measured"].to_numpy(),
        pd.read_csv(sim.DATA + "data11_1_1.csv")["LeverPosition"].to_numpy(),
    )
    print(
        f"Author's Simulink model (author_model_health.csv, measured == data11_1_1: {same}): "
        f"LeverPosition RMSE {1e3 * out['LeverPosition']:.3f} mm "
        f"(up {1e3 * out['LeverPosition_up']:.2f}, down {1e3 * out['LeverPosition_down']:.2f}), "
        f"FlowExtrusion {out['FlowExtrusion']:.2f} l/min, FlowContraction {out['FlowContraction']:.2f} l/min"
    )
    return out


base_nom = dict(MT.PARAMS)


def main(args):
    T0 = time.time()
    effects = tuple(a for a in args if a in EFFECT_PARAMS)
    nominal_only = "nominal" in args
    tag = "base" if not effects else "_".join(effects)
    recs = {n: sim.load(n) for n in RECS}
    out = {"effects": list(effects)}
    out["author"] = author_reference()

    if nominal_only or not effects:
        print("Nominal parameters (model_thesis.PARAMS):")
        out["nominal"] = evaluate(dict(MT.PARAMS), recs, (), "nominal")
        pa = dict(MT.PARAMS, ps=6.0e5, T=281.7)
        print(
            "Nominal with the author's params.m constants p_s = 6e5 Pa (abs), T = 281.7 K:"
        )
        out["nominal_author_constants"] = evaluate(pa, recs, (), "nominal-author-ps")
        if nominal_only:
            return out

    # start point
    start = dict(MT.PARAMS)
    if effects:
        with open(os.path.join(HERE, "fit_base.json")) as fh:
            start.update(json.load(fh)["fitted"])
    names = list(MT.FREE)
    for e in effects:
        for k, v in EFFECT_PARAMS[e].items():
            if k not in names:
                names.append(k)
            start.setdefault(k, v)
            if k not in base_nom:
                base_nom[k] = v
    for e in effects:
        start.update(EFFECT_START.get(e, {}))
    lo = np.array([0.0 if k in LINEAR else -5.0 for k in names])
    hi = np.array([20.0 if k in LINEAR else 5.0 for k in names])

    rec = recs["data11_1_1"]
    te = rec["time"][::10]
    ym = rec["LeverPosition"][::10]
    counter = {"n": 0}

    def resid(theta):
        counter["n"] += 1
        p = to_params(theta, names, start)
        try:
            o = sim.simulate(p, rec, te, effects)
        except Exception as exc:
            print("  sim failed:", exc, flush=True)
            return np.full(te.size, 50.0)
        return 1e3 * (o["LeverPosition"] - ym)

    # trf must not start on a bound (its Coleman-Li scaling then freezes the
    # step): a zero Coulomb friction starts at 5 N
    if start["F_C"] <= 0.0:
        start["F_C"] = 5.0
    x0 = np.clip(from_params(start, names), lo + 0.05, hi - 0.05)
    r0 = resid(x0)
    print(
        f"Fit [{tag}] of {names} on data11_1_1 @100 Hz: start RMSE {np.sqrt(np.mean(r0**2)):.3f} mm",
        flush=True,
    )
    t0 = time.time()
    sol = least_squares(
        resid,
        x0,
        bounds=(lo, hi),
        method="trf",
        diff_step=1e-2,
        x_scale=1.0,
        max_nfev=40,
        verbose=1,
    )
    fit_wall = time.time() - t0
    pf = to_params(sol.x, names, start)
    fitted = {k: float(pf[k]) for k in names}
    print(
        f"  least_squares: status {sol.status}, nfev {sol.nfev}, residual evaluations {counter['n']}, "
        f"final RMSE @100 Hz {np.sqrt(np.mean(sol.fun**2)):.3f} mm, wall {fit_wall:.1f} s"
    )
    for k in names:
        nom = MT.PARAMS.get(k)
        print(
            f"    {k:8s} = {fitted[k]:.5g}"
            + (f"   (nominal {nom:.5g})" if nom is not None else "")
        )
    print(
        "Fitted parameters, full recordings at 1 kHz (data11_1_1 = training, _2/_3 = validation):"
    )
    out["fitted"] = fitted
    out["fit"] = {
        "status": int(sol.status),
        "nfev": int(sol.nfev),
        "wall_s": fit_wall,
        "rmse_100Hz_mm": float(np.sqrt(np.mean(sol.fun**2))),
    }
    out["fitted_eval"] = evaluate(
        pf, recs, effects, "fitted" + ("" if not effects else "+" + tag)
    )
    val = [out["fitted_eval"][n]["pos_rmse_mm"] for n in RECS[1:]]
    print(f"Validation mean LeverPosition RMSE (data11_1_2, _3): {np.mean(val):.3f} mm")
    out["wall_total_s"] = time.time() - T0
    print(f"Total wall time: {out['wall_total_s']:.1f} s")
    with open(os.path.join(HERE, f"fit_{tag}.json"), "w") as fh:
        json.dump(out, fh, indent=1)
    return out


if __name__ == "__main__":
    main(sys.argv[1:])
