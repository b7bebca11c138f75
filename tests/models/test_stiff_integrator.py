"""The stiff integrator (ROS2) and how the fits choose it (issue 29, item 2).

References: closed-form solutions and scipy's Radau at tight tolerances."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pdmkit.models.mismatch import make_recording
from pdmkit.models.mismatch._sampling import choose_integrator
from pdmkit.models.ode import load_model_source, showcase_model, simulate_ode

FAST_SLOW = load_model_source(
    'STATES = {"y": "other", "z": "other"}\nOUTPUTS = ["y"]\nPARAMS = {"k": 1000.0}\n'
    'INITIAL = {"y": 0.0, "z": 1.0}\n'
    "def rhs(t, x, u, p):\n"
    '    return {"y": -p["k"] * (x["y"] - x["z"]), "z": -0.5 * x["z"]}\n'
)


def _exact_y(t, k=1000.0):
    # y' = -k (y - e^{-t/2}), y(0) = 0
    c = k / (k - 0.5)
    return c * (np.exp(-0.5 * t) - np.exp(-k * t))


def test_ros2_is_second_order_on_a_stiff_linear_system():
    t = np.linspace(0.0, 4.0, 41)  # h = 0.1: h * k = 100, far outside RK4's region
    errors = []
    for n_sub in (2, 4, 8):
        r = simulate_ode(FAST_SLOW, t, n_sub=n_sub, method="ros2")
        errors.append(np.max(np.abs(r.states["y"][0, 5:] - _exact_y(t[5:]))))
    assert errors[-1] < 5e-5
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.7), orders
    # explicit RK4 at the same steps blows up
    with np.errstate(all="ignore"):
        r = simulate_ode(FAST_SLOW, t, n_sub=2, method="rk4")
    assert not np.all(np.isfinite(r.states["y"])) or np.max(np.abs(r.states["y"])) > 1e3


# a chamber filled through an orifice by the thesis's flow law (choked below the
# critical ratio, subsonic above: psi has an infinite slope at the supply pressure, the
# stiffness that made explicit fits of the rig take half an hour)
CHAMBER = """
import math
STATES = {"p": "pressure"}
INPUTS = {"valve": "other"}
OUTPUTS = ["p"]
PARAMS = {"C": 2e-7, "V": 5e-5, "ps": 7e5, "p0": 1e5, "T": 293.0}
INITIAL = {"p": 1e5}
KAPPA, R = 1.4, 287.1

def psi(r):
    b = 0.528
    if r <= b:
        return (2 / (KAPPA + 1)) ** (1 / (KAPPA - 1)) * math.sqrt(KAPPA / (KAPPA + 1))
    q = r ** (2 / KAPPA) - r ** ((KAPPA + 1) / KAPPA)
    return math.sqrt(KAPPA / (KAPPA - 1) * max(q, 0.0))

def rhs(t, x, u, p):
    if u["valve"] > 0.5:
        up, down = p["ps"], x["p"]
    else:
        up, down = x["p"], p["p0"]
    m = p["C"] * up * math.sqrt(2 / (R * p["T"])) * psi(down / up)
    sign = 1.0 if u["valve"] > 0.5 else -1.0
    return {"p": sign * KAPPA * R * p["T"] / p["V"] * m}
