"""The two integrators behind :func:`~pdmkit.models.ode.simulate_ode`, batched.

``_rk4_records``: classical Runge-Kutta, ``n_sub`` fixed steps per sample interval.
``_ros2_records``: ROS2, a two-stage Rosenbrock-W method (L-stable, second order for any
Jacobian), for stiff models: a finite-difference Jacobian of the whole batch is reused
for a few steps and the embedded error halves the step for every member together. Both
apply the model's hard stops (``LIMITS``) after each step and record the state at each
output sample.
"""

from __future__ import annotations

import math

import numpy as np

from pdmkit.errors import ModelError

#: the ``attach`` kinds of augmentations whose ``derivs`` hook adds to the state
#: derivatives (the others transform inputs or outputs)
DERIVATIVE_ATTACH = ("velocity", "velocity_position", "level", "state")


def _stops(model, xp):
    """``stop(Xl) -> Xl``: the model's hard stops (``LIMITS``) applied after a step.

    A limited state is clipped to its range; its velocity state, when named, is set to
    zero where it would carry the state further out (a perfectly inelastic stop).
    None without limits.
    """
    if not model.limits:
        return None
    idx = {s: j for j, s in enumerate(model.state_names)}
    spec = [
        (idx[s], lo, hi, None if v is None else idx[v])
        for s, (lo, hi, v) in model.limits.items()
    ]

    def stop(Xl):
        Xl = list(Xl)
        for j, lo, hi, jv in spec:
            x = Xl[j]
            if jv is not None:
                v = Xl[jv]
                out = ((x >= hi) & (v > 0)) | ((x <= lo) & (v < 0))
                Xl[jv] = xp.where(out, 0.0 * v, v)
            Xl[j] = xp.clip(x, lo, hi)
        return Xl

    return stop


def _rk4_records(f, Xl, Zl, Useq, t, inputs, N, n_sub, h, hold, stop=None):
    """Classical RK4, ``n_sub`` steps per sample; the states at every sample.

    ``stop`` (the model's hard stops, :func:`_stops`) is applied after every step.

    Returns the lists of ``X`` (and ``Z``, empty without own states) per sample.
    """

    def comb(A, c, K):
        return [a + c * k for a, k in zip(A, K, strict=True)]

    if hold not in ("zoh", "foh"):
        raise ModelError(f"input hold must be 'zoh' or 'foh'; got {hold!r}.")
    foh = hold == "foh" and bool(inputs)
    nz = len(Zl)
    rec_x, rec_z = [], []
    h2, h6 = 0.5 * h, h / 6.0
    for k in range(N):
        rec_x.append(Xl)
        if nz:
            rec_z.append(Zl)
        if k == N - 1:
            break
        uk = {n: Useq[:, k, j] for j, n in enumerate(inputs)} if inputs else {}
        if foh:
            du = {n: Useq[:, k + 1, j] - uk[n] for j, n in enumerate(inputs)}
        for s in range(n_sub):
            t0 = float(t[k]) + s * h
            if foh:  # the input at the stage's time, on the line to the next sample
                a0, am, a1 = s / n_sub, (s + 0.5) / n_sub, (s + 1) / n_sub
                u0 = {n: uk[n] + a0 * du[n] for n in uk}
                um = {n: uk[n] + am * du[n] for n in uk}
                u1 = {n: uk[n] + a1 * du[n] for n in uk}
            else:
                u0 = um = u1 = uk
            k1, z1 = f(t0, Xl, Zl, u0)
            k2, z2 = f(t0 + h2, comb(Xl, h2, k1), comb(Zl, h2, z1), um)
            k3, z3 = f(t0 + h2, comb(Xl, h2, k2), comb(Zl, h2, z2), um)
            k4, z4 = f(t0 + h, comb(Xl, h, k3), comb(Zl, h, z3), u1)
            Xl = [
                x + h6 * (a + 2.0 * (b + c) + d)
                for x, a, b, c, d in zip(Xl, k1, k2, k3, k4, strict=True)
            ]
            if stop is not None:
                Xl = stop(Xl)
            if nz:
                Zl = [
                    z + h6 * (a + 2.0 * (b + c) + d)
                    for z, a, b, c, d in zip(Zl, z1, z2, z3, z4, strict=True)
                ]
    return rec_x, rec_z


#: gamma of ROS2 (Verwer, Spee, Blom & Hundsdorfer, SIAM J. Sci. Comput. 20, 1999)
_ROS2_GAMMA = 1.0 + 1.0 / math.sqrt(2.0)


def _fd_jacobian(f, tt, Y, nx, u, F0):
    """Batched forward-difference Jacobian ``(B, n, n)`` of ``f`` at the rows of ``Y``.

    ``Y`` is a list of ``(B,)`` arrays (states, then effect states); ``F0`` the value
    of ``f`` there. Each column costs one batched evaluation.
    """
    n = len(Y)
    B = Y[0].shape[0]
    J = np.empty((B, n, n))
    for j in range(n):
        y = Y[j]
        d = 1e-7 * np.maximum(np.abs(y), 1e-6 * (np.max(np.abs(y)) + 1e-12))
        d = np.where(d > 0, d, 1e-12)
        Y2 = list(Y)
        Y2[j] = y + d
        dx, dz = f(tt, Y2[:nx], Y2[nx:], u)
        F = np.stack([np.broadcast_to(v, (B,)) for v in (*dx, *dz)], 1)
        J[:, :, j] = (F - F0) / d[:, None]
    return np.where(np.isfinite(J), J, 0.0)


