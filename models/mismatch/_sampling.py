"""How a record is prepared for fitting: the step, a decimation, pieces; its scales.

:func:`_choose_n_sub` picks the RK4 steps per sample from the model's fastest mode,
:func:`choose_decimation` / :func:`decimate` thin an oversampled record,
:func:`choose_pieces` cuts a long one for multiple shooting, and :func:`_nominal_scales`
measures the trajectory that candidate guesses and widths are scaled by.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._xp import NumpyNamespace
from pdmkit.models.mismatch._candidates import Scales
from pdmkit.models.mismatch._recording import Recording, part
from pdmkit.models.ode import integrate_batch, stable_substeps, state_jacobians

_NP = NumpyNamespace()

__all__ = [
    "Sampling",
    "choose_decimation",
    "choose_integrator",
    "choose_pieces",
    "choose_sampling",
    "converged_n_sub",
    "decimate",
    "simulate_outputs",
    "simulate_states",
]


# ---------------------------------------------------------------------------- scales


def _model_params(model, values: Mapping[str, float]) -> dict[str, float]:
    """The model's parameters, those in ``values`` (``"p:<name>"``) taken from there."""
    return {k: values.get(f"p:{k}", v) for k, v in model.params.items()}


def simulate_states(model, rec: Recording, values: Mapping[str, float], n_sub: int):
    """States ``(N, n_states)`` of ``model`` with ``values`` along ``rec``'s inputs.

    ``values`` holds ``p:`` parameters and ``x0:`` initial states; missing parameters are
    nominal.
    """
    P = _model_params(model, values)
    X0 = np.array([[values[f"x0:{s}"] for s in model.states]])
    with np.errstate(all="ignore"):
        _, Xt = integrate_batch(
            model, [], [], [], rec.time, rec.inputs, P, X0, n_sub, _NP, True, hold=rec.hold
        )
    return Xt[0]


def _nominal_scales(
    model,
    rec: Recording,
    values: Mapping[str, float],
    n_sub: int,
    along: tuple[np.ndarray, np.ndarray] | None = None,
) -> Scales:
    """Magnitudes of the trajectory simulated with ``values`` (for candidate guesses).

    ``along = (X, index)``: states already simulated at the recording's samples
    ``index`` (the fitted pieces of a long record), instead of a whole simulation.
    """
    t = rec.time
    P = _model_params(model, values)
    if along is None:
        X, index = simulate_states(model, rec, values, n_sub), np.arange(rec.n)
    else:
        X, index = along
    inputs = {k: v[index] for k, v in rec.inputs.items()}
    if not np.all(np.isfinite(X)):
        raise ModelError(
            f"{model.name}: the simulation with the fitted nominal parameters is not "
            "finite (it diverges); check the model, its parameters or INITIAL."
        )
    states = model.state_names
    xd = {s: X[:, j] for j, s in enumerate(states)}
    with np.errstate(all="ignore"):
        d = model.derivatives(xd, dict(inputs), P)
    F = {s: np.broadcast_to(np.asarray(d[s], dtype=float), (index.size,)) for s in states}
    stiffness = {}
    kinds = model.states
    pos_of = {"velocity": "position", "angular_velocity": "angle"}
    for v, kv in kinds.items():
        if kv not in pos_of:
            continue
        for p, kp in kinds.items():
            if kp != pos_of[kv]:
                continue
            dx = 1e-6 * max(float(np.std(xd[p])), 1e-9)
            x2 = dict(xd)
            x2[p] = xd[p] + dx
            with np.errstate(all="ignore"):
                d2 = model.derivatives(x2, dict(inputs), P)
            k = -(np.asarray(d2[v], dtype=float) - F[v]) / dx
            k = k[np.isfinite(k)] if np.ndim(k) else np.array([k])
            stiffness[(v, p)] = float(np.median(k)) if k.size else 0.0
    input_gain = {}
    for v, kv in kinds.items():
        if kv not in pos_of:
            continue
        for u in model.inputs:
            du = 1e-6 * max(float(np.std(inputs[u])), 1e-9)
            u2 = dict(inputs)
            u2[u] = inputs[u] + du
            with np.errstate(all="ignore"):
                d2 = model.derivatives(xd, u2, P)
            g = (np.asarray(d2[v], dtype=float) - F[v]) / du
            g = g[np.isfinite(g)] if np.ndim(g) else np.array([g])
            input_gain[(v, u)] = float(np.median(g)) if g.size else 0.0
    measured = {o: np.asarray(rec.outputs[o], dtype=float) for o in model.outputs}
    return Scales(
        y_min={o: float(np.nanmin(y)) for o, y in measured.items()},
        y_max={o: float(np.nanmax(y)) for o, y in measured.items()},
        y_std={o: float(np.nanstd(y)) for o, y in measured.items()},
        input_gain=input_gain,
        ts=rec.ts,
        h=rec.ts / n_sub,
        duration=float(t[-1] - t[0] + rec.ts),
        x_min={s: float(np.min(xd[s])) for s in states},
        x_max={s: float(np.max(xd[s])) for s in states},
        x_std={s: float(np.std(xd[s])) for s in states},
        x_quantiles={s: np.quantile(xd[s], Scales.QUANTILES) for s in states},
        f_std={s: float(np.std(F[s])) for s in states},
        f_absmax={s: float(np.max(np.abs(F[s]))) for s in states},
        u_min={k: float(np.min(v)) for k, v in rec.inputs.items()},
        u_max={k: float(np.max(v)) for k, v in rec.inputs.items()},
        u_std={k: float(np.std(v)) for k, v in rec.inputs.items()},
        stiffness=stiffness,
    )


