"""A fit made in pieces is refined on the whole record (``polish_whole``).

Reference: scipy. An axis (position integrates speed) with Coulomb friction the model
leaves out, driven by force steps. The model (mass and viscous friction only) is
linear, so its whole-record simulation error is minimised outside pdmkit by
``scipy.optimize.least_squares`` over ``scipy.signal.lsim`` (exact for the held
input). Started from a fit that landed elsewhere (the viscous coefficient 8 % off, as
pieces that drift cheaply leave it), the refinement must land on scipy's optimum.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares
from scipy.signal import lsim

from pdmkit.models.mismatch._fit import _whole_rmse, polish_whole
from pdmkit.models.mismatch._fit_problem import _lm, _make_jobs, _Problem
from pdmkit.models.mismatch._setup import prepare
from pdmkit.models.ode import load_model_source

MODEL = """
STATES = {"q": "position", "v": "velocity"}
INPUTS = {"F": "force"}
OUTPUTS = ["q"]
PARAMS = {"M": 2.0, "Fv": 6.0}
FREE = ["M", "Fv"]
INITIAL = {"q": 0.0, "v": 0.0}

def rhs(t, x, u, p):
    return {"q": x["v"], "v": (u["F"] - p["Fv"] * x["v"]) / p["M"]}
"""
TS, N = 0.01, 2000  # long enough to be fitted in pieces (integrating: from 1000)


def _force(t):
    k = np.floor(t / 0.8).astype(int)
    return np.where(k % 2 == 0, 1.0, -1.0) * (0.6 + 0.3 * np.sin(0.7 * k))


@pytest.fixture(scope="module")
def record():
    t = np.arange(N) * TS

    def f(tt, x):  # the truth: Coulomb friction (0.25 N) beside the viscous
        F = _force(np.array([tt]))[0]
        return [x[1], (F - 6.0 * x[1] - 0.25 * np.tanh(x[1] / 0.01)) / 2.0]

    sol = solve_ivp(f, (0, t[-1]), [0.0, 0.0], t_eval=t, max_step=TS / 4, rtol=1e-8)
    q = sol.y[0] + np.random.default_rng(0).normal(0.0, 2e-4, N)
    return pd.DataFrame({"time": t, "F": _force(t), "q": q})


def _scipy_whole_fit(record):
    """M, Fv minimising the whole span's simulation error (initial state fitted)."""
    t, F, q = (record[c].to_numpy() for c in ("time", "F", "q"))

    def residual(th):
        M, Fv, q0, v0 = th
        A = [[0.0, 1.0], [0.0, -Fv / M]]
        sys = (A, [[0.0], [1.0 / M]], [[1.0, 0.0]], [[0.0]])
        return lsim(sys, F, t, X0=[q0, v0], interp=False)[1] - q

    return least_squares(residual, [2.0, 6.0, 0.0, 0.0], x_scale=[1, 1, 1e-3, 1e-2]).x


def test_a_fit_that_landed_elsewhere_is_refined_onto_scipys_whole_optimum(record):
    model = load_model_source(MODEL)
    model, s = prepare(model, record, None, data_name="data", validation_name=None,
                       input_hold="zoh")  # fmt: skip
    assert s.pieces is not None and s.factor == 1
    M_ref, Fv_ref, *_ = _scipy_whole_fit(record.iloc[: s.n_fit])
    problem = _Problem(model, s.rec, s.n_fit, s.w, max(s.n_sub, 2), *s.pieces)
    off = {**s.values0, "p:M": M_ref, "p:Fv": 1.08 * Fv_ref}
    (job,) = _make_jobs(model, (), None, [{}], off, s.x_scale, fit_free=False)
    _lm(problem, [job], 30)  # the pieces' states under the parameters that are off
    (start,) = _make_jobs(model, (), None, [{}], off, s.x_scale, x0=job.x0)
    _lm(problem, [start], 0)
    polished = polish_whole(model, problem, start, s.x_scale)
    after = polished.values()
    assert after["p:Fv"] == pytest.approx(Fv_ref, rel=0.01)
    assert after["p:M"] == pytest.approx(M_ref, rel=0.02)
    # a job on the pieces with every piece's state and the parameters free
    assert polished.x0.shape == (problem.n_pieces, 2) and np.isfinite(polished.cost)
    assert set(polished.layout.names) >= {"p:M", "p:Fv"}
    # and a fit already at the whole optimum is kept as it is
    whole = _Problem(model, s.rec, s.n_fit, s.w, problem.n_sub)
    assert _whole_rmse(whole, after, polished.x0[0]) <= _whole_rmse(
        whole, start.values(), start.x0[0]
    )
    assert polish_whole(model, problem, polished, s.x_scale) is polished
