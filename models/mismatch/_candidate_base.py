"""The building blocks of candidate effects: parameters, scales, the base class.

:class:`ParamSpec` (one parameter's bounds and scale), :class:`Scales` (magnitudes of
the nominal trajectory that candidates read their guesses and widths from),
:class:`Candidate` (the base class of every hypothesis, with its hooks) and
:class:`Effect` (a candidate attached to one target of a model), with the smooth
helpers the terms share. The effects themselves live beside this module by where they
attach (:mod:`._effects_motion`, :mod:`._effects_input`, :mod:`._effects_level`,
:mod:`._effects_sensor`); :mod:`._candidates` holds the registry.
"""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Mapping
from types import MappingProxyType as _frozen

import numpy as np

__all__ = ["Candidate", "Effect", "ParamSpec", "Scales"]


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
    y_std: dict[str, float] = dataclasses.field(default_factory=dict)
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

    def y_scale(self, output: str) -> float:
        """An output's scale: its measured spread (a state's scale for older callers)."""
        if output in self.y_std:
            hi = max(abs(self.y_max[output]), abs(self.y_min[output]), 1e-12)
            return max(self.y_std[output], 1e-3 * hi, 1e-12)
        return self.x_scale(output)

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
    #: the state kinds a ``level`` candidate attaches to (a vessel's shape: levels only)
    kinds: tuple[str, ...] = ("level", "pressure")

    # hooks -------------------------------------------------------------------
    def neutral_values(self, eff: Effect) -> Mapping[str, float]:
        """The parameter values for which ``eff`` has no effect (default ``neutral``)."""
        return self.neutral

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

    def __repr__(self) -> str:
        return f"<Candidate {self.id} on {self.attach}>"

    def in_input_units(self, eff: Effect, values: Mapping[str, float]) -> dict:
        """Per-unit-mass parameters as forces (N) or torques (N m).

        When a force or torque input drives the velocity; ``{}`` otherwise.
        """
        if not self.per_unit_mass or force_units(eff, 1.0) is None:
            return {}
        out: dict = {
            p: None if values[p] is None else force_units(eff, values[p])[0]
            for p in self.per_unit_mass
        }
        out["unit"] = eff.options.get("force_unit", "")
        return out


def force_units(eff: Effect, per_unit_mass: float) -> tuple[float, str] | None:
    """A per-unit-mass value in the units of the force input driving ``eff``'s target.

    ``(value, unit)`` (N or N m; the gain is 1 / mass), None when no force or torque
    input drives it.
    """
    gain = eff.options.get("force_gain")
    if not gain:
        return None
    return float(per_unit_mass) / gain, eff.options.get("force_unit", "")


def _g(v: float | None) -> str:
    """A value for a sentence; None is a limit the fitted model never reaches."""
    return "(never reached)" if v is None else f"{v:.3g}"


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

    @property
    def neutral(self) -> Mapping[str, float]:
        """Parameter values for which this effect does nothing (rows without it)."""
        return self.candidate.neutral_values(self)

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
