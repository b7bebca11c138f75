"""The library of candidate physics for mismatch discovery: the registry.

Each :class:`Candidate` is one parameterised hypothesis about what a model leaves out:
an id (``coulomb_friction``, ``overflow``, ...), where it can attach (a velocity state, a
velocity paired with its position, an input, a level or pressure state, an output), its
parameters with bounds and initial guesses, the term itself written once for numpy and
torch (smooth ``tanh`` / softplus approximations so gradients flow), and a sentence
that explains the physics. An :class:`Effect` is a candidate attached to a target of a
particular model; :func:`attach_candidates` lists every effect a model admits.

The base classes are in :mod:`._candidate_base`; the effects by where they attach in
:mod:`._effects_motion` (velocity, velocity with its position), :mod:`._effects_input`,
:mod:`._effects_level` and :mod:`._effects_sensor`. This module gathers them
(:data:`CANDIDATES`, :data:`CANDIDATE_IDS`), tables them and attaches them to a model.

Parameters are expressed in the units of the quantity they act on: friction and
stiffness terms as accelerations (per unit mass: the term is added to ``dv/dt``),
overflow caps in the level's units, dead times and lags in seconds, sensor offsets in the
output's units.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models.mismatch._candidate_base import Candidate, Effect, ParamSpec, Scales
from pdmkit.models.mismatch._effects_constant import FileConstant, attach_constants
from pdmkit.models.mismatch._effects_input import (
    DeadTime,
    DeadZone,
    InputBacklash,
    InputLag,
    InputSaturation,
)
from pdmkit.models.mismatch._effects_level import (
    CrossSection,
    Leak,
    Overflow,
    StateSaturation,
)
from pdmkit.models.mismatch._effects_motion import (
    AsymmetricFriction,
    BiasForce,
    CoulombFriction,
    CubicStiffness,
    Hysteresis,
    QuadraticDrag,
    SpringBacklash,
    StribeckFriction,
    ViscousFriction,
)
from pdmkit.models.mismatch._effects_sensor import (
    SensorDrift,
    SensorGain,
    SensorLag,
    SensorOffset,
    SensorSaturation,
)
from pdmkit.models.ode import DERIVATIVE_ATTACH, register_effects

if TYPE_CHECKING:
    import pandas as pd

    from pdmkit.models.ode import OdeModel

__all__ = [
    "CANDIDATES",
    "CANDIDATE_IDS",
    "SPARSE_ID",
    "Candidate",
    "Effect",
    "ParamSpec",
    "Scales",
    "attach_candidates",
    "candidate_library",
]

_VEL = ("velocity", "angular_velocity")
_POS_OF = {"velocity": "position", "angular_velocity": "angle"}


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
    CrossSection(),
    SensorOffset(),
    SensorSaturation(),
    SensorDrift(),
    SensorGain(),
    SensorLag(),
    FileConstant(),
)

# the effects that act inside the integration, offered to compiled models
# (pdmkit.models.ode._compiled_effects); the others act on inputs or outputs
register_effects([type(c) for c in _ALL if c.attach in DERIVATIVE_ATTACH or c.n_extra])

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
    "parameter": "a constant of PARAMS not in FREE (its value re-estimated)",
}


def candidate_library() -> pd.DataFrame:
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
    (25, ['input', 'level'])
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


def attach_candidates(
    model: OdeModel,
    scales: Scales,
    ids: Sequence[str] | None = None,
    extra: Sequence[Candidate] = (),
    *,
    clipped: Sequence[str] = (),
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
    clipped : sequence of str, optional
        Outputs whose recording is clipped by the sensor (it repeats its extreme value
        exactly, :func:`pdmkit.models.mismatch._locate.clipped_outputs`): no overflow
        is attached to the measured state of such an output, since a level limit at the
        reading's ceiling and the sensor's clip give the same recording there, and the
        exact repetition (no sensor noise at the limit) says it is the sensor
        (``sensor_saturation`` stays).

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
        if c.id in keep:
            out.extend(_ATTACH[c.attach](c, model, scales, clipped))
    return out


def _attach_velocity(c, model, scales: Scales, clipped) -> list[Effect]:
    """One effect per velocity state, smoothed over 0.5 % of its scale."""
    return [
        Effect(
            c, s, None, {"eps": 0.005 * scales.x_scale(s), **_force_gain(model, s, scales)}
        )
        for s, k in model.states.items()
        if k in _VEL
    ]


def _attach_velocity_position(c, model, scales: Scales, clipped) -> list[Effect]:
    """One effect per velocity state with the position (or angle) it drives."""
    out = []
    for s, k in model.states.items():
        if k in _VEL:
            p = _position_partner(model, s, scales)
            if p is not None:  # the nominal spring on the pair: what play would sit in
                spring = {"spring": float(scales.stiffness.get((s, p), 0.0))}
                out.append(Effect(c, s, p, {**spring, **_force_gain(model, s, scales)}))
    return out


def _attach_input(c, model, scales: Scales, clipped) -> list[Effect]:
    """One effect per input."""
    return [
        Effect(
            c,
            s,
            None,
            {"w": 0.01 * scales.u_absmax(s), "one_sided": float(scales.one_sided(s))},
        )
        for s in model.inputs
    ]


def _attach_level(c, model, scales: Scales, clipped) -> list[Effect]:
    """One effect per level / pressure state of the candidate's kinds.

    Overflow also once routed into each other state of the same kind, and none on the
    state of a clipped output.
    """
    out = []
    read_by = {o: s for o, (s, _, _) in model.output_states().items()}
    clipped_states = {read_by[o] for o in clipped if o in read_by}
    for s, k in model.states.items():
        if k not in c.kinds or (c.id == "overflow" and s in clipped_states):
            continue
        span = max(scales.x_max[s] - scales.x_min[s], scales.x_scale(s))
        opts = {
            "w": 0.005 * span,
            "wf": 0.01 * scales.f_scale(s),
            "ref": 0.0 if k == "level" else scales.x_min[s],
            "mid": scales.q(s, 0.5),
            "lo": scales.x_min[s],
            "hi": scales.x_max[s],
        }
        out.append(Effect(c, s, None, opts))
        if c.id == "overflow":
            out.extend(
                Effect(c, s, r, opts)
                for r, kr in model.states.items()
                if r != s and kr == k
            )
    return out


def _attach_output(c, model, scales: Scales, clipped) -> list[Effect]:
    """One effect per output, sized by the output's range."""
    out = []
    for s in model.outputs:
        lo = scales.y_min[s] if s in scales.y_min else scales.x_min[s]
        hi = scales.y_max[s] if s in scales.y_max else scales.x_max[s]
        out.append(Effect(c, s, None, {"span": max(hi - lo, 1e-12)}))
    return out


#: attach kind -> the function attaching a candidate of that kind to a model
_ATTACH = {
    "velocity": _attach_velocity,
    "velocity_position": _attach_velocity_position,
    "input": _attach_input,
    "level": _attach_level,
    "output": _attach_output,
    "parameter": attach_constants,
}


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
