"""Data-driven fallback of mismatch discovery: a sparse term found through the simulation.

When no named candidate of :mod:`pdmkit.models.mismatch._candidates` explains the residual,
pdmkit looks for a short equation instead: a sum of a few functions of the states and
inputs (monomials up to degree 3, ``abs``, ``sign``, ``sqrt`` of levels and pressures,
``v*abs(v)``) added to the derivative of one state. The terms are selected by
sequentially thresholded least squares (STLSQ, the SINDy algorithm of Brunton, Proctor &
Kutz, PNAS 2016) applied not to differentiated data but to the *output sensitivities*
of the simulation: around the current fit the weighted output residual is linear in the
term coefficients, ``r + J dc``, with ``J`` the finite-difference Jacobian of one
batched simulation. The surviving coefficients (with the free parameters and the initial
state) are then refined by simulation-error Levenberg-Marquardt, the Jacobian is
re-linearised there and the selection repeated until it stops changing; finally, terms
whose removal lowers the BIC are pruned. The result is reported as an equation such as
``dv/dt += -2.31*x**2*v``.

Every coefficient is fitted in normalised form: ``c_j`` is the RMS contribution of term
``j`` to the derivative in units of the derivative's own RMS on the nominal trajectory,
so one threshold fits all terms; :meth:`SparseTerms.equation` converts to raw units.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models.mismatch._candidates import Candidate, Effect, ParamSpec, Scales
from pdmkit.models.mismatch._fit_problem import _fd_jacobians, _fd_rows, _lm, _make_jobs
from pdmkit.models.mismatch._sparse_compiled import SOURCE, term_row
from pdmkit.models.mismatch._stlsq import stlsq_path
from pdmkit.models.ode import register_effects

if TYPE_CHECKING:
    from pdmkit.models.ode import OdeModel

__all__ = ["SparseTerms", "Term", "library_terms", "sparse_equation", "stlsq_path"]

#: state kinds whose derivative may receive a data-driven term (not kinematic identities)
_TARGET_KINDS = (
    "velocity",
    "angular_velocity",
    "level",
    "pressure",
    "temperature",
    "flow",
    "current",
    "voltage",
    "other",
)
_VEL = ("velocity", "angular_velocity")
_LEVEL = ("level", "pressure")
#: relative cost change below which a refit of an equation stops (twice in a row): the
#: selection compares equations by BIC, which a change this small does not reorder
SPARSE_FTOL = 1e-4


# ---------------------------------------------------------------------------- terms
def _factor(xp, f, x, u, eps):
    var, op = f
    a = x[var] if var in x else u[var]
    if op == 1:
        return a
    if isinstance(op, int):
        return a**op
    if op == "abs":
        return xp.abs(a)
    if op == "sign":
        return xp.tanh(a / eps[var])
    if op == "sqrt":
        return xp.sqrt(xp.abs(a))
    raise ModelError(f"Term: unknown factor op {op!r}; use 1, 2, 3, abs, sign or sqrt.")


def _factor_key(f: tuple[str, int | str]) -> tuple:
    var, op = f
    return (0, str(op), var) if isinstance(op, str) else (1, -op, var)


@dataclasses.dataclass(frozen=True)
class Term:
    """A product of factors ``(variable, op)``; op is 1, 2, 3, "abs", "sign" or "sqrt".

    ``sign`` is evaluated smoothly as ``tanh(a / eps)`` (``eps`` per variable) so the
    simulation stays differentiable; ``sqrt`` is ``sqrt(abs(a))``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._sparse import Term
    >>> t = Term((("x", 2), ("v", 1)))
    >>> t.label
    'x**2*v'
    >>> float(t.evaluate(np, {"x": 2.0, "v": 3.0}, {}, {}))
    12.0
    >>> Term.parse("abs(v)*v") == Term((("v", "abs"), ("v", 1)))
    True
    """

    factors: tuple[tuple[str, int | str], ...]

    def __post_init__(self) -> None:
        # canonical order (functions, then powers high to low, then names)
        object.__setattr__(self, "factors", tuple(sorted(self.factors, key=_factor_key)))

    @property
    def label(self) -> str:
        if not self.factors:
            return "1"
        parts = []
        for var, op in self.factors:
            if op == 1:
                parts.append(var)
            elif isinstance(op, int):
                parts.append(f"{var}**{op}")
            else:
                parts.append(f"{op}({var})")
        return "*".join(parts)

    @property
    def variables(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(v for v, _ in self.factors))

    def evaluate(
        self,
        xp,
        x: Mapping,
        u: Mapping,
        eps: Mapping[str, float],
        cache: dict | None = None,
    ):
        """The term's value; ``cache`` shares factor values between terms of one call."""
        cache = {} if cache is None else cache
        out = None
        for f in self.factors:
            v = cache.get(f)
            if v is None:
                v = cache[f] = _factor(xp, f, x, u, eps)
            out = v if out is None else out * v
        return 1.0 if out is None else out

    @classmethod
    def parse(cls, text: str) -> Term:
        """Build a term from its label (``"x**2*v"``, ``"sign(v)"``, ``"1"``)."""
        text = text.replace(" ", "")
        if text == "1":
            return cls(())
        factors = []
        for part in text.split("*"):
            if not part:
                continue
            factors.append(part)
        out: list[tuple[str, int | str]] = []
        i = 0
        while i < len(factors):
            f = factors[i]
            if i + 1 < len(factors) and factors[i + 1].isdigit() and f.isidentifier():
                out.append((f, int(factors[i + 1])))
                i += 2
                continue
            if f.endswith(")") and "(" in f:
                op, var = f[:-1].split("(", 1)
                if op not in ("abs", "sign", "sqrt") or not var.isidentifier():
                    raise ModelError(f"Term.parse: cannot read factor {f!r} of {text!r}.")
                out.append((var, op))
            elif f.isidentifier():
                out.append((f, 1))
            else:
                raise ModelError(
                    f"Term.parse: cannot read factor {f!r} of {text!r}; write products of "
                    "names, name**k, abs(name), sign(name) or sqrt(name)."
                )
            i += 1
        return cls(tuple(out))


