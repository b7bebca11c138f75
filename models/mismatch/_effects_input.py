"""Candidate effects on an input: dead time, dead zone, saturation, lag, backlash.

Each transforms the signal the model receives (``input_sequence``) or adds an
actuator state that replaces it (``input_lag``).
"""

from __future__ import annotations

import numpy as np

from pdmkit.models.mismatch._candidate_base import (
    Candidate,
    _frozen,
    _g,
    _lin,
    _log,
    _sp,
)

__all__ = ["DeadTime", "DeadZone", "InputBacklash", "InputLag", "InputSaturation"]


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
