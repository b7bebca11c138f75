"""A model file's ``rhs`` / ``outputs`` compiled with numba once it has cost enough time.

pdmkit integrates a batch of members in lock step and calls ``rhs`` with numpy arrays
at every stage of every step. For a small model on a small batch each numpy call costs
a microsecond or two of overhead whatever the batch holds, and a model such as the
source thesis's pneumatic cylinder (about 150 element-wise operations: valve flows with
the flow function, chamber pressures, dampers) spends nearly all of a fit there; a
model written for numbers (``math.sqrt``, ``if``) is called once per member, slower
still. :class:`CompiledModelFunction` wraps such a function: it runs the function as
written, and once the calls have taken more than ``PDMKIT_COMPILE_AFTER`` seconds
(default 2 s: about what numba takes to compile a model) it translates the file's
source into scalar code (:mod:`pdmkit.models.ode._compiled_source`), compiles it with
numba into one loop over the batch, checks the compiled values against the function's
own on the call at hand (relative 1e-9) and from then on uses the compiled loop. Any
step that does not work (numba not installed, a construct outside the translation, a
compile error, different values) leaves the function as written and says why in
:attr:`CompiledModelFunction.note`.

An ``rhs`` is compiled with the terms of the candidate effects registered with
:func:`~pdmkit.models.ode.register_effects` (:mod:`pdmkit.models.ode._compiled_effects`)
and, where the file has one, its ``outputs`` (a sensor's lag follows an output):
:meth:`CompiledModelFunction.simulate` then runs a fit's batch with its effects in one
compiled loop, RK4's members on every core.

``PDMKIT_COMPILE=never`` keeps every model as written; ``always`` compiles at the first
batch call (the tests use it). The compiled code runs the same arithmetic in the same
order as the numpy version, so results agree to rounding (numba's ``error_model
"numpy"``: a division by zero gives inf, as numpy does).
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import math
import os
import pathlib
import sys
import time
import types
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from pdmkit.models.ode._compiled_effects import effect_rows, hooks_source, registered
from pdmkit.models.ode._compiled_loops import NO_HOOKS, loops_source
from pdmkit.models.ode._compiled_source import Untranslatable, translate
from pdmkit.models.ode._integrators import (
    _ROS2_GAMMA,
    ROS2_JACOBIAN_AGE,
    ROS2_MAX_HALVINGS,
    ROS2_RTOL,
    _rk4_records,
    _ros2_records,
    _stops,
)

__all__ = ["CompiledModelFunction", "compile_mode"]

#: the table of a batch without effects (:func:`.effect_rows`)
_EMPTY_TABLE = (np.zeros((0, 7), dtype=np.int64), np.zeros((0, 1)))

_MODES = ("auto", "always", "never")


def compile_mode() -> tuple[str, float]:
    """``(mode, seconds)`` from ``PDMKIT_COMPILE`` and ``PDMKIT_COMPILE_AFTER``.

    Examples
    --------
    >>> compile_mode()[0] in ("auto", "always", "never")
    True
    """
    mode = os.environ.get("PDMKIT_COMPILE", "auto").strip().lower() or "auto"
    if mode not in _MODES:
        mode = "auto"
    try:
        after = float(os.environ.get("PDMKIT_COMPILE_AFTER", "2.0"))
    except ValueError:
        after = 2.0
    return mode, after if math.isfinite(after) and after >= 0 else 2.0


def cache_folder() -> pathlib.Path | None:
    """Where compiled models are kept between runs, or None where it cannot be written.

    ``PDMKIT_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/pdmkit/compiled`` (default
    ``~/.cache/pdmkit/compiled``). Each model's translated source is a file named by its
    SHA-256 there, and numba keeps its machine code beside it (``__pycache__``): the
    next run of the same model loads it in a fraction of a second instead of compiling
    for several seconds.

    Examples
    --------
    >>> folder = cache_folder()
    >>> folder is None or folder.is_dir()
    True
    """
    base = os.environ.get("PDMKIT_CACHE_DIR")
    if base:
        folder = pathlib.Path(base)
    else:
        xdg = os.environ.get("XDG_CACHE_HOME") or str(pathlib.Path.home() / ".cache")
        folder = pathlib.Path(xdg) / "pdmkit" / "compiled"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return folder if os.access(folder, os.W_OK) else None


def _module(
    text: str, folder: pathlib.Path | None, kind: str = "model"
) -> tuple[dict, bool]:
    """The translated source run as a module: from a cache file when one can be kept."""
    import numba  # heavy: only when a model is compiled

    stamp = f"# numba {numba.__version__}, numpy {np.__version__}\n"
    text = stamp + "import math\n\nimport numpy as np\nfrom numba import prange\n\n" + text
    if folder is not None:
        digest = hashlib.sha256(text.encode()).hexdigest()[:32]
        path = folder / f"{kind}_{digest}.py"
        try:
            if not path.exists():
                tmp = path.with_suffix(f".{os.getpid()}.tmp")
                tmp.write_text(text)
                os.replace(tmp, path)
            name = f"_pdmkit_{kind}_{digest}"
            if name not in sys.modules:  # numba's cache finds the module by its name
                spec = importlib.util.spec_from_file_location(name, path)
                module = importlib.util.module_from_spec(spec)
                spec.loader.exec_module(module)  # the user's model, translated
                sys.modules[name] = module
            return vars(sys.modules[name]), True
        except OSError:
            pass
    ns: dict[str, Any] = {}
    exec(compile(text, "<pdmkit model>", "exec"), ns)  # the user's model, translated
    return ns, False


#: the effects' dispatchers compiled in this process, by the digest of their source
_SHARED_HOOKS: dict[str, Any] = {}


def _shared_hooks(hooks: str) -> tuple[str, Any]:
    """``(digest, _hook)``: the effects' terms compiled once per process, kept on disk."""
    import numba  # heavy: only when a model is compiled

    key = hashlib.sha256(hooks.encode()).hexdigest()[:16]
    if key not in _SHARED_HOOKS:
        ns, cached = _module(hooks, cache_folder(), kind="effects")
        for name in [k for k, v in ns.items() if isinstance(v, types.FunctionType)]:
            # the dispatcher is inlined into each model's loop (numba's IR): called,
            # it cost more than the terms it dispatches to (the rig: 145 ns a call)
            inline = "always" if name == "_hook" else "never"
            jit = numba.njit(error_model="numpy", cache=cached, inline=inline)
            ns[name] = jit(ns[name])
        _SHARED_HOOKS[key] = ns["_hook"]
    return key, _SHARED_HOOKS[key]