def sparse_equation(target: str, labels: Sequence[str], coefs: Sequence[float]) -> str:
    """``d<target>/dt += c1*term1 + c2*term2`` with 3 significant digits.

    Examples
    --------
    >>> from pdmkit.models.mismatch._sparse import sparse_equation
    >>> sparse_equation("v", ["x**2*v", "sign(v)"], [-2.3141, 0.5])
    'dv/dt += -2.31*x**2*v + 0.5*sign(v)'
    """
    parts = []
    for lab, c in zip(labels, coefs, strict=True):
        mag = f"{abs(c):.3g}"
        body = mag if lab == "1" else f"{mag}*{lab}"
        if not parts:
            parts.append(f"-{body}" if c < 0 else body)
        else:
            parts.append(f"- {body}" if c < 0 else f"+ {body}")
    return f"d{target}/dt += " + (" ".join(parts) if parts else "0")


class SparseTerms(Candidate):
    """The data-driven candidate: ``d target/dt += f_s * sum_j c_j * n_j * term_j``.

    One instance per set of terms (its ``param_names`` are ``c0, c1, ...``); ``norms``
    ``n_j`` make every ``c_j`` the RMS contribution of its term relative to ``f_s``,
    the RMS of the target's nominal derivative.

    Parameters
    ----------
    terms : sequence of Term
    norms : sequence of float
        Raw coefficient of term j per unit of ``c_j``.
    eps : dict of str to float
        Smoothing width of ``sign`` per variable.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._sparse import SparseTerms, Term
    >>> from pdmkit.models.mismatch._candidates import Effect
    >>> cand = SparseTerms([Term((("x", 2), ("v", 1)))], [0.5], {})
    >>> eff = Effect(cand, "v")
    >>> eff.key, eff.param_names
    ('sparse@v', ('c0',))
    >>> dx = cand.derivs(np, eff, {"c0": np.array([2.0])}, 0.0,
    ...                  {"x": np.array([3.0]), "v": np.array([1.0])}, {},
    ...                  {"v": np.array([0.0])})
    >>> dx["v"].tolist()
    [9.0]
    >>> cand.equation(eff, {"c0": -4.0})
    'dv/dt += -2*x**2*v'
    """

    id = "sparse"
    attach = "state"
    physics = (
        "Data-driven term (no named candidate explains the residual; found by sparse "
        "regression through the simulation): {equation}."
    )

    def __init__(
        self, terms: Sequence[Term], norms: Sequence[float], eps: Mapping[str, float]
    ):
        self.terms = tuple(terms)
        self.norms = tuple(float(n) for n in norms)
        if len(self.terms) != len(self.norms):
            raise ModelError("SparseTerms: terms and norms must have the same length.")
        self.eps = dict(eps)
        self.param_names = tuple(f"c{j}" for j in range(len(self.terms)))
        self.neutral = dict.fromkeys(self.param_names, 0.0)

    @property
    def signature(self) -> tuple:
        return (self.terms, self.norms)

    @property
    def labels(self) -> list[str]:
        return [t.label for t in self.terms]

    def specs(self, eff, sc):
        return {p: ParamSpec(p, -1e4, 1e4, False, 1.0) for p in self.param_names}

    def guesses(self, eff, sc):
        return [dict.fromkeys(self.param_names, 0.0)]

    #: the term in the compiled loops, with its terms as numbers (._sparse_compiled)
    compiled_derivs = SOURCE

    def compiled_options(self, eff: Effect, layout: Mapping) -> list[float] | None:
        return term_row(self.terms, self.norms, self.eps, layout)

    def derivs(self, xp, eff, th, t, x, u, dx):
        s = eff.target
        acc = dx[s]
        cache: dict = {}
        for p, term, n in zip(self.param_names, self.terms, self.norms, strict=True):
            acc = acc + (th[p] * n) * term.evaluate(xp, x, u, self.eps, cache)
        dx[s] = acc
        return dx

    def raw(self, values: Mapping[str, float]) -> dict[str, float]:
        """Raw coefficients keyed by term label."""
        return {
            t.label: float(values[p]) * n
            for p, t, n in zip(self.param_names, self.terms, self.norms, strict=True)
        }

    def equation(self, eff: Effect, values: Mapping[str, float]) -> str:
        raw = self.raw(values)
        return sparse_equation(eff.target, list(raw), list(raw.values()))

    def explain(self, eff, values):
        return self.physics.format(equation=self.equation(eff, values))

    def __repr__(self) -> str:
        return f"<SparseTerms {', '.join(self.labels)}>"


