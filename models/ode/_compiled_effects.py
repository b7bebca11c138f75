"""Effects' terms (friction, leaks, lags, hysteresis) translated for the compiled loops.

:func:`~pdmkit.models.ode.integrate_batch` adds the terms of candidate effects to a
model's derivatives through their hooks, written with an array namespace ``xp``::

    def derivs(self, xp, eff, th, t, x, u, dx):
        v = x[eff.target]
        dx[eff.target] = dx[eff.target] - th["a"] * xp.tanh(v / th["_eps"])
        return dx

:func:`hooks_source` rewrites each hook of each registered effect class into a scalar
function that numba compiles into the same module as the model
(:mod:`pdmkit.models.ode._compiled`), so a fit whose rows carry effects runs in one
compiled loop as the model alone does. What an effect is attached to becomes numbers
read at run time from a table (:func:`effect_rows`), not constants of the source: one
compiled module serves every combination of effects and targets, compiled once per
model. The rewrite:

- ``x[eff.target]``, ``u[eff.target]``, ``dx[eff.partner]`` -> ``x[tg]`` (the index
  of the target among the states or the inputs, found when the table is built);
- ``th["a"]`` -> ``p[th0 + j]`` (the effect's values after ``prepare`` are rows of the
  parameter array, after the model's own);
- ``z[0]`` (the effect's own states) -> ``x[zo + 0]`` (appended to the states);
- ``eff.opt("w")`` / ``eff.options["w"]`` -> ``op[k]``; ``eff.partner is None`` ->
  ``pr < 0``;
- ``xp.tanh`` and the other element-wise functions -> numpy's; ``xp.where`` -> a
  conditional expression; ``xp.softplus`` and ``xp.sigmoid`` -> scalar functions that
  compute what :class:`~pdmkit.models._xp.NumpyNamespace` computes;
- ``return dx`` -> ``return`` (``dx`` is written in place); ``return [a, b]`` (the
  derivatives of the effect's own states) -> ``dx[zo + 0] = a; dx[zo + 1] = b``.

A hook that reads anything else (``self``'s attributes, a loop over a dict) leaves its
class out: batches with that effect run in numpy as before.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import types
from collections.abc import Sequence

import numpy as np

from pdmkit.models._xp import NumpyNamespace
from pdmkit.models.ode._compiled_source import (
    Untranslatable,
    _fail,
    _Rewriter,
    _source,
    element_wise,
)
from pdmkit.models.ode._integrators import DERIVATIVE_ATTACH

__all__ = [
    "HOOKS",
    "EffectHooks",
    "effect_rows",
    "hooks_source",
    "register_effects",
    "runs_compiled",
]

#: the hooks translated, with their arguments after ``self, xp, eff, th``
HOOKS = {
    "derivs": ("t", "x", "u", "dx"),
    "derivs_with_extra": ("t", "x", "u", "dx", "z"),
    "extra_derivs": ("x", "u", "z"),
}
#: stages of a table row: an input replaced by an effect's state, a term on the
#: derivatives, a term reading the effect's states, the derivatives of those states
STAGE_OVERRIDE, STAGE_DERIVS, STAGE_WITH_EXTRA, STAGE_EXTRA = 0, 1, 2, 3
_STAGE_HOOK = {1: "derivs", 2: "derivs_with_extra", 3: "extra_derivs"}

#: scalar versions of the namespace's own functions (NumpyNamespace's formulas)
XP_SHIMS = """
def _xp_logaddexp0(a):
    # numpy's npy_logaddexp(0, a)
    if a == 0.0:
        return 0.6931471805599453
    if a > 0:
        return a + np.log1p(np.exp(-a))
    if a <= 0:
        return np.log1p(np.exp(a))
    return a


def _xp_softplus(a, w):
    return w * _xp_logaddexp0(a / w)


def _xp_sigmoid(a):
    return 0.5 * (1.0 + np.tanh(0.5 * a))


def _xp_relu(a):
    return np.maximum(a, 0.0)


def _xp_clip(a, lo, hi):
    return np.minimum(np.maximum(a, lo), hi)
