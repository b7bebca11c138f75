"""The step a fit simulates with, chosen by simulation agreement (issue 29, item 3).

The source rig's model (examples/pneumatic_rig/model_numpy.py, written from the thesis by
an engineer who did not read pdmkit) has a chamber mode that is fast only for a moment,
as a valve opens: the fastest-mode rule asks for several RK4 steps per 1 ms sample of
the whole record. ``choose_sampling`` finds a far cheaper step, and what it chooses must
agree with scipy's Radau at tight tolerances (an integrator pdmkit does not share).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from pdmkit.models.mismatch import make_recording
from pdmkit.models.mismatch._fit import _initial_values
from pdmkit.models.mismatch._sampling import (
    _choose_n_sub,
    choose_sampling,
    converged_n_sub,
    decimate,
    simulate_outputs,
)
from pdmkit.models.ode import load_model_file

RIG = Path(__file__).resolve().parents[2] / "examples" / "pneumatic_rig"


def _radau_position(model, t, program, switches):
    """The lever position by Radau (rtol 1e-8), one solve between command switches."""
    return _radau_states(model, t, program, switches)[:, list(model.states).index("x")]


def _radau_states(model, t, program, switches):
    """Every state by Radau (rtol 1e-8), one solve between command switches, ``(N, nx)``."""
    names = list(model.states)
    p = dict(model.params)
    y = [model.initial[s] for s in names]
    out = np.empty((t.size, len(names)))
    edges = [0, *(int(np.searchsorted(t, ts)) for ts in switches), t.size]
    for a, b in itertools.pairwise(edges):
        u = {name: float(v[a]) for name, v in program.items()}

        def f(tt, yy, u=u):
            d = model.rhs(tt, dict(zip(names, yy, strict=True)), u, p)
            return [float(d[s]) for s in names]

        t_end = t[b] if b < t.size else t[-1]
        sol = solve_ivp(
            f,
            (t[a], t_end),
            y,
            method="Radau",
            t_eval=t[a:b],
            rtol=1e-8,
            atol=[1e-9, 1e-8, 1e-2, 1e-2],
            dense_output=True,
        )
        assert sol.success, sol.message
        out[a:b] = sol.y.T
        y = sol.sol(t_end)
    return out


def test_rig_step_is_checked_against_radau():
    model = load_model_file(RIG / "model_position.py")  # the lever position alone
    t = np.arange(2400) * 1e-3  # 2.4 s at 1 kHz: an up stroke and a down stroke
    work = ((t >= 0.05) & (t < 1.2)).astype(float)
    program = {"outValveHP": 1.0 - work, "outValveWP": work}
    x = _radau_position(model, t, program, switches=(0.05, 1.2))
    data = {"time": t, **program, "LeverPosition": x}
    rec = make_recording(model, data)
    values = _initial_values(model, rec)
    s = choose_sampling(model, rec, values)
    eigen = _choose_n_sub(model.with_integrator("rk4"), rec, values)
    assert s.checked and s.model.integrator == "rk4"
    # at least twice cheaper than the fastest-mode rule (RK4 calls per recorded sample)
    assert 4 * s.n_sub / s.factor <= 4 * eigen / 2
    y = simulate_outputs(s.model, decimate(rec, s.factor), values, s.n_sub)
    err = np.abs(y[:, 0] - x[: y.shape[0] * s.factor : s.factor])
    assert err.max() <= 0.02 * np.std(x), (err.max(), np.std(x))
    # the step stays converged at its own parameters
    assert converged_n_sub(s.model, decimate(rec, s.factor), values, s.n_sub) == s.n_sub


def test_flow_meters_as_outputs_still_decimate_and_agree_with_radau():
    """Outputs an input drives directly (the flow meters) jump at the valve's switches.

    There a decimated input's block mean differs from a finer one's at any step, so the
    check counts all but the 1 % largest differences of such an output
    (``CHECK_SKIP``); the step it then takes must still follow Radau's position and
    flows (computed by the file's ``outputs`` from Radau's states) away from the
    switching samples.
    """
    model = load_model_file(RIG / "model_numpy.py")  # position and both flow meters
    t = np.arange(2400) * 1e-3
    work = ((t >= 0.05) & (t < 1.2)).astype(float)
    program = {"outValveHP": 1.0 - work, "outValveWP": work}
    X = _radau_states(model, t, program, switches=(0.05, 1.2))
    x = {s: X[:, j] for j, s in enumerate(model.states)}
    y_ref = model.output_values(x, program, dict(model.params))
    rec = make_recording(model, {"time": t, **program, **y_ref})
    values = _initial_values(model, rec)
    s = choose_sampling(model, rec, values)
    assert s.checked and s.factor > 1, (s.factor, s.n_sub)
    y = simulate_outputs(s.model, decimate(rec, s.factor), values, s.n_sub)
    k = np.arange(y.shape[0]) * s.factor
    near_switch = np.zeros(k.size, dtype=bool)
    for ts in (0.05, 1.2):  # the decimated samples whose block holds a switch
        near_switch |= np.abs(t[k] - ts) <= s.factor * 1e-3
    for j, name in enumerate(model.outputs):
        ref = np.asarray(y_ref[name])[k]
        err = np.abs(y[:, j] - ref)[~near_switch]
        assert err.max() <= 0.03 * np.std(y_ref[name]), (name, err.max())
