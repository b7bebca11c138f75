"""A fit's batch with candidate effects: their terms in numpy around the compiled model,
and compiled into the model's loop (models/ode/_compiled_effects.py), in one run.

The batch is what the rig's discovery screens: ``examples/pneumatic_rig/
model_position.py`` on ``data11_1_1.csv`` at 100 Hz, RK4 with 8 steps per sample,
``--rows`` rows cycling through Coulomb and direction-dependent friction, a leak on
chamber A, a lag on a valve command, a lag of the position sensor (an output computed by
``outputs``), Bouc-Wen hysteresis and none, each at its first guess. Path A, the one
before: the model's ``rhs`` compiled, the effects' terms and the integration in numpy
(forced here by refusing the table of effects). Path B: everything in the compiled
loop. Reported: median wall and CPU seconds of ``--repeats`` simulations of the batch
each, their ratio, the largest output difference (metres) and the load average.

Usage::

    .venv/bin/python benchmarks/compiled_effects.py [--rows 60] [--json out.json]
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

import pdmkit.models.ode._compiled as compiled_module
from pdmkit.models.mismatch._candidates import _dummy_scales, attach_candidates
from pdmkit.models.mismatch._fit_problem import _lm, _make_jobs, _Problem
from pdmkit.models.mismatch._setup import prepare
from pdmkit.models.ode import load_model_file

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("PDMKIT_DATA", ROOT.parent / "shared" / "data"))
EFFECTS = (
    "coulomb_friction@v",
    "asymmetric_friction@v",
    "leak@pA",
    "input_lag@outValveWP",
    "sensor_lag@LeverPosition",
    "hysteresis@v",
    None,
)


def _batch(rows: int):
    model = load_model_file(ROOT / "examples" / "pneumatic_rig" / "model_position.py")
    data = pd.read_csv(DATA / "pneumatic_rig" / "data11_1_1.csv")
    model, s = prepare(model, data, None, data_name="data11_1_1", validation_name=None,
                       input_hold="zoh")  # fmt: skip
    model = model.with_integrator("rk4")
    sc = _dummy_scales(model)
    y = data["LeverPosition"].to_numpy()
    sc.y_min, sc.y_max, sc.y_std = ({"LeverPosition": f(y)} for f in (np.min, np.max,
                                    np.std))  # fmt: skip
    found = {e.key: e for e in attach_candidates(model, sc)}
    jobs = []
    for r in range(rows):
        key = EFFECTS[r % len(EFFECTS)]
        effs = () if key is None else (found[key],)
        start = {f"{e.key}.{k}": v for e in effs
                 for k, v in e.candidate.guesses(e, sc)[0].items()}  # fmt: skip
        jobs += _make_jobs(model, effs, sc, [start], s.values0, s.x_scale, tag=str(key))
    problem = _Problem(model, s.rec, s.n_fit, s.w, 8)
    _lm(problem, jobs, 0)  # compiles the model (numba's cache keeps it between runs)
    return model, problem, [(j, j.values(), j.x0) for j in jobs]


def _time(problem, rows, repeats):
    problem.simulate(rows)  # the first run of each path checks it against numpy
    wall, cpu, out = [], [], None
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        out = problem.simulate(rows)
        wall.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return out, float(np.median(wall)), float(np.median(cpu))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", type=int, default=60)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    os.environ.setdefault("PDMKIT_COMPILE", "always")
    model, problem, rows = _batch(a.rows)
    table = compiled_module.effect_rows
    compiled_module.effect_rows = lambda *args, **kw: None  # A: terms in numpy
    try:
        y_a, wall_a, cpu_a = _time(problem, rows, a.repeats)
    finally:
        compiled_module.effect_rows = table
    y_b, wall_b, cpu_b = _time(problem, rows, a.repeats)  # B: all compiled
    assert model.rhs.ran("rk4", with_effects=True), model.rhs.note
    out = {
        "rows": a.rows,
        "samples": int(problem.n_fit),
        "steps_per_sample": int(problem.n_sub),
        "numpy_terms_wall_s": wall_a,
        "numpy_terms_cpu_s": cpu_a,
        "compiled_wall_s": wall_b,
        "compiled_cpu_s": cpu_b,
        "speedup_wall": wall_a / wall_b,
        "max_output_difference_m": float(np.nanmax(np.abs(y_a - y_b))),
        "load_average": os.getloadavg()[0],
        "machine": platform.processor() or platform.machine(),
    }
    for k, v in out.items():
        print(f"{k:28s} {v:.4g}" if isinstance(v, float) else f"{k:28s} {v}")
    if a.json:
        a.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
