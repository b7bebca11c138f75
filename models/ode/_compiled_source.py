"""Translate a model file's ``rhs`` / ``outputs`` into scalar code numba can compile.

A model function reads its states, inputs and parameters from dicts (``x["pA"]``,
``p["C_A_in"]``) and calls the file's own helpers and numpy's or math's element-wise
functions. :func:`translate` rewrites it, and every helper of the file it calls, into
plain scalar Python over three float arrays:

- ``x["pA"]`` becomes ``x[2]`` (the index of ``pA`` in STATES; the same for INPUTS and
  PARAMS). Which dict an argument is, is followed from ``rhs(t, x, u, p)`` into the
  helpers through their call sites (``mass_flow(p1, p2, C, T, p)``);
- ``np.where(c, a, b)`` becomes ``a if c else b`` (only the branch taken is computed)
  and ``np.clip`` a scalar function (:data:`SHIMS`); numpy's other element-wise
  functions and ``math`` are kept (numba compiles both on numbers);
- the returned dict ``{"x": ..., "v": ...}`` becomes a tuple in the order of the names.

Anything else that reads a dict (a loop over ``x.items()``, ``p.get``, a dict passed to a
function outside the file) or a global that is not a number, a helper, numpy or math
makes :func:`translate` raise :class:`Untranslatable` with the construct's line: the
model then runs as written (``_compiled.py`` decides). Translation never changes what
the function computes; ``_compiled.py`` checks the compiled values against the
function's own on a batch before using them.
"""

from __future__ import annotations

import ast
import inspect
import math
import textwrap
import types
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["SHIMS", "Untranslatable", "element_wise", "translate"]


class Untranslatable(Exception):
    """The function uses a construct the scalar translation does not cover."""


#: scalar stand-ins for numpy functions whose numba versions want arrays
SHIMS = """
def _np_clip(v, lo, hi):
    return lo if v < lo else (hi if v > hi else v)
"""

#: numpy names kept as they are: numba compiles them on numbers
_NUMPY_KEPT = {
    "sqrt", "exp", "log", "log10", "log1p", "expm1", "tanh", "sinh", "cosh", "sin",
    "cos", "tan", "arctan", "arctan2", "arcsin", "arccos", "abs", "absolute", "fabs",
    "sign", "maximum", "minimum", "fmax", "fmin", "power", "hypot", "floor", "ceil",
    "square", "cbrt", "isfinite", "isnan", "exp2", "log2", "heaviside",
}  # fmt: skip
_NUMPY_SHIMMED = {"clip"}  # np.where: a conditional expression
_NUMPY_CONSTANTS = {"pi": math.pi, "e": math.e, "inf": math.inf}
_BUILTINS = {"abs", "min", "max", "float", "int", "bool", "pow", "round", "range", "len"}
_NAMESPACES = ("x", "u", "p")


def _fail(node: ast.AST, why: str) -> Untranslatable:
    return Untranslatable(f"line {getattr(node, 'lineno', '?')}: {why}")


def _source(fn: Callable) -> ast.FunctionDef:
    fn = inspect.unwrap(fn)
    if not isinstance(fn, types.FunctionType):
        raise Untranslatable(f"{fn!r} is not a Python function")
    try:
        text = textwrap.dedent(inspect.getsource(fn))
    except (OSError, TypeError) as exc:
        raise Untranslatable(
            f"the source of {fn.__name__} is not readable ({exc})"
        ) from None
    tree = ast.parse(text)
    node = tree.body[0]
    if not isinstance(node, ast.FunctionDef) or node.decorator_list:
        raise Untranslatable(f"{fn.__name__} is not a plain def")
    a = node.args
    if a.vararg or a.kwarg or a.kwonlyargs or a.posonlyargs or a.defaults:
        raise Untranslatable(f"{fn.__name__} has *args, **kwargs or defaults")
    return node


def element_wise(node: ast.Attribute, space: str, constants, shimmed, shim_prefix):
    """``np.<name>`` (or the array namespace's ``xp.<name>``) as the translation writes it.

    A constant, a scalar stand-in (``shim_prefix + name``) or numpy's own function.
    """
    if node.attr in constants:
        return ast.copy_location(ast.Constant(constants[node.attr]), node)
    if node.attr in shimmed:
        return ast.copy_location(ast.Name(f"{shim_prefix}{node.attr}", ast.Load()), node)
    if node.attr in _NUMPY_KEPT:
        return ast.copy_location(
            ast.Attribute(ast.Name("np", ast.Load()), node.attr, ast.Load()), node
        )
    raise _fail(node, f"{space}.{node.attr} is not among the translated functions")