register_effects([SparseTerms])  # its terms run in a compiled model's loops


# ---------------------------------------------------------------------------- library
def _influences(model, target: str, X: Mapping[str, np.ndarray], U, P) -> list[str]:
    """States and inputs whose change moves ``d target/dt`` along the trajectory."""
    n = next(iter(X.values())).size
    idx = np.unique(np.linspace(0, n - 1, min(n, 40)).astype(int))
    x = {s: np.asarray(v, dtype=float)[idx] for s, v in X.items()}
    u = {k: np.asarray(v, dtype=float)[idx] for k, v in U.items()}
    with np.errstate(all="ignore"):
        base = np.asarray(model.derivatives(x, u, P)[target], dtype=float)
    out = []
    for name in [*X, *U]:
        src = x if name in x else u
        d = 1e-6 * max(float(np.std(src[name])), 1e-9)
        moved = dict(src)
        moved[name] = src[name] + d
        with np.errstate(all="ignore"):
            if name in x:
                f = model.derivatives(moved, u, P)[target]
            else:
                f = model.derivatives(x, moved, P)[target]
        if np.any(np.abs(np.asarray(f, dtype=float) - base) > 1e-9 * (np.abs(base) + 1)):
            out.append(name)
    return out


def library_terms(
    model: OdeModel,
    target: str,
    X: Mapping[str, np.ndarray],
    U: Mapping[str, np.ndarray],
    P: Mapping[str, float],
    *,
    max_terms: int = 40,
) -> list[Term]:
    """The candidate functions for a data-driven term on ``d target/dt``.

    Variables: ``target``, the states and inputs its derivative depends on, and the
    position a velocity target drives. Terms: a constant; monomials up to degree 3 (all
    cross products when there are at most three variables, otherwise pairs and single
    cubes); for a variable that changes sign ``abs(a)``, ``abs(a)*a`` and, for
    velocities, ``sign(a)``; ``sqrt(a)`` for levels and pressures. Terms that repeat the
    effect of a free parameter (proportional to ``d rhs[target] / d p``) or that are
    constant along the trajectory are left out, as are exact duplicates.

    Parameters
    ----------
    model : OdeModel
    target : str
        A state whose kind admits a term (not a position or an angle).
    X, U : dict of str to ndarray (N,)
        Nominal state trajectory and inputs.
    P : dict of str to float
        Parameter values of the nominal fit.
    max_terms : int
        Keep at most this many (lowest degree first).

    Returns
    -------
    list of Term

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch._sparse import library_terms
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.linspace(0, 6, 300)
    >>> X = {"x": 0.1 * np.sin(3 * t), "v": 0.3 * np.cos(3 * t)}
    >>> U = {"F": np.sign(np.sin(t))}
    >>> labels = [term.label for term in library_terms(msd, "v", X, U, msd.params)]
    >>> "x**2*v" in labels, "x" in labels     # x repeats the free stiffness k
    (True, False)
    """
    kind = model.states.get(target)
    if kind not in _TARGET_KINDS:
        raise ModelError(
            f"library_terms: {target!r} is not a state that can receive a term (kinds "
            f"{', '.join(_TARGET_KINDS)}); got kind {kind!r}."
        )
    data = {**{k: np.asarray(v, float) for k, v in U.items()}}
    data.update({k: np.asarray(v, float) for k, v in X.items()})
    vars_ = _term_variables(model, target, kind, data, X, U, P)
    kinds = {**dict.fromkeys(U, "input"), **model.states}
    terms = _candidate_terms(vars_, data, kinds)
    n = data[target].size
    idx = np.unique(np.linspace(0, n - 1, min(n, 400)).astype(int))
    xs = {s: data[s][idx] for s in X}
    us = {k: data[k][idx] for k in U}
    sens = _parameter_sensitivities(model, target, xs, us, P)
    eps = {v: 0.01 * max(float(np.std(data[v])), 1e-12) for v in vars_}
    kept, seen = [], []
    for term in terms:
        phi = np.broadcast_to(np.asarray(term.evaluate(np, xs, us, eps), float), idx.shape)
        if term.factors and not (np.std(phi) > 1e-12 * (1 + np.max(np.abs(phi)))):
            continue
        unit = phi / max(float(np.linalg.norm(phi)), 1e-300)
        if any(abs(float(np.dot(unit, s))) > 0.9999 for s in seen):
            continue
        if any(abs(_corr(phi, g)) > 0.9999 for g in sens):
            continue
        seen.append(unit)
        kept.append(term)
    return kept[:max_terms]


