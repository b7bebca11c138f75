"""The source rig's model file simulated as written (numpy) and compiled (numba).

One run measures both on the same batch: ``examples/pneumatic_rig/model_numpy.py``,
``--members`` members (member 0 the file's values, the others' valve coefficient C_A_in
spread by +-20 %), the rig's own
valve program from ``data11_1_1.csv`` at 100 Hz, ROS2 and RK4 with ``--n-sub`` steps
per sample, through ``integrate_batch`` (the path every fit takes), ``--repeats`` times
each. Reported per integrator: median wall and CPU seconds as written and compiled,
their ratio, the compile time of the first run, the largest position difference
between the two (metres), and the load average. Peer for accuracy: scipy's
``solve_ivp`` (Radau, rtol 1e-8) on member 0, the file's own ``rhs`` per sample.

Usage::

    .venv/bin/python benchmarks/compiled_model_file.py [--members 13] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from pdmkit.models._xp import NumpyNamespace
from pdmkit.models.ode import integrate_batch, load_model_file

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("PDMKIT_DATA", ROOT.parent / "shared" / "data"))


def _program():
    cols = ["time", "outValveHP", "outValveWP", "LeverPosition"]
    d = pd.read_csv(DATA / "pneumatic_rig" / "data11_1_1.csv", usecols=cols)
    d = d.iloc[::10].reset_index(drop=True)
    return d.time.to_numpy() - d.time.iloc[0], {k: d[k].to_numpy() for k in cols[1:3]}


def _run(model, t, u, members, n_sub, method):
    P = dict(model.params)
    P["C_A_in"] = P["C_A_in"] * np.r_[1.0, np.linspace(0.8, 1.2, members - 1)]  # 0: file
    X0 = np.tile([model.initial[s] for s in model.state_names], (members, 1))
    model.integrator = method
    wall, cpu = time.perf_counter(), time.process_time()
    with np.errstate(all="ignore"):
        _, X = integrate_batch(model, [], [], [], t, u, P, X0, n_sub, NumpyNamespace(),
                               want_states=True)  # fmt: skip
    return X, time.perf_counter() - wall, time.process_time() - cpu


def _radau(model, t, u):
    """Member 0 by scipy's Radau, inputs held between samples, restarted at each."""
    x = np.array([model.initial[s] for s in model.state_names])
    out = [x]
    for k in range(t.size - 1):
        uk = {n: float(v[k]) for n, v in u.items()}

        def f(tt, y, uk=uk):
            d = model.rhs.python(tt, dict(zip(model.state_names, y, strict=True)), uk,
                                 model.params)  # fmt: skip
            return [float(d[s]) for s in model.state_names]

        x = solve_ivp(f, (t[k], t[k + 1]), x, method="Radau", rtol=1e-8, atol=1e-9).y[:, -1]
        out.append(x)
    return np.array(out)


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=13)
    ap.add_argument("--n-sub", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    t, u = _program()
    result = {"machine": platform.processor() or platform.machine(), "runs": {}}
    for method in ("rk4", "ros2"):
        row = {}
        for mode in ("never", "always"):
            os.environ["PDMKIT_COMPILE"] = mode
            model = load_model_file(ROOT / "examples" / "pneumatic_rig" / "model_numpy.py")
            runs = [_run(model, t, u, args.members, args.n_sub, method)
                    for _ in range(args.repeats + (mode == "always"))]  # fmt: skip
            if mode == "always":
                row["first_compiled_s"] = runs.pop(0)[1]
            row[mode] = {"wall_s": float(np.median([r[1] for r in runs])),
                         "cpu_s": float(np.median([r[2] for r in runs]))}  # fmt: skip
            row[f"X_{mode}"] = runs[0][0]
        row["ratio"] = row["never"]["wall_s"] / row["always"]["wall_s"]
        gap = np.abs(row.pop("X_never")[..., 0] - row["X_always"][..., 0])
        row["max_position_diff_m"] = float(np.max(gap))
        X = row.pop("X_always")
        result["runs"][method] = row
        never, always = row["never"], row["always"]
        print(f"{method}: as written {never['wall_s']:.2f} s wall "
              f"({never['cpu_s']:.2f} CPU), compiled {always['wall_s']:.3f} s "
              f"({always['cpu_s']:.3f} CPU), ratio {row['ratio']:.1f}x; first "
              f"compiled run {row['first_compiled_s']:.2f} s; positions differ by at most "
              f"{row['max_position_diff_m']:.2e} m")  # fmt: skip
    ref = _radau(model, t, u)
    gap = float(np.max(np.abs(X[0, :, 0] - ref[:, 0])))
    result["ros2_vs_radau_max_position_m"] = gap
    result["load_average"] = os.getloadavg()
    print(
        f"compiled ROS2 member 0 against scipy Radau (rtol 1e-8): {gap:.2e} m; "
        f"load average {result['load_average'][0]:.2f}"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
