"""Candidate effects on an output: the sensor's offset, range, drift, gain and lag.

Each maps the simulated state to what the sensor reads (``output``).
"""

from __future__ import annotations

import math

from pdmkit.models.mismatch._candidate_base import (
    Candidate,
    _frozen,
    _lin,
    _log,
    _sclip,
)

__all__ = ["SensorDrift", "SensorGain", "SensorLag", "SensorOffset", "SensorSaturation"]


class SensorOffset(Candidate):
    id = "sensor_offset"
    attach = "output"
    param_names = ("offset",)
    neutral = _frozen({"offset": 0.0})
    physics = (
        "Sensor offset: the sensor of {target} reads {offset} too high (bias, zero error)."
    )

    def specs(self, eff, sc):
        s = sc.y_scale(eff.target)
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
        lo = sc.y_min.get(eff.target, -1.0)
        hi = sc.y_max.get(eff.target, 1.0)
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
        s = sc.y_scale(eff.target)
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