def _term_variables(model, target: str, kind: str, data: dict, X, U, P) -> list[str]:
    """The target, what its derivative depends on and the position a velocity drives."""
    vars_ = [target]
    for name in _influences(model, target, X, U, P):
        if name not in vars_:
            vars_.append(name)
    if kind in _VEL:
        want = "position" if kind == "velocity" else "angle"
        for s, k in model.states.items():
            if k == want and s not in vars_:
                vars_.append(s)
    return [v for v in vars_ if np.std(data[v]) > 1e-12 * (1 + np.max(np.abs(data[v])))]


def _candidate_terms(vars_: list[str], data: dict, kinds: dict) -> list[Term]:
    """A constant, monomials up to degree 3 and the sign-changing / level functions."""
    terms: list[Term] = [Term(())]
    full = len(vars_) <= 3
    for deg in (1, 2, 3):
        for combo in itertools.combinations_with_replacement(vars_, deg):
            if not full and deg == 3 and len(set(combo)) > 1:
                continue
            counts: dict[str, int] = {}
            for v in combo:
                counts[v] = counts.get(v, 0) + 1
            terms.append(Term(tuple(counts.items())))
    for v in vars_:
        a = data[v]
        if np.min(a) < 0 < np.max(a):
            terms.append(Term(((v, "abs"),)))
            terms.append(Term(((v, "abs"), (v, 1))))
            if kinds[v] in _VEL:
                terms.append(Term(((v, "sign"),)))
        if kinds[v] in _LEVEL:
            terms.append(Term(((v, "sqrt"),)))
    return terms


