"""Simulation-error fitting: data checks, nominal fit, effect parameters recovered."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError
from pdmkit.models.mismatch._candidates import CANDIDATES, Effect
from pdmkit.models.mismatch._fit import fit_model, make_recording, nominal_scales
from pdmkit.models.ode import showcase_model
from pdmkit.models.ode._simulate import simulate_ode


@pytest.fixture
def msd_data(rng):
    msd = showcase_model("mass_spring_damper")
    t = np.arange(600) * 0.02
    F = np.repeat(rng.uniform(-40, 40, 60), 10)
    return msd, t, F


def frame(t, **cols):
    return pd.DataFrame({"time": t, **cols})


def test_data_errors_name_the_column_and_row(msd_data):
    msd, t, F = msd_data
    x = np.zeros_like(t)
    with pytest.raises(DataError, match=r"run.csv: missing column\(s\) \['x'\]"):
        make_recording(msd, frame(t, F=F), name="run.csv")
    bad = x.copy()
    bad[17] = np.nan
    with pytest.raises(DataError, match=r"column 'x' has 1 missing .* at row 17"):
        make_recording(msd, frame(t, F=F, x=bad))
    t2 = t.copy()
    t2[40:] += 0.005
    with pytest.raises(DataError, match=r"time must be uniform; row 40"):
        make_recording(msd, frame(t2, F=F, x=x))
    with pytest.raises(DataError, match="column 'F' must be numeric"):
        make_recording(msd, frame(t, F=["a"] * t.size, x=x))


def test_nominal_fit_recovers_free_parameter_and_initial_state(msd_data, rng):
    msd, t, F = msd_data
    y = simulate_ode(
        msd, t, {"F": F}, params={"k": 320.0}, x0={"x": 0.03, "v": -0.2}, n_sub=2
    ).outputs["x"][0]
    fit = fit_model(msd, frame(t, F=F, x=y), n_sub=2)
    assert fit.params()["k"] == pytest.approx(320.0, rel=1e-6)
    assert fit.values["x0:x"] == pytest.approx(0.03, abs=1e-6)
    assert fit.values["x0:v"] == pytest.approx(-0.2, abs=1e-4)
    # with 2 % noise the estimate stays within a few per mille
    noisy = y + rng.normal(0, 0.02 * y.std(), y.size)
    fit = fit_model(msd, frame(t, F=F, x=noisy), n_sub=2)
    assert fit.params()["k"] == pytest.approx(320.0, rel=5e-3)
    assert fit.rmse_fit == pytest.approx(0.02 * y.std(), rel=0.15)


def test_effect_parameters_recovered(rng):
    """Overflow cap and routing of a two-tank system recovered from noisy data."""
    tanks = showcase_model("two_tanks")
    t = np.arange(600) * 2.0
    u = np.repeat(rng.uniform(0.5, 6, 15), 40)
    eff = Effect(CANDIDATES["overflow", "level"], "h1", "h2", {"w": 1e-3, "wf": 1e-6})
    truth = {"overflow@h1->h2.cap": 0.35, "overflow@h1->h2.into": 0.5}
    r = simulate_ode(tanks, t, {"u": u}, effects=[eff], effect_params=truth, n_sub=2)
    data = frame(
        t,
        u=u,
        h1=r.outputs["h1"][0] + rng.normal(0, 0.002, t.size),
        h2=r.outputs["h2"][0] + rng.normal(0, 0.002, t.size),
    )
    nominal = fit_model(tanks, data, n_sub=1)
    sc = nominal_scales(tanks, data, nominal, 1)
    fitted_eff = Effect(
        eff.candidate,
        "h1",
        "h2",
        {"w": 0.005 * (sc.x_max["h1"] - sc.x_min["h1"]), "wf": 0.01 * sc.f_scale("h1")},
    )
    fit = fit_model(tanks, data, effects=[fitted_eff], scales=sc, n_sub=1)
    assert fit.values["overflow@h1->h2.cap"] == pytest.approx(0.35, rel=0.03)
    assert fit.values["overflow@h1->h2.into"] == pytest.approx(0.5, abs=0.1)
    assert fit.params()["b"] == pytest.approx(0.002, rel=0.02)
    assert fit.rmse_fit < 0.2 * nominal.rmse_fit


def test_rough_residual_columns_get_the_large_finite_difference_step():
    """A fixed-step simulation of a switching law (the rig's end-stop dampers) is a
    staircase in the parameter that moves the switching instant: flat between
    jumps, so a 1e-6 step sees no slope (the rig's nominal fit stopped at b_up = 3.3
    N s/m, 7.2 mm validation; with the large step 1.1e4 and 2.1 mm). The first
    Jacobian compares both steps per column and keeps the large one where they
    disagree."""
    from types import SimpleNamespace

    from pdmkit.models.mismatch import _fit_problem as fp

    rng = np.random.default_rng(3)
    a, b = rng.normal(size=50), rng.normal(size=50)
    tread = 1e-3  # the staircase's width in the parameter

    def residual(theta):  # smooth in theta[0], a staircase in theta[1]
        return a * np.sin(theta[0]) + b * tread * np.floor(theta[1] / tread)

    theta = np.array([0.3, 0.5004])
    layout = SimpleNamespace(n=2, scale=np.ones(2), hi=np.full(2, np.inf))
    job = SimpleNamespace(layout=layout, fd_rel=None)
    steps = np.stack([fp._fd_steps(job, theta), fp._fd_steps(job, theta, fp.FD_LARGE)])
    rows = [residual(theta)]
    for step in steps:
        rows += [residual(theta + np.eye(2)[i] * step[i]) for i in range(2)]
    J = fp._fd_columns(np.array(rows), 0, job, steps)
    assert list(job.fd_rel) == [fp.FD_SMALL, fp.FD_LARGE]
    np.testing.assert_allclose(J[:, 0], a * np.cos(0.3), rtol=1e-4)  # the small step
    np.testing.assert_allclose(J[:, 1], b, rtol=0.2)  # the staircase's mean slope
    assert np.allclose(fp._fd_steps(job, theta), [1e-6, 1e-2])  # kept for the fit