def _build(source: str, entry: str, nout: int, sizes: tuple, hooks: str, outputs=None):
    """Compile the translated source with its loops (:mod:`._compiled_loops`).

    ``hooks`` is the source of the effects' terms (:func:`.hooks_source`), or the
    dispatcher of a function without them; ``outputs`` the translated ``outputs``
    function's entry and size, for sensor lags (:func:`.loops_source`). numba compiles
    each function at its first call (or loads it from :func:`cache_folder`), so an
    integrator costs nothing until it is used.
    """
    import numba  # heavy: only when a model is compiled

    loops = loops_source(entry, nout, *sizes, outputs)
    if hooks == NO_HOOKS:
        ns, cached = _module("\n\n".join([source, hooks, loops]), cache_folder())
    else:  # the effects' terms compiled once for every model (they do not depend on it)
        key, hook = _shared_hooks(hooks)
        # the effects' digest in the model's text: new terms, a new compiled model
        ns, cached = _module(f"# effects {key}\n\n{source}\n\n{loops}", cache_folder())
        ns["_hook"] = hook
    for name in [k for k, v in ns.items() if isinstance(v, types.FunctionType)]:
        threads = name in ("_rk4", "_rk4_plain")  # its members on every core (prange)
        ns[name] = numba.njit(error_model="numpy", cache=cached, parallel=threads)(ns[name])
    names = ("kernel", "rk4", "ros2", "rk4_plain", "ros2_plain")
    return {k: ns[f"_{k}"] for k in names}