def _parameter_sensitivities(model, target: str, xs: dict, us: dict, P) -> list:
    """``d rhs[target] / d p`` of each free parameter: a term along one only re-tunes p."""
    sens = []
    with np.errstate(all="ignore"):
        f0 = np.asarray(model.derivatives(xs, us, P)[target], dtype=float)
        for p in model.free:
            dp = 1e-6 * max(abs(P[p]), 1e-9)
            f1 = model.derivatives(xs, us, {**P, p: P[p] + dp})[target]
            g = (np.broadcast_to(np.asarray(f1, dtype=float), f0.shape) - f0) / dp
            if np.all(np.isfinite(g)) and np.std(g) > 0:
                sens.append(g)
    return sens


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    """Cosine similarity (uncentred: terms act through their value, not deviations)."""
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na == 0 or nb == 0:
        return 0.0
    return float(np.dot(a, b) / (na * nb))


def make_sparse_effect(
    model,
    target: str,
    terms: Sequence[Term],
    X: Mapping[str, np.ndarray],
    U: Mapping[str, np.ndarray],
    sc: Scales,
) -> Effect:
    """An :class:`Effect` with normalised coefficients for ``terms`` on ``target``."""
    data = {**U, **X}
    eps = {
        v: 0.01 * (sc.x_scale(v) if v in X else max(sc.u_std.get(v, 1.0), 1e-12))
        for t in terms
        for v in t.variables
    }
    fs = sc.f_scale(target)
    norms = []
    for t in terms:
        phi = np.asarray(t.evaluate(np, data, data, eps), float)
        rms = float(np.sqrt(np.mean(np.square(phi)))) if phi.ndim else abs(float(phi))
        norms.append(fs / max(rms, 1e-300))
    return Effect(SparseTerms(terms, norms, eps), target)


# ---------------------------------------------------------------------------- fitting
def _jacobian(problem, job):
    """Weighted residual ``r`` at the job's point, its Jacobian ``J`` and ``recover(d)``.

    ``J`` is the finite-difference Jacobian in the job's parameters; ``recover(d)`` gives
    the change of the pieces' initial states that goes with a parameter step ``d``.

    The initial states are nuisance values: ``r`` and ``J`` are projected onto what
    they cannot explain (piece by piece), so a selection on ``(r, J)`` is the selection
    with the initial states refitted at every step.
    """
    rows, steps, dx = _fd_rows(job, job.theta, job.x0)
    R = problem.residuals(problem.simulate(rows))
    R = np.where(np.isfinite(R), R, 0.0)
    r, J, Jx = _fd_jacobians(R, 0, job, steps, dx)
    if Jx is None:
        return r, J, lambda d: np.zeros_like(job.x0)
    K, mk, _ = Jx.shape
    pinv = np.linalg.pinv(Jx)  # (K, nx, mk)
    rk, Jk = r.reshape(K, mk), J.reshape(K, mk, -1)
    r_p = rk - np.einsum("kmi,kil,kl->km", Jx, pinv, rk)
    J_p = Jk - np.einsum("kmi,kil,klj->kmj", Jx, pinv, Jk)

    def recover(d):
        return -np.einsum("kil,kl->ki", pinv, rk + Jk @ d)

    return r_p.ravel(), J_p.reshape(K * mk, -1), recover


def _bic_lin(cost: float, m: int, k: int) -> float:
    return m * math.log(max(2.0 * cost / m, 1e-300)) + k * math.log(m)


