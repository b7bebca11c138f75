"""What a mismatch discovery says: the verdict, the candidate table, the result.

:class:`MismatchResult` holds the verdict (the effect named, its physics in one
sentence, its parameters, further effects, alternatives the data cannot tell apart,
warnings), the ranked candidate table, the located residual and the fit before and
after; the functions here turn the selected structures into those parts.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit._plot_signals import axis_label, plot_signal
from pdmkit.errors import ModelError
from pdmkit.models.mismatch._candidates import SPARSE_ID, Effect, _position_partner
from pdmkit.models.mismatch._fit_problem import _Job
from pdmkit.models.mismatch._locate import (
    region_statistics,
    residual_spectrum,
    residual_windows,
    whiteness_test,
)
from pdmkit.models.mismatch._sampling import simulate_states
from pdmkit.models.mismatch._select import _rmse, _Scored, _structured, p_value

__all__ = [
    "MismatchResult",
    "add_warnings",
    "build_verdict",
    "candidate_table",
    "headline",
]

_NONE_PHYSICS = (
    "No candidate effect improves the validation fit significantly beyond the noise: "
    "the model explains these data as well as they allow."
)
_PARTIAL_PHYSICS = (
    "A named effect explains part of the residual (best_partial), but a data-driven "
    "equation beats it clearly without leaving a noise-like residual either: the "
    "missing physics is not (only) a named effect. See lead_equation."
)
_UNEXPLAINED_PHYSICS = (
    "Something systematic is left in the residual, but no effect of the library (nor a "
    "sparse equation) explains it significantly: the missing physics is not a named "
    "effect. See best_partial and lead_equation for what comes closest."
)
_UNEXPLAINED_NO_SPARSE = (
    "Something systematic is left in the residual, but no effect of the library "
    "explains it significantly (no data-driven equation was tried: that stage did not "
    "run). See best_partial for what comes closest."
)
_UNEXPLAINED_NO_EQUATION = (
    "Something systematic is left in the residual, but no effect of the library "
    "explains it significantly, and the data-driven stage found no equation it could "
    "fit (no term set selected, or every one it selected diverged). See best_partial "
    "for what comes closest."
)


@dataclasses.dataclass
class MismatchResult:
    """What :func:`discover_mismatch` found.

    Attributes
    ----------
    verdict : dict
        ``effect`` (id or ``"none"``), ``target``, ``physics`` (one sentence),
        ``params``; ``also`` lists the further effects when more than one was
        accepted.
    candidates : pandas.DataFrame
        Every candidate (best variant per effect and target), best first: ``effect``,
        ``target``, ``variant``, ``rmse_validation``, ``improvement`` (relative to the
        nominal), ``criterion`` (BIC on the training part), ``p_value``,
        ``n_params``, ``refit`` (fully refitted, or only screened).
    located : list of dict
        Time windows of the nominal residual, ``{"start", "end", "share"}``.
    regions : pandas.DataFrame
        Residual energy over regions of the state / input space.
    fit : dict
        ``rmse_nominal``, ``rmse_augmented`` (validation part), and training RMSEs.
    whiteness : dict
        ``{"before": ..., "after": ...}`` per output (:func:`whiteness_test`).
    spectrum : pandas.DataFrame
        Spectrum of the nominal residual and its coherence with the inputs.
    signals : dict
        Arrays for plots: ``time``, ``measured``, ``nominal``, ``augmented`` (train
        recording), and the same with ``val_`` prefixes for a separate validation
        recording; ``split`` is the time where validation starts (or None).
    nominal_values, augmented_values : dict
        Fitted values (``"p:<param>"``, ``"x0:<state>"``, ``"<effect key>.<param>"``).
    augmented_effects : tuple of Effect
        The accepted effects (empty for the verdict ``none``); with
        ``augmented_values`` they re-simulate the augmented model
        (:func:`~pdmkit.models.ode.simulate_ode`).

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import example_result
    >>> res = example_result()
    >>> res.verdict["effect"], res.augmented_effects
    ('none', ())
    """

    verdict: dict
    candidates: Any
    located: list
    regions: Any
    fit: dict
    whiteness: dict
    spectrum: Any
    signals: dict
    outputs: list
    nominal_values: dict
    augmented_values: dict | None
    augmented_effects: tuple
    timings: dict

    def to_dict(self) -> dict:
        """The JSON summary (verdict, located, candidates, fit, plus diagnostics).

        Examples
        --------
        >>> from pdmkit.models.mismatch._cases import example_result
        >>> res = example_result()
        >>> sorted(res.to_dict())[:4]
        ['candidates', 'fit', 'located', 'regions']
        """
        cands = [
            {
                "effect": r["effect"],
                "target": r["target"],
                "variant": r["variant"],
                "rmse_validation": _f(r["rmse_validation"]),
                "improvement": _f(r["improvement"]),
                "criterion": _f(r["criterion"]),
                "p_value": _f(r["p_value"]),
            }
            for r in self.candidates.to_dict("records")
        ]
        return {
            "verdict": self.verdict,
            "located": self.located,
            "candidates": cands,
            "fit": self.fit,
            "regions": self.regions.head(8).to_dict("records") if len(self.regions) else [],
            "whiteness": self.whiteness,
            "timings": self.timings,
        }

    def to_pandas(self):
        """The ranked candidate table (a copy).

        Examples
        --------
        >>> from pdmkit.models.mismatch._cases import example_result
        >>> res = example_result()
        >>> list(res.to_pandas().columns)[:3]
        ['effect', 'target', 'variant']
        """
        return self.candidates.copy()

    def plot(self, ax=None, output: str | None = None, *, unit: str | None = None):
        """Measured vs nominal vs augmented (top) and the residuals (bottom).

        Located windows are shaded; the validation split is a dashed line. A long
        record is drawn decimated, each bin's min-max as a band
        (:func:`pdmkit._plot_signals.plot_signal`).

        Parameters
        ----------
        ax : array of two matplotlib Axes, optional
            Where to draw; a new figure when omitted.
        output : str, optional
            The output to show (default: the first).
        unit : str, optional
            Its unit, shown on the value axes (``"pa [Pa]"``; without one,
            ``"pa (as recorded)"``).

        Examples
        --------
        >>> from pdmkit.models.mismatch._cases import example_result
        >>> res = example_result()
        >>> ax = res.plot(unit="m")
        >>> ax.shape, ax[0].get_ylabel(), ax[1].get_xlabel()
        ((2,), 'h1 [m]', 'time [s]')
        """
        import matplotlib.pyplot as plt

        output = self.outputs[0] if output is None else output
        if output not in self.outputs:
            raise ModelError(f"plot: unknown output {output!r}; outputs: {self.outputs}.")
        j = self.outputs.index(output)
        s = self.signals
        if ax is None:
            _, ax = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
        ax = np.asarray(ax, dtype=object).ravel()
        t = s["time"]
        plot_signal(ax[0], t, s["measured"][:, j], color="k", lw=0.8, label="measured")
        plot_signal(ax[0], t, s["nominal"][:, j], color="C0", label="nominal model")
        if s.get("augmented") is not None:
            plot_signal(ax[0], t, s["augmented"][:, j], color="C3", label="augmented model")
        ax[0].set_ylabel(axis_label(output, unit))
        ax[0].legend(loc="best", fontsize="small")
        residual = s["measured"][:, j] - s["nominal"][:, j]
        plot_signal(ax[1], t, residual, color="C0", lw=0.8, label="residual, nominal")
        if s.get("augmented") is not None:
            residual = s["measured"][:, j] - s["augmented"][:, j]
            plot_signal(ax[1], t, residual, color="C3", lw=0.8, label="residual, augmented")
        ax[1].set_ylabel(axis_label(f"{output} residual", unit))
        ax[1].set_xlabel("time [s]")
        ax[1].legend(loc="best", fontsize="small")
        for w in self.located:
            for a in ax[:2]:
                a.axvspan(w["start"], w["end"], color="orange", alpha=0.15, lw=0)
        if s.get("split") is not None:
            for a in ax[:2]:
                a.axvline(s["split"], color="gray", ls="--", lw=0.8)
        return ax


def _f(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


#: terms of a sparse equation that are a named effect's signature
_SIGNATURES = {
    "sign": ("coulomb_friction", "Coulomb (dry) friction"),
    "const": ("bias_force", "a constant (bias) force"),
    "cube": ("cubic_stiffness", "cubic (Duffing) stiffness"),
    "abs*": ("quadratic_drag", "quadratic drag"),
}


def _signatures(labels: Sequence[str], target: str, partner: str | None) -> list[dict]:
    """Named effects whose signature the sparse terms hold.

    ``sign(v)`` -> Coulomb, ``1`` -> a bias force, ``x**3`` -> cubic stiffness,
    ``abs(v)*v`` -> drag.
    """
    found = []
    for lab in labels:
        if lab == f"sign({target})":
            key = "sign"
        elif lab == "1":
            key = "const"
        elif partner is not None and lab == f"{partner}**3":
            key = "cube"
        elif lab in (f"abs({target})*{target}", f"{target}*abs({target})"):
            key = "abs*"
        else:
            continue
        effect, words = _SIGNATURES[key]
        found.append({"term": lab, "effect": effect, "physics": words})
    return found


def _at_bounds(job: _Job) -> list[str]:
    """Fitted values that ended on a bound of their search range.

    Free model parameters always; effect parameters when the bound is not their neutral
    value.
    """
    lay = job.layout
    out = []
    neutral = {}
    for e in job.effects:
        for p in e.param_names:
            if p in e.neutral:
                neutral[f"{e.key}.{p}"] = float(e.neutral[p])
    vals = job.values()
    for i, name in enumerate(lay.names):
        if name.startswith("x0:"):
            continue
        th, lo, hi = job.theta[i], lay.lo[i], lay.hi[i]
        width = (hi - lo) if math.isfinite(hi - lo) else abs(th) + 1.0
        tol = 1e-6 * max(width, 1e-12)
        for bound in (lo, hi):
            if math.isfinite(bound) and abs(th - bound) <= tol:
                v = vals[name]
                if name in neutral:  # the side where the effect fades out is natural
                    other = hi if bound == lo else lo
                    real = math.exp(bound) if lay.log[i] else bound
                    far = math.exp(other) if lay.log[i] else other
                    if abs(real - neutral[name]) <= abs(far - neutral[name]):
                        continue
                side = "lower" if bound == lo else "upper"
                out.append(
                    f"{name[2:] if name.startswith('p:') else name} = {v:.4g} ended on the "
                    f"{side} bound of its search range; the model structure is probably "
                    "wrong there (a missing effect, wrong units, or a parameter that "
                    "should not be free)"
                )
    return out


def _partner_of(model, velocity: str) -> str | None:
    """The position a velocity state drives (for the x**3 signature), if any."""
    if model.states.get(velocity) not in ("velocity", "angular_velocity"):
        return None
    return _position_partner(model, velocity, None)


def _variant(e: Effect) -> str:
    if e.candidate.id == SPARSE_ID:
        return " + ".join(e.candidate.labels)
    if e.candidate.id == "overflow":
        return f"into {e.partner}" if e.partner else "lost"
    if e.partner:
        return f"with {e.partner}"
    return ""


def _reached(vals: Mapping[str, float], inactive: frozenset) -> dict:
    """``vals`` with the parameters the fitted model never reaches set to None."""
    return {k: (None if k in inactive else v) for k, v in vals.items()}


def _verdict_params(s: _Scored, inactive: frozenset = frozenset()) -> dict:
    vals = _reached(s.job.values(), inactive)
    e = s.effects[0]
    if e.candidate.id == SPARSE_ID:
        c = {p: vals[f"{e.key}.{p}"] for p in e.param_names}
        return {"equation": e.candidate.equation(e, c), **e.candidate.raw(c)}
    out = {}
    for e in s.effects:
        for p in e.param_names:
            out[p if len(s.effects) == 1 else f"{e.id}.{p}"] = vals[f"{e.key}.{p}"]
        if e.partner and e.candidate.id == "overflow":
            out["into_state"] = e.partner
    return out


def _explain(e: Effect, vals: Mapping[str, float], model=None, rec=None) -> str:
    """The effect's sentence.

    With the model and recording, forces in N use the input gain (1 / mass) of the fit that
    ``vals`` come from, not the nominal one.
    """
    if model is not None and rec is not None and "force_gain" in e.options:
        gain = _input_gain(model, e.target, e.options["force_input"], vals, rec)
        if gain > 0:
            e = dataclasses.replace(e, options={**e.options, "force_gain": gain})
    return e.candidate.explain(e, {p: vals[f"{e.key}.{p}"] for p in e.param_names})


def _input_gain(model, velocity: str, name: str, vals: Mapping[str, float], rec) -> float:
    """d(d velocity/dt)/d input at the fitted parameters (1 / mass for a force)."""
    P = {k: vals.get(f"p:{k}", v) for k, v in model.params.items()}
    x = {s: vals.get(f"x0:{s}", model.initial[s]) for s in model.states}
    u0 = {k: float(np.mean(v)) for k, v in rec.inputs.items()}
    du = 1e-6 * max(float(np.std(rec.inputs[name])), 1e-9)
    u1 = {**u0, name: u0[name] + du}
    with np.errstate(all="ignore"):
        d0 = float(np.asarray(model.derivatives(x, u0, P)[velocity]))
        d1 = float(np.asarray(model.derivatives(x, u1, P)[velocity]))
    g = (d1 - d0) / du
    return g if math.isfinite(g) else 0.0


# ---------------------------------------------------------------------------- assembly
def candidate_table(
    singles: list[_Scored], sparse_scored: list[_Scored], base: _Scored, top
):
    """Every candidate, the best variant per effect and target, best first.

    ``top``, the one chosen by the BIC tie-break, leads.
    """
    import pandas as pd

    by_target: dict[tuple[str, str], _Scored] = {}
    for s in [*singles, *sparse_scored]:
        e = s.effects[0]
        k = (e.id, e.target)
        if k not in by_target or s.rmse_val < by_target[k].rmse_val:
            by_target[k] = s
    rows = []
    for s in by_target.values():
        e = s.effects[0]
        checked = s.e_val is not None  # screened only, on a long record: not validated
        gain = 1.0 - s.rmse_val / base.rmse_val if base.rmse_val > 0 else 0.0
        rows.append(
            {
                "effect": e.id,
                "target": e.target,
                "variant": _variant(e),
                "rmse_validation": s.rmse_val if checked else math.nan,
                "improvement": gain if checked else math.nan,
                "criterion": s.bic - base.bic,
                "p_value": s.p_value if checked else math.nan,
                "n_params": s.job.n_fitted,
                "refit": s.refit,
                "_s": s,
            }
        )
    table = pd.DataFrame(rows)
    if not len(table):
        return table
    table = table.sort_values(["rmse_validation", "criterion"], ignore_index=True)
    if top is not None:
        first = table.index[table["_s"].map(lambda s: s is top)]
        if len(first):
            table = pd.concat([table.loc[first], table.drop(first)], ignore_index=True)
    return table.drop(columns="_s")


def _no_effect(model, rec, base, singles, sparse_scored, beaten, sparse_tried) -> dict:
    """``none``, or ``unexplained`` (with what comes closest).

    ``unexplained`` when something systematic is left that no candidate explains;
    its text says whether the data-driven stage ran (``sparse_tried``) and found none.
    """
    if not (_structured(base) or beaten is not None):
        return {"effect": "none", "target": None, "physics": _NONE_PHYSICS, "params": {}}
    lead = beaten or (min(singles, key=lambda s: s.rmse_val) if singles else None)
    verdict = {
        "effect": "unexplained",
        "target": None,
        "physics": _PARTIAL_PHYSICS
        if beaten is not None
        else (
            _UNEXPLAINED_PHYSICS
            if sparse_scored
            else (_UNEXPLAINED_NO_EQUATION if sparse_tried else _UNEXPLAINED_NO_SPARSE)
        ),
        "params": {},
    }
    if lead is not None:
        e = lead.effects[0]
        verdict["best_partial"] = {
            "effect": e.id,
            "target": e.target,
            "also": [f"{f.id}@{f.target}" for f in lead.effects[1:]],
            "improvement": 1.0 - lead.rmse_val / base.rmse_val
            if base.rmse_val > 0
            else 0.0,
            "p_value": lead.p_value,
            "physics": _explain(e, lead.job.values(), model, rec),
        }
    if sparse_scored:
        lead_eq = min(sparse_scored, key=lambda s: s.rmse_val)
        verdict["lead_equation"] = _verdict_params(lead_eq).get("equation")
    return verdict


def _named(
    model, rec, accepted: _Scored, pair: _Scored | None, pair_order, inactive: frozenset
) -> dict:
    """The verdict for an accepted effect (and the further ones of a pair).

    Parameters in ``inactive`` (never reached by the fitted model) are reported as
    None, not as findings.
    """
    e = accepted.effects[0]
    verdict = {
        "effect": e.id,
        "target": e.target,
        "physics": _explain(e, _reached(accepted.job.values(), inactive), model, rec),
        "params": _verdict_params(accepted, inactive),
    }
    if inactive:
        verdict["never_reached"] = sorted(inactive)
    if pair is not None:
        pv = _reached(pair.job.values(), inactive)
        verdict["params"] = {p: pv[f"{e.key}.{p}"] for p in e.param_names}
        if e.partner and e.id == "overflow":
            verdict["params"]["into_state"] = e.partner
        verdict["also"] = [
            {
                "effect": e2.id,
                "target": e2.target,
                "physics": _explain(e2, pv, model, rec),
                "params": {p: pv[f"{e2.key}.{p}"] for p in e2.param_names},
            }
            for e2 in pair_order[1:]
        ]
        verdict["physics"] = _explain(e, pv, model, rec)
        if pair.removal:
            verdict["weights"] = [
                {"effect": x.id, "target": x.target, "rmse_without": r}
                for x, r in pair.removal
            ]
    if e.id == SPARSE_ID:
        named = _signatures(e.candidate.labels, e.target, _partner_of(model, e.target))
        if named:
            verdict["signatures"] = named
            verdict["physics"] += (
                " Its terms hold the signature of "
                + ", ".join(f"{n['physics']} ({n['term']})" for n in named)
                + "."
            )
    return verdict


def _alternatives(verdict: dict, final: _Scored, singles, tie_tolerance: float) -> None:
    """Other single effects these data cannot tell from the verdict.

    A constant force on a spring and a sensor offset look alike once the transients have
    died.
    """
    held = {(e.id, e.target) for e in final.effects}
    close = [
        s
        for s in singles
        if s.refit
        and s.e_val is not None
        and (s.effects[0].id, s.effects[0].target) not in held
        and s.rmse_val <= final.rmse_val * (1.0 + tie_tolerance)
    ]
    if not close:
        return
    verdict["alternatives"] = [
        {
            "effect": s.effects[0].id,
            "target": s.effects[0].target,
            "rmse_validation": s.rmse_val,
        }
        for s in sorted(close, key=lambda s: s.rmse_val)
    ]
    said = ", ".join(f"{a['effect']} on {a['target']}" for a in verdict["alternatives"])
    verdict["physics"] += (
        f" As close on these data: {said} (they may be equivalent here, or a "
        "richer excitation would tell them apart)."
    )


def build_verdict(
    model,
    rec,
    *,
    accepted: _Scored | None,
    pair: _Scored | None,
    pair_order: Sequence[Effect],
    base: _Scored,
    singles: list[_Scored],
    sparse_scored: list[_Scored],
    beaten: _Scored | None,
    tie_tolerance: float,
    inactive: frozenset = frozenset(),
    sparse_tried: bool = False,
) -> dict:
    """The verdict: the effect named (or ``none`` / ``unexplained``).

    With its physics in one sentence, its parameters, further effects and look-alike
    alternatives. ``sparse_tried``: the data-driven stage ran (it may find nothing).
    """
    if accepted is None:
        return _no_effect(model, rec, base, singles, sparse_scored, beaten, sparse_tried)
    verdict = _named(model, rec, accepted, pair, pair_order, inactive)
    _alternatives(verdict, pair or accepted, singles, tie_tolerance)
    return verdict


def add_warnings(verdict: dict, job: _Job, budget: dict | None) -> None:
    """``verdict["warnings"]``: values on a bound of their range, a budget run out."""
    verdict["warnings"] = _at_bounds(job)
    if budget is None:
        return
    verdict["budget"] = budget
    if budget["reached"]:
        skipped = ", ".join(budget["skipped"])
        verdict["warnings"].append(
            f"the time budget of {budget['max_seconds']:g} s ran out: this is the "
            "best verdict so far (fits stopped early"
            + (f"; skipped: {skipped}" if skipped else "")
            + ")."
        )


# ---------------------------------------------------------------------------- result
def _fit_summary(model, s, problem, nominal, base, final) -> dict:
    """RMSEs before / after (validation and training), free values, how it was fitted.

    ``s`` holds the discovery's recordings and weights (``_setup.Setup``).
    """
    fitted = problem.sample_index()  # the training samples simulated
    train_err_nom = s.y_all[fitted] - base.y_train[fitted]
    return {
        "rmse_nominal": base.rmse_val,
        "rmse_augmented": final.rmse_val if final is not None else base.rmse_val,
        "rmse_train_nominal": _rmse(train_err_nom, s.w),
        "rmse_train_augmented": (
            _rmse(s.y_all[fitted] - final.y_train[fitted], s.w)
            if final is not None
            else _rmse(train_err_nom, s.w)
        ),
        "free_nominal": {p: nominal.values()[f"p:{p}"] for p in model.free},
        "free_augmented": (
            {p: final.job.values()[f"p:{p}"] for p in model.free}
            if final is not None
            else None
        ),
        "validation": s.validation,
        "n_sub": problem.n_sub,
        "integrator": problem.model.integrator
        if problem.model.integrator != "auto"
        else "rk4",
        "decimated": s.factor,
        "pieces": (
            {"n": problem.n_pieces, "samples": int(problem.length)}
            if problem.n_pieces > 1
            else None
        ),
        "input_hold": s.hold,
        "n_sub_augmented": final.n_sub if final is not None else None,
        "rmse_by_output": _by_output(model, s.w, base, final or base),
    }


def _by_output(model, w, base, final) -> dict:
    """Validation RMSE of each output in its own units, nominal and augmented."""

    def rmse(scored, k):
        e = scored.e_val[:, k] / w[k]
        return float(np.sqrt(np.mean(e**2)))

    return {
        name: {"nominal": rmse(base, k), "augmented": rmse(final, k)}
        for k, name in enumerate(model.outputs)
    }


def _localise(model, s, problem, nominal, x_nominal, base, final) -> dict:
    """Step 6: where the nominal residual lies, and its whiteness before / after.

    Where: in time, state space and frequency. Also the signals for plots.
    """
    rec, y_all, w, n_fit = s.rec, s.y_all, s.w, s.n_fit
    if problem.n_pieces == 1:  # the whole training recording
        Xt = simulate_states(model, rec, nominal.values(), problem.n_sub)
        at = np.arange(rec.n)
    else:  # the fitted pieces
        Xt, at = x_nominal, problem.sample_index()
    xs = {name: Xt[:, j] for j, name in enumerate(model.states)}
    res_nom = (y_all[at] - base.y_train[at]) * w  # weighted residual
    u_at = {k: v[at] for k, v in rec.inputs.items()}
    if s.rec_val is None:
        uval = {k: v[n_fit:] for k, v in rec.inputs.items()}
        yval = y_all[n_fit:]
    else:
        uval = s.rec_val.inputs
        yval = s.rec_val.y(model)
    white = {"before": {}, "after": {}}
    for j, o in enumerate(model.outputs):
        white["before"][o] = whiteness_test(yval[:, j] - base.y_val[:, j], uval)
        if final is not None:
            white["after"][o] = whiteness_test(yval[:, j] - final.y_val[:, j], uval)
    signals = {
        "time": rec.time,
        "measured": y_all,
        "nominal": base.y_train,
        "augmented": final.y_train if final is not None else None,
        "split": float(rec.time[n_fit]) if s.rec_val is None else None,
    }
    if s.rec_val is not None:
        signals.update(
            val_time=s.rec_val.time,
            val_measured=yval,
            val_nominal=base.y_val,
            val_augmented=final.y_val if final is not None else None,
        )
    return {
        "located": residual_windows(rec.time[at], res_nom),
        "regions": region_statistics(model, xs, u_at, res_nom),
        "spectrum": residual_spectrum(res_nom.sum(axis=1), u_at, 1.0 / rec.ts),
        "whiteness": white,
        "signals": signals,
    }


#: effects whose removal costs are within this share of the largest explain "equally"
TIED_WEIGHT = 0.02


def _white_words(white: bool | None) -> str:
    if white is None:
        return ""
    if white:
        return "the residual left is white (noise-like): nothing systematic remains"
    return "the residual left is not white: something systematic remains unexplained"


def headline(verdict: dict, fit: dict) -> str:
    """The verdict in one sentence: the effects by weight, the fit, the residual.

    Effects are named by what each explains (the validation RMSE without it, the
    rest refitted), the weightiest first; then the fit before and after and, in
    words, whether the residual left is white.

    Examples
    --------
    >>> from pdmkit.models.mismatch._verdict import headline
    >>> v = {"effect": "overflow", "target": "h1", "confidence": {"white_after": False},
    ...      "weights": [{"effect": "overflow", "target": "h1", "rmse_without": 0.41},
    ...                  {"effect": "dead_zone", "target": "u", "rmse_without": 0.29}]}
    >>> headline(v, {"rmse_nominal": 0.672, "rmse_augmented": 0.283})[:62]
    'overflow on h1 explains most (validation RMSE 0.41 without it)'
    """
    conf = verdict.get("confidence", {})
    before, after = fit["rmse_nominal"], fit["rmse_augmented"]
    effect = verdict["effect"]
    if effect == "none":
        return "No effect is missing: " + (
            _white_words(conf.get("white_before")) or "the model explains the data"
        )
    if effect == "unexplained":
        lead = verdict.get("best_partial")
        closest = f"; closest: {lead['effect']} on {lead['target']}" if lead else ""
        return (
            "Unexplained: something systematic is left in the residual that no "
            f"candidate effect explains significantly{closest}"
        )
    weights = verdict.get("weights")
    if weights:
        top = weights[0]["rmse_without"]
        k = sum(1 for w in weights if w["rmse_without"] >= (1 - TIED_WEIGHT) * top)
        first, rest = weights[:k], weights[k:]
        if k == 1:
            text = (
                f"{first[0]['effect']} on {first[0]['target']} explains most (validation "
                f"RMSE {top:.4g} without it)"
            )
        else:
            text = (
                " and ".join(f"{w['effect']} on {w['target']}" for w in first)
                + " explain most, about equally (validation RMSE "
                + " and ".join(f"{w['rmse_without']:.4g}" for w in first)
                + " without each)"
            )
        if rest:
            text += ", then " + ", ".join(
                f"{w['effect']} on {w['target']} ({w['rmse_without']:.4g} without it)"
                for w in rest
            )
    else:
        text = f"{effect} on {verdict['target']}"
    text += f"; validation RMSE {before:.4g} -> {after:.4g}"
    words = _white_words(conf.get("white_after"))
    return text + (f"; {words}" if words else "")


def _result(model, s, problem, nominal, x_nominal, base, final, verdict, table, timings):
    """The :class:`MismatchResult`.

    The fit before / after, where the residual lies and how sure the verdict is.
    """
    fit = _fit_summary(model, s, problem, nominal, base, final)
    where = _localise(model, s, problem, nominal, x_nominal, base, final)
    nom_rmse, aug_rmse = fit["rmse_nominal"], fit["rmse_augmented"]
    white = where["whiteness"]
    verdict["confidence"] = {
        "p_value": p_value(base, final) if final is not None else None,
        "improvement": 1.0 - aug_rmse / nom_rmse if nom_rmse > 0 else 0.0,
        "white_before": all(x["white"] for x in white["before"].values()),
        "white_after": (
            all(x["white"] for x in white["after"].values()) if white["after"] else None
        ),
    }
    verdict["headline"] = headline(verdict, fit)
    return MismatchResult(
        verdict=verdict,
        candidates=table,
        fit=fit,
        outputs=list(model.outputs),
        nominal_values=nominal.values(),
        augmented_values=final.job.values() if final is not None else None,
        augmented_effects=final.effects if final is not None else (),
        timings=timings,
        **where,
    )