#: samples of a record's start simulated to choose the step and the pieces
_PREFIX = 4000


def _head_states(model, rec: Recording, values: Mapping[str, float]):
    """RK4 states along the record's first samples, with 1, 4 or 16 steps per sample.

    Returns ``(head, X)``, ``X`` None when even 16 steps per sample diverge.
    """
    head = part(rec, 0, min(rec.n, _PREFIX))
    rk4 = model.with_integrator("rk4")
    for n_sub in (1, 4, 16):
        X = simulate_states(rk4, head, values, n_sub)
        if np.all(np.isfinite(X)):
            return head, X
    return head, None


def _choose_n_sub(
    model,
    rec: Recording,
    values: Mapping[str, float],
    along: tuple[np.ndarray, np.ndarray] | None = None,
) -> int:
    """RK4 steps per sample for a stable simulation, from the model's fastest mode.

    The mode is taken along the record's first samples, or along given states
    ``(X, index)``.
    """
    if model.integrator == "ros2":  # stable at any step; its error control refines
        return 1
    P = _model_params(model, values)
    if along is None:
        head, X = _head_states(model, rec, values)
        if X is None:
            return 16
        index = np.arange(head.n)
    else:
        X, index = along
    with np.errstate(all="ignore"):
        need = stable_substeps(
            model, P, X, rec.ts, {k: v[index] for k, v in rec.inputs.items()}
        )
    return int(min(max(need, 1), 32))


#: RK4 steps per sample beyond which a model counts as stiff (integrated with ROS2)
STIFF_SUBSTEPS = 8


