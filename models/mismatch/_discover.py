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
import time
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from pdmkit._progress import progress_bar
from pdmkit.errors import ConvergenceWarning, ModelError
from pdmkit.models.mismatch._candidates import SPARSE_ID, Scales, attach_candidates
from pdmkit.models.mismatch._fit import nominal_starts, polish_whole
from pdmkit.models.mismatch._fit_problem import (
    DEADLINE,
    _effect_starts,
    _Job,
    _lm,
    _make_jobs,
    _Problem,
)
from pdmkit.models.mismatch._locate import clipped_outputs
from pdmkit.models.mismatch._recording import Recording
from pdmkit.models.mismatch._sampling import (
    PIECES_FROM,
    _choose_n_sub,
    _nominal_scales,
    converged_n_sub,
)
from pdmkit.models.mismatch._screen_constants import promising_constants
from pdmkit.models.mismatch._select import (
    Significance,
    _adds_companion,
    _by_weight,
    _choose,
    _companion_pairs,
    _friction_step,
    _grow,
    _score,
    _Scored,
    _simpler_rival,
    _structured,
    _white,
    _within_reach,
    inactive_params,
    p_value,
)
from pdmkit.models.mismatch._setup import Setup, prepare
from pdmkit.models.mismatch._sparse import fit_sparse
from pdmkit.models.mismatch._verdict import (
    MismatchResult,
    _result,
    add_warnings,
    build_verdict,
    candidate_table,
)
from pdmkit.models.ode import PARAMETER_ATTACH

if TYPE_CHECKING:
    from pdmkit.models.ode import OdeModel

__all__ = ["MismatchResult", "discover_mismatch"]