class _Rewriter(ast.NodeTransformer):
    """One function's body rewritten.

    The helpers it calls are queued with the namespaces of their dict arguments.
    """

    def __init__(self, fn, kinds: dict[str, str], layout, queue, returns) -> None:
        self.glob = fn.__globals__
        self.kinds = kinds  # argument name -> "x" / "u" / "p"
        self.layout = layout  # namespace -> {name: index}
        self.queue = queue  # callback(helper function, {arg index: namespace})
        self.returns = returns  # names of the returned dict, in order (None: helper)

    # dict reads ----------------------------------------------------------------
    def visit_Subscript(self, node: ast.Subscript) -> ast.AST:
        base = node.value
        if isinstance(base, ast.Name) and base.id in self.kinds:
            ns = self.kinds[base.id]
            key = node.slice
            if not (isinstance(key, ast.Constant) and isinstance(key.value, str)):
                raise _fail(node, f"{base.id}[...] is read with a key that is not a name")
            if not isinstance(node.ctx, ast.Load):
                raise _fail(node, f"{base.id}[{key.value!r}] is written")
            if key.value not in self.layout[ns]:
                raise _fail(node, f"{key.value!r} is not a name of {ns}")
            idx = ast.Constant(self.layout[ns][key.value])
            return ast.copy_location(ast.Subscript(base, idx, ast.Load()), node)
        return self.generic_visit(node)

    def visit_Name(self, node: ast.Name) -> ast.AST:
        if node.id in self.kinds:
            raise _fail(node, f"the dict {node.id!r} is used other than as {node.id}[name]")
        if isinstance(node.ctx, ast.Load) and node.id in self.glob:
            val = self.glob[node.id]
            if isinstance(val, bool | int | float):
                return ast.copy_location(ast.Constant(val), node)
        return node

    # calls -----------------------------------------------------------------------
    def visit_Attribute(self, node: ast.Attribute) -> ast.AST:
        base = node.value
        if isinstance(base, ast.Name) and base.id in self.kinds:
            raise _fail(node, f"the dict {base.id!r} is used other than as {base.id}[name]")
        mod = self._module(base)
        if mod is np:
            return element_wise(node, "np", _NUMPY_CONSTANTS, _NUMPY_SHIMMED, "_np_")
        if mod is math:
            if isinstance(getattr(math, node.attr, None), float):
                return ast.copy_location(ast.Constant(getattr(math, node.attr)), node)
            return ast.copy_location(
                ast.Attribute(ast.Name("math", ast.Load()), node.attr, ast.Load()), node
            )
        raise _fail(node, f"attribute {ast.unparse(node)!r}")

    def _module(self, node: ast.AST):
        if isinstance(node, ast.Name):
            return self.glob.get(node.id)
        return None

    def visit_Call(self, node: ast.Call) -> ast.AST:
        if (
            isinstance(node.func, ast.Attribute)
            and node.func.attr == "where"
            and self._module(node.func.value) is np
            and len(node.args) == 3
            and not node.keywords
        ):  # only the branch taken is evaluated: the same value, less work
            c, a, b = (self.visit(v) for v in node.args)
            return ast.copy_location(ast.IfExp(c, a, b), node)
        if node.keywords:
            raise _fail(node, f"keyword arguments in {ast.unparse(node.func)}(...)")
        if isinstance(node.func, ast.Name):
            name = node.func.id
            target = self.glob.get(name)
            if isinstance(target, types.FunctionType):
                spaces = {}
                for i, a in enumerate(node.args):
                    if isinstance(a, ast.Name) and a.id in self.kinds:
                        spaces[i] = self.kinds[a.id]
                called = self.queue(target, spaces)
                args = [
                    a if isinstance(a, ast.Name) and a.id in self.kinds else self.visit(a)
                    for a in node.args
                ]
                new = ast.Call(ast.Name(called, ast.Load()), args, [])
                return ast.copy_location(new, node)
            if name not in _BUILTINS or name in self.glob:
                raise _fail(node, f"call of {name!r}, which is not a function of the file")
            return self.generic_visit(node)
        return self.generic_visit(node)

    # structure ---------------------------------------------------------------------
    def visit_Return(self, node: ast.Return) -> ast.AST:
        if self.returns is None:
            return self.generic_visit(node)
        d = node.value
        if not isinstance(d, ast.Dict) or any(
            not (isinstance(k, ast.Constant) and isinstance(k.value, str)) for k in d.keys
        ):
            raise _fail(node, "the result is not a dict literal {'name': value, ...}")
        got = {k.value: v for k, v in zip(d.keys, d.values, strict=True)}
        if sorted(got) != sorted(self.returns):
            raise _fail(node, f"the dict's names {sorted(got)} are not {self.returns}")
        vals = [self.visit(got[k]) for k in self.returns]
        return ast.copy_location(ast.Return(ast.Tuple(vals, ast.Load())), node)

    def _refuse(self, node, what):
        raise _fail(node, what)

    def visit_Lambda(self, node):
        self._refuse(node, "a lambda")

    def visit_ListComp(self, node):
        self._refuse(node, "a comprehension")

    visit_DictComp = visit_SetComp = visit_GeneratorExp = visit_ListComp

    def visit_Global(self, node):
        self._refuse(node, "a global statement")

    visit_Nonlocal = visit_Global

    def visit_FunctionDef(self, node):
        self._refuse(node, "a function defined inside the model function")