def fit_sparse(
    problem,
    model,
    values: Mapping[str, float],
    sc: Scales,
    x_scale: Mapping[str, float],
    targets: Sequence[str] | None = None,
    *,
    max_rounds: int = 3,
    max_iter: int = 20,
    refit_sets: int = 3,
    max_terms: int = 4,
    max_targets: int = 1,
    x0: np.ndarray | None = None,
) -> list:
    """Data-driven terms for each target state, selected by STLSQ through the simulation.

    Parameters
    ----------
    problem : _Problem
        The training problem of the nominal fit (recording, span, weights, step).
    model : OdeModel
    values : dict
        The fitted nominal values (``p:``, ``x0:``).
    sc : Scales
    x_scale : dict
    targets : sequence of str, optional
        States to try (default: every state whose kind admits a term).
    max_rounds : int
        Re-linearisations of the selection.
    max_iter : int
        Levenberg-Marquardt iterations of each refit.
    refit_sets : int
        Active sets (lowest linearised BIC first) refitted by simulation each round.
    max_terms : int
        Largest number of terms in an equation (a readable term, and a bounded cost).
    max_targets : int
        Targets refitted by simulation, best linearised BIC first (the others are only
        linearised).
    x0 : ndarray, shape (n_pieces, n_states), optional
        The nominal fit's initial state of every fitted piece (default: ``values``'
        ``x0:`` entries, the other pieces guessed from the data).

    Returns
    -------
    list of _Job
        One fitted job per refitted target (its effect a :class:`SparseTerms` with the
        selected terms), tagged ``"sparse@<target>"``.

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import generate_concealed_case
    >>> from pdmkit.models.mismatch._discover import discover_mismatch
    >>> case = generate_concealed_case("sparse", 0.3, seed=0, n_samples=600)
    >>> res = discover_mismatch(case.model, case.data, effects=["sparse"])
    >>> res.verdict["effect"], res.verdict["target"], case.params["term"]
    ('sparse', 'v', 'x**2*v')
    >>> "x**2*v" in res.verdict["params"]["equation"]
    True
    """
    base = {k: v for k, v in values.items() if not k.startswith("sparse@")}
    P = {k: base.get(f"p:{k}", v) for k, v in model.params.items()}
    if x0 is None:
        x0 = np.array([[base[f"x0:{s}"] for s in model.states]])
    if x0.shape[0] != problem.n_pieces:
        x0 = problem.initial_pieces(x0[0])
    if targets is None:
        targets = [s for s, k in model.states.items() if k in _TARGET_KINDS]
    m = problem.n_res
    ctx = _rank_targets(problem, model, targets, base, P, x0, sc, x_scale, max_terms)
    out = []
    for _, target, eff_all, lin, ranked in ctx[:max_targets]:
        fit = _SparseFit(problem, model, eff_all, target, sc, x_scale, m)
        best_job = fit.select(lin, ranked, max_rounds, refit_sets, max_iter, max_terms)
        if best_job is not None:
            out.append(_prune(problem, model, best_job, sc, x_scale, m, max_iter))
    return out


def _rank_targets(problem, model, targets, base, P, x0, sc, x_scale, max_terms):
    """The first linearisation of every target, best linearised BIC first.

    Returns ``(BIC, target, effect with every term, linearisation, ranked sets)`` per
    target that has terms and a non-empty path (only the best are refitted).
    """
    Xt = problem.states(base, x0)  # along the fitted samples
    X = {s: Xt[:, j] for j, s in enumerate(model.states)}
    U = {k: v[problem.sample_index()] for k, v in problem.rec.inputs.items()}
    ctx = []
    for target in targets:
        terms = library_terms(model, target, X, U, P)
        if len(terms) == 0:
            continue
        eff_all = make_sparse_effect(model, target, terms, X, U, sc)
        lin = _linearise(
            problem, model, eff_all, base, np.zeros(len(terms)), sc, x_scale, x0
        )
        ranked = _ranked_sets(lin, problem.n_res, max_terms)
        if ranked:
            ctx.append((ranked[0][0], target, eff_all, lin, ranked))
    ctx.sort(key=lambda c: c[0])
    return ctx