class CompiledModelFunction:
    """``fn(t, x, u, p)`` that switches to a numba-compiled loop once it is worth it.

    Parameters
    ----------
    fn : callable
        The function as pdmkit evaluates it (batched numpy or per sample); called
        until the compiled loop takes over and whenever a call does not fit it (scalars,
        torch tensors, a parameter array of another length).
    layout : dict
        ``{"x": state names, "u": input names, "p": parameter names}``.
    returns : sequence of str
        The names of the dict ``fn`` returns (states for ``rhs``, OUTPUTS for
        ``outputs``).

    Attributes
    ----------
    note : str
        What happened: ``"as written"`` until compiled, ``"compiled after 2.1 s"``, or
        why it was not compiled.

    Examples
    --------
    >>> import numpy as np
    >>> def rhs(t, x, u, p):
    ...     return {"h": u["q"] - p["a"] * np.sqrt(np.maximum(x["h"], 0.0))}
    >>> f = CompiledModelFunction(rhs, {"x": ["h"], "u": ["q"], "p": ["a"]}, ["h"])
    >>> f(0.0, {"h": np.array([4.0, 9.0])}, {"q": np.zeros(2)}, {"a": 1.0})["h"]
    array([-2., -3.])
    >>> f.note
    'as written'
    """

    def __init__(
        self,
        fn: Callable,
        layout: Mapping[str, Sequence[str]],
        returns: Sequence[str],
        outputs: tuple[Callable, Sequence[str]] | None = None,
    ) -> None:
        self.python = fn
        #: an rhs's model ``outputs`` function and its names: compiled beside it for
        #: sensor lags that follow an output
        self.outputs = outputs
        self._outputs_compiled: list[str] = []
        self.layout = {k: list(v) for k, v in layout.items()}
        self.returns = list(returns)
        self.per_sample = bool(getattr(fn, "per_sample", False))
        self.note = "as written"
        self._kernel: Callable | None = None
        self._loops: dict[str, Callable] = {}
        #: ``{effect class: EffectHooks}`` compiled with an ``rhs``
        self.hooks: dict = {}
        self._checked: dict[tuple, bool] = {}  # (integrator, effects) -> first run agreed
        self._failed = False
        self._spent = 0.0
        self._p_obj: Any = None
        self._p_shape: tuple | None = None
        self._p_arr: np.ndarray | None = None
        self.__wrapped__ = fn
        self.__name__ = getattr(fn, "__name__", "rhs")

    def ran(self, method: str, with_effects: bool = False) -> bool:
        """True once a simulation with ``method`` ran compiled and was checked.

        ``with_effects``: one whose batch carried effects' terms or states.
        """
        return any(
            ok and (len(rows) > 0 or not with_effects)
            for (m, rows), ok in self._checked.items()
            if m == method
        )

    @property
    def compiled(self) -> bool:
        """True once the compiled loops have taken over."""
        return self._kernel is not None

    def __call__(self, t, x, u, p):
        if self._kernel is not None:
            out = self._run(t, x, u, p)
            if out is not None:
                return out
            return self.python(t, x, u, p)
        mode, after = compile_mode()
        if self._failed or mode == "never":
            return self.python(t, x, u, p)
        start = time.perf_counter()
        out = self.python(t, x, u, p)
        self._spent += time.perf_counter() - start
        if (mode == "always" or self._spent > after) and _batch_length(x, u) is not None:
            self._compile(t, x, u, p, out)
        return out

    # ------------------------------------------------------------------ compiling
    def _compile(self, t, x, u, p, expected) -> None:
        spent = self._spent
        try:
            source = translate(self.python, self.layout, self.returns)
            entry = f"_f0_{inspect.unwrap(self.python).__name__}"  # translate's naming
            sizes = tuple(len(self.layout[k]) for k in ("x", "u", "p"))
            hooks, out = NO_HOOKS, None
            if self.returns == self.layout["x"]:  # an rhs: the effects' terms with it
                hooks, self.hooks, _left = hooks_source(registered())
                source, out = self._with_outputs(source)
            self._loops = _build(source, entry, len(self.returns), sizes, hooks, out)
            self._kernel = self._loops["kernel"]
            got = self._run(t, x, u, p)
        except ImportError:
            return self._give_up("numba is not installed (pip install 'pdmkit[fast]')")
        except Untranslatable as exc:
            return self._give_up(f"not translated: {exc}")
        except Exception as exc:  # numba's typing and lowering errors have many types
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
            return self._give_up(
                f"numba could not compile it ({type(exc).__name__}: {first})"
            )
        if got is None or not _same(got, expected, self.returns):
            return self._give_up("the compiled values differ from the function's own")
        self.note = f"compiled after {spent:.1f} s"
        return None

    def _with_outputs(self, source: str) -> tuple[str, tuple[str, int] | None]:
        """The source with the model's ``outputs`` translated, where it translates."""
        if self.outputs is None:
            return source, None
        fn, names = self.outputs
        try:
            text = translate(fn, self.layout, list(names), prefix="_g")
        except Untranslatable:
            return source, None  # sensor lags on its outputs stay in numpy
        self._outputs_compiled = list(names)
        entry = f"_g0_{inspect.unwrap(fn).__name__}"
        return source + "\n\n" + text, (entry, len(names))

    def _give_up(self, why: str) -> None:
        self._kernel, self._loops = None, {}
        self._failed = True
        self.note = why

    # ------------------------------------------------------------------ simulating
    def simulate(self, method, Xl, Useq, params, t, n_sub, h, foh, limits, batch=None):
        """A whole simulation in a compiled loop, or None where it cannot run.

        ``method``: ``"rk4"`` or ``"ros2"``; ``Xl``: the ``(B,)`` initial states in
        STATES order; ``Useq``: ``(B, N, nu)`` inputs (None without inputs);
        ``params``: the parameter dict; ``limits``: the model's checked ``LIMITS``,
        ``{state: (lo, hi, velocity state or None)}``. ``batch`` holds the effects of
        the batch: ``(effects, theta, masks, extra, Zl, f)`` as
        :func:`~pdmkit.models.ode.integrate_batch` has them, ``Zl`` the effects' own
        initial states and ``f`` the numpy right-hand side with their terms (None: the
        model alone). Returns the states at every sample, ``(B, N, nx + nz)``, the
        effects' own states last. Each integrator's first simulation with a set of
        effects is checked against the numpy integrator over its first samples (to
        1e-6 of each state's largest value); a difference leaves that combination to
        numpy from then on.
        """
        loop = self._loops.get(method)
        if loop is None or compile_mode()[0] == "never" or self.returns != self.layout["x"]:
            return None
        B, N, nx = int(np.size(Xl[0])) if Xl else 0, int(np.size(t)), len(Xl)
        if not B or any(not isinstance(v, np.ndarray) or v.shape != (B,) for v in Xl):
            return None
        U = np.zeros((B, N, 0)) if Useq is None else np.ascontiguousarray(Useq, float)
        P = _stack([params.get(k) for k in self.layout["p"]], (B,), B)
        if U.shape != (B, N, len(self.layout["u"])) or P is None:
            return None
        table = self._table(batch, B, method)
        if table is None:
            return None
        tab, opt, values, Zl, f = table
        if not tab.shape[0]:  # the model alone: the loop without the effects' terms
            loop = self._loops.get(f"{method}_plain", loop)
        key = (method, tuple(map(tuple, tab[:, :2])))
        if self._checked.get(key) is False:
            return None
        X0 = np.array(list(Xl) + list(Zl), dtype=float).reshape(-1, B)
        idx = {k: j for j, k in enumerate(self.layout["x"])}
        lim = np.array(
            [
                [idx[k], lo, hi, -1 if v is None else idx[v]]
                for k, (lo, hi, v) in limits.items()
            ],
            dtype=float,
        ).reshape(-1, 4)
        args = [X0, U, np.vstack([P, values]), np.ascontiguousarray(t, dtype=float)]
        args += [int(n_sub), float(h), bool(foh), lim, np.empty((B, N, X0.shape[0]))]
        args += [tab, opt]
        if method == "ros2":
            args += [ROS2_RTOL, ROS2_MAX_HALVINGS, ROS2_JACOBIAN_AGE, _ROS2_GAMMA]
        try:
            loop(*args)
        except Exception as exc:  # a numba typing error at the first call
            self._checked[key] = False
            self.note += f"; its {method} loop did not compile ({type(exc).__name__})"
            return None
        rec = args[8]
        if key not in self._checked:
            self._checked[key] = self._agrees(method, rec, args, f, limits, nx)
            if not self._checked[key]:
                self.note += f"; its {method} loop differed from numpy's"
                return None
        return rec

    def _table(self, batch, B, method):
        """``(tab, opt, values, Zl, f)`` of a batch's effects, or None (numpy runs it)."""
        if batch is None:
            return (*_EMPTY_TABLE, np.empty((0, B)), [], None)
        effects, theta, masks, extra, Zl, f = batch
        if not effects:
            return (*_EMPTY_TABLE, np.empty((0, B)), [], f)
        layout = {**self.layout, "y": self._outputs_compiled}
        rows = effect_rows(effects, theta, masks, extra, layout, self.hooks, B, method)
        if rows is None or any(
            not isinstance(z, np.ndarray) or z.shape != (B,) for z in Zl
        ):
            return None
        return (*rows, Zl, f)

    def _agrees(self, method, rec, args, f, limits, nx) -> bool:
        """The compiled simulation against the numpy integrator, first samples.

        ``f`` is the numpy right-hand side with the effects' terms (None: the model's
        own function as written).
        """
        X0, U, _, t, n_sub, h, foh = args[:7]
        n = min(int(rec.shape[1]), 25)
        states = self.layout["x"]
        if f is None:
            python, params = self.python, dict(zip(self.layout["p"], args[2], strict=False))

            def f(tt, Xl, Zl, u):
                d = python(tt, dict(zip(states, Xl, strict=True)), u, params)
                return [np.broadcast_to(d[k], Xl[0].shape) for k in states], ()

        stop = _stops(types.SimpleNamespace(limits=limits, state_names=states), np)
        step = _rk4_records if method == "rk4" else _ros2_records
        hold = "foh" if foh else "zoh"
        Xl, Zl = list(X0[:nx]), list(X0[nx:])
        with np.errstate(all="ignore"):
            rx, _ = step(
                f, Xl, Zl, U[:, :n], t[:n], self.layout["u"], n, n_sub, h, hold, stop
            )
        # the model's states (an effect's own state is followed only by the members
        # that carry it, and acts only through them)
        want = np.stack([np.stack(list(xs), 1) for xs in rx], 1)
        got = rec[:, :n, :nx]
        # per state, against its largest value: a finite-difference Jacobian (ROS2)
        # turns the last bit of a libm function into 1e-8 of the step
        scale = np.nanmax(np.abs(want), axis=(0, 1)) + 1e-300
        gap = np.abs(got - want) / scale
        same_nan = np.isnan(got) == np.isnan(want)
        return bool(np.all(same_nan) and np.all(np.nan_to_num(gap) <= 1e-6))

    # ------------------------------------------------------------------ running
    def _run(self, t, x, u, p):
        """The compiled loop on one call, or None where the call does not fit it."""
        if not isinstance(t, float | int):
            return None
        shape = _batch_length(x, u)
        if shape is None:
            return None
        n = math.prod(shape)
        try:
            X = _stack([x[k] for k in self.layout["x"]], shape, n)
            U = _stack([u[k] for k in self.layout["u"]], shape, n)
        except KeyError:
            return None  # the function as written says which name is missing
        P = self._params(p, shape, n)
        if X is None or U is None or P is None:
            return None
        out = np.empty((len(self.returns), n))
        self._kernel(float(t), X, U, P, out)  # numba's numpy error model: no warnings
        if len(shape) == 1:
            return dict(zip(self.returns, out, strict=True))
        return {k: out[j].reshape(shape) for j, k in enumerate(self.returns)}

    def _params(self, p, shape, n):
        """Parameters as an ``(n_params, n)`` array, kept while ``p`` is the same dict.

        A simulation builds its parameter dict once and passes that same dict to every
        call; the dict is held, so its identity cannot be taken by another.
        """
        if p is self._p_obj and shape == self._p_shape:
            return self._p_arr
        try:
            values = [p[k] for k in self.layout["p"]]
        except KeyError:
            return None
        self._p_obj, self._p_shape = p, shape
        self._p_arr = _stack(values, shape, n)
        return self._p_arr


