"""The library of candidate physics for mismatch discovery.

Each :class:`Candidate` is one parameterised hypothesis about what a model leaves out:
an id (``coulomb_friction``, ``overflow``, ...), where it can attach (a velocity state, a
velocity paired with its position, an input, a level or pressure state, an output), its
parameters with bounds and initial guesses, the term itself written once for numpy and
torch (smooth ``tanh`` / softplus approximations so gradients flow), and a sentence
that explains the physics. An :class:`Effect` is a candidate attached to a target of a
particular model; :func:`attach_candidates` lists every effect a model admits.

Parameters are expressed in the units of the quantity they act on: friction and
stiffness terms as accelerations (per unit mass: the term is added to ``dv/dt``),
overflow caps in the level's units, dead times and lags in seconds, sensor offsets in the
output's units.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Mapping, Sequence
from types import MappingProxyType as _frozen
from typing import Any

import numpy as np

from pdmkit.errors import ModelError

__all__ = ["CANDIDATE_IDS", "Candidate", "Effect", "attach_candidates", "candidate_library"]

_VEL = ("velocity", "angular_velocity")
_POS_OF = {"velocity": "position", "angular_velocity": "angle"}
_LEVEL = ("level", "pressure")


@dataclasses.dataclass(frozen=True)
class ParamSpec:
    """One parameter of a candidate: bounds, log-space flag, a typical magnitude.

    ``log`` fits the parameter in log space (it must then stay positive); ``scale`` is
    its typical size (finite-difference steps, and the step of a linear search space).

    Examples
    --------
    >>> from pdmkit.models.mismatch import ParamSpec
    >>> ParamSpec("k3", lower=-1e6, upper=1e6, log=False, scale=1e3).scale
    1000.0
    """

    name: str
    lower: float
    upper: float
    log: bool
    scale: float


# ---------------------------------------------------------------------------- context
@dataclasses.dataclass
class Scales:
    """Magnitudes of a nominal trajectory that candidates use for guesses and widths.

    Built by :func:`pdmkit.models.mismatch.nominal_scales` from the fitted
    nominal model; every dict is keyed by state / input / output name.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch import fit_model, nominal_scales
    >>> from pdmkit.models.ode import showcase_model
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(200) * 0.02
    >>> data = {"time": t, "F": 40 * np.sin(3 * t), "x": 0.1 * np.sin(3 * t)}
    >>> sc = nominal_scales(msd, data, fit_model(msd, data), 1)
    >>> round(sc.ts, 6), sorted(sc.x_std)
    (0.02, ['v', 'x'])
    """

    ts: float
    h: float
    duration: float
    x_min: dict[str, float]
    x_max: dict[str, float]
    x_std: dict[str, float]
    x_quantiles: dict[str, np.ndarray]  # at QUANTILES
    f_std: dict[str, float]
    f_absmax: dict[str, float]
    u_min: dict[str, float]
    u_max: dict[str, float]
    u_std: dict[str, float]
    stiffness: dict[tuple[str, str], float]  # -d f_v / d x_p (per unit mass)
    #: measured range of each output (a sensor's ceiling lies in the data, not in the
    #: nominal simulation)
    y_min: dict[str, float] = dataclasses.field(default_factory=dict)
    y_max: dict[str, float] = dataclasses.field(default_factory=dict)
    #: ``(velocity, input) -> d(dv/dt)/du`` for force / torque inputs: 1 / mass (or
    #: inertia) when the input is the force; turns per-unit-mass terms into N (N m)
    input_gain: dict[tuple[str, str], float] = dataclasses.field(default_factory=dict)

    QUANTILES = (0.5, 0.7, 0.8, 0.9, 0.95, 0.99)

    def q(self, state: str, level: float) -> float:
        i = self.QUANTILES.index(level)
        return float(self.x_quantiles[state][i])

    def u_absmax(self, name: str) -> float:
        return max(abs(self.u_min[name]), abs(self.u_max[name]), 1e-12)

    def one_sided(self, name: str) -> bool:
        return self.u_min[name] >= 0.0

    def x_scale(self, state: str) -> float:
        return max(self.x_std[state], 1e-3 * max(abs(self.x_max[state]), 1e-12), 1e-12)

    def f_scale(self, state: str) -> float:
        return max(self.f_std[state], 1e-3 * self.f_absmax[state], 1e-12)


# ---------------------------------------------------------------------------- base
class Candidate(abc.ABC):
    """A candidate physical effect: the hypothesis, its parameters and its term.

    Subclasses set the class attributes and override the hooks they need:
    ``derivs`` (state-derivative terms), ``input_sequence`` (a transform of a sampled
    input), ``extra_*`` (an added state such as a lag), ``output`` (sensor models).

    Attributes
    ----------
    id : str
        Effect id (the name used in reports and JSON).
    attach : str
        ``"velocity"``, ``"velocity_position"``, ``"input"``, ``"level"`` or ``"output"``.
    param_names : tuple of str
    physics : str
        A sentence template (``{target}``, ``{partner}`` and the parameter names).

    Examples
    --------
    >>> from pdmkit.models.mismatch._candidates import candidate_library
    >>> lib = candidate_library()
    >>> lib.loc[lib["id"] == "coulomb_friction", "attach"].tolist()
    ['velocity']
    """

    id: str = ""
    attach: str = ""
    param_names: tuple[str, ...] = ()
    physics: str = ""
    #: parameter values for which the term has no effect (rows of a batch without it)
    neutral: Mapping[str, float] = _frozen({})
    n_extra: int = 0
    input_override: bool = False
    #: also fit from the neutral values (the nominal model itself): for a term linear
    #: in its strength the first Gauss-Newton step there is the least-squares strength,
    #: a start no guess of the magnitude can beat
    start_neutral: bool = False
    #: effects that real machines show together with this one (Coulomb friction and a
    #: bias force; an overflowing tank and a saturating level sensor): tried as a pair
    #: even when one of them alone does not help (each hides the other)
    companions: tuple[str, ...] = ()
    #: the simpler effect this one contains (a parameter at zero, or a limit): the
    #: simpler one is preferred unless this one does clearly better
    nests: str | None = None

    # hooks -------------------------------------------------------------------
    @abc.abstractmethod
    def specs(self, eff: Effect, sc: Scales) -> dict[str, ParamSpec]:
        """The effect's parameters: bounds, scales and neutral values."""

    @abc.abstractmethod
    def guesses(self, eff: Effect, sc: Scales) -> list[dict[str, float]]:
        """Starting points of the fit."""

    def prepare(self, xp, eff, th, h):
        """Values that stay constant during a simulation (computed once per run)."""
        return th

    def derivs(self, xp, eff, th, t, x, u, dx):
        return dx

    def input_sequence(self, xp, eff, th, useq, ts):
        return useq

    def extra_init(self, xp, eff, th, x0, u0):
        return []

    def extra_derivs(self, xp, eff, th, x, u, z):
        return []

    def derivs_with_extra(self, xp, eff, th, t, x, u, dx, z):
        """A state-derivative term that reads the effect's added states ``z``."""
        return dx

    def override(self, xp, eff, th, z):
        return z[0]

    def resolved(self, eff: Effect, values: Mapping[str, float], h: float) -> bool:
        """Whether the fitted values can be told from the simpler effect this one nests.

        Told apart by the simulation with step ``h``; the values are keyed by qualified
        names.
        """
        return True

    def output(self, xp, eff, th, t, y, z):
        return y

    #: parameters that are accelerations (forces per unit mass) on a velocity state
    per_unit_mass: tuple[str, ...] = ()

    def explain(self, eff: Effect, values: Mapping[str, float]) -> str:
        fmt = {k: _g(v) for k, v in values.items()}
        text = self.physics.format(target=eff.target, partner=eff.partner, **fmt)
        forces = self.in_input_units(eff, values)
        if forces:
            unit = forces.pop("unit")
            said = ", ".join(f"{k} ≈ {_g(v)} {unit}" for k, v in forces.items())
            text += f" In the units of the input {eff.options['force_input']}: {said}."
        return text

    def in_input_units(self, eff: Effect, values: Mapping[str, float]) -> dict:
        """Per-unit-mass parameters as forces (N) or torques (N m).

        When a force or torque input drives the velocity; ``{}`` otherwise.
        """
        gain = eff.options.get("force_gain")
        if not self.per_unit_mass or not gain:
            return {}
        out: dict = {p: float(values[p]) / gain for p in self.per_unit_mass}
        out["unit"] = eff.options.get("force_unit", "")
        return out

    def __repr__(self) -> str:
        return f"<Candidate {self.id} on {self.attach}>"