@dataclasses.dataclass
class _SparseFit:
    """One target's selection: linearise, refit the best active sets, repeat."""

    problem: Any
    model: Any
    eff_all: Effect  # every library term of the target
    target: str
    sc: Scales
    x_scale: Mapping[str, float]
    m: int  # residuals (for the BIC)

    def bic(self, job) -> float:
        """Linearised-cost BIC of a fitted job."""
        return _bic_lin(job.cost, self.m, job.n_fitted)

    def select(self, lin, ranked, max_rounds, refit_sets, max_iter, max_terms):
        """The best refitted job over at most ``max_rounds`` re-linearisations (or None).

        Each round refits the ``refit_sets`` best active sets by simulation; the
        selection is linearised again at the best one until the set stops changing.
        """
        key, n_terms = self.eff_all.key, len(self.eff_all.candidate.terms)
        chosen: tuple[int, ...] | None = None
        best_job = None
        for _ in range(max_rounds):
            jobs = self.refit(lin, ranked[:refit_sets])
            _lm(self.problem, jobs, max_iter, ftol=SPARSE_FTOL)
            good = [j for j in jobs if math.isfinite(j.cost)]
            if not good:
                break
            best = min(good, key=self.bic)
            if best_job is None or self.bic(best) < self.bic(best_job):
                best_job = best
            if best.active == chosen:
                break
            chosen = best.active
            bv = best.values()
            point = {k: v for k, v in bv.items() if not k.startswith(key)}
            coefs = np.zeros(n_terms)
            for i, a in enumerate(best.active):
                coefs[a] = bv[f"{key}.c{i}"]
            lin = _linearise(
                self.problem,
                self.model,
                self.eff_all,
                point,
                coefs,
                self.sc,
                self.x_scale,
                best.x0,
            )
            ranked = _ranked_sets(lin, self.m, max_terms)
            if not ranked:
                break
        return best_job

    def refit(self, lin, ranked) -> list:
        """Jobs for the active sets ``ranked``, from the linearised step of each."""
        job_all, recover = lin[0], lin[5]
        cand, key = self.eff_all.candidate, self.eff_all.key
        jobs = []
        for _, active, d in ranked:
            lin_vals = job_all.values(job_all.theta + d)
            lin_x0 = np.maximum(job_all.x0 + recover(d), job_all.x0_lo[None, :])
            sub = Effect(
                SparseTerms(
                    [cand.terms[a] for a in active],
                    [cand.norms[a] for a in active],
                    cand.eps,
                ),
                self.target,
            )
            start = {f"{key}.c{i}": lin_vals[f"{key}.c{a}"] for i, a in enumerate(active)}
            start_vals = {k: v for k, v in lin_vals.items() if not k.startswith(key)}
            jobs += _make_jobs(
                self.model,
                (sub,),
                self.sc,
                [start],
                start_vals,
                self.x_scale,
                tag=f"sparse@{self.target}",
                x0=lin_x0,
            )
            jobs[-1].active = active
        return jobs


def _linearise(problem, model, eff_all, point, coefs, sc, x_scale, x0):
    """``(job with every term, r, J, term columns)`` at ``point`` and ``coefs``."""
    key = eff_all.key
    vals = {**point, **{f"{key}.c{j}": float(c) for j, c in enumerate(coefs)}}
    job_all = _make_jobs(model, (eff_all,), sc, [{}], vals, x_scale, x0=x0)[0]
    r, J, recover = _jacobian(problem, job_all)
    names = job_all.layout.names
    tcols = [names.index(f"{key}.c{j}") for j in range(len(coefs))]
    return job_all, r, J, tcols, np.asarray(coefs, dtype=float), recover


def _ranked_sets(lin, m: int, max_terms: int):
    """STLSQ path of a linearisation, ``(linear BIC, active, step)`` best first."""
    job_all, r, J, tcols, coefs, _ = lin
    path = stlsq_path(r, J, tcols, coefs)
    k0 = job_all.n_fitted - len(tcols)
    return sorted(
        (
            (_bic_lin(cost, m, k0 + len(a)), a, d)
            for a, d, cost in path
            if 0 < len(a) <= max_terms
        ),
        key=lambda z: z[0],
    )


def _prune(problem, model, job, sc, x_scale, m, max_iter):
    """Backward elimination: drop terms while that lowers the BIC."""
    while True:
        eff = job.effects[0]
        cand = eff.candidate
        k = len(cand.terms)
        if k <= 1:
            return job
        vals = job.values()
        jobs = []
        for drop in range(k):
            keep = [i for i in range(k) if i != drop]
            sub = Effect(
                SparseTerms(
                    [cand.terms[i] for i in keep], [cand.norms[i] for i in keep], cand.eps
                ),
                eff.target,
            )
            start = {f"{eff.key}.c{n}": vals[f"{eff.key}.c{i}"] for n, i in enumerate(keep)}
            base = {q: v for q, v in vals.items() if not q.startswith(eff.key)}
            jobs += _make_jobs(
                model, (sub,), sc, [start], base, x_scale, tag=job.tag, x0=job.x0
            )
        _lm(problem, jobs, max_iter, ftol=SPARSE_FTOL)
        best = min(jobs, key=lambda j: _bic_lin(j.cost, m, j.n_fitted))
        if _bic_lin(best.cost, m, best.n_fitted) < _bic_lin(job.cost, m, job.n_fitted):
            job = best
        else:
            return job