def _batch_length(x, u) -> tuple[int, ...] | None:
    """The batch's shape when states and inputs are numpy float arrays of one shape."""
    shape = None
    for v in list(x.values()) + list(u.values()):
        if isinstance(v, np.ndarray):
            if v.dtype != np.float64 or v.ndim == 0:
                return None
            if shape is None:
                shape = v.shape
            elif v.shape != shape:
                return None
        elif not isinstance(v, float | int):
            return None
    return shape


def _stack(values: list, shape: tuple[int, ...], n: int) -> np.ndarray | None:
    """``(len(values), n)`` float array of values broadcast to ``shape``, or None."""
    if all(isinstance(v, np.ndarray) and v.shape == shape for v in values):
        if not values:
            return np.empty((0, n))
        return np.array(values).reshape(len(values), n)
    out = np.empty((len(values), n))
    for j, v in enumerate(values):
        if isinstance(v, np.ndarray):
            if v.shape == shape:
                out[j] = v.reshape(n)
            elif v.size == 1:
                out[j] = float(v.reshape(()))
            else:
                return None
        elif isinstance(v, float | int):
            out[j] = v
        else:
            return None
    return out


def _same(got: Mapping, expected: Any, names: Sequence[str]) -> bool:
    if not isinstance(expected, Mapping):
        return False
    for k in names:
        a = np.asarray(got[k], dtype=float)
        try:
            b = np.broadcast_to(np.asarray(expected[k], dtype=float), a.shape)
        except (KeyError, TypeError, ValueError):
            return False
        same = np.isclose(a, b, rtol=1e-9, atol=1e-300) | (np.isnan(a) & np.isnan(b))
        if not np.all(same):
            return False
    return True
