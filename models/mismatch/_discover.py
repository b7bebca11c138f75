"""Mismatch discovery: locate what a model gets wrong, name the missing physics, fit it.

:func:`discover_mismatch` runs the loop an engineer runs by hand:

1. fit the nominal model (free parameters + initial state) by simulation error on the
   training part (the first two thirds, or all of ``data`` when a separate validation
   recording is given);
2. locate the residual in time, in the state / input space and in frequency, and test
   it for whiteness (:mod:`pdmkit.models.mismatch._locate`);
3. attach every candidate of the library (:mod:`pdmkit.models.mismatch._candidates`)
   that the model admits and screen them all cheaply (a few batched Levenberg-Marquardt
   iterations each, from several starting points), then refit the best ones to
   convergence (their parameters + the free ones + the initial state);
4. rank by validation RMSE (ties within ``tie_tolerance`` go to the lower BIC), and
   accept the best only when its gain is significant against the noise (a
   Diebold-Mariano test on the validation errors with a HAC variance, a minimum
   relative improvement, and a lower BIC); otherwise the verdict is ``none``;
5. when one effect is accepted, try it together with each runner-up and with its
   companions (effects that real machines show together and that hide each other
   alone: Coulomb friction and a bias force, an overflow and a saturating sensor), and
   keep adding the one that helps most while it improves significantly again (up to
   ``max_effects``);
6. when the residual left (after the accepted effect, or of the nominal model when none
   was accepted) still fails the whiteness test, run the data-driven fallback
   (:mod:`pdmkit.models.mismatch._sparse`): a short equation selected by sparse regression
   through the simulation. It becomes the verdict (``sparse``) only when it beats that
   model by the same significance test and, when it would replace an accepted named
   effect, also leaves a white validation residual; its output is an equation such as
   ``dv/dt += -2.31*x**2*v``.

References: Ljung, *System Identification*, 2nd ed., 1999 (residual tests); Diebold &
Mariano, *Comparing predictive accuracy*, JBES 1995.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit.errors import ConvergenceWarning, ModelError
from pdmkit.models.mismatch._candidates import (
    SPARSE_ID,
    Effect,
    Scales,
    _position_partner,
    attach_candidates,
)
from pdmkit.models.mismatch._fit import (
    DEADLINE,
    PIECES_FROM,
    Recording,
    _choose_n_sub,
    _cost,
    _effect_starts,
    _initial_values,
    _Job,
    _lm,
    _make_jobs,
    _nominal_scales,
    _Problem,
    choose_decimation,
    choose_pieces,
    data_states,
    decimate,
    make_recording,
    part,
    simulate_states,
)
from pdmkit.models.mismatch._locate import (
    region_statistics,
    residual_spectrum,
    residual_windows,
    whiteness_test,
)
from pdmkit.models.ode import DERIVATIVE_ATTACH

__all__ = ["MismatchResult", "discover_mismatch", "dm_test"]

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


def _structured(s) -> bool:
    """A residual with clear structure: not white and strongly correlated (a model
    error, not measurement noise, which a control's residual is)."""
    for j in range(s.e_val.shape[1]):
        w = whiteness_test(s.e_val[:, j])
        if not w["white"] and w["acf_max"] > 0.5:
            return True
    return False


# ---------------------------------------------------------------------------- statistics
def dm_test(e_ref: np.ndarray, e_new: np.ndarray) -> tuple[float, float]:
    """One-sided Diebold-Mariano test that ``e_new`` has smaller squared errors.

    ``d_t = sum(e_ref**2) - sum(e_new**2)`` (over outputs); the variance of its mean is
    a Bartlett (Newey-West) HAC estimate with the plug-in bandwidth
    ``floor(4 (N/100)^(2/9))``.

    Returns
    -------
    (statistic, p_value)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._discover import dm_test
    >>> rng = np.random.default_rng(0)
    >>> noise = rng.normal(size=500)
    >>> round(dm_test(noise + 1.0, noise)[1], 6)
    0.0
    >>> bool(dm_test(noise, noise + 0.01 * rng.normal(size=500))[1] > 0.01)
    True
    """
    from scipy import stats

    a = np.asarray(e_ref, dtype=float)
    b = np.asarray(e_new, dtype=float)
    a = a[:, None] if a.ndim == 1 else a
    b = b[:, None] if b.ndim == 1 else b
    with np.errstate(over="ignore", invalid="ignore"):
        d = np.sum(a**2, axis=1) - np.sum(b**2, axis=1)
    if not np.all(np.isfinite(d)):  # a diverged simulation: infinitely worse
        worse = bool(np.any(np.isnan(d)) or np.any(d == -np.inf))
        return (-math.inf, 1.0) if worse else (math.inf, 0.0)
    n = d.size
    dc = d - d.mean()
    g0 = float(np.dot(dc, dc) / n)
    if g0 <= 0:
        return (math.inf if d.mean() > 0 else 0.0), (0.0 if d.mean() > 0 else 1.0)
    var = g0
    # Newey-West (1994) plug-in bandwidth
    L = int(min(max(1, math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0))), n - 1))
    for k in range(1, L + 1):
        gk = float(np.dot(dc[k:], dc[: n - k]) / n)
        var += 2.0 * (1.0 - k / (L + 1)) * gk
    var = max(var, g0 / n)
    stat = float(d.mean() / math.sqrt(var / n))
    return stat, float(stats.norm.sf(stat))