def _g(v: float) -> str:
    return f"{v:.3g}"


@dataclasses.dataclass(frozen=True)
class Effect:
    """A candidate attached to one target of a model.

    Parameters
    ----------
    candidate : Candidate
    target : str
        The state whose derivative receives the term, the input, or the output.
    partner : str, optional
        The position paired with a velocity (cubic stiffness, backlash), or the state
        that receives an overflow.
    options : dict, optional
        Fixed settings chosen from the data (smoothing widths, one-sided inputs).

    Examples
    --------
    >>> from pdmkit.models.mismatch._candidates import CANDIDATES, Effect
    >>> Effect(CANDIDATES["coulomb_friction", "velocity"], "v").key
    'coulomb_friction@v'
    """

    candidate: Candidate
    target: str
    partner: str | None = None
    options: Mapping[str, float] = dataclasses.field(default_factory=dict)

    @property
    def id(self) -> str:
        return self.candidate.id

    @property
    def key(self) -> str:
        k = f"{self.candidate.id}@{self.target}"
        if self.partner and self.candidate.id == "overflow":
            k += f"->{self.partner}"
        return k

    @property
    def param_names(self) -> tuple[str, ...]:
        names = self.candidate.param_names
        if self.candidate.id == "overflow" and self.partner is None:
            names = names[:1]
        return names

    def qualified(self) -> list[str]:
        """Parameter names prefixed by the effect key (unique within a structure)."""
        return [f"{self.key}.{p}" for p in self.param_names]

    def opt(self, name: str) -> float:
        return float(self.options[name])

    def __hash__(self) -> int:
        sig = getattr(self.candidate, "signature", None)  # data-driven term sets
        return hash(
            (self.candidate.id, self.candidate.attach, self.target, self.partner, sig)
        )

    def __eq__(self, other) -> bool:
        return isinstance(other, Effect) and hash(self) == hash(other)

    def __repr__(self) -> str:
        return f"<Effect {self.key}>"


# ---------------------------------------------------------------------------- helpers
def _sp(xp, x, w):
    """Softplus of width ``w``: a smooth ``max(x, 0)``."""
    return xp.softplus(x, w)


def _sclip(xp, x, lo, hi, w):
    """Smooth clip of ``x`` to ``[lo, hi]`` with corner width ``w``."""
    return x - _sp(xp, x - hi, w) + _sp(xp, lo - x, w)


def _lin(name, lo, hi, scale):
    return ParamSpec(name, lo, hi, False, max(float(scale), 1e-12))


def _log(name, lo, hi, scale):
    return ParamSpec(name, lo, hi, True, max(float(scale), 1e-12))


def _eps(eff, a_max, h, xp):
    """Friction smoothing width, widened so that the slope a/eps stays below 2/h.

    A steeper ``tanh`` than the RK4 step can follow would make the simulation chatter.
    """
    e0 = eff.opt("eps")
    return xp.sqrt(e0 * e0 + (0.5 * a_max * h) ** 2)


