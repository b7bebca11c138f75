"""A constant the model file holds fixed, re-estimated: the file's own value questioned.

Engineers write the physics they know and fix the constants they believe: a dead
volume, the supply pressure, a polytropic exponent, where a damper engages. When the
recordings say such a constant is wrong, no term *beside* the model explains it; the
model's own law must change. :class:`FileConstant` attaches to every nonzero
parameter of ``PARAMS`` that is not in ``FREE`` and fits it, so the verdict can point
at the term: "the dead volume V0A = 4.7e-06 fits at 3.1e-05 (6.6x)". Its sentence says
what such a change usually stands for (something the file leaves out that acts
through that constant: line volume beside a dead volume, a sagging supply, heat
exchange) and that the engineer must judge which.

The substitution happens in the integrator (:func:`pdmkit.models.ode.integrate_batch`
replaces the parameter by the effect's value in every row), so a re-estimated
constant works for every model file, batched or written per sample.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from pdmkit.models.mismatch._candidate_base import Candidate, Effect, _g, _lin, _log
from pdmkit.models.ode import PARAMETER_ATTACH

__all__ = ["FileConstant"]

#: how far from the file's value a constant may move (factor either way)
CONSTANT_RANGE = 20.0


class FileConstant(Candidate):
    """A fixed constant of the model file, re-estimated (``target`` names it).

    Examples
    --------
    >>> from pdmkit.models.mismatch._candidates import CANDIDATES, Effect
    >>> c = CANDIDATES["constant", "parameter"]
    >>> eff = Effect(c, "V0A", None, {"nominal": 4.7e-6})
    >>> c.neutral_values(eff)
    {'value': 4.7e-06}
    >>> c.explain(eff, {"value": 3.1e-5}).split(":")[0]
    'The file holds V0A fixed at 4.7e-06; the data fit 3.1e-05 (6.6x)'
    """

    id = "constant"
    attach = PARAMETER_ATTACH
    param_names = ("value",)
    start_neutral = True
    physics = (
        "The file holds {target} fixed at {nominal}; the data fit {value} ({ratio}x): "
        "the file's value is wrong, or something the file leaves out acts through it "
        "(for a volume, volume it does not count, such as lines; for a pressure, a "
        "supply that sags; for an exponent, heat exchange)."
    )

    def neutral_values(self, eff: Effect) -> Mapping[str, float]:
        return {"value": eff.opt("nominal")}

    def specs(self, eff, sc):
        v = eff.opt("nominal")
        if v > 0:
            return {"value": _log("value", v / CONSTANT_RANGE, v * CONSTANT_RANGE, v)}
        return {"value": _lin("value", v * CONSTANT_RANGE, v / CONSTANT_RANGE, abs(v))}

    def guesses(self, eff, sc):
        return [{"value": eff.opt("nominal")}]

    def explain(self, eff, values):
        v, nominal = values["value"], eff.opt("nominal")
        ratio = "?" if v is None or nominal == 0 else f"{v / nominal:.3g}"
        return self.physics.format(
            target=eff.target, nominal=_g(nominal), value=_g(v), ratio=ratio
        )


def attach_constants(c: Candidate, model, scales, clipped) -> list[Effect]:
    """One effect per nonzero, finite constant of ``PARAMS`` that is not in ``FREE``."""
    out = []
    for name, value in model.params.items():
        v = float(value)
        if name in model.free or v == 0.0 or not math.isfinite(v):
            continue
        out.append(Effect(c, name, None, {"nominal": v}))
    return out
