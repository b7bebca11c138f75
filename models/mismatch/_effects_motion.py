"""Candidate effects on a velocity: friction, drag, bias force, stiffness, hysteresis.

Terms added to the derivative of a ``velocity`` / ``angular_velocity`` state, some
paired with its position (``velocity_position``). Parameters are accelerations (per
unit mass); :meth:`Candidate.explain` also says them in N (N m) where a force
(torque) input drives the velocity.
"""

from __future__ import annotations

import numpy as np

from pdmkit.models.mismatch._candidate_base import (
    Candidate,
    _eps,
    _frozen,
    _g,
    _lin,
    _log,
    _sclip,
    force_units,
)

__all__ = [
    "AsymmetricFriction",
    "BiasForce",
    "CoulombFriction",
    "CubicStiffness",
    "Hysteresis",
    "QuadraticDrag",
    "SpringBacklash",
    "StribeckFriction",
    "ViscousFriction",
]


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
        d2 = 2.0 * float(values["d"])
        text = self.physics.format(target=eff.target, d2=_g(d2))
        forced = force_units(eff, d2)
        if forced:  # per unit mass -> N per unit of speed (N s/m for a velocity in m/s)
            text += (
                f" In the units of the input {eff.options['force_input']}: 2 d ≈ "
                f"{_g(forced[0])} {forced[1]} per unit of {eff.target}."
            )
        return text


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

    #: the sentence on a plant without a spring on the pair (the term is then no play)
    physics_no_spring = (
        "A force along {partner} that grows over ±b = ±{b} of its zero and stays at "
        "±{level} per unit mass beyond (fitted as `backlash`: the model has no spring "
        "on {partner} for play to sit in, so the term is a position-dependent force, "
        "such as a cable or hose, a seal or a guide whose drag varies along the travel)."
    )

    def explain(self, eff, values):
        if eff.options.get("spring", 1.0) != 0.0:
            return super().explain(eff, values)
        level = float(values["kappa"]) * float(values["b"])
        text = self.physics_no_spring.format(
            partner=eff.partner, b=_g(values["b"]), level=_g(level)
        )
        forced = force_units(eff, level)
        if forced:
            text += (
                f" In the units of the input {eff.options['force_input']}: "
                f"±{_g(forced[0])} {forced[1]}."
            )
        return text

    def derivs(self, xp, eff, th, t, x, u, dx):
        b = th["b"]
        dx[eff.target] = dx[eff.target] + th["kappa"] * _sclip(
            xp, x[eff.partner], -b, b, 0.05 * b
        )
        return dx