# ---------------------------------------------------------------------------- velocity
class CoulombFriction(Candidate):
    companions = ("bias_force", "asymmetric_friction")
    start_neutral = True
    per_unit_mass = ("a",)
    id = "coulomb_friction"
    attach = "velocity"
    param_names = ("a",)
    neutral = _frozen({"a": 0.0})
    physics = (
        "Coulomb (dry) friction: a constant force opposes the motion whatever its speed "
        "(a = {a} per unit mass, in {target}/s), so the system sticks and stops short "
        "near {target} = 0 where the nominal model keeps moving."
    )

    def specs(self, eff, sc):
        a = sc.f_scale(eff.target)
        return {"a": _lin("a", 0.0, 50 * sc.f_absmax[eff.target] + a, a)}

    def guesses(self, eff, sc):
        return [{"a": k * sc.f_scale(eff.target)} for k in (0.2, 0.8)]

    def prepare(self, xp, eff, th, h):
        return {**th, "_eps": _eps(eff, th["a"], h, xp)}

    def derivs(self, xp, eff, th, t, x, u, dx):
        v = x[eff.target]
        dx[eff.target] = dx[eff.target] - th["a"] * xp.tanh(v / th["_eps"])
        return dx


class StribeckFriction(Candidate):
    nests = "coulomb_friction"
    per_unit_mass = ("a_c", "a_s")
    id = "stribeck_friction"
    attach = "velocity"
    param_names = ("a_c", "a_s", "v_s")
    neutral = _frozen({"a_c": 0.0, "a_s": 0.0, "v_s": 1.0})
    physics = (
        "Stribeck friction: breakaway friction (a_c + a_s = {a_c} + {a_s} per unit mass) "
        "drops to the Coulomb level a_c as the speed {target} exceeds about v_s = {v_s}, "
        "so the motion sticks, then jumps."
    )

    def specs(self, eff, sc):
        a = sc.f_scale(eff.target)
        top = 50 * sc.f_absmax[eff.target] + a
        v = sc.x_scale(eff.target)
        return {
            "a_c": _lin("a_c", 0.0, top, a),
            "a_s": _lin("a_s", 0.0, top, a),
            "v_s": _log("v_s", 1e-3 * v, 10 * v, v),
        }

    def guesses(self, eff, sc):
        a = sc.f_scale(eff.target)
        v = sc.x_scale(eff.target)
        return [
            {"a_c": 0.15 * a, "a_s": 0.15 * a, "v_s": 0.2 * v},
            {"a_c": 0.6 * a, "a_s": 0.6 * a, "v_s": 0.5 * v},
        ]

    def prepare(self, xp, eff, th, h):
        return {**th, "_eps": _eps(eff, th["a_c"] + th["a_s"], h, xp)}

    def resolved(self, eff, values, h):
        # a Stribeck speed within a few widths of the smoothed Coulomb transition is
        # that transition made sharper, not a breakaway the data show
        k = eff.key
        a = float(values[f"{k}.a_c"]) + float(values[f"{k}.a_s"])
        return float(values[f"{k}.v_s"]) > 3.0 * float(_eps(eff, a, h, np))

    def derivs(self, xp, eff, th, t, x, u, dx):
        v = x[eff.target]
        mag = th["a_c"] + th["a_s"] * xp.exp(-((v / th["v_s"]) ** 2))
        dx[eff.target] = dx[eff.target] - mag * xp.tanh(v / th["_eps"])
        return dx


