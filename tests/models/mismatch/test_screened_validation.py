"""A screened-only structure is validated from the nominal's fitted initial state.

Only the refitted structures (and the nominal) get their own initial-state fit on a
validation recording; one that was only screened starts where the nominal's fit put
that recording's state (its score is a screen's too). Checked with an effect at its
neutral value, where the structure *is* the nominal model: from the same state its
validation outputs must equal the nominal's to rounding. The shared state must be the
one fitted on the validation recording, not the training recording's, which is also
checked: the validation half starts elsewhere, and a simulation from the training
state misses it.
"""

import numpy as np

from pdmkit.models.mismatch._candidates import attach_candidates
from pdmkit.models.mismatch._cases import generate_concealed_case
from pdmkit.models.mismatch._fit_problem import _lm, _make_jobs, _Problem
from pdmkit.models.mismatch._sampling import _nominal_scales
from pdmkit.models.mismatch._select import _rmse, _Scored, _validate_one
from pdmkit.models.mismatch._setup import prepare


def _setup():
    case = generate_concealed_case("coulomb_friction", 0.2, seed=3, n_samples=800)
    d = case.data
    half = len(d) // 2
    train = d.iloc[:half].reset_index(drop=True)
    val = d.iloc[half:].reset_index(drop=True)
    model, s = prepare(
        case.model, train, val, data_name="train", validation_name="val", input_hold="auto"
    )
    problem = _Problem(model, s.rec, s.n_fit, s.w, s.n_sub)
    (nominal,) = _make_jobs(model, (), None, [{}], s.values0, s.x_scale, tag="nominal")
    _lm(problem, [nominal], 40)
    along = (problem.states(nominal.values(), nominal.x0), problem.sample_index())
    sc = _nominal_scales(model, s.rec, nominal.values(), problem.n_sub, along)
    (eff,) = attach_candidates(model, sc, ["viscous_friction"])
    neutral = {f"{eff.key}.{k}": float(v) for k, v in eff.neutral.items()}
    jobs = [
        _make_jobs(
            model,
            (eff,),
            sc,
            [neutral],
            nominal.values(),
            s.x_scale,
            tag=eff.key,
            x0=nominal.x0,
        )[0]
        for _ in range(2)
    ]
    return model, s, problem, nominal, jobs


def test_screened_structure_starts_from_the_nominals_validation_state():
    model, s, problem, nominal, (screened, refitted) = _setup()
    scored = [
        _Scored(nominal, "nominal", ()),
        _Scored(screened, screened.tag, screened.effects, refit=False),
        _Scored(refitted, refitted.tag, refitted.effects, refit=True),
    ]
    _validate_one(model, problem, s.rec_val, scored, s.x_scale, 30)
    base, only_screened, own_fit = scored
    np.testing.assert_allclose(only_screened.y_val, base.y_val, rtol=0, atol=1e-12)
    # the refitted one has a fit of its own, from its own start: the same optimum
    # within the fit's tolerance, not to rounding
    assert abs(own_fit.rmse_val - base.rmse_val) <= 0.05 * base.rmse_val
    # the shared state is the validation recording's: from the training state the
    # same model misses the validation half's start
    rows = [(nominal, nominal.values(), nominal.x0)]
    pv = _Problem(model, s.rec_val, s.rec_val.n, s.w, problem.n_sub)
    y_val = s.rec_val.y(model)
    naive = pv.simulate(rows, n=s.rec_val.n)[0]
    head = slice(0, 20)  # the initial state shapes the start of the record
    fitted_start = _rmse(base.y_val[head] - y_val[head], s.w)
    assert _rmse(naive[head] - y_val[head], s.w) > 3 * fitted_start
