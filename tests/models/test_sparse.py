"""The data-driven fallback of mismatch discovery (pdmkit.models.mismatch._sparse)."""

import numpy as np
import pytest

from pdmkit.errors import ModelError
from pdmkit.models.mismatch._candidates import CANDIDATE_IDS, Effect, candidate_library
from pdmkit.models.mismatch._cases import generate_concealed_case
from pdmkit.models.mismatch._discover import discover_mismatch
from pdmkit.models.mismatch._sparse import (
    SparseTerms,
    Term,
    library_terms,
    sparse_equation,
    stlsq_path,
)
from pdmkit.models.ode import showcase_model
from pdmkit.models.ode._modelfile import OdeModel
from pdmkit.models.ode._simulate import simulate_ode


def test_term_labels_parse_and_values():
    rng = np.random.default_rng(0)
    x, v = rng.normal(size=50), rng.normal(size=50)
    cases = {
        "x**2*v": x**2 * v,
        "abs(v)*v": np.abs(v) * v,
        "sqrt(x)": np.sqrt(np.abs(x)),
        "x*v": x * v,
        "1": np.ones(50),
    }
    for label, ref in cases.items():
        term = Term.parse(label)
        assert Term.parse(term.label) == term  # the label reads back
        np.testing.assert_allclose(
            term.evaluate(np, {"x": x, "v": v}, {}, {}) * np.ones(50), ref
        )
    # smooth sign: tanh(v / eps) -> sign(v) away from zero
    far = np.array([-3.0, -1.0, 1.0, 3.0])
    s = Term.parse("sign(v)").evaluate(np, {"v": far}, {}, {"v": 1e-4})
    np.testing.assert_allclose(s, np.sign(far))
    assert Term.parse("v*x**2").label == "x**2*v"  # canonical order
    with pytest.raises(ModelError, match="cannot read factor"):
        Term.parse("exp(x)")


def test_equation_text():
    assert sparse_equation("h1", ["sqrt(h1)", "1"], [-0.5, 2e-4]) == (
        "dh1/dt += -0.5*sqrt(h1) + 0.0002"
    )


def test_stlsq_recovers_the_support_of_a_sparse_linear_model():
    rng = np.random.default_rng(1)
    n, p = 400, 12
    J = rng.normal(size=(n, p))
    J[:, 5] = J[:, 4] + 0.3 * rng.normal(size=n)  # correlated columns
    truth = np.zeros(p)
    truth[[0, 4, 9]] = [1.5, -2.0, 0.7]  # column 0 is an unpenalised parameter
    r = -(J @ truth) + 0.05 * rng.normal(size=n)
    path = stlsq_path(r, J, list(range(1, p)), np.zeros(p - 1))
    m = n
    bic = [m * np.log(2 * c / m) + (1 + len(a)) * np.log(m) for a, _, c in path]
    active, step, _ = path[int(np.argmin(bic))]
    assert sorted(1 + a for a in active) == [4, 9]
    # coefficients equal the least-squares fit on the true support (numpy reference)
    cols = [0, 4, 9]
    ref = np.linalg.lstsq(J[:, cols], -r, rcond=None)[0]
    np.testing.assert_allclose(step[cols], ref, rtol=1e-6)


def test_library_leaves_out_terms_of_free_parameters():
    msd = showcase_model("mass_spring_damper")
    t = np.linspace(0, 6, 300)
    X = {"x": 0.1 * np.sin(3 * t), "v": 0.3 * np.cos(3 * t)}
    U = {"F": 30 * np.sign(np.sin(0.7 * t))}
    labels = [term.label for term in library_terms(msd, "v", X, U, msd.params)]
    assert "x" not in labels  # k is free: a term in x only re-tunes it
    for want in ("x**2*v", "x**3", "abs(v)*v", "sign(v)", "v", "F", "1"):
        assert want in labels
    assert len(labels) == len(set(labels))
    with pytest.raises(ModelError, match="is not a state that can receive a term"):
        library_terms(msd, "x", X, U, msd.params)


def test_sparse_term_simulates_like_the_equation_written_by_hand():
    msd = showcase_model("mass_spring_damper")
    c = -300.0

    def rhs(t, x, u, p):
        acc = (u["F"] - p["c"] * x["v"] - p["k"] * x["x"]) / p["m"] + c * x["x"] ** 2 * x[
            "v"
        ]
        return {"x": x["v"], "v": acc}

    by_hand = OdeModel(msd.states, msd.inputs, msd.outputs, msd.params, rhs)
    t = np.arange(300) * 0.01
    F = np.repeat(np.random.default_rng(2).normal(0, 40, 30), 10)
    cand = SparseTerms([Term.parse("x**2*v")], [2.0], {})
    eff = Effect(cand, "v")
    got = simulate_ode(
        msd, t, {"F": F}, effects=[eff], effect_params={"sparse@v.c0": c / 2}
    )
    ref = simulate_ode(by_hand, t, {"F": F})
    np.testing.assert_allclose(got.outputs["x"], ref.outputs["x"], rtol=1e-10, atol=1e-12)
    # distinct term sets are distinct effects (a batch may carry several)
    other = Effect(SparseTerms([Term.parse("v")], [2.0], {}), "v")
    assert eff != other and len({eff, other}) == 2
    assert "sparse" in CANDIDATE_IDS and candidate_library()["id"].iloc[-1] == "sparse"


@pytest.mark.slow
def test_concealed_term_outside_the_library_is_found_as_an_equation():
    case = generate_concealed_case("sparse", 0.25, seed=7, n_samples=900)
    assert case.target == "v" and case.params["term"] == "x**2*v"
    named = ["coulomb_friction", "viscous_friction", "quadratic_drag", "cubic_stiffness"]
    res = discover_mismatch(case.model, case.data, effects=[*named, "sparse"], pairs=False)
    v = res.verdict
    assert v["effect"] == "sparse" and v["target"] == "v"
    assert "x**2*v" in v["params"]["equation"]
    assert v["params"]["equation"].startswith("dv/dt += ")
    np.testing.assert_allclose(v["params"]["x**2*v"], case.params["coefficient"], rtol=0.15)
    assert res.fit["rmse_augmented"] <= 0.5 * res.fit["rmse_nominal"]
    # the named candidates were tried and lost to it
    assert set(named) <= set(res.candidates["effect"])
    assert res.candidates["effect"].iloc[0] == "sparse"


@pytest.mark.slow
def test_named_effect_is_not_replaced_by_the_fallback():
    case = generate_concealed_case("quadratic_drag", 0.3, seed=4, n_samples=900)
    res = discover_mismatch(
        case.model,
        case.data,
        effects=["viscous_friction", "quadratic_drag", "sparse"],
        pairs=False,
    )
    assert (res.verdict["effect"], res.verdict["target"]) == ("quadratic_drag", "v")
