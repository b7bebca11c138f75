"""Candidate effects on a level or pressure state: overflow, leak, rate saturation, shape.

Terms on the derivative of a ``level`` / ``pressure`` state; an overflow may route
what spills into another state of the same kind; a level-dependent cross-section
scales the whole derivative (the same flow moves the level by more where the vessel
is narrower).
"""

from __future__ import annotations

import math

from pdmkit.models.mismatch._candidate_base import (
    Candidate,
    _frozen,
    _g,
    _lin,
    _log,
    _sp,
)

__all__ = ["CrossSection", "Leak", "Overflow", "StateSaturation"]


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


class CrossSection(Candidate):
    """Level-dependent cross-section: ``d level/dt`` = net flow / A(level).

    A(h) = A(h_mid) · exp(c · (h − h_mid)), ``h_mid`` the median level of the nominal
    simulation (option ``mid``): the exponential keeps the area positive over any range
    the fit visits, and its first-order term is the linear taper ``1 + c (h − h_mid)``.
    """

    id = "cross_section"
    attach = "level"
    kinds = ("level",)  # a vessel's shape (a pressure's capacity is another story)
    param_names = ("c",)
    neutral = _frozen({"c": 0.0})
    physics = (
        "Level-dependent cross-section: the area of the vessel holding {target} changes "
        "with its level, by a factor exp(c·({target} − {mid})) with c = {c} per unit of "
        "{target} (area ×{top} at {hi}, ×{bottom} at {lo}, relative to {mid}): the same "
        "net flow moves the level faster where the vessel is narrower (tapered or "
        "conical walls, fittings inside the tank). A level sensor that is not linear in "
        "the stored volume reads the same."
    )

    def specs(self, eff, sc):
        span = max(sc.x_max[eff.target] - sc.x_min[eff.target], sc.x_scale(eff.target))
        return {"c": _lin("c", -3.0 / span, 3.0 / span, 0.1 / span)}

    def guesses(self, eff, sc):
        span = max(sc.x_max[eff.target] - sc.x_min[eff.target], sc.x_scale(eff.target))
        return [{"c": -0.5 / span}, {"c": 0.5 / span}]

    def derivs(self, xp, eff, th, t, x, u, dx):
        s = eff.target
        dx[s] = dx[s] * xp.exp(-th["c"] * (x[s] - eff.opt("mid")))
        return dx

    def explain(self, eff, values):
        c = float(values["c"])
        mid, lo, hi = eff.opt("mid"), eff.opt("lo"), eff.opt("hi")
        return self.physics.format(
            target=eff.target,
            c=_g(c),
            mid=_g(mid),
            lo=_g(lo),
            hi=_g(hi),
            top=_g(math.exp(c * (hi - mid))),
            bottom=_g(math.exp(c * (lo - mid))),
        )