# ---------------------------------------------------------------------------- result
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

    def plot(self, ax=None, output: str | None = None):
        """Measured vs nominal vs augmented (top) and the residuals (bottom).

        Located windows are shaded; the validation split is a dashed line.

        Examples
        --------
        >>> from pdmkit.models.mismatch._cases import example_result
        >>> res = example_result()
        >>> res.plot().shape
        (2,)
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
        ax[0].plot(t, s["measured"][:, j], color="k", lw=0.8, label="measured")
        ax[0].plot(t, s["nominal"][:, j], color="C0", lw=1.0, label="nominal model")
        if s.get("augmented") is not None:
            ax[0].plot(t, s["augmented"][:, j], color="C3", lw=1.0, label="augmented model")
        ax[0].set_ylabel(output)
        ax[0].legend(loc="best", fontsize="small")
        ax[1].plot(
            t,
            s["measured"][:, j] - s["nominal"][:, j],
            color="C0",
            lw=0.8,
            label="residual, nominal",
        )
        if s.get("augmented") is not None:
            ax[1].plot(
                t,
                s["measured"][:, j] - s["augmented"][:, j],
                color="C3",
                lw=0.8,
                label="residual, augmented",
            )
        ax[1].set_ylabel(f"{output} residual")
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


# ---------------------------------------------------------------------------- helpers
@dataclasses.dataclass
class _Scored:
    job: _Job
    key: str
    effects: tuple
    rmse_val: float = math.inf
    e_val: np.ndarray | None = None  # weighted validation errors (Nv, n_out)
    y_val: np.ndarray | None = None
    y_train: np.ndarray | None = None
    bic: float = math.inf
    p_value: float = 1.0
    refit: bool = True
    n_sub: int = 0  # RK4 steps per sample it was fitted with


def _bic(cost: float, m: int, k: int) -> float:
    if not math.isfinite(cost):
        return math.inf
    return m * math.log(max(2.0 * cost / m, 1e-300)) + k * math.log(m)


def _rmse(err: np.ndarray, weights: np.ndarray) -> float:
    with np.errstate(over="ignore"):  # a diverged simulation: inf
        if err.shape[1] == 1:
            return float(np.sqrt(np.mean(err**2)))
        return float(np.sqrt(np.mean((err * weights) ** 2)))


#: samples at the start of a validation record on which its initial state is fitted
#: (a record fitted in pieces: one piece's length)
VALIDATION_X0_SAMPLES = 2000


def _validate(
    model,
    problems: Mapping[int, _Problem],
    rec_val: Recording | None,
    scored: list[_Scored],
    x_scale,
    max_iter: int,
) -> None:
    """Validation outputs and errors for every scored structure (batched per step)."""
    for n_sub, problem in problems.items():
        group = [s for s in scored if s.n_sub == n_sub]
        if group:
            _validate_one(model, problem, rec_val, group, x_scale, max_iter)


def _validate_one(model, problem, rec_val, scored, x_scale, max_iter) -> None:
    rec = problem.rec
    w = problem.weights
    rows = [(s.job, s.job.values(), s.job.x0) for s in scored]
    if rec_val is None:
        Y = problem.simulate(rows, n=rec.n)
        y = rec.y(model)
        for s, Yi in zip(scored, Y, strict=True):
            s.y_train = Yi
            s.y_val = Yi[problem.n_fit :]
            err = Yi[problem.n_fit :] - y[problem.n_fit :]
            s.e_val = np.where(np.isfinite(err * w), err * w, 1e3)
            s.rmse_val = _rmse(np.where(np.isfinite(err), err, np.inf), w)
        return
    if problem.n_pieces == 1:
        Ytr = problem.simulate(rows, n=rec.n)
    else:  # the fitted pieces; samples between them are not simulated (NaN)
        Ytr = np.full((len(rows), rec.n, len(model.outputs)), np.nan)
        Ytr[:, problem.sample_index()] = problem.simulate(rows)
    # the initial state is estimated on the record's first samples, then the whole
    # record is simulated once: the initial state only shapes the start (a long record
    # would otherwise be simulated at every iteration of this small fit)
    n0 = VALIDATION_X0_SAMPLES if problem.n_pieces == 1 else problem.length
    pv = _Problem(model, rec_val, min(rec_val.n, n0), w, problem.n_sub)
    jobs = []
    for s in scored:
        x0 = data_states(model, rec_val, np.array([0]), s.job.x0[0])
        jobs += _make_jobs(
            model,
            s.effects,
            None,
            [{}],
            s.job.values(),
            x_scale,
            fit_free=False,
            fit_effects=False,
            x0=x0,
        )
    _lm(pv, jobs, max_iter, budgeted=False)
    Y = pv.simulate([(j, j.values(), j.x0) for j in jobs], n=rec_val.n)
    y = rec_val.y(model)
    for s, Yi, Yt in zip(scored, Y, Ytr, strict=True):
        s.y_train = Yt
        s.y_val = Yi
        err = Yi - y
        s.e_val = np.where(np.isfinite(err * w), err * w, 1e3)
        s.rmse_val = _rmse(np.where(np.isfinite(err), err, np.inf), w)


def _friction_step(job: _Job, ts: float, n_sub: int) -> int:
    """RK4 steps per sample at which a fitted friction's smoothing is not step-limited.

    The smoothing width of Coulomb / Stribeck friction is widened to ``a h / 2`` so the
    explicit step stays stable (:func:`pdmkit.models.mismatch._candidates._eps`); when that
    dominates the intended width, the term is much smoother than real friction and the
    refit needs finer steps (at most twice as many: the cost grows with them).
    """
    vals = job.values()
    need = n_sub
    for e in job.effects:
        if e.id == "coulomb_friction":
            a = vals[f"{e.key}.a"]
        elif e.id == "stribeck_friction":
            a = vals[f"{e.key}.a_c"] + vals[f"{e.key}.a_s"]
        else:
            continue
        eps0 = e.opt("eps")
        n = n_sub
        while 0.5 * a * ts / n > 2.0 * eps0 and n < 2 * n_sub:
            n *= 2
        need = max(need, n)
    return need


def _choose(scored: list[_Scored], tol: float, min_gain: float, ts: float) -> _Scored:
    """Lowest validation RMSE; within ``tol`` of it, the lowest BIC.

    A hypothesis that nests a simpler one on the same target (Stribeck friction
    contains Coulomb friction, drift contains offset) must beat it by ``min_gain``,
    with values the simulation resolves (``Candidate.resolved``; ``ts`` the sample
    interval).
    """
    best = min(scored, key=lambda s: s.rmse_val)
    close = [s for s in scored if s.rmse_val <= best.rmse_val * (1.0 + tol)]
    chosen = min(close, key=lambda s: (s.bic, s.rmse_val))
    e = chosen.effects[0]
    simpler = e.candidate.nests
    if simpler is not None:
        for s in scored:
            f = s.effects[0]
            if f.id == simpler and f.target == e.target:
                h = ts / max(chosen.n_sub, 1)
                unresolved = not e.candidate.resolved(e, chosen.job.values(), h)
                if unresolved or chosen.rmse_val > s.rmse_val * (1.0 - min_gain):
                    return s
    return chosen


#: a screened candidate is refit when it removes at least this share of what the best
#: screened candidate removes from the nominal cost (a few iterations from a guess can
#: leave a right candidate behind a wrong one that happens to start closer)
REACH = 0.3


def _within_reach(ranked: list[_Job], nominal_cost: float, keep: int) -> list[_Job]:
    """The screened jobs to refit: the ``keep`` best, and every other one whose gain
    over the nominal cost is within :data:`REACH` of the best gain (at most
    ``3 * keep`` in all, best first)."""
    if not ranked:
        return []
    best_gain = nominal_cost - ranked[0].cost
    kept = list(ranked[:keep])
    if math.isfinite(best_gain) and best_gain > 0:
        kept += [
            j
            for j in ranked[keep:]
            if math.isfinite(j.cost) and nominal_cost - j.cost >= REACH * best_gain
        ]
    return kept[: 3 * keep]


#: terms of a sparse equation that are a named effect's signature
_SIGNATURES = {
    "sign": ("coulomb_friction", "Coulomb (dry) friction"),
    "const": ("bias_force", "a constant (bias) force"),
    "cube": ("cubic_stiffness", "cubic (Duffing) stiffness"),
    "abs*": ("quadratic_drag", "quadratic drag"),
}


def _grow(current: _Scored, singles: list[_Scored], top: int) -> dict:
    """``{effect keys: (current, single)}`` for the ``top`` refitted runner-ups (lowest
    validation RMSE first) and the companions of ``current``'s effects: effects it
    does not hold already, nor nests (Stribeck and Coulomb on one velocity)."""
    held = {(e.id, e.target) for e in current.effects}
    for e in current.effects:  # nor one that nests it or that it nests
        if e.candidate.nests:
            held.add((e.candidate.nests, e.target))
        held |= {
            (s.effects[0].id, e.target)
            for s in singles
            if s.effects[0].candidate.nests == e.id
        }
    keys = {e.key for e in current.effects}
    out: dict = {}
    for s in sorted(singles, key=lambda s: s.rmse_val):
        f = s.effects[0]
        if (f.id, f.target) in held:
            continue
        companion = any(f.id in e.candidate.companions for e in current.effects)
        if (s.refit and len(out) < top) or companion:
            held.add((f.id, f.target))
            out[frozenset({*keys, f.key})] = (current, s)
    return out


def _simpler_rival(chosen: _Scored, considered: list[_Scored], min_gain: float):
    """A considered structure that holds, instead of each effect of ``chosen`` that
    nests a simpler one (``Candidate.nests``), that simpler effect on the same target, with
    no more fitted values and a validation RMSE within ``min_gain`` of ``chosen``'s
    (the best such, or None)."""
    nesting = [(e, e.candidate.nests) for e in chosen.effects if e.candidate.nests]
    if not nesting:
        return None
    best = None
    for s in considered:
        held = {(f.id, f.target) for f in s.effects}
        if s is chosen or any((e.id, e.target) in held for e, _ in nesting):
            continue
        if not all((small, e.target) in held for e, small in nesting):
            continue
        close = s.rmse_val <= chosen.rmse_val * (1.0 + min_gain)
        if close and s.job.n_fitted <= chosen.job.n_fitted:
            if best is None or s.rmse_val < best.rmse_val:
                best = s
    return best


def _by_weight(problem: _Problem, s: _Scored) -> list:
    """The effects of a structure, the one whose removal (its parameters at their
    neutral values, nothing refitted) raises the fitted cost most first."""
    vals = s.job.values()
    rows, order = [], []
    for e in s.effects:
        if set(e.param_names) <= set(e.candidate.neutral):
            off = {
                **vals,
                **{f"{e.key}.{p}": e.candidate.neutral[p] for p in e.param_names},
            }
            rows.append((s.job, off, s.job.x0))
            order.append(e)
    if len(rows) < 2:
        return list(s.effects)
    costs = [_cost(r) for r in problem.residuals(problem.simulate(rows))]
    ranked = [e for _, e in sorted(zip(costs, order, strict=True), key=lambda z: -z[0])]
    return ranked + [e for e in s.effects if e not in ranked]


def _companion_pairs(singles: list[_Scored], top: int) -> list:
    """``(single, companion)`` for each of the ``top`` refitted singles (lowest
    validation RMSE first) and every candidate listed as its companion (on the same
    target when both act on a state's derivative), screened or refitted alike."""
    ranked = [s for s in sorted(singles, key=lambda s: s.rmse_val) if s.refit][:top]
    out, seen = [], set()
    for s in ranked:
        e = s.effects[0]
        for c in singles:
            f = c.effects[0]
            if f.id not in e.candidate.companions or c is s:
                continue
            same_kind = (e.candidate.attach in DERIVATIVE_ATTACH) and (
                f.candidate.attach in DERIVATIVE_ATTACH
            )
            if same_kind and f.target != e.target:
                continue
            key = frozenset((e.key, f.key))
            if key in seen:
                continue
            seen.add(key)
            out.append((s, c))
    return out


def _signatures(labels: Sequence[str], target: str, partner: str | None) -> list[dict]:
    """Named effects whose signature the sparse terms hold (``sign(v)`` -> Coulomb,
    ``1`` -> a bias force, ``x**3`` -> cubic stiffness, ``abs(v)*v`` -> drag)."""
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
    """Fitted values that ended on a bound of their search range (free model
    parameters always; effect parameters when the bound is not their neutral value)."""
    lay = job.layout
    out = []
    neutral = {}
    for e in job.effects:
        for p in e.param_names:
            if p in e.candidate.neutral:
                neutral[f"{e.key}.{p}"] = float(e.candidate.neutral[p])
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


def _verdict_params(s: _Scored) -> dict:
    vals = s.job.values()
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


def _white(s: _Scored) -> bool:
    """Whether every output's validation residual passes the whiteness test."""
    return all(whiteness_test(s.e_val[:, j])["white"] for j in range(s.e_val.shape[1]))


def _explain(e: Effect, vals: Mapping[str, float], model=None, rec=None) -> str:
    """The effect's sentence; with the model and recording, forces in N use the input
    gain (1 / mass) of the fit that ``vals`` come from, not the nominal one."""
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


# ---------------------------------------------------------------------------- public
def choose_input_hold(rec: Recording) -> str:
    """``"zoh"`` when the inputs are held (most samples repeat the one before: steps,
    a digital controller's output), else ``"foh"`` (a sampled continuous signal).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._fit import Recording
    >>> t = np.arange(100) * 0.01
    >>> steps = np.repeat([0.0, 1.0, -1.0, 0.5], 25)
    >>> choose_input_hold(Recording(t, 0.01, {"u": steps}, {}))
    'zoh'
    >>> choose_input_hold(Recording(t, 0.01, {"u": np.sin(7 * t)}, {}))
    'foh'
    """
    if not rec.inputs:
        return "zoh"
    repeats = [
        float(np.mean(np.diff(np.asarray(u, dtype=float)) == 0))
        for u in rec.inputs.values()
    ]
    return "zoh" if max(repeats) > 0.3 else "foh"


def discover_mismatch(
    model,
    data: Any,
    validation: Any = None,
    *,
    effects: Sequence[str] | None = None,
    min_improvement: float = 0.1,
    alpha: float = 0.01,
    tie_tolerance: float = 0.02,
    keep: int = 6,
    screen_iter: int = 8,
    max_iter: int = 30,
    pairs: bool = True,
    pair_candidates: int = 3,
    max_effects: int = 3,
    data_name: str = "data",
    validation_name: str = "validation",
    input_hold: str = "auto",
    max_seconds: float | None = None,
    progress: bool | None = None,
    candidates: Sequence = (),
) -> MismatchResult:
    """Find the physics a model leaves out, from a recording.

    Parameters
    ----------
    model : OdeModel
        The nominal model (e.g. from :func:`load_model_file`).
    data : DataFrame, mapping or Recording
        ``time``, the model's inputs and outputs. Without ``validation``, its last
        third is the validation part.
    validation : DataFrame, mapping or Recording, optional
        A second recording used only for validation (its initial state is
        re-estimated).
    effects : sequence of str, optional
        Restrict the candidate ids (default: the whole library, ``sparse`` included).
    min_improvement : float
        Smallest relative validation-RMSE improvement that can count as a finding.
    alpha : float
        Significance level of the Diebold-Mariano test against the nominal model.
    tie_tolerance : float
        Candidates within this relative validation RMSE of the best are ranked by BIC
        (the simpler explanation wins a tie).
    keep : int
        How many screened candidates are refitted to convergence.
    screen_iter, max_iter : int
        Levenberg-Marquardt iterations for screening and for the full refit.
    pairs : bool
        Try pairs of effects when one is accepted.
    pair_candidates : int
        How many runner-up effects (distinct effect and target) are paired with it.
    max_effects : int
        Most effects in one explanation: after a pair, the effect that helps most is
        added while it helps significantly (forward selection).
    data_name, validation_name : str
        Names used in error messages (e.g. the file names).
    input_hold : {"auto", "zoh", "foh"}
        What the inputs do between samples: held (``"zoh"``: steps, a digital
        controller's output) or straight lines (``"foh"``: a sampled continuous
        signal, which a hold would lag by half a sample, a mismatch of its own).
        ``"auto"`` (default) picks ``"zoh"`` when the inputs stay on one value for
        runs of samples (:func:`choose_input_hold`), else ``"foh"``.
    max_seconds : float, optional
        Time budget. When it runs out, the fits stop where they are, the remaining
        optional stages (pairs, data-driven terms) are skipped, and the verdict is the
        best so far, marked so (``verdict["budget"]``).
    progress : bool, optional
        Show a progress bar with the stage names (default: when stderr is a terminal).
    candidates : sequence of Candidate, optional
        Your own candidate effects (instances of
        :class:`~pdmkit.models.mismatch.Candidate` subclasses), tried with the library.

    Returns
    -------
    MismatchResult

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import generate_concealed_case
    >>> from pdmkit.models.mismatch._discover import discover_mismatch
    >>> case = generate_concealed_case("coulomb_friction", 0.2, seed=0, n_samples=600)
    >>> res = discover_mismatch(case.model, case.data, pairs=False,
    ...                         effects=["coulomb_friction", "viscous_friction"])
    >>> res.verdict["effect"], res.verdict["target"]
    ('coulomb_friction', 'v')
    >>> res.fit["rmse_augmented"] < 0.5 * res.fit["rmse_nominal"]
    True
    """
    if max_seconds is not None and not (
        isinstance(max_seconds, int | float) and max_seconds > 0
    ):
        raise ModelError(
            "discover_mismatch: max_seconds must be a positive number; got "
            f"{max_seconds!r}."
        )
    stages = _Stages(max_seconds, progress)
    token = DEADLINE.set(stages.deadline)
    try:
        return _discover(
            model,
            data,
            validation,
            stages,
            effects=effects,
            min_improvement=min_improvement,
            alpha=alpha,
            tie_tolerance=tie_tolerance,
            keep=keep,
            screen_iter=screen_iter,
            max_iter=max_iter,
            pairs=pairs,
            pair_candidates=pair_candidates,
            max_effects=max_effects,
            data_name=data_name,
            validation_name=validation_name,
            input_hold=input_hold,
            candidates=tuple(candidates),
        )
    finally:
        DEADLINE.reset(token)
        stages.close()


class _Stages:
    """The stages of a discovery on a progress bar, and its time budget."""

    NAMES = (
        "nominal fit",
        "screening",
        "refit",
        "validation",
        "pairs",
        "data-driven terms",
        "localisation",
    )

    def __init__(self, max_seconds: float | None, enable: bool | None):
        import time

        from pdmkit._progress import progress_bar

        self.start = time.perf_counter()
        self.max_seconds = max_seconds
        self.deadline = self.start + max_seconds if max_seconds else math.inf
        self.skipped: list[str] = []
        self._bar = progress_bar(len(self.NAMES), desc="mismatch", enable=enable)

    def enter(self, name: str) -> None:
        if self._bar is not None:
            self._bar.set_description(f"mismatch: {name}")

    def leave(self) -> None:
        if self._bar is not None:
            self._bar.update(1)

    def over(self) -> bool:
        import time

        return time.perf_counter() > self.deadline

    def skip(self, name: str) -> None:
        self.skipped.append(name)
        self.leave()

    def report(self) -> dict | None:
        """``{"max_seconds", "reached", "skipped"}`` when a budget was given."""
        if self.max_seconds is None:
            return None
        return {
            "max_seconds": self.max_seconds,
            "reached": self.over() or bool(self.skipped),
            "skipped": list(self.skipped),
        }

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def _discover(
    model,
    data,
    validation,
    stages: _Stages,
    *,
    effects,
    min_improvement,
    alpha,
    tie_tolerance,
    keep,
    screen_iter,
    max_iter,
    pairs,
    pair_candidates,
    max_effects,
    data_name,
    validation_name,
    input_hold,
    candidates,
) -> MismatchResult:
    """:func:`discover_mismatch`'s steps (arguments checked there, budget set)."""
    import time as _time

    t_start = stages.start
    for name, v in (
        ("min_improvement", min_improvement),
        ("alpha", alpha),
        ("tie_tolerance", tie_tolerance),
    ):
        if not (isinstance(v, int | float) and 0 <= v < 1):
            raise ModelError(f"discover_mismatch: {name} must be in [0, 1); got {v!r}.")
    rec = data if isinstance(data, Recording) else make_recording(model, data, data_name)
    rec_val = None
    if validation is not None:
        rec_val = (
            validation
            if isinstance(validation, Recording)
            else make_recording(model, validation, validation_name)
        )
        if abs(rec_val.ts - rec.ts) > 1e-3 * rec.ts:  # as uniform_step's tolerance
            raise ModelError(
                f"discover_mismatch: {validation_name} is sampled every {rec_val.ts:g} s, "
                f"{data_name} every {rec.ts:g} s; resample them to the same step."
            )
    hold = choose_input_hold(rec) if input_hold == "auto" else input_hold
    if hold not in ("zoh", "foh"):
        raise ModelError(
            f"discover_mismatch: input_hold must be 'auto', 'zoh' or 'foh'; got "
            f"{input_hold!r}."
        )
    rec = dataclasses.replace(rec, hold=hold)
    if rec_val is not None:
        rec_val = dataclasses.replace(rec_val, hold=hold)
    # an oversampled record is decimated first (the model and the inputs say how far)
    factor = choose_decimation(model, rec, _initial_values(model, rec), 1)
    if factor > 1:
        rec = decimate(rec, factor)
        rec_val = decimate(rec_val, factor) if rec_val is not None else None
    n_fit = rec.n if rec_val is not None else round(rec.n * 2 / 3)
    y_all = rec.y(model)
    w = 1.0 / np.maximum(np.std(y_all[:n_fit], axis=0), 1e-12)
    values0 = _initial_values(model, rec)
    n_sub = _choose_n_sub(model, rec, values0)
    x_scale = {s: 1.0 for s in model.states}
    for o in model.outputs:
        x_scale[o] = float(np.std(rec.outputs[o])) or 1.0
    # a long record is fitted in pieces, each from its own fitted initial state
    pieces = choose_pieces(model, rec, n_fit, values0, n_sub)
    if pieces is not None and rec_val is None:  # validate on the tail, restarted
        rec_val = part(rec, n_fit)

    # ------------------------------------------------------------ 1. nominal fit
    stages.enter("nominal fit")
    problem = _Problem(model, rec, n_fit, w, n_sub, *(pieces or (None, None)))
    nom = _make_jobs(model, (), None, [{}], values0, x_scale, tag="nominal")
    _lm(problem, nom, 80)
    along = (problem.states(nom[0].values(), nom[0].x0), problem.sample_index())
    n_sub2 = _choose_n_sub(model, rec, nom[0].values(), along)
    if any(k in ("velocity", "angular_velocity") for k in model.states.values()):
        # friction switches sign at zero speed: at least two RK4 steps per sample keep
        # the smoothed stick-slip close to the real one (Coulomb is otherwise mistaken
        # for Stribeck, whose low-speed peak mimics a sharper transition)
        n_sub2 = max(n_sub2, 2)
    if n_sub2 > n_sub:
        problem = problem.with_step(n_sub2)
        nom = _make_jobs(
            model, (), None, [{}], nom[0].values(), x_scale, tag="nominal", x0=nom[0].x0
        )
        _lm(problem, nom, 80)
    nominal = nom[0]
    if not math.isfinite(nominal.cost):
        raise ModelError(
            f"{model.name}: the nominal model cannot be simulated on {data_name} (the "
            "simulation diverges or gives NaN); check PARAMS, INITIAL and the units."
        )
    t_nominal = _time.perf_counter() - t_start
    stages.leave()
    x_nominal = problem.states(nominal.values(), nominal.x0)  # along the fitted samples
    sc: Scales = _nominal_scales(
        model, rec, nominal.values(), problem.n_sub, (x_nominal, problem.sample_index())
    )
    x_scale = {s: sc.x_scale(s) for s in model.states}

    # ------------------------------------------------------------ 2. candidates
    stages.enter("screening")
    cands = attach_candidates(model, sc, effects, extra=candidates)
    jobs: list[_Job] = []
    for e in cands:
        jobs += _make_jobs(
            model,
            (e,),
            sc,
            _effect_starts((e,), sc),
            nominal.values(),
            x_scale,
            tag=e.key,
            x0=nominal.x0,
        )
    _lm(problem, jobs, screen_iter)
    best_by_key: dict[str, _Job] = {}
    for j in jobs:
        if j.tag not in best_by_key or j.cost < best_by_key[j.tag].cost:
            best_by_key[j.tag] = j
    ranked = sorted(best_by_key.values(), key=lambda j: j.cost)
    kept = _within_reach(ranked, nominal.cost, keep)
    stages.leave()
    stages.enter("refit")
    _lm(problem, kept, max_iter)
    # friction whose smoothing is limited by the step: refit on finer steps
    problems = {problem.n_sub: problem}
    n_sub_of = {id(j): problem.n_sub for j in ranked}
    for i, j in enumerate(kept):
        n_f = _friction_step(j, rec.ts, problem.n_sub)
        if n_f > problem.n_sub:
            if n_f not in problems:
                problems[n_f] = problem.with_step(n_f)
            fine = _make_jobs(
                model, j.effects, sc, [{}], j.values(), x_scale, tag=j.tag, x0=j.x0
            )[0]
            _lm(problems[n_f], [fine], max(5, max_iter // 2))
            if fine.cost <= j.cost:
                ranked[ranked.index(j)] = fine
                kept[i] = fine
                n_sub_of[id(fine)] = n_f
    t_screen = _time.perf_counter() - t_start - t_nominal
    stages.leave()
    stages.enter("validation")

    # ------------------------------------------------------------ 3. validation, scores
    m = problem.n_res
    scored = [_Scored(nominal, "nominal", (), n_sub=problem.n_sub)]
    for j in ranked:
        scored.append(_Scored(j, j.tag, j.effects, refit=j in kept, n_sub=n_sub_of[id(j)]))
    # a long validation record is simulated for the refitted candidates only
    n_val = rec_val.n if rec_val is not None else rec.n - n_fit
    checked = [s for s in scored if s.refit or n_val <= PIECES_FROM]
    _validate(model, problems, rec_val, checked, x_scale, 30)
    for s in scored:
        s.bic = _bic(s.job.cost, m, s.job.n_fitted)
    base = scored[0]
    for s in checked[1:]:
        s.p_value = dm_test(base.e_val, s.e_val)[1]
    singles = scored[1:]

    def significant(s: _Scored, ref: _Scored) -> bool:
        gain = 1.0 - s.rmse_val / ref.rmse_val if ref.rmse_val > 0 else 0.0
        p = dm_test(ref.e_val, s.e_val)[1]
        return gain >= min_improvement and p < alpha and s.bic < ref.bic

    chosen = (
        _choose([s for s in singles if s.refit], tie_tolerance, min_improvement, rec.ts)
        if singles
        else None
    )
    accepted = chosen if chosen is not None and significant(chosen, base) else None
    stages.leave()

    # ------------------------------------------------------------ 4. pairs
    pair = None
    pair_order: list = []
    stages.enter("pairs")
    if pairs and stages.over():
        stages.skipped.append("pairs")
    elif pairs:
        # forward selection: add the runner-up (or a companion) that helps most, while
        # it helps significantly, up to max_effects effects in all; companions are
        # paired even when neither helps alone (each hides the other)
        current = accepted
        considered = [s for s in singles if s.refit and s.e_val is not None]
        for size in range(2, max_effects + 1):
            if stages.over():
                stages.skipped.append(f"{size} effects")
                break
            grown = _grow(current, singles, pair_candidates) if current else {}
            if size == 2:
                for first, o in _companion_pairs(singles, pair_candidates):
                    grown.setdefault(frozenset((first.key, o.key)), (first, o))
            if not grown:
                break
            pjobs = []
            for first, o in grown.values():
                vals = {**o.job.values(), **first.job.values()}
                eff = (*first.effects, *o.effects)
                pjobs += _make_jobs(
                    model,
                    eff,
                    sc,
                    [{}],
                    vals,
                    x_scale,
                    tag="+".join(e.key for e in eff),
                    x0=first.job.x0,
                )
            if not pjobs:
                break
            pp = problem  # the base step: these are the costliest fits
            _lm(pp, pjobs, max_iter, ftol=1e-7)
            pscored = [_Scored(j, j.tag, j.effects, n_sub=pp.n_sub) for j in pjobs]
            _validate(model, problems, rec_val, pscored, x_scale, 30)
            for s in pscored:
                s.bic = _bic(s.job.cost, m, s.job.n_fitted)
            considered += pscored
            best = min(pscored, key=lambda s: s.rmse_val)
            if not significant(best, current or base):
                break
            current = best
        # a structure with the simpler effect that a chosen one nests (Coulomb friction
        # for hysteresis), within min_improvement of it and not larger, is preferred
        simpler = _simpler_rival(current, considered, min_improvement) if current else None
        if simpler is not None and significant(simpler, base):
            current = simpler
        if current is None:
            pass
        elif len(current.effects) > 1:
            pair = current
            pair_order = _by_weight(problem, pair)
            # the effect whose removal costs most leads the verdict
            accepted = next(s for s in singles if s.effects[0] == pair_order[0])
        else:
            accepted = current
    stages.leave()

    # ------------------------------------------------------------ 5. data-driven fallback
    stages.enter("data-driven terms")
    sparse_scored: list[_Scored] = []
    sparse_best = None
    beaten: _Scored | None = None  # a named explanation an equation beat
    ref = pair or accepted or base
    t_sparse = 0.0
    wanted = (effects is None or SPARSE_ID in effects) and not _white(ref)
    if wanted and stages.over():
        stages.skipped.append("data-driven terms")
    elif wanted:
        from pdmkit.models.mismatch._sparse import fit_sparse

        t0 = _time.perf_counter()
        sjobs = fit_sparse(problem, model, nominal.values(), sc, x_scale, x0=nominal.x0)
        sparse_scored = [_Scored(j, j.tag, j.effects, n_sub=problem.n_sub) for j in sjobs]
        if sparse_scored:
            _validate(model, problems, rec_val, sparse_scored, x_scale, 30)
            for s in sparse_scored:
                s.bic = _bic(s.job.cost, m, s.job.n_fitted)
                s.p_value = dm_test(base.e_val, s.e_val)[1]
            cand = min(sparse_scored, key=lambda s: s.rmse_val)
            # it replaces an accepted named effect only when it also whitens the
            # residual (the named one did not): a closer fit alone is not a better
            # explanation of real data that neither model captures fully
            if significant(cand, ref) and (ref is base or _white(cand)):
                sparse_best = cand
                accepted, pair = cand, None
            elif significant(cand, ref):
                # an equation beats the named explanation clearly, without whitening
                # the residual either: the named effect is only part of the story
                beaten, accepted, pair = ref, None, None
        t_sparse = _time.perf_counter() - t0
    stages.leave()
    stages.enter("localisation")
    t_total = _time.perf_counter() - t_start

    # ------------------------------------------------------------ 5. summary
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
        rows.append(
            {
                "effect": e.id,
                "target": e.target,
                "variant": _variant(e),
                "rmse_validation": s.rmse_val if checked else math.nan,
                "improvement": (
                    1.0 - s.rmse_val / base.rmse_val if base.rmse_val > 0 else 0.0
                )
                if checked
                else math.nan,
                "criterion": s.bic - base.bic,
                "p_value": s.p_value if checked else math.nan,
                "n_params": s.job.n_fitted,
                "refit": s.refit,
                "_s": s,
            }
        )
    table = pd.DataFrame(rows)
    if len(table):
        table = table.sort_values(["rmse_validation", "criterion"], ignore_index=True)
        top = sparse_best or chosen
        if top is not None:
            # the chosen candidate (BIC tie-break) first
            first = table.index[table["_s"].map(lambda s: s is top)]
            if len(first):
                table = pd.concat([table.loc[first], table.drop(first)], ignore_index=True)
        table = table.drop(columns="_s")

    final = pair or accepted
    if accepted is None:
        verdict = {"effect": "none", "target": None, "physics": _NONE_PHYSICS, "params": {}}
        if _structured(base) or beaten is not None:
            # something systematic is left, but no candidate explains it: say so
            lead = beaten or (min(singles, key=lambda s: s.rmse_val) if singles else None)
            verdict = {
                "effect": "unexplained",
                "target": None,
                "physics": _UNEXPLAINED_PHYSICS if beaten is None else _PARTIAL_PHYSICS,
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
    else:
        e = accepted.effects[0]
        vals = accepted.job.values()
        verdict = {
            "effect": e.id,
            "target": e.target,
            "physics": _explain(e, vals, model, rec),
            "params": _verdict_params(accepted),
        }
        if pair is not None:
            pv = pair.job.values()
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
    if accepted is not None and accepted.effects[0].id == SPARSE_ID:
        e = accepted.effects[0]
        named = _signatures(e.candidate.labels, e.target, _partner_of(model, e.target))
        if named:
            verdict["signatures"] = named
            verdict["physics"] += (
                " Its terms hold the signature of "
                + ", ".join(f"{n['physics']} ({n['term']})" for n in named)
                + "."
            )
    if final is not None and accepted is not None:
        # other single effects these data cannot tell from the verdict (a constant force
        # on a spring and a sensor offset look alike once the transients have died)
        held = {(e.id, e.target) for e in final.effects}
        close = [
            s
            for s in singles
            if s.refit
            and s.e_val is not None
            and (s.effects[0].id, s.effects[0].target) not in held
            and s.rmse_val <= final.rmse_val * (1.0 + tie_tolerance)
        ]
        if close:
            verdict["alternatives"] = [
                {
                    "effect": s.effects[0].id,
                    "target": s.effects[0].target,
                    "rmse_validation": s.rmse_val,
                }
                for s in sorted(close, key=lambda s: s.rmse_val)
            ]
            said = ", ".join(
                f"{a['effect']} on {a['target']}" for a in verdict["alternatives"]
            )
            verdict["physics"] += (
                f" As close on these data: {said} (they may be equivalent here, or a "
                "richer excitation would tell them apart)."
            )
    verdict["warnings"] = _at_bounds((final or base).job)
    budget = stages.report()
    if budget is not None:
        verdict["budget"] = budget
        if budget["reached"]:
            skipped = ", ".join(budget["skipped"])
            verdict["warnings"].append(
                f"the time budget of {budget['max_seconds']:g} s ran out: this is the "
                "best verdict so far (fits stopped early"
                + (f"; skipped: {skipped}" if skipped else "")
                + ")."
            )
    for text in verdict["warnings"]:
        warnings.warn(f"mismatch: {text}", ConvergenceWarning, stacklevel=2)
    fitted = problem.sample_index()  # the training samples simulated
    train_err_nom = y_all[fitted] - base.y_train[fitted]
    fit = {
        "rmse_nominal": base.rmse_val,
        "rmse_augmented": final.rmse_val if final is not None else base.rmse_val,
        "rmse_train_nominal": _rmse(train_err_nom, w),
        "rmse_train_augmented": (
            _rmse(y_all[fitted] - final.y_train[fitted], w)
            if final is not None
            else _rmse(train_err_nom, w)
        ),
        "free_nominal": {p: nominal.values()[f"p:{p}"] for p in model.free},
        "free_augmented": (
            {p: final.job.values()[f"p:{p}"] for p in model.free}
            if final is not None
            else None
        ),
        "validation": "separate recording" if rec_val is not None else "last third",
        "n_sub": problem.n_sub,
        "decimated": factor,
        "pieces": (
            {"n": problem.n_pieces, "samples": int(problem.length)}
            if problem.n_pieces > 1
            else None
        ),
        "input_hold": hold,
        "n_sub_augmented": final.n_sub if final is not None else None,
    }

    # ------------------------------------------------------------ 6. localisation
    if problem.n_pieces == 1:  # the whole training recording
        Xt = simulate_states(model, rec, nominal.values(), problem.n_sub)
        at = np.arange(rec.n)
    else:  # the fitted pieces
        Xt, at = x_nominal, fitted
    xs = {s: Xt[:, j] for j, s in enumerate(model.states)}
    res_nom = (y_all[at] - base.y_train[at]) * w  # weighted residual
    u_at = {k: v[at] for k, v in rec.inputs.items()}
    located = residual_windows(rec.time[at], res_nom)
    regions = region_statistics(model, xs, u_at, res_nom)
    spectrum = residual_spectrum(res_nom.sum(axis=1), u_at, 1.0 / rec.ts)
    if rec_val is None:
        uval = {k: v[n_fit:] for k, v in rec.inputs.items()}
        yval = y_all[n_fit:]
    else:
        uval = rec_val.inputs
        yval = rec_val.y(model)
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
        "split": float(rec.time[n_fit]) if rec_val is None else None,
    }
    if rec_val is not None:
        signals.update(
            val_time=rec_val.time,
            val_measured=yval,
            val_nominal=base.y_val,
            val_augmented=final.y_val if final is not None else None,
        )
    nom_rmse, aug_rmse = fit["rmse_nominal"], fit["rmse_augmented"]
    verdict["confidence"] = {
        "p_value": dm_test(base.e_val, final.e_val)[1] if final is not None else None,
        "improvement": 1.0 - aug_rmse / nom_rmse if nom_rmse > 0 else 0.0,
        "white_before": all(w["white"] for w in white["before"].values()),
        "white_after": (
            all(w["white"] for w in white["after"].values()) if white["after"] else None
        ),
    }
    return MismatchResult(
        verdict=verdict,
        candidates=table,
        located=located,
        regions=regions,
        fit=fit,
        whiteness=white,
        spectrum=spectrum,
        signals=signals,
        outputs=list(model.outputs),
        nominal_values=nominal.values(),
        augmented_values=final.job.values() if final is not None else None,
        augmented_effects=final.effects if final is not None else (),
        timings={
            "nominal_s": t_nominal,
            "screen_refit_s": t_screen,
            "sparse_s": t_sparse,
            "total_s": t_total,
            "n_candidates": len(cands),
            "n_jobs": len(jobs),
        },
    )