"""
_XP_SHIMMED = {"softplus", "sigmoid", "relu", "clip"}

_REGISTERED: list[type] = []


def register_effects(classes: Sequence[type]) -> None:
    """Offer effect classes to the compiled loops (compiled models built afterwards).

    The candidate library registers its classes when it is imported; a class whose
    hooks cannot be translated is left out when a model is compiled.

    Examples
    --------
    >>> import pdmkit.models.mismatch  # registers the library
    >>> from pdmkit.models.ode._compiled_effects import registered
    >>> len(registered()) > 10
    True
    """
    for c in classes:
        if c not in _REGISTERED:
            _REGISTERED.append(c)


def registered() -> list[type]:
    """The effect classes registered so far, in order."""
    return list(_REGISTERED)


@dataclasses.dataclass
class EffectHooks:
    """How one effect class was translated: its code and what its tables hold."""

    code: int
    #: the keys of ``th`` the hooks read, in the order of the parameter rows (None: the
    #: effect's parameters, for a class with source of its own)
    theta: list[str] | None
    #: the option names read with ``eff.opt`` (a class with source of its own gives
    #: the whole row: ``compiled_options(eff, layout)``)
    options: list[str]
    #: the namespace ``eff.target`` indexes in each hook (``"x"`` or ``"u"``)
    target_in: dict[str, str]
    #: the hooks that add something (the others are the base class's)
    hooks: list[str] = dataclasses.field(default_factory=list)


class _HookRewriter(_Rewriter):
    """One hook (or a helper it calls) rewritten into a scalar function."""

    def __init__(self, fn, kinds, info: EffectHooks, queue, hook: str | None) -> None:
        super().__init__(fn, kinds, {}, queue, None)
        self.info = info
        self.hook = hook
        self.aliases: dict[str, str] = {}  # local name -> "tg" / "pr"

    def _eff(self, node) -> bool:
        return isinstance(node, ast.Name) and self.kinds.get(node.id) == "eff"

    def _index(self, node) -> str | None:
        """``tg`` / ``pr`` when ``node`` is ``eff.target`` / ``eff.partner`` or an alias."""
        if isinstance(node, ast.Attribute) and self._eff(node.value):
            return {"target": "tg", "partner": "pr"}.get(node.attr)
        if isinstance(node, ast.Name):
            return self.aliases.get(node.id)
        return None

    def _option(self, name: str) -> ast.AST:
        if name not in self.info.options:
            self.info.options.append(name)
        k = self.info.options.index(name)
        return ast.Subscript(ast.Name("op", ast.Load()), ast.Constant(k), ast.Load())

    # statements -----------------------------------------------------------------
    def visit_Assign(self, node: ast.Assign):
        if len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            idx = self._index(node.value)
            if idx is not None:
                self.aliases[node.targets[0].id] = idx
                return None  # s = eff.target: the index itself is used
        return self.generic_visit(node)

    def visit_Return(self, node: ast.Return):
        v = node.value
        if self.hook in ("derivs", "derivs_with_extra"):
            if not (isinstance(v, ast.Name) and self.kinds.get(v.id) == "dx"):
                raise _fail(node, "a derivative hook returns something other than dx")
            return ast.copy_location(ast.Return(None), node)
        if self.hook == "extra_derivs":
            if not isinstance(v, ast.List | ast.Tuple):
                raise _fail(node, "extra_derivs returns something other than a list")
            out = []
            for j, e in enumerate(v.elts):
                idx = ast.BinOp(ast.Name("zo", ast.Load()), ast.Add(), ast.Constant(j))
                tgt = ast.Subscript(ast.Name("dx", ast.Load()), idx, ast.Store())
                out.append(ast.Assign([tgt], self.visit(e)))
            out.append(ast.Return(None))
            return [ast.copy_location(s, node) for s in out]
        return self.generic_visit(node)

    # expressions ------------------------------------------------------------------
    def visit_Subscript(self, node: ast.Subscript) -> ast.AST:
        base = node.value
        if (
            self._eff(getattr(base, "value", None))
            and getattr(base, "attr", "") == "options"
        ):
            key = node.slice
            if isinstance(key, ast.Constant) and isinstance(key.value, str):
                return ast.copy_location(self._option(key.value), node)
            raise _fail(node, "eff.options is read with a key that is not a name")
        kind = self.kinds.get(base.id) if isinstance(base, ast.Name) else None
        if kind is None:
            return self.generic_visit(node)
        key = node.slice
        if kind == "th":
            if not (isinstance(key, ast.Constant) and isinstance(key.value, str)):
                raise _fail(node, "th[...] is read with a key that is not a name")
            if key.value not in self.info.theta:
                self.info.theta.append(key.value)
            j = self.info.theta.index(key.value)
            idx = ast.BinOp(ast.Name("th0", ast.Load()), ast.Add(), ast.Constant(j))
            return ast.copy_location(
                ast.Subscript(ast.Name("p", ast.Load()), idx, node.ctx), node
            )
        if kind == "z":
            if not (isinstance(key, ast.Constant) and isinstance(key.value, int)):
                raise _fail(node, "z[...] is read with an index that is not a number")
            idx = ast.BinOp(ast.Name("zo", ast.Load()), ast.Add(), ast.Constant(key.value))
            return ast.copy_location(
                ast.Subscript(ast.Name("x", ast.Load()), idx, node.ctx), node
            )
        idx = self._index(key)
        if idx is None:
            raise _fail(node, f"{base.id}[...] is read with a key other than eff.target")
        if kind in ("x", "u") and not isinstance(node.ctx, ast.Load):
            raise _fail(node, f"{base.id}[...] is written")
        if idx == "tg" and kind in ("x", "u"):
            seen = self.info.target_in.setdefault(self.hook or "", kind)
            if seen != kind:
                raise _fail(node, "eff.target indexes both the states and the inputs")
        return ast.copy_location(
            ast.Subscript(
                ast.Name(base.id, ast.Load()), ast.Name(idx, ast.Load()), node.ctx
            ),
            node,
        )

    def visit_Name(self, node: ast.Name) -> ast.AST:
        if node.id in self.aliases:
            return ast.copy_location(ast.Name(self.aliases[node.id], ast.Load()), node)
        if self.kinds.get(node.id) in ("eff", "xp", "self"):
            raise _fail(node, f"{node.id!r} is used other than through its attributes")
        if node.id in self.kinds:
            raise _fail(node, f"{node.id!r} is used other than as {node.id}[...]")
        return super().visit_Name(node)

    def visit_Compare(self, node: ast.Compare) -> ast.AST:
        # eff.partner is None / is not None -> pr < 0 / pr >= 0
        if (
            len(node.ops) == 1
            and isinstance(node.ops[0], ast.Is | ast.IsNot)
            and isinstance(node.comparators[0], ast.Constant)
            and node.comparators[0].value is None
            and self._index(node.left) == "pr"
        ):
            op = ast.Lt() if isinstance(node.ops[0], ast.Is) else ast.GtE()
            new = ast.Compare(ast.Name("pr", ast.Load()), [op], [ast.Constant(0)])
            return ast.copy_location(new, node)
        return self.generic_visit(node)

    def visit_Attribute(self, node: ast.Attribute) -> ast.AST:
        base = node.value
        kind = self.kinds.get(base.id) if isinstance(base, ast.Name) else None
        if kind == "xp":
            return element_wise(node, "xp", {"pi": np.pi}, _XP_SHIMMED, "_xp_")
        if kind == "eff":
            idx = self._index(node)
            if idx is not None:
                return ast.copy_location(ast.Name(idx, ast.Load()), node)
            raise _fail(node, f"eff.{node.attr}")
        if kind == "self":
            raise _fail(node, f"self.{node.attr} (the class's own state)")
        return super().visit_Attribute(node)

    def visit_Call(self, node: ast.Call) -> ast.AST:
        f = node.func
        if isinstance(f, ast.Attribute) and self._eff(f.value) and f.attr == "opt":
            key = node.args[0] if len(node.args) == 1 else None
            if isinstance(key, ast.Constant) and isinstance(key.value, str):
                return ast.copy_location(self._option(key.value), node)
            raise _fail(node, "eff.opt(...) with a name that is not a constant")
        if (
            isinstance(f, ast.Attribute)
            and self.kinds.get(getattr(f.value, "id", "")) == "xp"
        ):
            if f.attr == "where" and len(node.args) == 3:
                c, a, b = (self.visit(v) for v in node.args)
                return ast.copy_location(ast.IfExp(c, a, b), node)
            if f.attr == "step" and len(node.args) == 1:
                new = ast.Compare(self.visit(node.args[0]), [ast.Gt()], [ast.Constant(0.0)])
                return ast.copy_location(new, node)
        if isinstance(f, ast.Name) and isinstance(self.glob.get(f.id), types.FunctionType):
            if node.keywords:
                raise _fail(node, f"keyword arguments in {f.id}(...)")
            drop = [
                i
                for i, a in enumerate(node.args)
                if isinstance(a, ast.Name) and self.kinds.get(a.id) == "xp"
            ]
            if any(
                isinstance(a, ast.Name) and self.kinds.get(a.id) not in (None, "xp")
                for a in node.args
            ):
                raise _fail(node, f"{f.id}(...) is passed a dict of the hook")
            called = self.queue(self.glob[f.id], tuple(drop))
            args = [self.visit(a) for i, a in enumerate(node.args) if i not in drop]
            return ast.copy_location(ast.Call(ast.Name(called, ast.Load()), args, []), node)
        return super().visit_Call(node)


def _translate_class(cls: type, code: int, helpers: dict) -> tuple[list[str], EffectHooks]:
    """The scalar functions of ``cls``'s hooks, ``_c<code>_<hook>(t, x, u, p, dx, ...)``.

    Helpers the hooks call are added to ``helpers`` (``{(function, dropped arguments):
    (name, source or None)}``) and translated here too.
    """
    info = EffectHooks(code, [], [], {})
    parts = []

    def queue(helper, drop):
        key = (helper, drop)
        if key not in helpers:
            helpers[key] = (f"_h{len(helpers)}_{helper.__name__}", None)
        return helpers[key][0]

    for hook, roles in HOOKS.items():
        fn = inspect.unwrap(getattr(cls, hook))
        node = _source(fn)
        names = [a.arg for a in node.args.args]
        if len(names) != 4 + len(roles):
            raise Untranslatable(f"{cls.__name__}.{hook} has other arguments")
        if any(n != r for n, r in zip(names[4:], roles, strict=True)):
            raise Untranslatable(f"{cls.__name__}.{hook} names its arguments otherwise")
        kinds = {names[0]: "self", names[1]: "xp", names[2]: "eff", names[3]: "th"}
        kinds.update({r: r for r in roles if r != "t"})
        rw = _HookRewriter(fn, kinds, info, queue, hook)
        body = []
        for s in node.body:
            if isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant):
                continue  # a docstring
            new = rw.visit(s)
            if new is not None:
                body.extend(new if isinstance(new, list) else [new])
        while body and isinstance(body[-1], ast.Return) and body[-1].value is None:
            body.pop()
        if not body:  # the base class's hook: nothing to add
            continue
        new_fn = ast.parse(f"def _c{code}_{hook}({_SIGNATURE}):\n    pass\n").body[0]
        new_fn.body = body
        parts.append(ast.unparse(ast.fix_missing_locations(new_fn)))
        info.hooks.append(hook)
    parts += _translate_helpers(helpers, queue)
    return parts, info


def _translate_helpers(helpers: dict, queue) -> list[str]:
    """The helpers not yet translated (``_sclip(xp, a, lo, hi, w)`` without ``xp``)."""
    parts = []
    pending = [k for k, (_, src) in helpers.items() if src is None]
    while pending:
        key = pending.pop(0)
        helper, drop = key
        name = helpers[key][0]
        node = _source(helper)
        kinds = {node.args.args[i].arg: "xp" for i in drop}
        rw = _HookRewriter(helper, kinds, EffectHooks(-1, [], [], {}), queue, None)
        node.body = [rw.visit(s) for s in node.body]
        node.args.args = [a for i, a in enumerate(node.args.args) if i not in drop]
        for a in node.args.args:
            a.annotation = None
        node.name, node.returns = name, None
        text = ast.unparse(ast.fix_missing_locations(node))
        helpers[key] = (name, text)
        parts.append(text)
        pending += [
            k for k, (_, src) in helpers.items() if src is None and k not in pending
        ]
    return parts


_SIGNATURE = "t, x, u, p, dx, tg, pr, th0, zo, op"
_DISPATCH_HEAD = f"def _hook(code, stage, {_SIGNATURE}):\n"


def hooks_source(classes: Sequence[type]) -> tuple[str, dict[type, EffectHooks], dict]:
    """Scalar source of the classes' hooks and the dispatcher ``_hook(code, stage, ...)``.

    Returns ``(source, {class: EffectHooks}, {class name: why it was left out})``.

    Examples
    --------
    >>> import pdmkit.models.mismatch
    >>> from pdmkit.models.ode._compiled_effects import hooks_source, registered
    >>> src, info, left = hooks_source(registered())
    >>> "def _hook(" in src and len(info) > 10
    True
    """
    helpers: dict = {}
    parts, info, left = [XP_SHIMS], {}, {}
    for cls in classes:
        own = getattr(cls, "compiled_derivs", None)
        if isinstance(own, str):  # scalar source of its own, options from the effect
            info[cls] = EffectHooks(len(info), None, [], {}, ["derivs"])
            parts.append(own.replace("def _derivs(", f"def _c{info[cls].code}_derivs(", 1))
            continue
        local = dict(helpers)
        try:
            texts, hooks = _translate_class(cls, len(info), local)
        except Untranslatable as exc:
            left[cls.__name__] = str(exc)
            continue
        helpers.update(local)
        parts += texts
        info[cls] = hooks
    lines = [_DISPATCH_HEAD]
    first = True
    for h in info.values():
        for stage, hook in _STAGE_HOOK.items():
            if hook in h.hooks:
                test = f"code == {h.code} and stage == {stage}"
                lines.append(f"    {'if' if first else 'elif'} {test}:\n")
                lines.append(f"        _c{h.code}_{hook}({_SIGNATURE})\n")
                first = False
    if first:
        lines.append("    pass\n")
    parts.append("".join(lines))
    return "\n\n".join(parts) + "\n", info, left


#: columns of a table row: stage, class code, target index, partner index (-1: none),
#: first parameter row of the effect's values, index of its first own state, 1 where
#: the target is an output (its index counts from the end of the states)
TABLE_COLUMNS = ("stage", "code", "target", "partner", "theta", "state", "output")


def _stage_rows(effects, extra):
    """``(stage, effect index, hook)`` in the order ``integrate_batch`` applies them."""
    rows = [
        (STAGE_OVERRIDE, i, None) for i, _ in extra if effects[i].candidate.input_override
    ]
    rows += [
        (STAGE_DERIVS, i, "derivs")
        for i, e in enumerate(effects)
        if e.candidate.attach in DERIVATIVE_ATTACH
    ]
    rows += [
        (STAGE_WITH_EXTRA, i, "derivs_with_extra")
        for i, _ in extra
        if effects[i].candidate.attach in DERIVATIVE_ATTACH
    ]
    rows += [(STAGE_EXTRA, i, "extra_derivs") for i, _ in extra]
    return rows


def effect_rows(effects, theta, masks, extra, layout, hooks, B, method):
    """The effects of a batch as a table for the compiled loops, or None.

    Parameters
    ----------
    effects, theta, masks
        As :func:`~pdmkit.models.ode.integrate_batch` holds them (``theta`` after
        ``prepare``; a mask None: every row).
    extra : list of (int, int)
        ``(effect index, offset)`` of the effects' own states.
    layout : dict
        ``{"x": states, "u": inputs, "p": parameters}`` of the model, and ``"y"``: its
        outputs where the compiled module computes them (a model with ``outputs``).
    hooks : dict
        ``{class: EffectHooks}`` of the compiled module.
    B : int
        Rows of the batch.
    method : str
        ``"rk4"``: each member evaluates only the effects it carries (the own states of
        the others stay put); ``"ros2"``: every member follows every effect's own
        states, as numpy does (the batch's step control sees them all).

    Returns
    -------
    (table, options, values) or None
        ``table`` ``(rows, 7)`` int64 (:data:`TABLE_COLUMNS`), ``options`` ``(rows, k)``,
        ``values`` ``(m, B)``: the effects' parameter rows, then each member's list of
        the table rows it carries (their number, then their indices), then the index
        of that list; appended to the model's parameters. None when an effect has no
        compiled hooks or its target is not where its hooks read it.
    """
    states, npar = layout["x"], len(layout["p"])
    # a sensor's own state follows its output: the outputs are read before the states
    # (as integrate_batch's numpy rhs sees them), where the module computes them
    lag_on_output = any(effects[i].candidate.attach == "output" for i, _ in extra)
    where = {
        "nx": len(states),
        "n_all": len(states) + sum(effects[i].candidate.n_extra for i, _ in extra),
        "outputs": list(layout.get("y") or []) if lag_on_output else [],
        "zoff": dict(extra),
    }
    values: list = []
    placed: dict[int, tuple[int, list]] = {}
    table, options, carried = [], [], []
    for stage, i, hook in _stage_rows(effects, extra):
        e = effects[i]
        h = hooks.get(type(e.candidate))
        if h is None:
            return None
        if i not in placed:
            # a key the effect does not have is read on a path it does not take
            # (overflow's share into a partner it lacks): NaN, never a number
            keys = e.param_names if h.theta is None else h.theta
            placed[i] = (npar + len(values), _options(e, h, layout))
            values += [theta[i].get(k, np.nan) for k in keys]
        th0, row = placed[i]
        located = _locate(e, i, h, stage, hook, layout, where)
        if row is None or located is None:
            return None
        table.append((stage, h.code, located[0], located[1], th0, located[2], located[3]))
        options.append(row or [0.0])
        everyone = stage == STAGE_EXTRA and method == "ros2"
        carried.append(np.ones(B, bool) if masks[i] is None or everyone else masks[i])
    return _arrays(table, options, values, carried, npar, B)


def _locate(e, i, h, stage, hook, layout, where) -> tuple[int, int, int, int] | None:
    """``(target, partner, own state, from outputs)`` of a table row; None: not found."""
    states, inputs = list(layout["x"]), list(layout["u"])
    reads = "u" if stage == STAGE_OVERRIDE else h.target_in.get(hook, "x")
    if e.partner is not None and e.partner not in states:
        return None
    partner = -1 if e.partner is None else states.index(e.partner)
    zo = where["nx"] + where["zoff"].get(i, 0)
    names = inputs if reads == "u" else states
    if stage == STAGE_EXTRA and reads == "x" and e.target in where["outputs"]:
        return where["n_all"] + where["outputs"].index(e.target), partner, zo, 1
    if e.target in names:
        return names.index(e.target), partner, zo, 0
    return None


def _arrays(table, options, values, carried, npar, B):
    """The table, options and parameter rows as arrays (None: a value of another shape)."""
    width = max([len(o) for o in options] + [1])
    opt = np.zeros((len(table), width))
    for r, o in enumerate(options):
        opt[r, : len(o)] = o
    tab = np.array(table, dtype=np.int64).reshape(-1, len(TABLE_COLUMNS))
    C = np.array(carried, dtype=bool).reshape(len(table), B)
    counts = C.sum(axis=0)
    kmax = int(counts.max()) if len(table) else 0
    n = len(values)
    out = np.empty((n + kmax + 2, B))
    for r, v in enumerate(values):
        try:
            out[r] = np.broadcast_to(np.asarray(v, dtype=float), (B,))
        except ValueError:
            return None
    out[n] = counts
    # each member's carried rows, in table order (the order numpy applies them)
    out[n + 1 : n + 1 + kmax] = np.argsort(~C, axis=0, kind="stable")[:kmax]
    out[-1] = npar + n  # where the lists start
    return tab, opt, out


def _options(e, h: EffectHooks, layout) -> list[float] | None:
    """The option row of effect ``e`` (None: an option it lacks, a name not found)."""
    if h.theta is None:
        return e.candidate.compiled_options(e, layout)
    if any(k not in e.options for k in h.options):
        return None
    return [float(e.options[k]) for k in h.options]


# ---------------------------------------------------------------- which batches
def _extra_state_columns(effects) -> list[tuple[int, int]]:
    """``(effect index, column offset)`` of the effects with states of their own."""
    extra = []
    off = 0
    for i, e in enumerate(effects):
        if e.candidate.n_extra:
            extra.append((i, off))
            off += e.candidate.n_extra
    return extra


def _compiled_fits(model, effects, extra, hold, xp) -> bool:
    """Whether a compiled model's loop can run this batch (numpy, inputs held).

    A sensor lag follows an output computed by ``outputs``: the loop evaluates it only
    where the ``outputs`` function was compiled with the ``rhs``.
    """
    if hold not in ("zoh", "foh") or xp.name != "numpy":
        return False
    lag_on_output = model.output_fn is not None and any(
        effects[i].candidate.attach == "output" for i, _ in extra
    )
    return not lag_on_output or bool(getattr(model.rhs, "_outputs_compiled", None))


def runs_compiled(model, effects: Sequence, hold: str = "zoh") -> bool:
    """True when a batch with ``effects`` runs in the model's compiled loop.

    The model's ``rhs`` must be compiled (:mod:`._compiled`) and every effect that acts
    inside the integration translated (:mod:`._compiled_effects`); a sensor lag on an
    output computed by ``outputs`` keeps a batch in numpy. A fit simulates such rows
    apart from the others.

    Examples
    --------
    >>> from pdmkit.models.ode import showcase_model
    >>> runs_compiled(showcase_model("mass_spring_damper").check(), [])
    False
    """
    rhs = model.rhs
    if not getattr(rhs, "compiled", False):
        return False
    extra = _extra_state_columns(effects)
    if not _compiled_fits(model, effects, extra, hold, NumpyNamespace()):
        return False
    return all(
        type(e.candidate) in rhs.hooks
        for e in effects
        if e.candidate.attach in DERIVATIVE_ATTACH or e.candidate.n_extra
    )