"""


def _chamber_reference(model, t, valve):
    def f(tt, y):
        k = min(int(tt / (t[1] - t[0]) + 1e-9), t.size - 1)
        return [float(model.derivatives({"p": y[0]}, {"valve": valve[k]})["p"])]

    out = np.empty_like(t)
    out[0] = 1e5
    y = [1e5]
    switches = np.flatnonzero(np.diff(valve)) + 1
    bounds = [0, *switches.tolist(), t.size - 1]
    for a, b in itertools.pairwise(bounds):
        sol = solve_ivp(
            f,
            (t[a], t[b]),
            y,
            method="Radau",
            t_eval=t[a : b + 1],
            rtol=1e-10,
            atol=1e-3,
            first_step=1e-7,
        )
        out[a : b + 1] = sol.y[0]
        y = [sol.y[0, -1]]
    return out


def test_ros2_follows_radau_on_a_switching_chamber():
    model = load_model_source(CHAMBER)
    assert model.evaluation == "per-sample"
    t = np.arange(0.0, 0.6, 1e-3)
    valve = ((t >= 0.05) & (t < 0.3)).astype(float)
    ref = _chamber_reference(model, t, valve)
    r = simulate_ode(model, t, {"valve": valve}, method="ros2")
    err = np.abs(r.states["p"][0] - ref)
    assert np.max(err) < 0.01 * (7e5 - 1e5), np.max(err)
    assert np.sqrt(np.mean(err**2)) < 3e-3 * 6e5  # measured 0.2 % of the range


# a piston pushed by a pressure force onto its end stop: the stop is a stiff spring and
# damper (the thesis's hard stop, eq. 4.38, "tuned for numerical stability")
STOP = """
import numpy as np
STATES = {"x": "position", "v": "velocity"}
INPUTS = {"valve": "other"}
OUTPUTS = ["x"]
PARAMS = {"m": 7.0, "F": 300.0, "K": 5e8, "D": 2e4, "top": 0.2, "g": 9.81, "c": 80.0}
INITIAL = {"x": 0.0, "v": 0.0}

def rhs(t, x, u, p):
    over = np.maximum(x["x"] - p["top"], 0.0)
    under = np.maximum(-x["x"], 0.0)
    stop = -p["K"] * over - p["D"] * x["v"] * (over > 0) + p["K"] * under
    stop = stop - p["D"] * x["v"] * (under > 0)
    force = p["F"] * (2 * u["valve"] - 1) - p["m"] * p["g"] - p["c"] * x["v"] + stop
    return {"x": x["v"], "v": force / p["m"]}
"""


def test_fits_choose_ros2_for_stiff_stops():
    model = load_model_source(STOP)
    t = np.arange(0.0, 1.5, 1e-3)
    valve = (t < 1.0).astype(float)
    r = simulate_ode(model, t, {"valve": valve}, method="ros2")
    p = model.params

    def f(tt, y):  # the same equations in plain Python for scipy's LSODA
        u = 1.0 if tt < 1.0 else 0.0
        over, under = max(y[0] - p["top"], 0.0), max(-y[0], 0.0)
        stop = -p["K"] * over - p["D"] * y[1] * (over > 0) + p["K"] * under
        stop -= p["D"] * y[1] * (under > 0)
        force = p["F"] * (2 * u - 1) - p["m"] * p["g"] - p["c"] * y[1] + stop
        return [y[1], force / p["m"]]

    ref = solve_ivp(
        f, (0, t[-1]), [0.0, 0.0], method="LSODA", t_eval=t, rtol=1e-8, atol=1e-10
    )
    err = np.abs(r.states["x"][0] - ref.y[0])
    # the impacts are resolved to a few ms: a bounce's peak may shift, the rest agrees
    assert np.sqrt(np.mean(err**2)) < 5e-3 * p["top"]
    assert np.max(err[t > 1.4]) < 1e-6
    rec = make_recording(model, {"time": t, "valve": valve, "x": r.states["x"][0]})
    values = {f"p:{k}": v for k, v in p.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    assert choose_integrator(model, rec, values).integrator == "ros2"
    # a mass-spring-damper sampled at 100 Hz is not stiff
    msd = showcase_model("mass_spring_damper")
    t2 = np.arange(1000) * 0.01
    rec2 = make_recording(msd, {"time": t2, "F": np.sin(t2), "x": 0 * t2})
    v2 = {f"p:{k}": v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    assert choose_integrator(msd, rec2, v2).integrator == "rk4"


def test_integrator_in_the_model_file_is_checked():
    with pytest.raises(Exception, match="INTEGRATOR must be one of"):
        load_model_source(
            'STATES = {"y": "other"}\nOUTPUTS = ["y"]\nPARAMS = {}\nINTEGRATOR = "euler"\n'
            'def rhs(t, x, u, p):\n    return {"y": 0.0}\n'
        )
    m = load_model_source(
        'STATES = {"y": "other"}\nOUTPUTS = ["y"]\nPARAMS = {}\nINTEGRATOR = "ros2"\n'
        'def rhs(t, x, u, p):\n    return {"y": -1.0 * x["y"]}\n'
    )
    assert m.integrator == "ros2" and m.with_params().integrator == "ros2"
