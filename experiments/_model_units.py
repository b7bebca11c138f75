"""The units of a model file's quantities, for axis labels and captions.

A model file declares each state's and output's physical kind (``STATES = {"pa":
"pressure"}``) and computes in SI units (docs/CONVENTIONS.md), so a kind names its
unit: a pressure is in Pa. A kind whose SI unit is open (a flow: volume or mass per
second?) or ``"other"`` has none, and plots say the numbers are the recording's own
(:func:`pdmkit._plot_signals.axis_label`).
"""

from __future__ import annotations

from typing import Any

__all__ = ["KIND_UNITS", "output_units"]

#: The SI unit of each physical kind a model file may declare (none for flow, other).
KIND_UNITS = {
    "position": "m",
    "velocity": "m/s",
    "angle": "rad",
    "angular_velocity": "rad/s",
    "level": "m",
    "pressure": "Pa",
    "temperature": "K",
    "force": "N",
    "torque": "N m",
    "voltage": "V",
    "current": "A",
}


def output_units(model: Any) -> dict[str, str | None]:
    """The unit of each output of a model file: the SI unit of its declared kind.

    Parameters
    ----------
    model : pdmkit.models.ode.OdeModel
        The model (its ``outputs`` and ``output_kinds``).

    Returns
    -------
    dict
        Output name -> unit, None where the kind does not fix one.

    Examples
    --------
    >>> from pdmkit.models.ode import showcase_model
    >>> output_units(showcase_model("pneumatic_piston"))
    {'x': 'm', 'pa': 'Pa', 'pb': 'Pa'}
    """
    kinds = getattr(model, "output_kinds", None) or {}
    return {o: KIND_UNITS.get(kinds.get(o, "other")) for o in model.outputs}
