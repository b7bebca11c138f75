"""Batched fixed-step RK4 simulation of :class:`OdeModel`, inputs held or interpolated.

Members run together, batch on the first axis, in numpy (fast, float64) or in torch
(autograd through the whole trajectory). A batch may mix *structures*: groups of rows
that share a set of candidate effects (:mod:`pdmkit.models.mismatch._candidates`), so
that many hypotheses, parameter sets and finite-difference perturbations are simulated
in one pass. Between samples the inputs are held or interpolated; each sample interval
takes ``n_sub`` classical Runge-Kutta steps. Long records can run as pieces side by
side (multiple shooting, ``segments``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._xp import NumpyNamespace, TorchNamespace, is_torch
from pdmkit.models.ode._compiled_effects import (
    _compiled_fits,
    _extra_state_columns,
    runs_compiled,
)
from pdmkit.models.ode._integrators import (
    DERIVATIVE_ATTACH,
    _rk4_records,
    _ros2_records,
    _stops,
)
from pdmkit.models.ode._response import ResponseData

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from pdmkit.models.ode._modelfile import OdeModel

__all__ = [
    "DERIVATIVE_ATTACH",
    "PARAMETER_ATTACH",
    "integrate_batch",
    "runs_compiled",
    "simulate_ode",
    "stable_substeps",
    "state_jacobians",
]


# ---------------------------------------------------------------------------- backends
_NP = NumpyNamespace()


def _namespace(*values) -> Any:
    """The torch namespace when any value (nested in dicts / lists) is a tensor."""

    def any_torch(v):
        if isinstance(v, Mapping):
            return any(any_torch(w) for w in v.values())
        if isinstance(v, list | tuple):
            return any(any_torch(w) for w in v)
        return is_torch(v)

    return TorchNamespace() if any(any_torch(v) for v in values) else _NP


# ---------------------------------------------------------------------------- engine
def _check_time(time) -> tuple[np.ndarray, float]:
    t = np.asarray(time, dtype=np.float64)
    if t.ndim != 1 or t.size < 2:
        raise ModelError(
            f"simulate_ode: time must be a 1-D array of at least 2 sample times; got shape "
            f"{t.shape}."
        )
    dt = np.diff(t)
    ts = float(np.median(dt))
    if not (ts > 0 and np.all(np.abs(dt - ts) <= 1e-6 * ts + 1e-12)):
        k = int(np.argmax(np.abs(dt - ts)))
        raise ModelError(
            f"simulate_ode: time must be uniformly spaced and increasing; the step between "
            f"samples {k} and {k + 1} is {dt[k]:g} s, the median step {ts:g} s."
        )
    return t, ts


#: the attach kind of an effect that replaces a model parameter (a file's constant)
PARAMETER_ATTACH = "parameter"


def integrate_batch(
    model: OdeModel,
    effects: Sequence,
    theta: Sequence[Mapping[str, Any]],
    masks: Sequence[Any],
    t: np.ndarray,
    useq: Mapping[str, Any],
    params: Mapping[str, Any],
    x0: Any,
    n_sub: int,
    xp: NumpyNamespace | TorchNamespace,
    want_states: bool = False,
    hold: str = "zoh",
    segments: tuple[np.ndarray, int] | None = None,
    t_origin: float | None = None,
    method: str | None = None,
) -> tuple[Any, Any | None]:
    """Integrate a batch; return ``(y (B, N, n_out), x (B, N, nx) or None)``.

    ``method`` is ``"rk4"`` (classical Runge-Kutta, explicit) or ``"ros2"`` (a
    linearly implicit, L-stable second-order Rosenbrock-W method for stiff models:
    chamber pressures, end stops, switching valves; numpy only), ``n_sub`` steps per
    sample interval either way; default the model's ``integrator`` (``"auto"``: rk4).

    ``t_origin`` is the time from which time-dependent sensor effects (a drift) count
    (default ``t[0]``; the start of the training record when ``t`` is a later part).

    ``segments = (starts, L)`` simulates, for every row, ``K = len(starts)`` pieces of
    the record side by side instead of the whole record (multiple shooting): piece
    ``k`` covers samples ``starts[k] .. starts[k] + L - 1`` and starts from its own
    state, ``x0`` then being ``(B, K, nx)``; the result is ``(B, K * L, ...)``, pieces
    one after the other. The pieces run as extra rows of the batch, so a long record
    costs ``L`` steps of Python instead of ``N``. Input transforms (dead time, lags of
    the sequence) are applied to the whole record first. The model must not depend on
    time (the right-hand side sees the piece's own clock); numpy only.

    ``hold`` says what the inputs do between samples: ``"zoh"`` held constant (a
    digital controller's output, steps), ``"foh"`` straight lines from sample to sample
    (a sampled continuous signal; zero-order hold would lag it by half a sample).

    Every row carries every effect of ``effects`` (the union over the structures in
    the batch): ``theta[i]`` maps the parameters of ``effects[i]`` to ``(B,)`` arrays,
    holding the candidate's neutral values in rows without it, and ``masks[i]`` is a
    ``(B,)`` boolean array (None: all rows) that switches effects without a neutral
    value (input transforms, lags, sensor models). ``useq`` maps each input to a
    ``(N,)`` or ``(B, N)`` array; ``params`` each model parameter to a scalar or
    ``(B,)`` array; ``x0`` is ``(B, nx)``.

    Examples
    --------
    A plain batch of two members (no added terms), two RK4 steps per sample:

    >>> import numpy as np
    >>> from pdmkit.models._xp import NumpyNamespace
    >>> from pdmkit.models.ode import integrate_batch, showcase_model
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(400) * 0.01
    >>> params = {"m": 1.0, "c": 4.0, "k": np.array([400.0, 100.0])}
    >>> y, _ = integrate_batch(msd, [], [], [], t, {"F": np.ones(400)}, params,
    ...                        np.zeros((2, 2)), 2, NumpyNamespace())
    >>> y.shape, np.round(y[:, -1, 0] * [400, 100], 2).tolist()  # static gain 1/k
    ((2, 400, 1), [1.0, 1.0])
    """
    states = model.state_names
    inputs = model.input_names
    nx = len(states)
    N = t.size
    X = xp.asarray(x0)
    B = int(X.shape[0])
    want = (B, nx) if segments is None else (B, len(segments[0]), nx)
    if tuple(X.shape) != want:
        raise ModelError(f"internal: x0 has shape {tuple(X.shape)}, expected {want}.")
    if segments is not None and xp.name != "numpy":
        raise ModelError("internal: segmented simulation runs in numpy only.")
    if method is None:
        method = "ros2" if model.integrator == "ros2" else "rk4"
    if method not in ("rk4", "ros2"):
        raise ModelError(f"integration method must be 'rk4' or 'ros2'; got {method!r}.")
    if method == "ros2" and xp.name != "numpy":
        raise ModelError("the stiff integrator (ros2) runs in numpy only.")
    ts = float(t[1] - t[0])
    h = ts / n_sub
    params = _with_constants(effects, theta, params)
    M = _row_masks(masks, xp)
    U, transforms, Useq = _input_sequences(
        effects, theta, M, useq, inputs, B, N, ts, xp, whole=segments is None
    )
    origin = float(t[0]) if t_origin is None else float(t_origin)
    t_out = xp.asarray(t - origin)[None, :]  # output hooks: time since the origin
    if segments is not None:  # pieces become rows: row b * K + k is piece k of row b
        K, Useq, t_out, theta, M, params, X = _pieces_as_rows(
            segments, U, inputs, transforms, effects, theta, M, params, X, t, origin, xp, ts
        )
        L = int(segments[1])
        B, N, t = B * K, L, t[:L]

    theta = [
        e.candidate.prepare(xp, e, th, h) for e, th in zip(effects, theta, strict=True)
    ]
    where = _row_select(M, B, xp)
    extra = _extra_state_columns(effects)
    P = {k: (v if isinstance(v, float | int) else xp.asarray(v)) for k, v in params.items()}
    # states are kept as lists of (B,) arrays: no stacking inside the RK4 stages
    Xl = [X[:, j] for j in range(nx)]
    Zl = _initial_extra_states(
        effects, theta, extra, states, Xl, Useq, inputs, B, xp, (model, P, float(t[0]))
    )
    f = _augmented_rhs(model, effects, theta, M, where, extra, P, B, len(Zl), xp)
    rec_x, rec_z = None, []
    compiled = getattr(model.rhs, "simulate", None)
    if compiled is not None and _compiled_fits(model, effects, extra, hold, xp):
        # the model's equations with the effects' terms: one compiled loop
        # (models/ode/_compiled.py), or None where it cannot take this batch
        foh = hold == "foh" and bool(inputs)
        useq_b = Useq if inputs else None
        batch = (effects, theta, M, extra, Zl, f)
        rec = compiled(method, Xl, useq_b, P, t, n_sub, h, foh, model.limits, batch)
        if rec is not None:
            rec_x, rec_z = rec[:, :, :nx], rec[:, :, nx:]
    if rec_x is None:
        stops = _stops(model, xp)
        step = _rk4_records if method == "rk4" else _ros2_records
        rec_x, rec_z = step(f, Xl, Zl, Useq, t, inputs, N, n_sub, h, hold, stops)
    Yt, Xt = _batch_outputs(
        model, effects, theta, where, extra, rec_x, rec_z, t_out, xp, (Useq, P, origin)
    )
    if segments is not None:  # rows of pieces back to one row per member
        Yt = Yt.reshape(B // K, K * N, Yt.shape[2])
        Xt = Xt.reshape(B // K, K * N, nx)
    return Yt, (Xt if want_states else None)


def _with_constants(effects, theta, params: Mapping[str, Any]) -> Mapping[str, Any]:
    """``params`` with the model constants that effects re-estimate replaced.

    An effect attached to ``"parameter"`` (a constant the model file holds fixed,
    :class:`pdmkit.models.mismatch.FileConstant`) carries the constant's value in every
    row, the file's value in rows without it.
    """
    swaps = {
        e.target: th["value"]
        for e, th in zip(effects, theta, strict=True)
        if e.candidate.attach == PARAMETER_ATTACH
    }
    return {**params, **swaps} if swaps else params


def _row_masks(masks: Sequence[Any], xp) -> list:
    """Each effect's ``(B,)`` row mask as a boolean array of the backend (None: all)."""
    M = [None if m is None else (m if is_torch(m) else np.asarray(m, bool)) for m in masks]
    if xp.name == "torch":
        M = [None if m is None else xp.torch.as_tensor(m) for m in M]
    return M


def _row_select(M: list, B: int, xp):
    """``where(i, a, b)``: ``a`` in the rows of effect ``i``, ``b`` in the others."""

    def where(i, a, b):
        if M[i] is None:
            return a
        m = M[i]
        nd = len(getattr(a, "shape", ())) or len(getattr(b, "shape", ()))
        if nd > 1:
            m = m.reshape((B,) + (1,) * (nd - 1))
        return xp.where(m, a, b)

    return where


def _input_sequences(effects, theta, M, useq, inputs, B, N, ts, xp, whole):
    """Inputs as ``(B, N)`` rows, the input-transform effects, and the stacked inputs.

    With ``whole`` (no pieces) the transforms (dead time, lags) are applied and the
    inputs stacked to ``(B, N, nu)``; otherwise the stack is None (pieces take theirs).
    """
    U = {}
    for name in inputs:
        seq = xp.asarray(useq[name])
        U[name] = xp.bcast(seq, (B, N)) if seq.ndim == 1 else seq
    transforms = [
        i
        for i, e in enumerate(effects)
        if e.candidate.attach == "input" and not e.candidate.input_override
    ]
    Useq = None  # (B, N, nu), or (B * K, L, nu) for pieces
    if whole:
        where = _row_select(M, B, xp)
        for i in transforms:
            e = effects[i]
            U[e.target] = where(
                i, e.candidate.input_sequence(xp, e, theta[i], U[e.target], ts), U[e.target]
            )
        if inputs:
            Useq = xp.stack([U[n] for n in inputs], 2)
    return U, transforms, Useq


def _pieces_as_rows(
    segments, U, inputs, transforms, effects, theta, M, params, X, t, origin, xp, ts
):
    """The batch with the record's pieces as rows (row ``b * K + k``: piece ``k`` of ``b``).

    Returns ``K`` and the pieces' inputs ``(B * K, L, nu)``, output times, theta, masks,
    parameters and initial states ``(B * K, nx)``.
    """
    B, nx = int(X.shape[0]), int(X.shape[2])
    starts, L = np.asarray(segments[0], dtype=int), int(segments[1])
    K = starts.size
    idx = starts[:, None] + np.arange(L)[None, :]  # (K, L)
    Useq = None
    if inputs:  # the pieces' samples only (a held record is never stacked whole)
        Useq = np.stack(
            [
                _piece_inputs(U, n, idx, transforms, effects, theta, M, B, xp, ts)
                for n in inputs
            ],
            2,
        )
    t_out = np.tile(t[idx] - origin, (B, 1))
    theta = [{p: np.repeat(np.asarray(v), K) for p, v in th.items()} for th in theta]
    M = [None if m is None else np.repeat(m, K) for m in M]
    params = {
        k: (v if isinstance(v, float | int) or np.ndim(v) == 0 else np.repeat(v, K))
        for k, v in params.items()
    }
    return K, Useq, t_out, theta, M, params, X.reshape(B * K, nx)


def _piece_inputs(U, name, idx, transforms, effects, theta, M, B, xp, ts):
    """Input ``name`` at the pieces' samples, ``(B * K, L)``.

    Transforms (a dead time reaching before a piece's start) act on the whole record,
    but only for the rows that carry them.
    """
    out = np.array(U[name][:, idx])  # (B, K, L)
    mine = [i for i in transforms if effects[i].target == name]
    if not mine:
        return out.reshape(-1, idx.shape[1])
    carry = np.zeros(B, dtype=bool)
    for i in mine:
        carry |= True if M[i] is None else np.asarray(M[i], bool)
    rows = np.flatnonzero(carry)
    seq = np.array(U[name][rows])  # (R, N) the whole record, these rows only
    for i in mine:
        e, th = effects[i], {p: v[rows] for p, v in theta[i].items()}
        on = np.ones(rows.size, bool) if M[i] is None else np.asarray(M[i], bool)[rows]
        new = e.candidate.input_sequence(xp, e, th, seq, ts)
        seq = np.where(on[:, None], new, seq)
    out[rows] = seq[:, idx]
    return out.reshape(-1, idx.shape[1])


def _with_outputs(model, effects, extra, P):
    """``f(t, x, u) -> x`` with the outputs' values added, where sensors need them.

    A sensor effect with a state of its own (a lag) follows its output; when the
    output is computed by ``outputs(t, x, u, p)`` its value is added to the states.
    """
    needs = model.output_fn is not None and any(
        effects[i].candidate.attach == "output" for i, _ in extra
    )
    if not needs:
        return lambda t, x, u: x
    return lambda t, x, u: {**x, **model.output_values(x, u, P, t)}


def _initial_extra_states(effects, theta, extra, states, Xl, Useq, inputs, B, xp, mp):
    """The effects' own states at the start, ``(B,)`` each (hysteresis, lags)."""
    Zl: list = []
    if extra:
        model, P, t0 = mp
        Uk = Useq[:, 0, :] if inputs else None
        u0d = {n: Uk[:, j] for j, n in enumerate(inputs)} if inputs else {}
        x0d = _with_outputs(model, effects, extra, P)(
            t0, dict(zip(states, Xl, strict=True)), u0d
        )
        for i, _o in extra:
            e = effects[i]
            Zl += [
                xp.bcast(c, (B,)) for c in e.candidate.extra_init(xp, e, theta[i], x0d, u0d)
            ]
        Zl = [z * 1.0 for z in Zl]
    return Zl


def _derivative_blocks(effects, theta, M, deriv, xp) -> tuple[dict, dict]:
    """Row slices of the derivative effects whose rows are adjacent, and theta there.

    An effect whose rows form one block (one structure of a batch: its jobs' rows are
    adjacent) is evaluated on that block only, not on every row with neutral values:
    with dozens of structures in a batch this is most of the arithmetic saved.
    """
    block = {}
    if xp.name == "numpy":
        for i in deriv:
            m = M[i]
            if m is None or effects[i].candidate.n_extra:
                continue
            rows = np.flatnonzero(m)
            if rows.size and rows[-1] - rows[0] + 1 == rows.size:
                block[i] = slice(int(rows[0]), int(rows[-1]) + 1)
    th_block = {i: {p: v[sl] for p, v in theta[i].items()} for i, sl in block.items()}
    return block, th_block


def _augmented_rhs(model, effects, theta, M, where, extra, P, B, nz, xp):
    """``f(t, X, Z, u) -> (dX, dZ)``: the model's rhs with the effects' terms added.

    States ``X`` and the effects' own states ``Z`` are lists of ``(B,)`` arrays.
    """
    states = model.state_names
    deriv = [i for i, e in enumerate(effects) if e.candidate.attach in DERIVATIVE_ATTACH]
    block, th_block = _derivative_blocks(effects, theta, M, deriv, xp)
    overrides = [(i, o) for i, o in extra if effects[i].candidate.input_override]
    seen = _with_outputs(model, effects, extra, P)

    def f(tt, Xl, Zl, u_raw):
        x = dict(zip(states, Xl, strict=True))
        u = u_raw
        if overrides:
            u = dict(u_raw)
            for i, o in overrides:
                e = effects[i]
                u[e.target] = where(i, Zl[o], u[e.target])
        d = model.rhs(tt, x, u, P)
        dx = {}
        for s in states:
            v = d[s]
            shp = getattr(v, "shape", None)
            dx[s] = v if shp is not None and tuple(shp) == (B,) else xp.bcast(v, (B,))
        if block:  # written in place by blocks below: own, writable arrays
            dx = {s: np.array(v, dtype=np.float64) for s, v in dx.items()}
        for i in deriv:
            e = effects[i]
            sl = block.get(i)
            if sl is None:
                dx = e.candidate.derivs(xp, e, theta[i], tt, x, u, dx)
                continue
            part = {s: v[sl] for s, v in dx.items()}
            new = e.candidate.derivs(
                xp,
                e,
                th_block[i],
                tt,
                {s: v[sl] for s, v in x.items()},
                {n: v[sl] for n, v in u.items()},
                dict(part),
            )
            for s, v in new.items():
                if v is not part[s]:
                    if dx[s].base is not None or not dx[s].flags.writeable:
                        dx[s] = np.array(dx[s], dtype=np.float64)
                    dx[s][sl] = v
        for i, o in extra:  # terms that read an effect's own states (hysteresis)
            e = effects[i]
            if e.candidate.attach in DERIVATIVE_ATTACH:
                zz = Zl[o : o + e.candidate.n_extra]
                dx = e.candidate.derivs_with_extra(xp, e, theta[i], tt, x, u, dx, zz)
        DX = [dx[s] for s in states]
        if not nz:
            return DX, ()
        DZ = []
        xo = seen(tt, x, u)
        for i, o in extra:
            e = effects[i]
            zz = Zl[o : o + e.candidate.n_extra]
            DZ += e.candidate.extra_derivs(xp, e, theta[i], xo, u_raw, zz)
        return DX, DZ

    return f


def _batch_outputs(model, effects, theta, where, extra, rec_x, rec_z, t_out, xp, given):
    """Stack the records to ``(B, N, ...)``, evaluate the outputs, apply sensor effects.

    ``given = (Useq (B, N, nu), params, origin)`` feeds the model's ``outputs``
    function, when it has one (otherwise the outputs are measured states).
    Returns ``(Y (B, N, n_out), X (B, N, nx))``.
    """
    states = model.state_names
    if isinstance(rec_x, np.ndarray):  # the compiled simulation's (B, N, nx)
        Xt = rec_x
    else:
        Xt = xp.stack([xp.stack(xs, 1) for xs in rec_x], 1)  # (B, N, nx)
    if isinstance(rec_z, np.ndarray):  # the compiled simulation's (B, N, m)
        Zt = rec_z if rec_z.shape[2] else None
    else:
        Zt = xp.stack([xp.stack(zs, 1) for zs in rec_z], 1) if rec_z else None
    outs = model.outputs
    if model.output_fn is None:
        Y = {o: Xt[:, :, states.index(o)] for o in outs}
    else:
        Y = _output_equations(model, effects, where, extra, Xt, Zt, t_out, xp, given)
    zoff = dict(extra)
    for i, e in enumerate(effects):
        c = e.candidate
        if c.attach == "output":
            o = zoff.get(i)
            zz = [Zt[:, :, o + j] for j in range(c.n_extra)] if o is not None else []
            Y[e.target] = where(
                i, c.output(xp, e, theta[i], t_out, Y[e.target], zz), Y[e.target]
            )
    return xp.stack([Y[o] for o in outs], 2), Xt


def _output_equations(model, effects, where, extra, Xt, Zt, t_out, xp, given) -> dict:
    """The model's ``outputs(t, x, u, p)`` along the records, ``(B, N)`` each.

    The inputs are those the states saw: after input transforms (a dead time) and
    with an actuator lag's own state in place of its command.
    """
    Useq, P, origin = given
    B, N = int(Xt.shape[0]), int(Xt.shape[1])
    x = {s: Xt[:, :, j] for j, s in enumerate(model.state_names)}
    u = (
        {n: Useq[:, :, j] for j, n in enumerate(model.input_names)}
        if Useq is not None
        else {}
    )
    for i, o in extra:
        e = effects[i]
        if e.candidate.input_override:
            u[e.target] = where(i, Zt[:, :, o], u[e.target])
    p = {
        k: (
            v
            if isinstance(v, float | int) or len(getattr(v, "shape", ())) == 0
            else v.reshape(B, 1)
        )
        for k, v in P.items()
    }
    y = model.output_values(x, u, p, t_out + origin)
    return {o: xp.bcast(xp.asarray(v) * 1.0, (B, N)) for o, v in y.items()}


# ---------------------------------------------------------------------------- public
def _resolve_inputs(model, time_n: int, inputs: Mapping[str, Any] | None, where: str):
    inputs = {} if inputs is None else dict(inputs)
    missing = [n for n in model.inputs if n not in inputs]
    extra = [n for n in inputs if n not in model.inputs]
    if missing or extra:
        raise ModelError(
            f"{where}: inputs must give exactly the model inputs {model.input_names}; "
            + (f"missing {missing}" if missing else "")
            + ("; " if missing and extra else "")
            + (f"unknown {extra}" if extra else "")
            + "."
        )
    out = {}
    for n, v in inputs.items():
        if not is_torch(v):
            v = np.asarray(v, dtype=np.float64)
            if v.ndim == 0:
                v = np.full(time_n, float(v))
        if v.shape[-1] != time_n or v.ndim > 2:
            raise ModelError(
                f"{where}: input {n!r} must have shape (n_samples,) or (n_members, "
                f"n_samples) with n_samples = {time_n}; got {tuple(v.shape)}."
            )
        out[n] = v
    return out


def _batch_size(where: str, *collections) -> int:
    sizes = set()
    for coll in collections:
        for v in coll.values():
            shp = tuple(getattr(v, "shape", ()))
            if len(shp) == 1:
                sizes.add(shp[0])
    sizes.discard(1)
    if len(sizes) > 1:
        raise ModelError(
            f"{where}: batched values disagree on the number of members: {sorted(sizes)}."
        )
    return sizes.pop() if sizes else 1


def simulate_ode(
    model: OdeModel,
    time: ArrayLike,
    inputs: Mapping[str, Any] | None = None,
    *,
    params: Mapping[str, Any] | None = None,
    x0: Mapping[str, Any] | None = None,
    effects: Sequence = (),
    effect_params: Mapping[str, Any] | None = None,
    n_sub: int = 1,
    hold: str = "zoh",
    method: str | None = None,
) -> ResponseData:
    """Simulate an :class:`OdeModel` (optionally with candidate effects) for a batch.

    Classical fourth-order Runge-Kutta with ``n_sub`` steps per sample interval; inputs
    are held constant between samples (``hold="zoh"``, default) or follow straight lines
    from sample to sample (``hold="foh"``, for sampled continuous signals). Any
    parameter, initial state or input may be a ``(n_members,)`` array
    (``(n_members, n_samples)`` for inputs) to simulate many members at once; when
    any of them is a torch tensor the whole simulation runs in torch and is
    differentiable.

    Parameters
    ----------
    model : OdeModel
    time : array_like, shape (n_samples,)
        Uniform sample times (s); the state is reported at each.
    inputs : dict of str to array_like
        One entry per model input.
    params : dict, optional
        Parameter values overriding the nominal ones (scalars or per-member arrays).
    x0 : dict, optional
        Initial states overriding ``model.initial``.
    effects : sequence of Effect, optional
        Candidate effects to add (:func:`attach_candidates`).
    effect_params : dict, optional
        Their parameters, keyed ``"<effect key>.<param>"`` (see ``Effect.qualified``).
    n_sub : int
        Integration steps per sample interval.
    hold : {"zoh", "foh"}
        Inputs held between samples, or straight lines.
    method : {"rk4", "ros2"}, optional
        Classical Runge-Kutta (explicit; numpy or torch), or ROS2, a linearly implicit
        Rosenbrock-W method for stiff models (numpy only): stable at any step, second
        order, a finite-difference Jacobian per step. Default: the model's
        ``integrator`` (rk4 when ``"auto"``).

    Returns
    -------
    ResponseData
        ``states`` and ``outputs`` of shape ``(n_members, n_samples)``; ``inputs`` as
        given.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode._modelfile import OdeModel
    >>> from pdmkit.models.ode._simulate import simulate_ode
    >>> decay = OdeModel({"h": "level"}, {}, ["h"], {"a": 1.0},
    ...                  lambda t, x, u, p: {"h": -p["a"] * x["h"]}, initial={"h": 1.0})
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> r = simulate_ode(decay, t, params={"a": np.array([1.0, 2.0])}, n_sub=4)
    >>> np.round(r.outputs["h"][:, -1], 5), np.round(np.exp([-1.0, -2.0]), 5)
    (array([0.36788, 0.13534]), array([0.36788, 0.13534]))
    """
    where = "simulate_ode"
    if not isinstance(n_sub, int | np.integer) or n_sub < 1:
        raise ModelError(f"{where}: n_sub must be a positive integer; got {n_sub!r}.")
    t, _ = _check_time(time)
    uin = _resolve_inputs(model, t.size, inputs, where)
    params = {} if params is None else dict(params)
    unknown = [k for k in params if k not in model.params]
    if unknown:
        raise ModelError(
            f"{where}: unknown parameters {unknown}; the model has {list(model.params)}."
        )
    x0 = {} if x0 is None else dict(x0)
    unknown = [k for k in x0 if k not in model.states]
    if unknown:
        raise ModelError(f"{where}: unknown states in x0: {unknown}.")
    effects = tuple(effects)
    effect_params = {} if effect_params is None else dict(effect_params)
    needed = [q for e in effects for q in e.qualified()]
    missing = [q for q in needed if q not in effect_params]
    extra = [q for q in effect_params if q not in needed]
    if missing or extra:
        raise ModelError(
            f"{where}: effect_params must give exactly {needed}; "
            f"missing {missing}, unknown {extra}."
        )
    seqs = {k: v for k, v in uin.items() if getattr(v, "ndim", 1) == 2}
    B = _batch_size(where, params, x0, effect_params, {k: v[:, 0] for k, v in seqs.items()})
    xp = _namespace(params, x0, effect_params, uin)
    P = {k: params.get(k, v) for k, v in model.params.items()}
    P = {
        k: (xp.bcast(v, (B,)) if is_torch(v) or np.ndim(v) else float(v))
        for k, v in P.items()
    }
    X0 = xp.stack(
        [xp.bcast(x0.get(s, model.initial[s]), (B,)) for s in model.state_names], 1
    )
    theta = [
        {p: xp.bcast(effect_params[f"{e.key}.{p}"], (B,)) for p in e.param_names}
        for e in effects
    ]
    U = {
        k: (xp.bcast(v, (B, t.size)) if getattr(v, "ndim", 1) == 2 else v)
        for k, v in uin.items()
    }
    masks = [None] * len(effects)
    Y, Xt = integrate_batch(
        model,
        effects,
        theta,
        masks,
        t,
        U,
        P,
        X0,
        int(n_sub),
        xp,
        True,
        hold,
        method=method,
    )
    states = {s: Xt[:, :, j] for j, s in enumerate(model.state_names)}
    outputs = {o: Y[:, :, j] for j, o in enumerate(model.outputs)}
    shown = {
        k: (v.expand(B, t.size) if is_torch(v) else np.broadcast_to(v, (B, t.size)))
        for k, v in uin.items()
    }
    return ResponseData(t, states=states, outputs=outputs, inputs=shown, name=model.name)


def stable_substeps(
    model: OdeModel,
    params: Mapping[str, Any],
    x_traj: np.ndarray,
    ts: float,
    u_traj: Mapping[str, ArrayLike] | None = None,
) -> int:
    """Smallest RK4 sub-step count keeping ``h * |lambda_max| <= 0.5`` along a trajectory.

    The local Jacobian is estimated by finite differences at a few points of ``x_traj``
    ``(N, nx)``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model, stable_substeps
    >>> msd = showcase_model("mass_spring_damper")  # |lambda| = 20 rad/s
    >>> x = np.zeros((10, 2))
    >>> stable_substeps(msd, msd.params, x, 0.01, {"F": np.zeros(10)})
    1
    >>> stable_substeps(msd, msd.params, x, 0.09, {"F": np.zeros(10)})  # 0.09 * 20 / 0.5
    4
    """
    lam = 0.0
    for J in state_jacobians(model, params, x_traj, u_traj, 25):
        lam = max(lam, float(np.max(np.abs(np.linalg.eigvals(J)))))
    return max(1, math.ceil(ts * lam / 0.5))


def state_jacobians(
    model: OdeModel,
    params: Mapping[str, Any],
    x_traj: np.ndarray,
    u_traj: Mapping[str, ArrayLike] | None,
    n_points: int,
) -> list[np.ndarray]:
    """Finite-difference state Jacobians of ``rhs`` at ``n_points`` points of a trajectory.

    The trajectory is ``x_traj (N, nx)`` (inputs ``u_traj``); only finite Jacobians are
    kept.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model, state_jacobians
    >>> msd = showcase_model("mass_spring_damper")  # m = 1, c = 4, k = 400
    >>> [J] = state_jacobians(msd, msd.params, np.zeros((5, 2)), {"F": np.zeros(5)}, 1)
    >>> np.round(J, 3).tolist()
    [[0.0, 1.0], [-400.0, -4.0]]
    """
    states = model.state_names
    N = x_traj.shape[0]
    idx = np.unique(np.linspace(0, N - 1, min(N, n_points)).astype(int))
    out = []
    for i in idx:
        x = {s: float(x_traj[i, j]) for j, s in enumerate(states)}
        u = {n: float(u_traj[n][i]) for n in model.inputs} if u_traj else None
        base = model.derivatives(x, u, params)
        J = np.zeros((len(states), len(states)))
        for j, s in enumerate(states):
            dxs = 1e-6 * max(abs(x[s]), 1e-3)
            x2 = dict(x)
            x2[s] = x[s] + dxs
            d2 = model.derivatives(x2, u, params)
            J[:, j] = [(float(d2[r]) - float(base[r])) / dxs for r in states]
        if np.all(np.isfinite(J)):
            out.append(J)
    return out