def choose_integrator(
    model,
    rec: Recording,
    values: Mapping[str, float],
    along: tuple[np.ndarray, np.ndarray] | None = None,
):
    r"""The model to fit: integrated with ROS2 when it is stiff at the record's step.

    Stiff: explicit RK4 would need more than :data:`STIFF_SUBSTEPS` steps per sample
    along the record's first samples (or diverges at 16), as a pneumatic chamber's
    pressure near equilibrium or an end stop does. A model whose ``integrator`` is not
    ``"auto"`` is returned as it is. ``along``: RK4 states ``(X, index)`` already
    simulated at the record's samples ``index``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import load_model_source
    >>> from pdmkit.models.mismatch import make_recording
    >>> fast = load_model_source('STATES = {"y": "other"}\nOUTPUTS = ["y"]\n'
    ...     'PARAMS = {"k": 5000.0}\nINITIAL = {"y": 1.0}\n'
    ...     'def rhs(t, x, u, p):\n    return {"y": -p["k"] * x["y"]}\n')
    >>> t = np.arange(100) * 0.01
    >>> rec = make_recording(fast, {"time": t, "y": np.exp(-5000 * t)})
    >>> choose_integrator(fast, rec, {"p:k": 5000.0, "x0:y": 1.0}).integrator
    'ros2'
    """
    if model.integrator != "auto":
        return model
    need = _choose_n_sub(model.with_integrator("rk4"), rec, values, along)
    return model.with_integrator("ros2" if need > STIFF_SUBSTEPS else "rk4")


#: the step after decimation still resolves the model's fastest mode this many times
DECIMATE_SAMPLES_PER_TIME_CONSTANT = 20
#: ... and keeps at least this share of the inputs' variance below half its Nyquist
DECIMATE_KEEP_POWER = 0.99
#: largest decimation factor, and fewest samples left
DECIMATE_MAX, DECIMATE_MIN_SAMPLES = 10, 1000


