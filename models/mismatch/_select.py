"""Score, compare and select model structures in mismatch discovery.

A *structure* is the nominal model with a set of candidate effects, fitted
(:class:`_Scored` holds one with its validation errors). This module simulates the
validation part for fitted structures, compares them (validation RMSE, BIC, and the
one-sided Diebold-Mariano test :func:`dm_test`), picks the best single effect
(:func:`_choose`: nested hypotheses must earn their extra parameters), and grows
explanations by forward selection (:func:`_grow`, :func:`_companion_pairs`,
:func:`_simpler_rival`, :func:`_by_weight`).

References: Diebold & Mariano, *Comparing predictive accuracy*, JBES 1995; Newey &
West, *Automatic lag selection in covariance matrix estimation*, RES 1994.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from pdmkit.models._optim import half_squares
from pdmkit.models._residuals import dm_test, whiteness_test
from pdmkit.models.mismatch._fit_problem import _Job, _lm, _make_jobs, _Problem
from pdmkit.models.mismatch._recording import Recording, data_states, segments
from pdmkit.models.ode import DERIVATIVE_ATTACH, PARAMETER_ATTACH

__all__ = ["dm_test"]


@dataclasses.dataclass
class _Scored:
    job: _Job
    key: str
    effects: tuple
    rmse_val: float = math.inf
    e_val: np.ndarray | None = None  # weighted validation errors (Nv, n_out)
    e_train: np.ndarray | None = None  # weighted errors on the fitted training samples
    y_val: np.ndarray | None = None
    y_train: np.ndarray | None = None
    bic: float = math.inf
    p_value: float = 1.0
    refit: bool = True
    removal: list | None = None  # [(effect, validation RMSE without it)], weightiest first
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
#: relative cost change below which the validation record's initial-state fit stops
#: (it only shapes the start of the record; twice in a row, as every fit)
X0_FTOL = 1e-3


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
        fitted = problem.sample_index()
        for s, Yi in zip(scored, Y, strict=True):
            s.y_train = Yi
            s.y_val = Yi[problem.n_fit :]
            s.e_train = (Yi[fitted] - y[fitted]) * w
            err = Yi[problem.n_fit :] - y[problem.n_fit :]
            s.e_val = np.where(np.isfinite(err * w), err * w, 1e3)
            s.rmse_val = _rmse(np.where(np.isfinite(err), err, np.inf), w)
        return
    if problem.n_pieces == 1:
        Ytr = problem.simulate(rows, n=rec.n)
    else:  # the fitted pieces; samples between them are not simulated (NaN)
        Ytr = np.full((len(rows), rec.n, len(model.outputs)), np.nan)
        Ytr[:, problem.sample_index()] = problem.simulate(rows)
    # each validation recording's initial state is estimated on its first samples, then
    # the whole recording is simulated once: the initial state only shapes the start (a
    # long record would otherwise be simulated at every iteration of this small fit)
    n0 = VALIDATION_X0_SAMPLES if problem.n_pieces == 1 else problem.length
    Y = np.concatenate(
        [
            _validation_outputs(model, seg, scored, w, problem.n_sub, n0, x_scale, max_iter)
            for seg in segments(rec_val)
        ],
        axis=1,
    )
    y = rec_val.y(model)
    fitted, y_fit = problem.sample_index(), rec.y(model)[problem.sample_index()]
    for s, Yi, Yt in zip(scored, Y, Ytr, strict=True):
        s.y_train = Yt
        s.e_train = (Yt[fitted] - y_fit) * w
        s.y_val = Yi
        err = Yi - y
        s.e_val = np.where(np.isfinite(err * w), err * w, 1e3)
        s.rmse_val = _rmse(np.where(np.isfinite(err), err, np.inf), w)


def _validation_outputs(model, rec_val, scored, w, n_sub, n0, x_scale, max_iter):
    """Every scored structure simulated on one validation recording, ``(S, N, n_out)``.

    Its initial state fitted on the first ``n0`` samples (from the data where they
    measure a state, else from the structure's fitted initial state). A structure that
    was only screened (not refitted) starts from the nominal's fitted initial state
    when the nominal is among ``scored``: its score is a screen's too, and the fits of
    the screened ones were most of a discovery's validation time (the rig's position
    model: 45 fits per recording, 15 s of 4 min).
    """
    pv = _Problem(model, rec_val, min(rec_val.n, n0), w, n_sub)
    nominal = next((k for k, s in enumerate(scored) if not s.effects), None)
    own = [k for k, s in enumerate(scored) if s.refit or nominal is None or k == nominal]
    jobs = []
    for s in (scored[k] for k in own):
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
    _lm(pv, jobs, max_iter, ftol=X0_FTOL, budgeted=False)
    fitted = dict(zip(own, jobs, strict=True))
    shared = fitted[nominal].x0 if nominal is not None else None  # the screened start
    rows = [
        (fitted[k], fitted[k].values(), fitted[k].x0)
        if k in fitted
        else (s.job, s.job.values(), shared)
        for k, s in enumerate(scored)
    ]
    return pv.simulate(rows, n=rec_val.n)


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
    """Lowest validation RMSE; within ``tol`` of it, a named effect, then the lowest BIC.

    A re-estimated constant of the file (``constant``) yields to a named effect that
    does as well: adding viscous friction and raising a fixed damping constant are the
    same model, and the named term says more. A hypothesis that nests a simpler one
    on the same target (Stribeck friction contains Coulomb friction, drift contains
    offset) must beat it by ``min_gain``,
    with values the simulation resolves (``Candidate.resolved``; ``ts`` the sample
    interval).
    """
    best = min(scored, key=lambda s: s.rmse_val)
    close = [s for s in scored if s.rmse_val <= best.rmse_val * (1.0 + tol)]
    chosen = min(close, key=lambda s: (_is_constant(s), s.bic, s.rmse_val))
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


def _is_constant(s: _Scored) -> bool:
    """Whether a hypothesis only re-estimates constants of the model file."""
    return all(e.candidate.attach == PARAMETER_ATTACH for e in s.effects)


#: a screened candidate is refit when it removes at least this share of what the best
#: screened candidate removes from the nominal cost (a few iterations from a guess can
#: leave a right candidate behind a wrong one that happens to start closer)
REACH = 0.3


def _within_reach(ranked: list[_Job], nominal_cost: float, keep: int) -> list[_Job]:
    """The screened jobs to refit, best first.

    The ``keep`` best, and every other one whose gain over the nominal cost is within
    :data:`REACH` of the best gain (at most ``3 * keep`` in all).
    """
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


def _grow(current: _Scored, singles: list[_Scored], top: int, wide: bool = False) -> dict:
    """``{effect keys: (current, single)}`` for the runner-ups and companions to try.

    For the ``top`` refitted runner-ups (lowest validation RMSE first) and the companions of
    ``current``'s effects: effects it does not hold already, nor nests (Stribeck and Coulomb
    on one velocity). With ``wide`` (used when ``current`` leaves a clearly structured
    residual), every such single, refitted or only screened: effects that hide each
    other (a pump's threshold and an overflow) help little alone, so the best few alone
    need not hold the one that helps once another is in (the caller screens them).
    A re-estimated constant of the file is a verdict on its own, never an addition:
    beside an effect whose smooth form only approximates the truth (a rate limit, a
    clip) a constant absorbs some of what is left, a gain that says nothing about the
    file's value.
    """
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
        if (f.id, f.target) in held or f.candidate.attach == PARAMETER_ATTACH:
            continue
        companion = any(f.id in e.candidate.companions for e in current.effects)
        if (s.refit and len(out) < top) or companion or wide:
            held.add((f.id, f.target))
            out[frozenset({*keys, f.key})] = (current, s)
    return out


def _simpler_rival(chosen: _Scored, considered: list[_Scored], min_gain: float):
    """A simpler considered structure that does about as well as ``chosen``.

    It holds, instead of each effect of ``chosen`` that nests a simpler one
    (``Candidate.nests``), that simpler effect on the same target, with no more fitted
    values and a validation RMSE within ``min_gain`` of ``chosen``'s (the best such, or
    None).
    """
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


def _by_weight(f, s: _Scored, considered: list[_Scored], max_iter: int) -> list:
    """The effects of a structure by what each explains, the weightiest first.

    An effect's weight is its removal cost: the validation RMSE of the structure
    without it, the other effects and the model's parameters refitted (a pump's dead
    zone that the pump's gain absorbs once refitted weighs little, however much the
    fit moves when only its parameters are set to neutral). Structures already
    fitted during the selection are reused; the others are fitted here from the
    structure's values. Returns ``[(effect, rmse_without), ...]``.
    """
    fitted = {
        frozenset(e.key for e in c.effects): c for c in considered if c.e_val is not None
    }
    without: dict[str, _Scored] = {}
    jobs, missing = [], []
    for e in s.effects:
        rest = tuple(x for x in s.effects if x is not e)
        known = fitted.get(frozenset(x.key for x in rest))
        if known is not None:
            without[e.key] = known
            continue
        jobs += _make_jobs(f.model, rest, f.sc, [{}], s.job.values(), f.x_scale,
                           tag="+".join(x.key for x in rest), x0=s.job.x0)  # fmt: skip
        missing.append(e)
    if jobs:  # started from the fitted structure: half the iterations suffice
        _lm(f.problem, jobs, max(5, max_iter // 2), ftol=1e-7)
        scored = [_Scored(j, j.tag, j.effects, n_sub=f.problem.n_sub) for j in jobs]
        f.score(scored)
        without.update({e.key: r for e, r in zip(missing, scored, strict=True)})
    ranked = sorted(s.effects, key=lambda e: -without[e.key].rmse_val)
    return [(e, float(without[e.key].rmse_val)) for e in ranked]


def inactive_params(problem: _Problem, s: _Scored, rtol: float = 1e-6) -> frozenset:
    """Effect parameters the fitted structure never reaches (``"key.param"``).

    A parameter is inactive when setting it alone to its neutral value leaves the
    training cost unchanged within ``rtol``: a sensor's lower limit below every value
    the model ever reads, an overflow rim the level never reaches. Its fitted number
    is then arbitrary (anywhere in the flat region) and not a finding.
    """
    vals = s.job.values()
    rows, names = [], []
    for e in s.effects:
        for p in e.param_names:
            if p in e.neutral:
                rows.append((s.job, {**vals, f"{e.key}.{p}": e.neutral[p]}, s.job.x0))
                names.append(f"{e.key}.{p}")
    if not rows:
        return frozenset()
    rows.append((s.job, vals, s.job.x0))
    costs = [half_squares(r) for r in problem.residuals(problem.simulate(rows))]
    ref = costs[-1]
    return frozenset(
        n
        for n, c in zip(names, costs[:-1], strict=True)
        if abs(c - ref) <= rtol * max(ref, 1e-300)
    )


def _companion_pairs(singles: list[_Scored], top: int) -> list:
    """``(single, companion)`` for each of the ``top`` refitted singles and its companions.

    Singles by lowest validation RMSE first; every candidate listed as a single's companion
    (on the same target when both act on a state's derivative), screened or refitted alike.
    """
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


def _adds_companion(s: _Scored, ref: _Scored) -> bool:
    """Whether ``s`` holds ``ref``'s effects plus companions of them only."""
    held = set(ref.effects)
    new = [e for e in s.effects if e not in held]
    if not new or len(held & set(s.effects)) != len(held):
        return False
    names = {c for e in ref.effects for c in e.candidate.companions}
    return all(e.id in names for e in new)


def _white(s: _Scored) -> bool:
    """Whether every output's validation residual passes the whiteness test."""
    return all(whiteness_test(s.e_val[:, j])["white"] for j in range(s.e_val.shape[1]))


def _structured(s) -> bool:
    """A residual with clear structure: not white and strongly correlated.

    A model error, not measurement noise, which a control's residual is.
    """
    for j in range(s.e_val.shape[1]):
        w = whiteness_test(s.e_val[:, j])
        if not w["white"] and w["acf_max"] > 0.5:
            return True
    return False


def _score(model, problems, rec_val, scored, x_scale, n_res: int, everyone=None) -> None:
    """Validation errors of ``scored`` and the BIC of ``everyone`` (default: ``scored``).

    The BIC is on ``n_res`` training residuals.
    """
    _validate(model, problems, rec_val, scored, x_scale, 30)
    for s in scored if everyone is None else everyone:
        s.bic = _bic(s.job.cost, n_res, s.job.n_fitted)


def p_value(ref: _Scored, s: _Scored) -> float:
    """One-sided Diebold-Mariano p-value that ``s`` predicts better than ``ref``.

    On the validation errors together with the errors on the fitted training samples.
    An effect that acts in episodes (a sensor clipping a few peaks) shows on few
    validation samples, where the test alone has little power; the training part holds
    more of its episodes. The training errors are in-sample, which favours the larger
    model only by about its number of fitted values, far below what the test accepts
    at ``alpha`` = 0.01 for the few values of an effect (and every finding must also
    gain ``min_improvement`` on validation alone).
    """
    a, b = ref.e_val, s.e_val
    if ref.e_train is not None and s.e_train is not None:
        finite = np.isfinite(ref.e_train) & np.isfinite(s.e_train)
        ok = np.all(finite, axis=1)
        a = np.concatenate([ref.e_train[ok], a])
        b = np.concatenate([s.e_train[ok], b])
    return dm_test(a, b)[1]


@dataclasses.dataclass(frozen=True)
class Significance:
    """Whether a structure beats a reference.

    It needs a relative validation-RMSE gain of at least ``min_improvement``, a
    Diebold-Mariano p-value (:func:`p_value`: validation and training errors) below
    ``alpha`` and a lower BIC.
    """

    min_improvement: float
    alpha: float

    def __call__(self, s: _Scored, ref: _Scored, companion: bool = False) -> bool:
        """Whether ``s`` beats ``ref``.

        ``companion``: ``s`` adds to ``ref`` an effect that one of ``ref``'s effects
        names as its companion (expected beside it, :attr:`Candidate.companions`);
        the relative gain it must make is then half of ``min_improvement`` (the test
        and the BIC unchanged).
        """
        gain = 1.0 - s.rmse_val / ref.rmse_val if ref.rmse_val > 0 else 0.0
        need = 0.5 * self.min_improvement if companion else self.min_improvement
        if gain < need or s.bic >= ref.bic:
            return False
        return p_value(ref, s) < self.alpha
