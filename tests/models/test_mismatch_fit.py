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