def _inline_single_use(node: ast.FunctionDef) -> None:
    """Move a value used once, in one branch of a conditional, into that branch.

    ``fill = flow(...); empty = flow(...); return fill if c else empty`` (how
    ``np.where`` reads after translation) computes both flows; with each moved into its
    branch only the one taken is computed. The values are the same: the translated code
    only computes (it writes no dict and calls only translated helpers and element-wise
    functions), and a value moves only when nothing it reads is assigned again.
    """
    stores: dict[str, int] = {}
    loads: dict[str, int] = {}
    for n in ast.walk(node):
        if isinstance(n, ast.Name):
            book = stores if isinstance(n.ctx, ast.Store) else loads
            book[n.id] = book.get(n.id, 0) + 1
    params = {a.arg for a in node.args.args}
    branch_uses: dict[str, tuple[ast.IfExp, str]] = {}
    for top in node.body:
        for n in ast.walk(top):
            if isinstance(n, ast.IfExp):
                for side in ("body", "orelse"):
                    v = getattr(n, side)
                    if isinstance(v, ast.Name) and isinstance(v.ctx, ast.Load):
                        branch_uses[v.id] = (n, side)
    keep = []
    for st in node.body:
        target = st.targets[0].id if _plain_assign(st) else None
        use = branch_uses.get(target) if target else None
        reads = [n.id for n in ast.walk(st.value) if isinstance(n, ast.Name)] if use else []
        if (
            use is None
            or target in params
            or stores.get(target) != 1
            or loads.get(target) != 1
            or any(stores.get(r, 0) > (0 if r in params else 1) for r in reads)
        ):
            keep.append(st)
            continue
        setattr(use[0], use[1], st.value)  # computed where it is used, when it is
    node.body = keep


def _plain_assign(st: ast.stmt) -> bool:
    return (
        isinstance(st, ast.Assign)
        and len(st.targets) == 1
        and isinstance(st.targets[0], ast.Name)
    )


def translate(
    fn: Callable,
    layout: dict[str, Sequence[str]],
    returns: Sequence[str],
    prefix: str = "_f",
) -> str:
    r"""Scalar source of ``fn(t, x, u, p)`` and its helpers, ready for numba.

    Parameters
    ----------
    fn : callable
        The model file's ``rhs`` or ``outputs``.
    layout : dict
        ``{"x": state names, "u": input names, "p": parameter names}``, in array order.
    returns : sequence of str
        The names of the dict ``fn`` returns, in the order of the returned tuple.
    prefix : str, optional
        The start of the translated functions' names (two translations in one module
        take two prefixes).

    Returns
    -------
    str
        Source defining ``_f<k>_<name>`` for ``fn`` (k = 0, the entry point
        ``_f0_<name>(t, x, u, p)`` over three float arrays) and each helper it calls,
        plus :data:`SHIMS` (with the default prefix).

    Raises
    ------
    Untranslatable
        A construct outside the translation (the message names it and its line).

    Examples
    --------
    >>> import numpy as np
    >>> def rhs(t, x, u, p):
    ...     return {"h": u["q"] - p["a"] * np.sqrt(np.maximum(x["h"], 0.0))}
    >>> src = translate(rhs, {"x": ["h"], "u": ["q"], "p": ["a"]}, ["h"])
    >>> print(src.split("\n\n\n")[-1].strip())
    def _f0_rhs(t, x, u, p):
        return (u[0] - p[0] * np.sqrt(np.maximum(x[0], 0.0)),)
    """
    fn = inspect.unwrap(fn)
    index = {ns: {n: i for i, n in enumerate(names)} for ns, names in layout.items()}
    found: list[tuple[Callable, dict[int, str], str]] = []  # function, dicts, new name

    def queue(helper: Callable, spaces: dict[int, str]) -> str:
        for f, sp, name in found:
            if f is helper:
                if sp != spaces:
                    raise Untranslatable(f"{helper.__name__} is called with other dicts")
                return name
        name = f"{prefix}{len(found)}_{helper.__name__}"
        found.append((helper, spaces, name))
        return name

    queue(fn, {1: "x", 2: "u", 3: "p"})
    parts = [SHIMS] if prefix == "_f" else []
    i = 0
    while i < len(found):
        helper, spaces, name = found[i]
        node = _source(helper)
        argnames = [a.arg for a in node.args.args]
        kinds = {argnames[j]: ns for j, ns in spaces.items() if j < len(argnames)}
        rw = _Rewriter(helper, kinds, index, queue, list(returns) if i == 0 else None)
        node.body = [rw.visit(s) for s in node.body]
        _inline_single_use(node)
        node.name = name
        node.returns = None
        for a in node.args.args:
            a.annotation = None
        parts.append(ast.unparse(ast.fix_missing_locations(node)))
        i += 1
    return "\n\n\n".join(parts) + "\n"