def choose_decimation(
    model,
    rec: Recording,
    values: Mapping[str, float],
    n_sub: int,
    along: tuple[np.ndarray, np.ndarray] | None = None,
) -> int:
    """How many samples of an oversampled record to merge into one (1: none).

    A record sampled far faster than the model's fastest mode and its inputs need is
    decimated: the new step must resolve the fastest mode
    :data:`DECIMATE_SAMPLES_PER_TIME_CONSTANT` times, the inputs must keep
    :data:`DECIMATE_KEEP_POWER` of their variance below half the new Nyquist
    frequency, at most :data:`DECIMATE_MAX`, and :data:`DECIMATE_MIN_SAMPLES` samples
    must remain (see :func:`decimate`). ``along``: states ``(X, index)`` already
    simulated at the record's samples ``index``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch import choose_decimation, make_recording
    >>> msd = showcase_model("mass_spring_damper")  # resonance near 3 Hz
    >>> t = np.arange(40000) * 1e-4  # sampled at 10 kHz
    >>> F = 20 * np.sin(2 * np.pi * 0.5 * t)
    >>> rec = make_recording(msd, {"time": t, "F": F, "x": 0 * t})
    >>> values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    >>> choose_decimation(msd, rec, values, 1)
    10
    """
    if model.integrator == "ros2":
        return _stiff_decimation(model, rec, values)
    if along is None:
        head = part(rec, 0, min(rec.n, _PREFIX))
        X, index = simulate_states(model, head, values, n_sub), np.arange(head.n)
    else:
        X, index = along
    if not np.all(np.isfinite(X)):
        return 1
    P = _model_params(model, values)
    inputs = {k: v[index] for k, v in rec.inputs.items()}
    fast = [
        float(np.max(np.abs(np.linalg.eigvals(J))))
        for J in state_jacobians(model, P, X, inputs, 12)
    ]
    if not fast or max(fast) <= 0:
        return 1
    d = int(1.0 / (DECIMATE_SAMPLES_PER_TIME_CONSTANT * max(fast) * rec.ts))
    return _input_decimation(rec, min(d, DECIMATE_MAX, rec.n // DECIMATE_MIN_SAMPLES))


#: a stiff model's decimated simulation may differ from the full-rate one by this
#: share of each output's spread (at the kept samples)
DECIMATE_STIFF_TOLERANCE = 0.01


def _stiff_decimation(model, rec: Recording, values: Mapping[str, float]) -> int:
    """The decimation of a stiff model's record, checked by simulation.

    The largest factor that changes the simulated outputs by less than
    :data:`DECIMATE_STIFF_TOLERANCE` of their spread.

    A stiff model's fastest modes (a chamber's pressure settling in microseconds)
    need not be resolved: the stiff integrator damps them. What must hold is the
    simulation the fit sees, so the factor is checked by simulating the whole record
    at full rate and decimated (the inputs' bandwidth bounds it too).
    """
    d_max = _input_decimation(rec, min(DECIMATE_MAX, rec.n // DECIMATE_MIN_SAMPLES))
    if d_max < 2:
        return 1
    full = simulate_outputs(model, rec, values)
    spread = np.nanstd(rec.y(model), axis=0) + 1e-300
    if not np.all(np.isfinite(full)):
        return 1
    for d in range(d_max, 1, -1):
        y = simulate_outputs(model, decimate(rec, d), values)
        n = y.shape[0]
        err = np.max(np.abs(y - full[: n * d : d]), axis=0) / spread
        if np.all(np.isfinite(err)) and np.all(err <= DECIMATE_STIFF_TOLERANCE):
            return d
    return 1


def simulate_outputs(
    model, rec: Recording, values: Mapping[str, float], n_sub: int = 1
) -> np.ndarray:
    """Outputs ``(N, n_out)`` of ``model`` with ``values`` along ``rec``'s inputs."""
    P = _model_params(model, values)
    X0 = np.array([[values[f"x0:{s}"] for s in model.states]])
    with np.errstate(all="ignore"):
        Y, _ = integrate_batch(
            model, [], [], [], rec.time, rec.inputs, P, X0, n_sub, _NP, False, hold=rec.hold
        )
    return Y[0]


@dataclasses.dataclass(frozen=True)
class Sampling:
    """How a record is simulated in a fit: integrator, decimation, steps per sample.

    ``checked``: chosen by simulation agreement (:func:`_checked_step`) rather than by
    the model's fastest mode; later refinements of ``n_sub`` are then checked the same
    way (:func:`converged_n_sub`).
    """

    model: Any
    factor: int
    n_sub: int
    checked: bool = False


def choose_sampling(model, rec: Recording, values: Mapping[str, float]) -> Sampling:
    """The integrator, decimation and RK4 steps per sample a fit of ``rec`` runs with.

    First by the model's fastest mode (:func:`choose_integrator`,
    :func:`choose_decimation`, RK4 steps for stability). That rule is cautious: a mode
    that is fast only for a moment (a chamber's pressure as a valve opens, a laminar
    region near equal pressures) sets the step for the whole record. When it leaves an
    RK4 fit at more than :data:`CHECK_COST` right-hand-side calls per recorded sample,
    a cheaper step is sought by simulation (:func:`_checked_step`) and taken when it
    agrees with one twice as fine.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch import make_recording
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(4000) * 1e-3
    >>> rec = make_recording(msd, {"time": t, "F": 20 * np.sin(2 * np.pi * t), "x": 0 * t})
    >>> values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    >>> s = choose_sampling(msd, rec, values)
    >>> s.model.integrator, s.factor, s.n_sub
    ('rk4', 2, 1)
    """
    head, X = _head_states(model, rec, values)  # simulated once for every rule
    along = None if X is None else (X, np.arange(head.n))
    model = choose_integrator(model, rec, values, along)
    factor = choose_decimation(model, rec, values, 1, along)
    if model.integrator == "ros2":
        return Sampling(model, factor, 1)
    if X is None:
        n_sub = 16
    else:
        slower = dataclasses.replace(rec, ts=rec.ts * factor)  # the decimated step
        n_sub = _choose_n_sub(model, slower, values, along)
    cost = 4.0 * n_sub / factor
    if cost > CHECK_COST:
        head_states = None if X is None else (head, X)
        found = _checked_step(model, rec, values, cost, head_states)
        if found is not None:
            return Sampling(model, *found, checked=True)
    return Sampling(model, factor, n_sub)


#: RK4 right-hand-side calls per recorded sample above which a cheaper step is sought
CHECK_COST = 4.0
#: two simulations agree when they differ by at most this share of each output's spread
CHECK_TOLERANCE = 0.01


#: share of the samples on which a decimated simulation of an output that an input drives
#: directly may disagree (its largest differences are not counted)
CHECK_SKIP = 0.01


def _agree(a: np.ndarray, b: np.ndarray, spread: np.ndarray, fed=None) -> bool:
    """``a`` and ``b`` (samples x outputs) finite and within the tolerance.

    The largest difference of each output counts, except for the outputs ``fed``
    (a boolean per output) through from an input: there the :data:`CHECK_SKIP`
    quantile. Such an output (a flow meter behind a valve) jumps when the input
    switches, and at the switching samples a decimated input's block mean differs
    from a finer one's at any integration step.
    """
    m = min(a.shape[0], b.shape[0])
    d = np.abs(a[:m] - b[:m]) / spread
    if not np.all(np.isfinite(d)):
        return False
    err = np.max(d, axis=0)
    if fed is not None and np.any(fed):
        err = np.where(fed, np.quantile(d, 1.0 - CHECK_SKIP, axis=0), err)
    return bool(np.all(err <= CHECK_TOLERANCE))


def fed_through(model, head: Recording, X: np.ndarray, values) -> np.ndarray:
    r"""Which outputs an input drives directly, a boolean per output.

    ``outputs(t, x, u, p)`` evaluated at the states ``X`` along ``head``'s samples with
    the recorded inputs, then with each input set to its smallest and its largest
    recorded value: an output that changes depends on the input itself, not only
    through the states. A model without an ``outputs`` function has none.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import load_model_source
    >>> from pdmkit.models.mismatch import make_recording
    >>> m = load_model_source('STATES = {"h": "level"}\nINPUTS = {"q": "flow"}\n'
    ...     'OUTPUTS = {"h": "level", "q_out": "flow"}\nPARAMS = {"a": 1.0}\n'
    ...     'INITIAL = {"h": 1.0}\n'
    ...     'def rhs(t, x, u, p):\n    return {"h": u["q"] - p["a"] * x["h"]}\n'
    ...     'def outputs(t, x, u, p):\n'
    ...     '    return {"h": x["h"], "q_out": u["q"] + x["h"]}\n')
    >>> t = np.arange(50) * 0.1
    >>> rec = make_recording(m, {"time": t, "q": (t > 2) * 1.0, "h": 0 * t, "q_out": 0 * t})
    >>> fed_through(m, rec, np.ones((50, 1)), {"p:a": 1.0}).tolist()
    [False, True]
    """
    n_out = len(model.outputs)
    if model.output_fn is None or not head.inputs:
        return np.zeros(n_out, dtype=bool)
    P = _model_params(model, values)
    x = {s: X[:, j] for j, s in enumerate(model.states)}
    recorded = {q: v[: X.shape[0]] for q, v in head.inputs.items()}

    def y(u):
        with np.errstate(all="ignore"):
            out = model.output_values(x, u, P)
        return np.column_stack(
            [np.broadcast_to(np.asarray(out[o], dtype=float), (X.shape[0],))
             for o in model.outputs]
        )  # fmt: skip

    base = y(recorded)
    scale = np.nanmax(np.abs(base), axis=0) + 1e-300
    fed = np.zeros(n_out, dtype=bool)
    for q, v in head.inputs.items():
        for value in (np.min(v), np.max(v)):
            moved = np.abs(y({**recorded, q: np.full_like(recorded[q], value)}) - base)
            fed |= np.nanmax(moved, axis=0) > 1e-9 * scale
    return fed


def _checked_step(
    model, rec: Recording, values: Mapping[str, float], cost: float, head=None
) -> tuple[int, int] | None:
    """``(factor, n_sub)`` at most half the ``cost``, checked by simulation, or None.

    For even factors from the largest the inputs allow, and 1, 2, 4... RK4 steps per
    sample: the whole record simulated at that step must agree (within
    :data:`CHECK_TOLERANCE` of each output's spread) with the record decimated half as
    far and simulated with half the step. The first that agrees is the cheapest.
    ``head``: ``(recording, states)`` along the record's first samples, to tell the
    outputs an input drives directly (:func:`fed_through`).
    """
    d_max = _input_decimation(rec, min(DECIMATE_MAX, rec.n // DECIMATE_MIN_SAMPLES))
    spread = np.nanstd(rec.y(model), axis=0) + 1e-300
    fed = fed_through(model, *head, values) if head is not None else None
    for d in range(d_max - d_max % 2, 1, -2):
        coarse_rec, fine_rec = decimate(rec, d), decimate(rec, d // 2)
        n = 1
        while 4.0 * n / d <= cost / 2:
            coarse = simulate_outputs(model, coarse_rec, values, n)
            if np.all(np.isfinite(coarse)):
                fine = simulate_outputs(model, fine_rec, values, n)
                if _agree(coarse, fine[::2], spread, fed):
                    return d, n
            n *= 2
    return None


def converged_n_sub(model, rec: Recording, values: Mapping[str, float], n_sub: int) -> int:
    """The fewest RK4 steps per sample, from ``n_sub``, that halving the step confirms.

    Used when the parameters have moved (after a fit) to recheck a step that was
    chosen by simulation (:class:`Sampling` ``checked``); at most 32.
    """
    spread = np.nanstd(rec.y(model), axis=0) + 1e-300
    n = max(int(n_sub), 1)
    while n < 32:
        if _agree(
            simulate_outputs(model, rec, values, n),
            simulate_outputs(model, rec, values, 2 * n),
            spread,
        ):
            return n
        n *= 2
    return 32


def _input_decimation(rec: Recording, d: int) -> int:
    """``d`` lowered until the inputs keep their power below half the new Nyquist."""
    for u in rec.inputs.values():
        if d < 2:
            break
        spec = np.abs(np.fft.rfft(u - np.mean(u))) ** 2
        total = float(np.sum(spec[1:]))
        if total <= 0:
            continue
        cum = np.cumsum(spec[1:]) / total
        f = np.fft.rfftfreq(u.size, rec.ts)[1:]
        f_need = float(f[min(np.searchsorted(cum, DECIMATE_KEEP_POWER), f.size - 1)])
        # half the new Nyquist frequency must lie above f_need
        d = min(d, int(1.0 / (4.0 * f_need * rec.ts)) if f_need > 0 else d)
    return max(int(d), 1)


def decimate(rec: Recording, factor: int) -> Recording:
    """Every ``factor``-th sample.

    A held input (``rec.hold == "zoh"``) becomes the mean over the ``factor`` samples it
    stands for (held over that interval it delivers the same impulse); an interpolated one
    (``"foh"``, a smooth sampled signal) and each output are the samples themselves.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch import Recording, decimate
    >>> t = np.arange(6) * 0.1
    >>> rec = Recording(t, 0.1, {"u": np.arange(6.0)}, {"y": 10 * np.arange(6.0)})
    >>> r = decimate(rec, 3)
    >>> r.time.tolist(), r.inputs["u"].tolist(), r.outputs["y"].tolist()
    ([0.0, 0.30000000000000004], [1.0, 4.0], [0.0, 30.0])
    """
    n = (rec.n // factor) * factor
    if rec.hold == "zoh":
        blocks = {k: v[:n].reshape(-1, factor).mean(axis=1) for k, v in rec.inputs.items()}
    else:
        blocks = {k: v[:n:factor] for k, v in rec.inputs.items()}
    return dataclasses.replace(
        rec,
        time=rec.time[:n:factor],
        ts=rec.ts * factor,
        inputs=blocks,
        outputs={k: v[:n:factor] for k, v in rec.outputs.items()},
    )


#: records of up to this many fitted samples are simulated whole ...
PIECES_FROM = 3000
#: ... unless the model integrates (a pole at zero: a position driven by a force), whose
#: free-run error drifts without bound: from this many samples such a record is fitted
#: in pieces too, so that no drift runs longer than a piece (one long drift leaves the
#: fit with many local minima: open-loop friction fits on EMPS stopped in them)
PIECES_FROM_INTEGRATING = 1000
#: at most this many samples in the fitted pieces of a long record
PIECES_BUDGET = 16000
#: a piece lasts this many of the model's slowest time constants ...
PIECE_TIME_CONSTANTS = 5
#: ... and at least this many samples
PIECE_MIN = 400


def choose_pieces(
    model, rec: Recording, n_fit: int, values: Mapping[str, float], n_sub: int
) -> tuple[np.ndarray, int] | None:
    """Where a long record is cut into pieces for the fit (multiple shooting).

    Returns ``(starts, length)`` or ``None`` (fit the record whole): records of up to
    :data:`PIECES_FROM` samples (:data:`PIECES_FROM_INTEGRATING` for a model with an
    integrating mode, a zero eigenvalue of its state Jacobian), and models whose
    right-hand side reads the time, are fitted whole. A piece lasts
    :data:`PIECE_TIME_CONSTANTS` of the model's slowest decaying mode (at least
    :data:`PIECE_MIN` samples), so that its own initial state, fitted with it, has
    faded long before its end; at most
    :data:`PIECES_BUDGET` samples are fitted, in pieces spread evenly over the record.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.ode import showcase_model
    >>> from pdmkit.models.mismatch import choose_pieces, make_recording
    >>> msd = showcase_model("mass_spring_damper")
    >>> t = np.arange(20000) * 0.01
    >>> rec = make_recording(msd, {"time": t, "F": np.sin(t), "x": 0 * t})
    >>> values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    >>> starts, length = choose_pieces(msd, rec, rec.n, values, 1)
    >>> int(starts[0]), len(starts) * length <= 16000
    (0, True)
    """
    if n_fit <= min(PIECES_FROM, PIECES_FROM_INTEGRATING):
        return None
    head = part(rec, 0, min(n_fit, _PREFIX))
    X = simulate_states(model, head, values, n_sub)
    if not np.all(np.isfinite(X)):
        return None
    P = _model_params(model, values)
    idx = np.unique(np.linspace(0, head.n - 1, 12).astype(int))
    x = {s: X[idx, j] for j, s in enumerate(model.states)}
    u = {k: v[idx] for k, v in head.inputs.items()}
    later = float(head.time[-1] - head.time[0]) * 3.7 + 11.3
    with np.errstate(all="ignore"):
        d0 = model.derivatives(x, u, P, t=float(head.time[0]))
        d1 = model.derivatives(x, u, P, t=float(head.time[0]) + later)
    for s in model.states:  # the model reads the clock: pieces would shift it
        a, b = np.asarray(d0[s], dtype=float), np.asarray(d1[s], dtype=float)
        if not np.allclose(a, b, rtol=1e-12, atol=0.0, equal_nan=True):
            return None
    rates, integrating = [], []
    for J in state_jacobians(model, P, X, {k: v for k, v in head.inputs.items()}, 12):
        lam = np.linalg.eigvals(J)
        fast = max(float(np.max(np.abs(lam))), 1e-300)
        decay = -lam.real[-lam.real > 1e-6 * fast]
        integrating.append(bool(np.any(np.abs(lam) <= 1e-9 * fast)))
        if decay.size:
            rates.append(float(np.min(decay)))
    if n_fit <= PIECES_FROM and not (integrating and all(integrating)):
        return None
    ts = rec.ts
    if rates:
        length = math.ceil(PIECE_TIME_CONSTANTS / float(np.median(rates)) / ts)
    else:  # no decaying mode: long pieces
        length = n_fit // 4
    length = int(min(max(length, PIECE_MIN), n_fit // 2))
    k_all = n_fit // length
    k = int(max(2, min(k_all, PIECES_BUDGET // length)))
    starts = np.round(np.linspace(0, n_fit - length, k)).astype(int)
    return starts, length