# ---------------------------------------------------------------------------- public
def discover_mismatch(
    model: OdeModel,
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
    max_effects: int = 4,
    data_name: str = "data",
    validation_name: str | Sequence[str] = "validation",
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
    validation : DataFrame, mapping or Recording, or a list of them, optional
        Recording(s) used only for validation, each from its own re-estimated initial
        state. Several are scored together: one RMSE and one significance test over
        all of them, so an effect that shows in a few events of each recording gains
        the power of all.
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
    data_name : str
        The data's name in error messages (e.g. its file name).
    validation_name : str or list of str
        The validation recording's name, or one per recording.
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
        options = _Options(
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
        return _discover(model, data, validation, stages, options)
    finally:
        DEADLINE.reset(token)
        stages.close()


#: screening iterations every start of an effect makes before only its best goes on
SCREEN_STARTS_ITER = 3


@dataclasses.dataclass(frozen=True)
class _Options:
    """:func:`discover_mismatch`'s settings (see its parameters)."""

    effects: Sequence[str] | None
    min_improvement: float
    alpha: float
    tie_tolerance: float
    keep: int
    screen_iter: int
    max_iter: int
    pairs: bool
    pair_candidates: int
    max_effects: int
    data_name: str
    validation_name: str | Sequence[str]
    input_hold: str
    candidates: tuple

    def __post_init__(self) -> None:
        for name in ("min_improvement", "alpha", "tie_tolerance"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0 <= v < 1):
                raise ModelError(f"discover_mismatch: {name} must be in [0, 1); got {v!r}.")


@dataclasses.dataclass
class _Fits:
    """What the later steps share: the fitting problem(s) and the nominal's scales."""

    model: Any
    problem: _Problem  # the training part at the base RK4 step
    problems: dict  # by RK4 steps per sample (friction refits use finer ones)
    rec_val: Recording | None
    sc: Scales
    x_scale: dict

    def score(self, scored: list[_Scored], everyone=None) -> None:
        _score(
            self.model,
            self.problems,
            self.rec_val,
            scored,
            self.x_scale,
            self.problem.n_res,
            everyone,
        )


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


def _fit_nominal(model, s: Setup, data_name: str) -> tuple[_Problem, _Job]:
    """Step 1: the nominal model's free parameters and initial state."""
    problem = _Problem(model, s.rec, s.n_fit, s.w, s.n_sub, *(s.pieces or (None, None)))
    nom = [
        job
        for values in nominal_starts(model, s.values0)
        for job in _make_jobs(model, (), None, [{}], values, s.x_scale, tag="nominal")
    ]
    _lm(problem, nom, 80)
    nom = [min(nom, key=lambda j: j.cost)]
    if s.step_checked:  # recheck the simulated step at the fitted parameters
        n_sub2 = converged_n_sub(model, s.rec, nom[0].values(), s.n_sub)
    else:
        along = (problem.states(nom[0].values(), nom[0].x0), problem.sample_index())
        n_sub2 = _choose_n_sub(model, s.rec, nom[0].values(), along)
    if any(k in ("velocity", "angular_velocity") for k in model.states.values()):
        # friction switches sign at zero speed: at least two RK4 steps per sample keep
        # the smoothed stick-slip close to the real one (Coulomb is otherwise mistaken
        # for Stribeck, whose low-speed peak mimics a sharper transition)
        n_sub2 = max(n_sub2, 2)
    if n_sub2 > s.n_sub:
        problem = problem.with_step(n_sub2)
        nom = _make_jobs(
            model, (), None, [{}], nom[0].values(), s.x_scale, tag="nominal", x0=nom[0].x0
        )
        _lm(problem, nom, 80)
    if not math.isfinite(nom[0].cost):
        raise ModelError(
            f"{model.name}: the nominal model cannot be simulated on {data_name} (the "
            "simulation diverges or gives NaN); check PARAMS, INITIAL and the units."
        )
    return problem, polish_whole(model, problem, nom[0], s.x_scale)


def _screen(model, problem, sc, x_scale, nominal, cands, screen_iter: int, keep: int):
    """Step 2a: every candidate from its starting points, a few iterations each.

    Returns ``(jobs, ranked best-per-effect first, kept for the refit)``.
    """
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
    # every start a few iterations, then only each effect's best start goes on: the
    # starts of one effect only guard against a poor basin, which the first
    # iterations show (the rig: 76 starts of 44 effects, a quarter of the screen)
    _lm(problem, jobs, min(SCREEN_STARTS_ITER, screen_iter))
    best_by_key = _best_by_tag(jobs)
    _lm(problem, list(best_by_key.values()), screen_iter)
    best_by_key = _best_by_tag(jobs)
    ranked = sorted(best_by_key.values(), key=lambda j: j.cost)
    return jobs, ranked, _within_reach(ranked, nominal.cost, keep)


def _best_by_tag(jobs: list[_Job]) -> dict[str, _Job]:
    """The lowest-cost job of each tag (an effect's starts share its tag)."""
    best: dict[str, _Job] = {}
    for j in jobs:
        if j.tag not in best or j.cost < best[j.tag].cost:
            best[j.tag] = j
    return best


def _refit(model, problem, sc, x_scale, ranked, kept, max_iter: int, ts: float):
    """Step 2b: the kept candidates to convergence.

    Friction whose smoothing is limited by the step is fitted again on finer steps
    (``ranked`` and ``kept`` updated in place). Returns ``(problems by RK4 steps per sample,
    steps of each job)``.
    """
    _lm(problem, kept, max_iter)
    problems = {problem.n_sub: problem}
    n_sub_of = {id(j): problem.n_sub for j in ranked}
    for i, j in enumerate(kept):
        n_f = _friction_step(j, ts, problem.n_sub)
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
    return problems, n_sub_of


def _grown_jobs(f: _Fits, grown) -> list[_Job]:
    """One job per ``(structure, single)``: the structure with the single's effect added.

    Started from both fits' values and the structure's initial state.
    """
    jobs: list[_Job] = []
    for first, other in grown:
        eff = (*first.effects, *other.effects)
        jobs += _make_jobs(
            f.model,
            eff,
            f.sc,
            [{}],
            {**other.job.values(), **first.job.values()},
            f.x_scale,
            tag="+".join(e.key for e in eff),
            x0=first.job.x0,
        )
    return jobs


def _screened_wide(f: _Fits, current, singles, grown: dict, o: _Options) -> list[_Job]:
    """Further grown structures when ``current`` leaves a clearly structured residual.

    The ``keep`` singles not tried already that fitted best alone (lowest training
    cost), each added to ``current`` and screened (``screen_iter`` iterations); the
    ``pair_candidates`` best are returned for the refit. Effects that hide each other
    (a pump's threshold beside an overflow) help little alone, so the runner-ups alone
    need not hold the one that helps once another is in.
    """
    if current is None or not _structured(current):
        return []
    wide = _grow(current, singles, o.pair_candidates, wide=True)
    extra = sorted(
        (v for k, v in wide.items() if k not in grown), key=lambda v: v[1].job.cost
    )
    jobs = _grown_jobs(f, extra[: o.keep])
    if not jobs:
        return []
    _lm(f.problem, jobs, o.screen_iter)
    return sorted(jobs, key=lambda j: j.cost)[: o.pair_candidates]


def _forward_selection(
    f: _Fits,
    singles: list[_Scored],
    accepted: _Scored | None,
    base: _Scored,
    significant: Significance,
    stages: _Stages,
    o: _Options,
) -> tuple[_Scored | None, _Scored | None, list]:
    """Step 4: add the effect that helps most, while it helps significantly.

    The effect is the runner-up or a companion, up to ``max_effects`` effects; companions
    are paired even when neither helps alone (each hides the other), and one added beside
    the effect that names it needs half the gain. While the structure leaves a clearly
    structured residual, every other effect is screened with it too
    (:func:`_screened_wide`). Returns ``(accepted single, the accepted structure of
    several effects or None, its effects by weight)``.
    """
    current = accepted
    considered = [s for s in singles if s.refit and s.e_val is not None]
    for size in range(2, o.max_effects + 1):
        if stages.over():
            stages.skipped.append(f"{size} effects")
            break
        grown = _grow(current, singles, o.pair_candidates) if current else {}
        if size == 2:
            for first, other in _companion_pairs(singles, o.pair_candidates):
                grown.setdefault(frozenset((first.key, other.key)), (first, other))
        pjobs = _grown_jobs(f, grown.values())
        pjobs += _screened_wide(f, current, singles, grown, o)
        if not pjobs:
            break
        _lm(f.problem, pjobs, o.max_iter, ftol=1e-7)  # the base step: the costliest fits
        pscored = [_Scored(j, j.tag, j.effects, n_sub=f.problem.n_sub) for j in pjobs]
        f.score(pscored)
        considered += pscored
        best = min(pscored, key=lambda s: s.rmse_val)
        ref = current or base
        companion = current is not None and _adds_companion(best, current)
        if not significant(best, ref, companion=companion):
            break
        current = best
    # a structure with the simpler effect that a chosen one nests (Coulomb friction
    # for hysteresis), within min_improvement of it and not larger, is preferred
    simpler = _simpler_rival(current, considered, o.min_improvement) if current else None
    if simpler is not None and significant(simpler, base):
        current = simpler
    if current is None:
        return accepted, None, []
    if len(current.effects) > 1:
        weights = _by_weight(f, current, considered, o.max_iter)
        current.removal = weights
        order = [e for e, _ in weights]
        # the effect whose removal costs most leads the verdict
        lead = next(s for s in singles if s.effects[0] == order[0])
        return lead, current, order
    return current, None, []


def _sparse_terms(f: _Fits, nominal: _Job, base: _Scored, ref: _Scored, significant):
    """Step 5: a sparse equation through the simulation, when the residual is not white.

    The residual of ``ref`` (the accepted structure, or the nominal). Returns ``(scored
    equations, the equation that became the verdict or None, whether an equation beat the
    named explanation without whitening the residual)``.
    """
    sjobs = fit_sparse(f.problem, f.model, nominal.values(), f.sc, f.x_scale, x0=nominal.x0)
    scored = [_Scored(j, j.tag, j.effects, n_sub=f.problem.n_sub) for j in sjobs]
    if not scored:
        return scored, None, False
    f.score(scored)
    for s in scored:
        s.p_value = p_value(base, s)
    cand = min(scored, key=lambda s: s.rmse_val)
    # it replaces an accepted named effect only when it also whitens the residual (the
    # named one did not): a closer fit alone is not a better explanation of real data
    # that neither model captures fully
    if significant(cand, ref) and (ref is base or _white(cand)):
        return scored, cand, False
    # an equation that beats the named explanation clearly, without whitening the
    # residual either: the named effect is only part of the story
    return scored, None, significant(cand, ref)


def _single_effects(f: _Fits, s: Setup, nominal, ranked, kept, n_sub_of, o: _Options):
    """Step 3: validation scores of the nominal and every screened effect.

    With the best single effect. Returns ``(base, singles, chosen, accepted or None)``.
    """
    scored = [_Scored(nominal, "nominal", (), n_sub=f.problem.n_sub)]
    scored += [
        _Scored(j, j.tag, j.effects, refit=j in kept, n_sub=n_sub_of[id(j)]) for j in ranked
    ]
    # a long validation record is simulated for the refitted candidates only
    n_val = s.rec_val.n if s.rec_val is not None else s.rec.n - s.n_fit
    checked = [x for x in scored if x.refit or n_val <= PIECES_FROM]
    f.score(checked, everyone=scored)
    base, singles = scored[0], scored[1:]
    for x in checked[1:]:
        x.p_value = p_value(base, x)
    refitted = [x for x in singles if x.refit]
    chosen = (
        _choose(refitted, o.tie_tolerance, o.min_improvement, s.rec.ts) if singles else None
    )
    significant = Significance(o.min_improvement, o.alpha)
    accepted = chosen if chosen is not None and significant(chosen, base) else None
    return base, singles, chosen, accepted


def _discover(model, data, validation, stages: _Stages, o: _Options) -> MismatchResult:
    """:func:`discover_mismatch`'s steps (arguments checked there, budget set)."""
    t = {"start": stages.start}
    model, s = prepare(
        model,
        data,
        validation,
        data_name=o.data_name,
        validation_name=o.validation_name,
        input_hold=o.input_hold,
    )
    significant = Significance(o.min_improvement, o.alpha)
    stages.enter("nominal fit")
    problem, nominal = _fit_nominal(model, s, o.data_name)
    t["nominal"] = time.perf_counter()
    stages.leave()
    x_nominal = problem.states(nominal.values(), nominal.x0)  # along the fitted samples
    sc: Scales = _nominal_scales(
        model, s.rec, nominal.values(), problem.n_sub, (x_nominal, problem.sample_index())
    )
    x_scale = {name: sc.x_scale(name) for name in model.states}
    stages.enter("screening")
    clipped = clipped_outputs(s.rec.outputs)
    cands = attach_candidates(model, sc, o.effects, extra=o.candidates, clipped=clipped)
    constants = [e for e in cands if e.candidate.attach == PARAMETER_ATTACH]
    cands = [e for e in cands if e.candidate.attach != PARAMETER_ATTACH]
    cands += promising_constants(problem, nominal, constants)
    jobs, ranked, kept = _screen(
        model, problem, sc, x_scale, nominal, cands, o.screen_iter, o.keep
    )
    stages.leave()
    stages.enter("refit")
    problems, n_sub_of = _refit(
        model, problem, sc, x_scale, ranked, kept, o.max_iter, s.rec.ts
    )
    t["screen"] = time.perf_counter()
    f = _Fits(model, problem, problems, s.rec_val, sc, x_scale)
    stages.leave()
    stages.enter("validation")
    base, singles, chosen, accepted = _single_effects(
        f, s, nominal, ranked, kept, n_sub_of, o
    )
    stages.leave()
    pair, pair_order = None, []
    stages.enter("pairs")
    if o.pairs and stages.over():
        stages.skipped.append("pairs")
    elif o.pairs:
        accepted, pair, pair_order = _forward_selection(
            f, singles, accepted, base, significant, stages, o
        )
    stages.leave()
    stages.enter("data-driven terms")
    sparse_scored, sparse_best, beaten = [], None, None
    ref = pair or accepted or base
    t["sparse"] = 0.0
    wanted = (o.effects is None or SPARSE_ID in o.effects) and not _white(ref)
    if wanted and stages.over():
        stages.skipped.append("data-driven terms")
    elif wanted:
        t0 = time.perf_counter()
        sparse_scored, sparse_best, beat = _sparse_terms(f, nominal, base, ref, significant)
        if sparse_best is not None:
            accepted, pair = sparse_best, None
        elif beat:  # the named explanation an equation beat
            beaten, accepted, pair = ref, None, None
        t["sparse"] = time.perf_counter() - t0
    stages.leave()
    stages.enter("localisation")
    t["end"] = time.perf_counter()
    t["counts"] = (len(cands), len(jobs))
    sel = _Selection(
        base,
        singles,
        accepted,
        pair,
        pair_order,
        sparse_scored,
        sparse_best or chosen,
        beaten,
    )
    return _conclude(model, s, f, nominal, x_nominal, sel, o, stages, t)


@dataclasses.dataclass
class _Selection:
    """What the steps selected.

    The nominal's score, every single effect's, the accepted effect or structure (None:
    none), the equations tried.
    """

    base: _Scored
    singles: list
    accepted: _Scored | None
    pair: _Scored | None  # the accepted structure of several effects
    pair_order: list  # its effects, the weightiest first
    sparse_scored: list
    top: _Scored | None  # the candidate table's first row
    beaten: _Scored | None  # a named explanation an equation beat


def _conclude(model, s, f, nominal, x_nominal, sel: _Selection, o, stages, t):
    """Verdict, warnings, candidate table, timings: the result."""
    final = sel.pair or sel.accepted
    verdict = build_verdict(
        model,
        s.rec,
        accepted=sel.accepted,
        pair=sel.pair,
        pair_order=sel.pair_order,
        base=sel.base,
        singles=sel.singles,
        sparse_scored=sel.sparse_scored,
        beaten=sel.beaten,
        tie_tolerance=o.tie_tolerance,
        inactive=inactive_params(f.problem, final) if final is not None else frozenset(),
        sparse_tried=t["sparse"] > 0,  # the stage's seconds: 0 when it did not run
    )
    add_warnings(verdict, (final or sel.base).job, stages.report())
    for text in verdict["warnings"]:
        warnings.warn(f"mismatch: {text}", ConvergenceWarning, stacklevel=2)
    timings = {
        "nominal_s": t["nominal"] - t["start"],
        "screen_refit_s": t["screen"] - t["nominal"],
        "sparse_s": t["sparse"],
        "total_s": t["end"] - t["start"],
        "n_candidates": t["counts"][0],
        "n_jobs": t["counts"][1],
    }
    table = candidate_table(sel.singles, sel.sparse_scored, sel.base, sel.top)
    return _result(
        model, s, f.problem, nominal, x_nominal, sel.base, final, verdict, table, timings
    )