class BiasForce(Candidate):
    companions = ("coulomb_friction",)
    start_neutral = True
    id = "bias_force"
    attach = "velocity"
    param_names = ("b",)
    per_unit_mass = ("b",)
    neutral = _frozen({"b": 0.0})
    physics = (
        "Bias force: a constant force acts on {target} whatever the motion (b = {b} per "
        "unit mass, in {target}/s): gravity on an inclined axis, an actuator's offset, a "
        "constant load or a cable's pull."
    )

    def specs(self, eff, sc):
        a = sc.f_scale(eff.target)
        top = 50 * sc.f_absmax[eff.target] + a
        return {"b": _lin("b", -top, top, a)}

    def guesses(self, eff, sc):
        a = sc.f_scale(eff.target)
        return [{"b": 0.1 * a}, {"b": -0.1 * a}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        dx[eff.target] = dx[eff.target] + th["b"]
        return dx


class ViscousFriction(Candidate):
    start_neutral = True
    id = "viscous_friction"
    attach = "velocity"
    param_names = ("b",)
    neutral = _frozen({"b": 0.0})
    physics = (
        "Viscous friction: an extra damping force proportional to the speed "
        "(b = {b} 1/s per unit mass) that the nominal model leaves out."
    )

    def specs(self, eff, sc):
        b = sc.f_scale(eff.target) / sc.x_scale(eff.target)
        return {"b": _lin("b", 0.0, 100 * b, b)}

    def guesses(self, eff, sc):
        return [{"b": 0.1 * sc.f_scale(eff.target) / sc.x_scale(eff.target)}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        dx[eff.target] = dx[eff.target] - th["b"] * x[eff.target]
        return dx


class AsymmetricFriction(Candidate):
    start_neutral = True
    companions = ("coulomb_friction",)
    id = "asymmetric_friction"
    attach = "velocity"
    param_names = ("d",)
    neutral = _frozen({"d": 0.0})
    physics = (
        "Direction-dependent viscous friction: the damping differs with the direction of "
        "motion, by 2 d = {d2} per unit mass between {target} > 0 and {target} < 0 (a "
        "force d |{target}| that always pushes one way: a seal, a cable or a guide that "
        "drags more in one direction)."
    )

    def specs(self, eff, sc):
        b = sc.f_scale(eff.target) / sc.x_scale(eff.target)
        return {"d": _lin("d", -50 * b, 50 * b, b)}

    def guesses(self, eff, sc):
        return [{"d": 0.0}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        dx[eff.target] = dx[eff.target] - th["d"] * xp.abs(x[eff.target])
        return dx

    def explain(self, eff, values):
        return self.physics.format(target=eff.target, d2=_g(2.0 * float(values["d"])))


class QuadraticDrag(Candidate):
    start_neutral = True
    id = "quadratic_drag"
    attach = "velocity"
    param_names = ("d",)
    neutral = _frozen({"d": 0.0})
    physics = (
        "Quadratic (aerodynamic or hydraulic) drag: a resisting force growing with the "
        "square of the speed {target} (d = {d} per unit mass), which matters only at high "
        "speed."
    )

    def specs(self, eff, sc):
        d = sc.f_scale(eff.target) / sc.x_scale(eff.target) ** 2
        return {"d": _lin("d", 0.0, 100 * d, d)}

    def guesses(self, eff, sc):
        return [{"d": 0.1 * sc.f_scale(eff.target) / sc.x_scale(eff.target) ** 2}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        v = x[eff.target]
        dx[eff.target] = dx[eff.target] - th["d"] * xp.abs(v) * v
        return dx


class CubicStiffness(Candidate):
    start_neutral = True
    id = "cubic_stiffness"
    attach = "velocity_position"
    param_names = ("k3",)
    neutral = _frozen({"k3": 0.0})
    physics = (
        "Cubic (Duffing) stiffness: the restoring force grows with the cube of the "
        "displacement {partner} (k3 = {k3} per unit mass; > 0 hardens, < 0 softens), so "
        "the resonance shifts with amplitude."
    )

    def specs(self, eff, sc):
        k = sc.f_scale(eff.target) / sc.x_scale(eff.partner) ** 3
        return {"k3": _lin("k3", -1e3 * k, 1e3 * k, k)}

    def guesses(self, eff, sc):
        return [{"k3": 0.1 * sc.f_scale(eff.target) / sc.x_scale(eff.partner) ** 3}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        dx[eff.target] = dx[eff.target] - th["k3"] * x[eff.partner] ** 3
        return dx


class Hysteresis(Candidate):
    nests = "coulomb_friction"  # Bouc-Wen, small yield: Dahl friction -> Coulomb
    id = "hysteresis"
    attach = "velocity_position"
    param_names = ("k_h", "beta", "gamma")
    neutral = _frozen({"k_h": 0.0, "beta": 0.0, "gamma": 0.0})
    n_extra = 1
    physics = (
        "Hysteresis (Bouc-Wen): part of the restoring force depends on the path of "
        "{partner}, not only on its value. A hysteretic displacement z follows "
        "{partner} for small motions and saturates for large ones (dz/dt = v - beta |v| "
        "z - gamma v |z|, beta = {beta}, gamma = {gamma} per unit of {partner}); the "
        "spring k_h = {k_h} per unit mass acts through z instead of {partner} "
        "(friction in joints, rubber mounts, magnetic materials)."
    )

    # The term is -k_h (z - x): zero while z follows x, so the nominal fit's stiffness
    # (the small-motion one) stays right and the fit starts from the nominal model.

    def _stiffness(self, eff, sc):
        k = abs(sc.stiffness.get((eff.target, eff.partner), 0.0))
        return k or sc.f_scale(eff.target) / sc.x_scale(eff.partner)

    def specs(self, eff, sc):
        k = self._stiffness(eff, sc)
        inv = 1.0 / sc.x_scale(eff.partner)
        return {
            "k_h": _lin("k_h", -2 * k, 2 * k, 0.1 * k),
            "beta": _lin("beta", -100 * inv, 1000 * inv, inv),
            "gamma": _lin("gamma", -1000 * inv, 1000 * inv, inv),
        }

    def guesses(self, eff, sc):
        k = self._stiffness(eff, sc)
        inv = 1.0 / sc.x_scale(eff.partner)
        # loops from as wide as the swing to a tenth of it, softening on loading or on
        # unloading (gamma of either sign)
        return [
            {"k_h": f * k, "beta": b * inv, "gamma": g * inv}
            for f, b, g in (
                (0.3, 1.0, 0.0),
                (0.3, 1.0, -1.5),
                (0.6, 0.5, -0.7),
                (0.3, 3.0, 1.0),
            )
        ]

    def extra_init(self, xp, eff, th, x0, u0):
        return [x0[eff.partner] * 1.0]

    def extra_derivs(self, xp, eff, th, x, u, z):
        v = x[eff.target]
        zz = z[0]
        return [v - th["beta"] * xp.abs(v) * zz - th["gamma"] * v * xp.abs(zz)]

    def derivs_with_extra(self, xp, eff, th, t, x, u, dx, z):
        dx[eff.target] = dx[eff.target] - th["k_h"] * (z[0] - x[eff.partner])
        return dx


class SpringBacklash(Candidate):
    id = "backlash"
    attach = "velocity_position"
    param_names = ("kappa", "b")
    neutral = _frozen({"kappa": 0.0, "b": 1.0})
    physics = (
        "Backlash (play) in the coupling: within ±b = ±{b} of its rest position "
        "{partner} moves freely and the restoring force (stiffness kappa = {kappa} per "
        "unit mass) acts only once the gap is closed."
    )

    def specs(self, eff, sc):
        k = max(abs(sc.stiffness.get((eff.target, eff.partner), 0.0)), 1e-12)
        if k <= 1e-12:
            k = sc.f_scale(eff.target) / sc.x_scale(eff.partner)
        xs = max(abs(sc.x_max[eff.partner]), abs(sc.x_min[eff.partner]), 1e-12)
        return {
            "kappa": _lin("kappa", 0.0, 20 * k, k),
            "b": _log("b", 1e-3 * xs, 2 * xs, 0.1 * xs),
        }

    def guesses(self, eff, sc):
        specs = self.specs(eff, sc)
        xs = max(abs(sc.x_max[eff.partner]), abs(sc.x_min[eff.partner]), 1e-12)
        k = specs["kappa"].scale
        return [{"kappa": k, "b": 0.1 * xs}, {"kappa": k, "b": 0.3 * xs}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        b = th["b"]
        dx[eff.target] = dx[eff.target] + th["kappa"] * _sclip(
            xp, x[eff.partner], -b, b, 0.05 * b
        )
        return dx


# ---------------------------------------------------------------------------- inputs
class DeadTime(Candidate):
    id = "dead_time"
    attach = "input"
    param_names = ("tau",)
    neutral = _frozen({"tau": 0.0})
    physics = (
        "Dead time: the input {target} acts only tau = {tau} s later (transport delay, "
        "communication or actuator latency)."
    )

    def specs(self, eff, sc):
        return {"tau": _lin("tau", 0.0, 0.25 * sc.duration, sc.ts)}

    def guesses(self, eff, sc):
        return [{"tau": k * sc.ts} for k in (1.5, 4.5, 12.5)]

    def input_sequence(self, xp, eff, th, useq, ts):
        # u(t - tau) with linear interpolation between samples (the average of the
        # delayed zero-order-hold signal over each sample interval).
        s = th["tau"] / ts  # (B,)
        n = xp.floor(s)
        frac = s - n
        k = np.arange(useq.shape[1])
        nn = xp.to_numpy(n).astype(np.int64)
        i0 = np.clip(k[None, :] - nn[:, None], 0, None)
        i1 = np.clip(i0 - 1, 0, None)
        u0 = xp.take(useq, i0)
        u1 = xp.take(useq, i1)
        return u0 + frac[:, None] * (u1 - u0)


class DeadZone(Candidate):
    id = "dead_zone"
    attach = "input"
    param_names = ("d",)
    neutral = _frozen({"d": 0.0})
    physics = (
        "Dead zone: the actuator does not respond while |{target}| < d = {d}, and "
        "beyond it responds only to the excess (valve overlap, stiction, pump "
        "threshold)."
    )

    def specs(self, eff, sc):
        a = sc.u_absmax(eff.target)
        return {"d": _lin("d", 0.0, 0.95 * a, 0.1 * a)}

    def guesses(self, eff, sc):
        a = sc.u_absmax(eff.target)
        return [{"d": 0.1 * a}, {"d": 0.3 * a}]

    def input_sequence(self, xp, eff, th, useq, ts):
        d = th["d"][:, None]
        w = eff.opt("w")
        out = _sp(xp, useq - d, w)
        if not eff.opt("one_sided"):
            out = out - _sp(xp, -useq - d, w)
        return out


class InputSaturation(Candidate):
    id = "saturation"
    attach = "input"
    param_names = ("s",)
    neutral = _frozen({"s": 1.0})
    physics = (
        "Saturation: the actuator driven by {target} cannot deliver more than "
        "|{target}| = s = {s}; larger commands are clipped."
    )

    def specs(self, eff, sc):
        a = sc.u_absmax(eff.target)
        return {"s": _lin("s", 0.05 * a, 2.0 * a, 0.1 * a)}

    def guesses(self, eff, sc):
        a = sc.u_absmax(eff.target)
        return [{"s": 0.8 * a}, {"s": 0.5 * a}]

    def input_sequence(self, xp, eff, th, useq, ts):
        s = th["s"][:, None]
        w = eff.opt("w")
        out = useq - _sp(xp, useq - s, w)
        if not eff.opt("one_sided"):
            out = out + _sp(xp, -useq - s, w)
        return out


class InputLag(Candidate):
    id = "input_lag"
    attach = "input"
    param_names = ("tau",)
    neutral = _frozen({"tau": 1.0})
    physics = (
        "Actuator lag: {target} reaches the process through a first-order lag with "
        "time constant tau = {tau} s (a valve, motor or pump that cannot follow steps)."
    )
    n_extra = 1
    input_override = True

    def specs(self, eff, sc):
        return {"tau": _log("tau", 0.5 * sc.h, 0.25 * sc.duration, sc.ts)}

    def guesses(self, eff, sc):
        return [{"tau": max(1.0 * sc.ts, sc.h)}, {"tau": 5.0 * sc.ts}]

    def extra_init(self, xp, eff, th, x0, u0):
        return [u0[eff.target]]

    def extra_derivs(self, xp, eff, th, x, u, z):
        return [(u[eff.target] - z[0]) / th["tau"]]


class InputBacklash(Candidate):
    id = "backlash"
    attach = "input"
    param_names = ("b",)
    neutral = _frozen({"b": 0.0})
    physics = (
        "Backlash (play) between the command {target} and the actuator: after a "
        "reversal the command must travel 2b = {b2} before the actuator follows."
    )

    def specs(self, eff, sc):
        r = max(sc.u_max[eff.target] - sc.u_min[eff.target], 1e-12)
        return {"b": _lin("b", 0.0, 0.5 * r, 0.05 * r)}

    def guesses(self, eff, sc):
        r = max(sc.u_max[eff.target] - sc.u_min[eff.target], 1e-12)
        return [{"b": 0.05 * r}, {"b": 0.15 * r}]

    def input_sequence(self, xp, eff, th, useq, ts):
        b = th["b"]
        z = useq[:, 0]
        out = [z]
        for k in range(1, useq.shape[1]):
            uk = useq[:, k]
            z = xp.minimum(xp.maximum(z, uk - b), uk + b)
            out.append(z)
        return xp.stack(out, 1)

    def explain(self, eff, values):
        return self.physics.format(target=eff.target, b2=_g(2 * values["b"]))


# ---------------------------------------------------------------------------- level
class Overflow(Candidate):
    companions = ("sensor_saturation",)
    id = "overflow"
    attach = "level"
    param_names = ("cap", "into")
    neutral = _frozen({"cap": 1e30, "into": 0.0})
    physics = (
        "Overflow: {target} cannot rise above cap = {cap}; what still flows in then "
        "spills over{route}."
    )

    def specs(self, eff, sc):
        t = eff.target
        span = max(sc.x_max[t] - sc.x_min[t], sc.x_scale(t))
        out = {"cap": _lin("cap", sc.x_min[t], sc.x_max[t] + 2 * span, 0.1 * span)}
        if eff.partner is not None:
            ratio = sc.f_scale(eff.partner) / sc.f_scale(t)
            out["into"] = _lin("into", 0.0, 100 * ratio, ratio)
        return out

    def guesses(self, eff, sc):
        t = eff.target
        return [
            {"cap": sc.q(t, q), **({"into": 0.0} if eff.partner else {})}
            for q in (0.9, 0.7)
        ]

    def derivs(self, xp, eff, th, t, x, u, dx):
        s = eff.target
        f = dx[s]
        excess = xp.sigmoid((x[s] - th["cap"]) / eff.opt("w")) * _sp(xp, f, eff.opt("wf"))
        dx[s] = f - excess
        if eff.partner is not None:
            dx[eff.partner] = dx[eff.partner] + th["into"] * excess
        return dx

    def explain(self, eff, values):
        if eff.partner is None:
            route = " and is lost"
        else:
            route = (
                f", partly into {eff.partner} (into = {_g(values['into'])} per unit of "
                f"{eff.target} spilled)"
            )
        return self.physics.format(target=eff.target, cap=_g(values["cap"]), route=route)


class Leak(Candidate):
    id = "leak"
    attach = "level"
    param_names = ("k",)
    neutral = _frozen({"k": 0.0})
    physics = (
        "Leak: {target} loses content through an orifice to the outside, an outflow "
        "k·√({target} − {ref}) with k = {k} that the nominal model leaves out."
    )

    def specs(self, eff, sc):
        t = eff.target
        k = sc.f_scale(t) / math.sqrt(max(sc.x_max[t] - eff.opt("ref"), 1e-12))
        return {"k": _lin("k", 0.0, 100 * k, k)}

    def guesses(self, eff, sc):
        return [{"k": 0.1 * self.specs(eff, sc)["k"].scale}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        s = eff.target
        head = _sp(xp, x[s] - eff.opt("ref"), eff.opt("w"))
        dx[s] = dx[s] - th["k"] * xp.sqrt(head)
        return dx

    def explain(self, eff, values):
        return self.physics.format(
            target=eff.target, ref=_g(eff.opt("ref")), k=_g(values["k"])
        )


class StateSaturation(Candidate):
    id = "saturation"
    attach = "level"
    param_names = ("r",)
    neutral = _frozen({"r": 1e30})
    physics = (
        "Rate saturation: the flow that fills or empties {target} is limited "
        "(a pump, valve or pipe at capacity), so {target} cannot change faster than "
        "r = {r} per second."
    )

    def specs(self, eff, sc):
        m = sc.f_absmax[eff.target] + 1e-12
        return {"r": _log("r", 0.01 * m, 10 * m, m)}

    def guesses(self, eff, sc):
        m = sc.f_absmax[eff.target] + 1e-12
        return [{"r": 0.8 * m}, {"r": 0.4 * m}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        s = eff.target
        r = th["r"]
        dx[s] = r * xp.tanh(dx[s] / r)
        return dx


# ---------------------------------------------------------------------------- outputs
class SensorOffset(Candidate):
    id = "sensor_offset"
    attach = "output"
    param_names = ("offset",)
    neutral = _frozen({"offset": 0.0})
    physics = (
        "Sensor offset: the sensor of {target} reads {offset} too high (bias, zero error)."
    )

    def specs(self, eff, sc):
        s = sc.x_scale(eff.target)
        return {"offset": _lin("offset", -math.inf, math.inf, s)}

    def guesses(self, eff, sc):
        return [{"offset": 0.0}]

    def output(self, xp, eff, th, t, y, z):
        return y + th["offset"][:, None]


class SensorSaturation(Candidate):
    companions = ("overflow",)
    id = "sensor_saturation"
    attach = "output"
    param_names = ("high", "low")
    neutral = _frozen({"high": 1e30, "low": -1e30})
    physics = (
        "Sensor saturation: the sensor of {target} cannot read above high = {high} or "
        "below low = {low} (its range or its amplifier's rail), so the recording is "
        "clipped where the true value goes further."
    )

    def _range(self, eff, sc):
        lo = sc.y_min.get(eff.target, sc.x_min.get(eff.target, -1.0))
        hi = sc.y_max.get(eff.target, sc.x_max.get(eff.target, 1.0))
        return lo, hi, max(hi - lo, 1e-12)

    def specs(self, eff, sc):
        lo, hi, span = self._range(eff, sc)
        mid = 0.5 * (lo + hi)
        return {
            "high": _lin("high", mid, hi + 2 * span, 0.01 * span),
            "low": _lin("low", lo - 2 * span, mid, 0.01 * span),
        }

    def guesses(self, eff, sc):
        lo, hi, span = self._range(eff, sc)
        return [
            {"high": hi + 0.001 * span, "low": lo - 2 * span},
            {"high": hi + 2 * span, "low": lo - 0.001 * span},
        ]

    def output(self, xp, eff, th, t, y, z):
        w = 0.002 * eff.opt("span")  # corner width: a sharp clip, still smooth
        return _sclip(xp, y, th["low"][:, None], th["high"][:, None], w)


class SensorDrift(Candidate):
    nests = "sensor_offset"
    id = "sensor_drift"
    attach = "output"
    param_names = ("offset", "rate")
    neutral = _frozen({"offset": 0.0, "rate": 0.0})
    physics = (
        "Sensor drift: the reading of {target} wanders away from the truth at {rate} per "
        "second (starting from an offset of {offset}): temperature or ageing drift."
    )

    def specs(self, eff, sc):
        s = sc.x_scale(eff.target)
        return {
            "offset": _lin("offset", -math.inf, math.inf, s),
            "rate": _lin("rate", -math.inf, math.inf, s / sc.duration),
        }

    def guesses(self, eff, sc):
        return [{"offset": 0.0, "rate": 0.0}]

    def output(self, xp, eff, th, t, y, z):
        # t: time since the record start, (1, N) or per row (B, N) for pieces
        return y + th["offset"][:, None] + th["rate"][:, None] * t


class SensorGain(Candidate):
    id = "sensor_gain"
    attach = "output"
    param_names = ("gain",)
    neutral = _frozen({"gain": 1.0})
    physics = (
        "Sensor gain error: the sensor of {target} reads {gain} times the true value "
        "(wrong calibration or scale factor)."
    )

    def specs(self, eff, sc):
        return {"gain": _lin("gain", 0.05, 20.0, 0.1)}

    def guesses(self, eff, sc):
        return [{"gain": 1.0}]

    def output(self, xp, eff, th, t, y, z):
        return y * th["gain"][:, None]


class SensorLag(Candidate):
    id = "sensor_lag"
    attach = "output"
    param_names = ("tau",)
    neutral = _frozen({"tau": 1.0})
    physics = (
        "Sensor lag: the sensor of {target} follows the true value through a "
        "first-order lag with time constant tau = {tau} s (thermal mass, filtering, a "
        "long pressure line)."
    )
    n_extra = 1

    def specs(self, eff, sc):
        return {"tau": _log("tau", 0.5 * sc.h, 0.25 * sc.duration, sc.ts)}

    def guesses(self, eff, sc):
        return [{"tau": max(1.0 * sc.ts, sc.h)}, {"tau": 5.0 * sc.ts}]

    def extra_init(self, xp, eff, th, x0, u0):
        return [x0[eff.target]]

    def extra_derivs(self, xp, eff, th, x, u, z):
        return [(x[eff.target] - z[0]) / th["tau"]]

    def output(self, xp, eff, th, t, y, z):
        return z[0]


# ---------------------------------------------------------------------------- registry
_ALL: tuple[Candidate, ...] = (
    CoulombFriction(),
    StribeckFriction(),
    BiasForce(),
    ViscousFriction(),
    AsymmetricFriction(),
    QuadraticDrag(),
    CubicStiffness(),
    Hysteresis(),
    SpringBacklash(),
    DeadTime(),
    DeadZone(),
    InputSaturation(),
    InputLag(),
    InputBacklash(),
    Overflow(),
    Leak(),
    StateSaturation(),
    SensorOffset(),
    SensorSaturation(),
    SensorDrift(),
    SensorGain(),
    SensorLag(),
)

#: candidate by ``(id, attach)``
CANDIDATES: dict[tuple[str, str], Candidate] = {(c.id, c.attach): c for c in _ALL}

#: id of the data-driven fallback (``mismatch._sparse``), tried after the others
SPARSE_ID = "sparse"

#: the effect ids, in library order (``saturation`` and ``backlash`` attach in two
#: places), then the data-driven fallback ``sparse``
CANDIDATE_IDS: tuple[str, ...] = (*dict.fromkeys(c.id for c in _ALL), SPARSE_ID)

_ATTACH_TEXT = {
    "velocity": "velocity / angular-velocity state (term on its derivative)",
    "velocity_position": "velocity state paired with its position (term on dv/dt)",
    "input": "an input (transforms the signal the model receives)",
    "level": "level / pressure state (term on its derivative)",
    "output": "an output (sensor model)",
    "state": "any non-kinematic state (term on its derivative)",
}


def candidate_library():
    """The candidate effects as a table: id, where each attaches, parameters, physics.

    The last row is the data-driven fallback ``sparse``
    (:mod:`pdmkit.models.mismatch._sparse`), whose parameters are the coefficients of
    the terms it selects.

    Returns
    -------
    pandas.DataFrame
        Columns ``id``, ``attach``, ``where``, ``params``, ``physics``.

    Examples
    --------
    >>> from pdmkit.models.mismatch._candidates import candidate_library
    >>> lib = candidate_library()
    >>> len(lib), sorted(lib.loc[lib["id"] == "saturation", "attach"])
    (23, ['input', 'level'])
    >>> lib["id"].iloc[-1]
    'sparse'
    """
    import pandas as pd

    rows = [
        {
            "id": c.id,
            "attach": c.attach,
            "where": _ATTACH_TEXT[c.attach],
            "params": ", ".join(c.param_names),
            "physics": c.physics.split(":")[0],
        }
        for c in _ALL
    ]
    rows.append(
        {
            "id": SPARSE_ID,
            "attach": "state",
            "where": _ATTACH_TEXT["state"],
            "params": "c0, c1, ... (one per selected term)",
            "physics": "Data-driven term (sparse regression through the simulation)",
        }
    )
    return pd.DataFrame(rows)


def _position_partner(model, velocity: str, sc: Scales | None) -> str | None:
    """The position state whose derivative is (most sensitive to) ``velocity``."""
    want = _POS_OF[model.states[velocity]]
    positions = [s for s, k in model.states.items() if k == want]
    if not positions:
        return None
    if len(positions) == 1:
        return positions[0]
    # pick the position whose derivative responds to this velocity
    x = dict(model.initial)
    base = model.derivatives(x)
    x2 = dict(x)
    x2[velocity] = x[velocity] + 1.0
    d2 = model.derivatives(x2)
    sens = {p: abs(float(d2[p]) - float(base[p])) for p in positions}
    best = max(sens, key=sens.get)
    return best if sens[best] > 0 else None


_FORCE_UNITS = {"force": "N", "torque": "N m"}


def _force_gain(model, velocity: str, scales: Scales) -> dict:
    """``force_gain`` of the force or torque input that drives ``velocity`` most.

    The gain is d(dv/dt)/dF, 1/mass; returned with the input's name and unit, or ``{}`` when
    no such input drives it.
    """
    best = None
    for u, kind in model.inputs.items():
        gain = scales.input_gain.get((velocity, u), 0.0)
        if kind in _FORCE_UNITS and gain > 0 and (best is None or gain > best[0]):
            best = (gain, u, _FORCE_UNITS[kind])
    if best is None:
        return {}
    return {"force_gain": best[0], "force_input": best[1], "force_unit": best[2]}


def attach_candidates(  # noqa: C901
    model,
    scales: Scales,
    ids: Sequence[str] | None = None,
    extra: Sequence[Candidate] = (),
) -> list[Effect]:
    """Every effect of the library that ``model`` admits, attached to its targets.

    Velocity effects go to ``velocity`` / ``angular_velocity`` states; cubic stiffness
    and backlash to a velocity whose paired position (``position`` / ``angle`` state
    driven by it) exists; input effects to every input; overflow, leak and saturation to
    ``level`` / ``pressure`` states (overflow once lost, and once routed into each other
    state of the same kind); sensor effects to every output.

    Parameters
    ----------
    model : OdeModel
    scales : Scales
        Magnitudes of the nominal trajectory (widths of the smooth approximations).
    ids : sequence of str, optional
        Restrict the library to these effect ids.
    extra : sequence of Candidate, optional
        The user's own candidates (instances of :class:`Candidate` subclasses with an
        ``id`` of their own and one of the ``attach`` kinds above), attached the same
        way and always tried.

    Returns
    -------
    list of Effect

    Examples
    --------
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch._candidates import attach_candidates, _dummy_scales
    >>> msd = showcase_model("mass_spring_damper")
    >>> [e.key for e in attach_candidates(msd, _dummy_scales(msd))][:4]
    ['coulomb_friction@v', 'stribeck_friction@v', 'bias_force@v', 'viscous_friction@v']
    """
    if ids is not None:
        unknown = [i for i in ids if i not in CANDIDATE_IDS]
        if unknown:
            raise ModelError(
                f"attach_candidates: unknown effect ids {unknown}; known: "
                f"{', '.join(CANDIDATE_IDS)}."
            )
    keep = set(CANDIDATE_IDS if ids is None else ids)
    kinds = ("velocity", "velocity_position", "input", "level", "output")
    for c in extra:
        if not isinstance(c, Candidate) or c.id in CANDIDATE_IDS or c.attach not in kinds:
            raise ModelError(
                f"attach_candidates: {c!r} is not a usable candidate: pass an instance of "
                "a Candidate subclass with an id not in the library and attach one of "
                f"{', '.join(kinds)}."
            )
        keep.add(c.id)
    out: list[Effect] = []
    for c in (*_ALL, *extra):
        if c.id not in keep:
            continue
        if c.attach == "velocity":
            for s, k in model.states.items():
                if k in _VEL:
                    eps = 0.005 * scales.x_scale(s)
                    out.append(
                        Effect(c, s, None, {"eps": eps, **_force_gain(model, s, scales)})
                    )
        elif c.attach == "velocity_position":
            for s, k in model.states.items():
                if k in _VEL:
                    p = _position_partner(model, s, scales)
                    if p is not None:
                        out.append(Effect(c, s, p, {}))
        elif c.attach == "input":
            for s in model.inputs:
                a = scales.u_absmax(s)
                out.append(
                    Effect(
                        c, s, None, {"w": 0.01 * a, "one_sided": float(scales.one_sided(s))}
                    )
                )
        elif c.attach == "level":
            for s, k in model.states.items():
                if k not in _LEVEL:
                    continue
                span = max(scales.x_max[s] - scales.x_min[s], scales.x_scale(s))
                opts = {
                    "w": 0.005 * span,
                    "wf": 0.01 * scales.f_scale(s),
                    "ref": 0.0 if k == "level" else scales.x_min[s],
                }
                out.append(Effect(c, s, None, opts))
                if c.id == "overflow":
                    for r, kr in model.states.items():
                        if r != s and kr == k:
                            out.append(Effect(c, s, r, opts))
        elif c.attach == "output":
            for s in model.outputs:
                lo = scales.y_min.get(s, scales.x_min[s])
                hi = scales.y_max.get(s, scales.x_max[s])
                out.append(Effect(c, s, None, {"span": max(hi - lo, 1e-12)}))
    return out


def _dummy_scales(model) -> Scales:
    """Unit scales for a model (for examples and tests without a nominal fit)."""
    st = list(model.states)
    one = dict.fromkeys(st, 1.0)
    return Scales(
        ts=0.01,
        h=0.01,
        duration=10.0,
        x_min=dict.fromkeys(st, -1.0),
        x_max=one,
        x_std=one,
        x_quantiles={s: np.linspace(0, 1, len(Scales.QUANTILES)) for s in st},
        f_std=one,
        f_absmax=one,
        u_min=dict.fromkeys(model.inputs, -1.0),
        u_max=dict.fromkeys(model.inputs, 1.0),
        u_std=dict.fromkeys(model.inputs, 1.0),
        stiffness={},
    )


def _as_mapping(values: Any) -> dict[str, float]:
    return {str(k): float(v) for k, v in dict(values).items()}
