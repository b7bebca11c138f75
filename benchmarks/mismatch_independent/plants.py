"""Six plants for the independent mismatch benchmark, written from docs/mismatch.md only.

Each plant knows three things: the model file a user would write for it (without any
concealed effect), its true equations with any one state effect added where it acts
physically (friction on a velocity, an overflow on a level, ...), and its excitation.
Input effects (dead time, dead zone, ...) and sensor effects (offset, lag, ...) are
the same for every plant and live in ``generate.py``.  SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class Signal:
    """One input record: its samples, and its value between them.

    Attributes
    ----------
    samples : numpy.ndarray
        Values at the sample times ``k * dt``.
    continuous : callable or None
        ``f(t)`` for a continuous signal (a multisine); ``None`` for a signal held
        between samples (steps, PRBS, a digital controller's output).
    """

    samples: np.ndarray
    continuous: object = None


def random_steps(rng, n, dt, low, high, hold_s, zero_share=0.0):
    """Levels drawn uniformly in [low, high], each held a random time in hold_s."""
    values = np.empty(n)
    k = 0
    while k < n:
        hold = max(1, round(rng.uniform(*hold_s) / dt))
        level = 0.0 if rng.random() < zero_share else rng.uniform(low, high)
        values[k : k + hold] = level
        k += hold
    return Signal(values)


def multisine(rng, n, dt, f_low, f_high, n_lines, rms):
    """Random-phase multisine with flat amplitude on log-spaced lines (continuous)."""
    freqs = np.geomspace(f_low, f_high, n_lines)
    phases = rng.uniform(0.0, 2.0 * np.pi, n_lines)
    amp = rms * math.sqrt(2.0 / n_lines)

    def value(t):
        return amp * float(np.sum(np.sin(2.0 * np.pi * freqs * t + phases)))

    samples = np.array([value(k * dt) for k in range(n)])
    return Signal(samples, value)


def dead_band(x, b):
    """Zero inside +-b, the excess outside (a gap that must close first)."""
    if x > b:
        return x - b
    if x < -b:
        return x + b
    return 0.0


class Plant:
    """Base class: the attributes every plant sets, and model-file rendering."""

    name = ""
    doc = ""
    dt = 0.01
    n_est = 3000
    n_val = 2000
    preroll_s = 1.0
    output = ""
    rhs_source = ""
    n_extra = 0  # extra true states of a state effect (hysteresis)

    def __init__(self, states, inputs, true_params, free, scales):
        self.states = states  # state name -> kind
        self.inputs = inputs  # input name -> kind
        self.true_params = true_params  # SI
        self.free = free  # re-estimated (the file's FREE)
        self.scales = scales  # state name -> typical magnitude (solver tolerances)

    def rest(self, p, u0):
        """Starting state of the pre-roll (a dict of the model's states)."""
        return dict.fromkeys(self.states, 0.0)

    def model_source(self, params, initial):
        """The model file a user writes: the plant without any concealed effect."""
        fmt = ", ".join(f'"{k}": {v!r}' for k, v in params.items())
        init = ", ".join(f'"{k}": {round(v, 6)!r}' for k, v in initial.items())
        states = ", ".join(f'"{k}": "{v}"' for k, v in self.states.items())
        inputs = ", ".join(f'"{k}": "{v}"' for k, v in self.inputs.items())
        return (
            f'"""{self.doc}"""\n\nimport numpy as np\n\n'
            f"STATES = {{{states}}}\nINPUTS = {{{inputs}}}\n"
            f'OUTPUTS = ["{self.output}"]\nPARAMS = {{{fmt}}}\n'
            f"FREE = {self.free!r}\nINITIAL = {{{init}}}\n\n\n{self.rhs_source}"
        )

    def extra_rest(self, effect):
        """Initial values of the extra true states (hysteretic displacement)."""
        return [0.0] * (self.n_extra if effect and effect.name == "hysteresis" else 0)


class MassSpringDamper(Plant):
    """A 1 kg cart on a spring, force-driven by a shaker (multisine)."""

    name = "msd"
    doc = "Cart on a linear spring and damper, driven by a shaker force F (N)."
    dt = 0.005
    n_est, n_val = 3000, 2000
    preroll_s = 10.0
    output = "x"
    rhs_source = (
        "def rhs(t, x, u, p):\n"
        '    spring = p["k"] * x["x"]\n'
        '    damper = p["c"] * x["v"]\n'
        '    return {"x": x["v"], "v": (u["F"] - spring - damper) / p["m"]}\n'
    )
    n_extra = 1

    def __init__(self):
        super().__init__(
            states={"x": "position", "v": "velocity"},
            inputs={"F": "force"},
            true_params={"m": 1.0, "k": 400.0, "c": 4.0},
            free=["k", "c"],
            scales={"x": 0.03, "v": 0.5},
        )

    def excite(self, rng, n):
        return {"F": multisine(rng, n, self.dt, 0.2, 6.0, 40, 10.0)}

    def deriv(self, x, u, p, eff, extra):
        pos, vel = x["x"], x["v"]
        spring = p["k"] * pos
        force = u["F"] - p["c"] * vel
        d_extra = []
        name = eff.name if eff else None
        s = eff.strength if eff else {}
        if name == "coulomb_friction":
            force -= s["Fc"] * math.tanh(vel / s["v_width"])
        elif name == "stribeck_friction":
            level = s["Fc"] + (s["Fs"] - s["Fc"]) * math.exp(-((vel / s["vs"]) ** 2))
            force -= level * math.tanh(vel / s["v_width"])
        elif name == "cubic_stiffness":
            force -= s["k3"] * pos**3
        elif name == "hysteresis":
            z = extra[0]
            force -= s["kh"] * z
            d_extra = [vel - s["beta"] * abs(vel) * z - s["gamma"] * vel * abs(z)]
        elif name == "backlash":
            spring = p["k"] * dead_band(pos, s["b"])
        return {"x": vel, "v": (force - spring) / p["m"]}, d_extra


class DcMotor(Plant):
    """A permanent-magnet DC motor with an unknown load inertia, voltage-driven."""

    name = "motor"
    doc = (
        "Permanent-magnet DC motor, speed w (rad/s) from armature voltage V (V); "
        "inductance neglected, load inertia J unknown."
    )
    dt = 0.005
    n_est, n_val = 3000, 2000
    preroll_s = 2.0
    output = "w"
    rhs_source = (
        "def rhs(t, x, u, p):\n"
        '    torque = p["K"] * (u["V"] - p["K"] * x["w"]) / p["R"]\n'
        '    return {"w": (torque - p["b"] * x["w"]) / p["J"]}\n'
    )

    def __init__(self):
        super().__init__(
            states={"w": "angular_velocity"},
            inputs={"V": "voltage"},
            true_params={"J": 2e-4, "R": 2.0, "K": 0.05, "b": 4e-4},
            free=["J"],
            scales={"w": 100.0},
        )

    def excite(self, rng, n):
        return {"V": random_steps(rng, n, self.dt, -12.0, 12.0, (0.15, 0.8))}

    def deriv(self, x, u, p, eff, extra):
        w = x["w"]
        torque = p["K"] * (u["V"] - p["K"] * w) / p["R"] - p["b"] * w
        name = eff.name if eff else None
        s = eff.strength if eff else {}
        if name == "viscous_friction":
            torque -= s["c"] * w
        elif name == "asymmetric_friction":
            torque -= s["d"] * abs(w)
        elif name == "coulomb_friction":
            torque -= s["Tc"] * math.tanh(w / s["w_width"])
        return {"w": torque / p["J"]}, []


class LiquidTank(Plant):
    """An open tank filled through a valve, draining through an orifice (Torricelli)."""

    name = "tank"
    doc = (
        "Open cylindrical tank, level h (m); inflow kin*s through an inlet valve whose "
        "stem travel s (m) is commanded, outflow ko*sqrt(h) through a bottom orifice."
    )
    dt = 2.0
    n_est, n_val = 2500, 1500
    preroll_s = 3000.0
    output = "h"
    rhs_source = (
        "def rhs(t, x, u, p):\n"
        '    outflow = p["ko"] * abs(x["h"]) ** 0.5\n'
        '    return {"h": (p["kin"] * u["s"] - outflow) / p["A"]}\n'
    )

    def __init__(self):
        super().__init__(
            states={"h": "level"},
            inputs={"s": "position"},
            true_params={"A": 0.02, "kin": 0.01, "ko": 9.5e-5},
            free=["ko"],
            scales={"h": 0.5},
        )

    def excite(self, rng, n):
        return {"s": random_steps(rng, n, self.dt, 0.002, 0.012, (150.0, 700.0))}

    def rest(self, p, u0):
        return {"h": (p["kin"] * u0["s"] / p["ko"]) ** 2}

    def deriv(self, x, u, p, eff, extra):
        h = x["h"]
        net = p["kin"] * u["s"] - p["ko"] * math.sqrt(max(h, 0.0))
        area = p["A"]
        name = eff.name if eff else None
        s = eff.strength if eff else {}
        if name == "overflow":
            # a weir at the rim: the excess leaves within a fraction of a sample
            net -= s["k_weir"] * max(h - s["rim"], 0.0)
        elif name == "cross_section" and "c_exp" in s:
            # pdmkit's documented form, for crosscheck.py only (no case uses it)
            area = p["A"] * math.exp(s["c_exp"] * (h - s["h_mid"]))
        elif name == "cross_section":
            # conical walls: the area grows linearly in radius with the level
            area = p["A"] * (1.0 + s["taper"] * (h - s["h_ref"])) ** 2
        rate = net / area
        if name == "saturation":
            rate = min(max(rate, -s["r"]), s["r"])
        return {"h": rate}, []


class ThermalPlate(Plant):
    """A heater cartridge in an aluminium plate; the plate's thermocouple is read."""

    name = "thermal"
    doc = (
        "Heater (Th) in a plate (Tp), temperatures in K; heater power V**2/Rh from the "
        "supply voltage V, conduction R1 heater->plate, R2 plate->ambient."
    )
    dt = 1.0
    n_est, n_val = 3000, 2000
    preroll_s = 3000.0
    output = "Tp"
    rhs_source = (
        "def rhs(t, x, u, p):\n"
        '    power = u["V"] ** 2 / p["Rh"]\n'
        '    to_plate = (x["Th"] - x["Tp"]) / p["R1"]\n'
        '    to_air = (x["Tp"] - p["Tamb"]) / p["R2"]\n'
        '    return {"Th": (power - to_plate) / p["Ch"], "Tp": (to_plate - to_air) / p["Cp"]}\n'  # noqa: E501
    )

    def __init__(self):
        super().__init__(
            states={"Th": "temperature", "Tp": "temperature"},
            inputs={"V": "voltage"},
            true_params={
                "Ch": 50.0,
                "Cp": 200.0,
                "R1": 0.5,
                "R2": 2.0,
                "Rh": 20.0,
                "Tamb": 293.15,
            },
            free=["Cp", "R2"],
            scales={"Th": 300.0, "Tp": 300.0},
        )

    def excite(self, rng, n):
        sig = random_steps(rng, n, self.dt, 0.0, 1.0, (40.0, 400.0))
        sig.samples = 12.0 * np.floor(sig.samples * 3.0)  # levels 0, 12, 24 V
        return {"V": sig}

    def rest(self, p, u0):
        power = u0["V"] ** 2 / p["Rh"]
        tp = p["Tamb"] + power * p["R2"]
        return {"Th": tp + power * p["R1"], "Tp": tp}

    def deriv(self, x, u, p, eff, extra):
        power = u["V"] ** 2 / p["Rh"]
        to_plate = (x["Th"] - x["Tp"]) / p["R1"]
        to_air = (x["Tp"] - p["Tamb"]) / p["R2"]
        return {"Th": (power - to_plate) / p["Ch"], "Tp": (to_plate - to_air) / p["Cp"]}, []


class AirVessel(Plant):
    """A compressed-air receiver filled through a proportional valve, vented by a bleed."""

    name = "vessel"
    doc = (
        "Air receiver, absolute pressure p (Pa), isothermal; mass inflow Kin*u from a "
        "proportional valve commanded with u (V), laminar bleed G*(p - patm)."
    )
    dt = 0.5
    n_est, n_val = 3000, 2000
    preroll_s = 600.0
    output = "p"
    rhs_source = (
        "def rhs(t, x, u, p):\n"
        '    bleed = p["G"] * (x["p"] - p["patm"])\n'
        '    return {"p": p["RT_V"] * (p["Kin"] * u["u"] - bleed)}\n'
    )

    def __init__(self):
        super().__init__(
            states={"p": "pressure"},
            inputs={"u": "voltage"},
            true_params={"RT_V": 1.68e6, "Kin": 2e-4, "G": 1e-8, "patm": 101325.0},
            free=["G"],
            scales={"p": 2e5},
        )

    def excite(self, rng, n):
        return {"u": random_steps(rng, n, self.dt, 0.0, 10.0, (20.0, 150.0), 0.25)}

    def rest(self, p, u0):
        return {"p": p["patm"] + p["Kin"] * u0["u"] / p["G"]}

    def deriv(self, x, u, p, eff, extra):
        gauge = x["p"] - p["patm"]
        outflow = p["G"] * gauge
        if eff and eff.name == "leak":
            outflow += eff.strength["kl"] * math.sqrt(max(gauge, 0.0))
        return {"p": p["RT_V"] * (p["Kin"] * u["u"] - outflow)}, []


class Pendulum(Plant):
    """A rigid pendulum on a motor shaft, torque-driven (multisine), large swings."""

    name = "pendulum"
    doc = (
        "Rigid pendulum, angle th (rad) from hanging, driven by a shaft torque tau "
        "(N m); point mass m at length l, viscous pivot damping c."
    )
    dt = 0.02
    n_est, n_val = 3000, 2000
    preroll_s = 30.0
    output = "th"
    rhs_source = (
        "def rhs(t, x, u, p):\n"
        '    gravity = p["m"] * p["g"] * p["l"] * np.sin(x["th"])\n'
        '    inertia = p["m"] * p["l"] ** 2\n'
        '    return {"th": x["w"], "w": (u["tau"] - gravity - p["c"] * x["w"]) / inertia}\n'
    )

    def __init__(self):
        super().__init__(
            states={"th": "angle", "w": "angular_velocity"},
            inputs={"tau": "torque"},
            true_params={"m": 0.5, "l": 0.3, "g": 9.81, "c": 0.05},
            free=["m", "c"],
            scales={"th": 1.0, "w": 5.0},
        )

    def excite(self, rng, n):
        return {"tau": multisine(rng, n, self.dt, 0.05, 2.0, 40, 0.35)}

    def deriv(self, x, u, p, eff, extra):
        th, w = x["th"], x["w"]
        torque = u["tau"] - p["m"] * p["g"] * p["l"] * math.sin(th) - p["c"] * w
        name = eff.name if eff else None
        s = eff.strength if eff else {}
        if name == "quadratic_drag":
            torque -= s["cd"] * abs(w) * w
        elif name == "bias_force":
            torque += s["T0"]
        elif name == "viscous_friction":
            torque -= s["c"] * w
        return {"th": w, "w": torque / (p["m"] * p["l"] ** 2)}, []


PLANTS = {
    cls.name: cls()
    for cls in (MassSpringDamper, DcMotor, LiquidTank, ThermalPlate, AirVessel, Pendulum)
}
