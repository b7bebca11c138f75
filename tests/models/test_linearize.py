"""Linearisation by torch autograd (as the S-Mobile paper: at the operating point)."""

import numpy as np
import pytest
import torch

from pdmkit.errors import ModelError
from pdmkit.models.ode._linearize import linearize
from pdmkit.models.ode._modelfile import OdeModel


def _msd():
    return OdeModel(
        {"x": "position", "v": "velocity"},
        {"F": "force"},
        ["x"],
        {"m": 2.0, "c": 3.0, "k": 50.0},
        lambda t, x, u, p: {
            "x": x["v"],
            "v": (u["F"] - p["c"] * x["v"] - p["k"] * x["x"]) / p["m"],
        },
    )


def test_mass_spring_damper_matches_analytic_matrices():
    lin = linearize(_msd(), {"x": 0.1, "v": -0.2}, {"F": 1.0})
    m, c, k = 2.0, 3.0, 50.0
    assert np.allclose(lin.A, [[0, 1], [-k / m, -c / m]])
    assert np.allclose(lin.B, [[0], [1 / m]])
    assert np.allclose(lin.C, [[1, 0]]) and np.allclose(lin.D, 0)
    # poles of m s^2 + c s + k
    assert np.allclose(np.sort_complex(lin.poles), np.sort_complex(np.roots([m, c, k])))
    # params override; static gain of the FRF is 1/k
    stiff = linearize(_msd(), {}, {}, params={"k": 200.0})
    assert stiff.frequency_response([0.0])[0, 0, 0].real == pytest.approx(1 / 200.0)


def _pendulum(g=9.81, ell=0.5, b=0.0):
    return OdeModel(
        {"th": "angle", "w": "angular_velocity"},
        {"T": "torque"},
        ["th"],
        {"g": g, "l": ell, "b": b},
        lambda t, x, u, p: {
            "th": x["w"],
            "w": -p["g"] / p["l"] * torch.sin(x["th"]) - p["b"] * x["w"] + u["T"],
        },
    )


def test_pendulum_bottom_and_top():
    g, ell = 9.81, 0.5
    bottom = linearize(_pendulum(g, ell), {"th": 0.0, "w": 0.0}, {"T": 0.0})
    assert bottom.is_equilibrium
    assert np.allclose(np.sort(bottom.poles.imag), [-np.sqrt(g / ell), np.sqrt(g / ell)])
    assert np.allclose(bottom.poles.real, 0.0)
    top = linearize(_pendulum(g, ell), {"th": np.pi, "w": 0.0}, {"T": 0.0})
    assert np.allclose(np.sort(top.poles.real), [-np.sqrt(g / ell), np.sqrt(g / ell)])
    off = linearize(_pendulum(g, ell), {"th": 0.3, "w": 0.0}, {"T": 0.0})
    assert not off.is_equilibrium
    assert off.A[1, 0] == pytest.approx(-g / ell * np.cos(0.3))
    df = bottom.to_pandas()
    assert df["wn_rad_s"].to_numpy() == pytest.approx([np.sqrt(g / ell)] * 2)


def test_pneumatic_twin_jacobian_matches_finite_differences():
    from pdmkit.models import PneumaticParams, initial_state, piston_rhs

    p = PneumaticParams()
    x0 = np.asarray(initial_state(p), dtype=float)
    x0[0] += 0.05  # mid-stroke, away from the end-stop contact
    x0[1] = 0.2
    # pressures away from the orifices' kinks (zero pressure difference), where the
    # flow function is not differentiable
    x0[2:5] = [3.0e5, 2.5e5, 5.9e5]
    lin = linearize(piston_rhs, x0, t=0.5, args=(p,))
    n = x0.size
    fd = np.zeros((n, n))
    for j in range(n):
        h = 1e-6 * max(1.0, abs(x0[j]))
        e = np.zeros(n)
        e[j] = h
        fd[:, j] = (piston_rhs(0.5, x0 + e, p) - piston_rhs(0.5, x0 - e, p)) / (2 * h)
    scale = np.maximum(np.abs(fd), 1e-6 * np.max(np.abs(fd), axis=1, keepdims=True))
    assert np.all(np.abs(lin.A - fd) <= 1e-4 * scale + 1e-8)
    assert lin.B.shape == (n, 0)


def test_errors():
    with pytest.raises(ModelError, match="x0"):
        linearize(_msd(), [0.0, 0.0, 0.0])
    with pytest.raises(ModelError, match="unknown"):
        linearize(_msd(), {"y": 1.0})
    with pytest.raises(ModelError, match="OdeModel"):
        linearize(42, [0.0])


def test_s_mobile_loop_linearise_then_fit_physical_parameters_to_frf():
    """Linearise the nonlinear model with free parameters, fit them to a measured FRF."""
    from pdmkit.models.frequency import FRF, fit_frf_params

    model = _pendulum(b=0.8)
    x0, u0 = {"th": 0.0, "w": 0.0}, {"T": 0.0}

    def frf_model(omega, l, b):
        lin = linearize(model, x0, u0, params={"l": l, "b": b})
        return lin.frequency_response(omega)[0, 0]

    f = np.linspace(0.05, 2.0, 120)
    rng = np.random.default_rng(0)
    H = frf_model(2 * np.pi * f, 0.5, 0.8)
    H = H * (1 + 0.02 * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)))
    fit = fit_frf_params(frf_model, {"l": 1.0, "b": 0.3}, FRF(f, H))
    assert fit.params["l"] == pytest.approx(0.5, rel=0.01)
    assert fit.params["b"] == pytest.approx(0.8, rel=0.05)