#: ROS2's local error tolerance (relative; absolute: this times the state's scale)
ROS2_RTOL = 1e-3
#: a sample interval's step is halved at most this many times (1/64 of its first size)
ROS2_MAX_HALVINGS = 6


#: accepted steps a finite-difference Jacobian is reused for (ROS2 keeps its order
#: with any matrix; a rejected step always takes a fresh one)
ROS2_JACOBIAN_AGE = 4


def _stack_rows(dx, dz, B):
    return np.stack([np.broadcast_to(v, (B,)) for v in (*dx, *dz)], 1)


def _ros2_step(f, t0, Y, nx, h, u0, u1, J):
    """One ROS2 step of size ``h`` with Jacobian ``J`` (None: a fresh one).

    Returns the new rows, the local error estimate and the Jacobian used.
    """
    B = Y[0].shape[0]
    F0 = _stack_rows(*f(t0, Y[:nx], Y[nx:], u0), B)
    if J is None:
        J = _fd_jacobian(f, t0, Y, nx, u0, F0)
    n = len(Y)
    Minv = np.linalg.inv(np.eye(n)[None] - (_ROS2_GAMMA * h) * J)
    k1 = np.einsum("bij,bj->bi", Minv, F0)
    Y1 = [y + h * k1[:, j] for j, y in enumerate(Y)]
    F1 = _stack_rows(*f(t0 + h, Y1[:nx], Y1[nx:], u1), B)
    k2 = np.einsum("bij,bj->bi", Minv, F1 - 2.0 * k1)
    new = [y + h * (1.5 * k1[:, j] + 0.5 * k2[:, j]) for j, y in enumerate(Y)]
    # against the embedded linearly implicit Euler step, filtered through
    # (I - g h J)^-1 as Shampine filters stiff error estimates: stiff modes damped
    # by both solutions do not count as error
    err = np.einsum("bij,bj->bi", Minv, 0.5 * h * (k1 + k2))
    return new, err, J


def _ros2_records(f, Xl, Zl, Useq, t, inputs, N, n_sub, h, hold, stop=None):
    """ROS2, a Rosenbrock-W method: L-stable, second order for any Jacobian.

    ``(I - g h J) k1 = f(y)``, ``(I - g h J) k2 = f(y + h k1) - 2 k1``,
    ``y += h (3 k1 + k2) / 2`` with ``g = 1 + 1/sqrt(2)`` and ``J`` a finite-difference
    Jacobian (reused for :data:`ROS2_JACOBIAN_AGE` steps). Stiff modes (a chamber's
    pressure near equilibrium, an end stop) are damped instead of limiting the step,
    so a sample interval takes one or two steps where explicit RK4 needs dozens.
    Where the embedded first-order solution differs from the step by more than
    :data:`ROS2_RTOL` (a valve switching, a stop reached), the step is halved for the
    whole batch (rows stay in lockstep, so the finite differences of a fit see the
    same steps) and grows back once steps pass. Returns what :func:`_rk4_records`
    returns.
    """
    if hold not in ("zoh", "foh"):
        raise ModelError(f"input hold must be 'zoh' or 'foh'; got {hold!r}.")
    foh = hold == "foh" and bool(inputs)
    nx, nz = len(Xl), len(Zl)
    rec_x, rec_z = [], []
    B = max([int(np.size(y)) for y in (*Xl, *Zl)] + [1])
    Y = [np.broadcast_to(np.asarray(y, dtype=float), (B,)).copy() for y in (*Xl, *Zl)]
    scale = np.array([np.max(np.abs(y)) for y in Y]) + 1e-300
    units = n_sub * 2**ROS2_MAX_HALVINGS  # a sample interval in the finest steps
    unit = h / 2**ROS2_MAX_HALVINGS
    level, J, age, calm = 0, None, 0, 0
    for k in range(N):
        rec_x.append(Y[:nx])
        if nz:
            rec_z.append(Y[nx:])
        if k == N - 1:
            break
        uk = {n: Useq[:, k, j] for j, n in enumerate(inputs)} if inputs else {}
        du = {n: Useq[:, k + 1, j] - uk[n] for j, n in enumerate(inputs)} if foh else {}
        done = 0
        while done < units:
            step = min(2 ** (ROS2_MAX_HALVINGS - level), units - done)
            hh = step * unit
            t0 = float(t[k]) + done * unit
            if foh:
                u0 = {n: uk[n] + done / units * du[n] for n in uk}
                u1 = {n: uk[n] + (done + step) / units * du[n] for n in uk}
            else:
                u0 = u1 = uk
            new, err, J = _ros2_step(
                f, t0, Y, nx, hh, u0, u1, J if age < ROS2_JACOBIAN_AGE else None
            )
            age = age + 1 if age < ROS2_JACOBIAN_AGE else 1
            tol = ROS2_RTOL * (np.abs(np.stack(Y, 1)) + 1e-3 * scale[None, :])
            bad = ~np.isfinite(err) | (np.abs(err) > tol)
            if np.any(bad) and level < ROS2_MAX_HALVINGS:
                level, J, age, calm = level + 1, None, 0, 0
                continue
            Y = new if stop is None else stop(new[:nx]) + new[nx:]
            scale = np.maximum(scale, [np.max(np.abs(y)) for y in Y])
            done += step
            calm += 1
            if calm >= 4 and level > 0:  # four steps passed: try twice as long again
                level, calm = level - 1, 0
    return rec_x, rec_z
