"""The loops numba compiles around a translated model: one call, RK4 and ROS2.

Each is Python source (numba's subset) built around ``_fvec(t, x, u, p, out, tab,
opt, uw, xw)``, the model's translated function writing its values into ``out``
(:mod:`pdmkit.models.ode._compiled_source`), then the terms of the effects listed in
the table ``tab`` (:mod:`pdmkit.models.ode._compiled_effects`; the effects' own states
follow the model's in ``x``, their values follow its parameters in ``p``). The
integrators repeat :mod:`pdmkit.models.ode._integrators` operation for operation, member
by member:

- ``_rk4``: classical RK4 with ``n_sub`` steps per sample and the hard stops after each
  step (members are independent);
- ``_ros2``: the Rosenbrock-W method with the same finite-difference Jacobian (its
  increments scaled by the batch's largest value per state), the same reuse of the
  Jacobian and the same step control for the whole batch at once (members stay in
  lock step, so a fit's finite differences see the same steps).

So a compiled simulation agrees with the numpy one to rounding;
:class:`~pdmkit.models.ode._compiled.CompiledModelFunction` checks that on the first
samples of its first simulation before trusting it.
"""

from __future__ import annotations

__all__ = ["loops_source"]

_FVEC = """
def _fvec(t, x, u, p, out, tab, opt, uw, xw):
    # the table rows this member carries: p[a0] of them, at p[a0 + 1 ...] (a0 = p[-1]);
    # uw and xw are the caller's scratch (the inputs after lags; the states then the
    # outputs): no array is created or rebound here, which would cost more than the
    # terms themselves (numba counts references of every array a branch may hold)
    a0 = int(p[p.shape[0] - 1])
    na = int(p[a0])
    for j in range({nu}):
        uw[j] = u[j]
    if na > 0 and tab[int(p[a0 + 1]), 0] == 0:  # an input replaced by a lag's state
        for j in range(na):
            i = int(p[a0 + 1 + j])
            if tab[i, 0] == 0:
                uw[tab[i, 2]] = x[tab[i, 5]]
    r = {entry}(t, x, uw, p)
{stores}
    for j in range({nout}, out.shape[0]):
        out[j] = 0.0  # effects' own states this member does not carry stay put
    seen = False
    for j in range(na):
        i = int(p[a0 + 1 + j])
        st = tab[i, 0]
        if st == 0:
            continue
        if tab[i, 6] == 1:  # a sensor's state that follows an output
            if not seen:
                for k in range(x.shape[0]):
                    xw[k] = x[k]
                _yvec(t, x, uw, p, xw, x.shape[0])
                seen = True
            _hook(
                tab[i, 1], st, t, xw, uw, p, out, tab[i, 2], tab[i, 3], tab[i, 4],
                tab[i, 5], opt[i],
            )
        elif st == 3:  # a lag's own state follows the input itself
            _hook(
                tab[i, 1], st, t, x, u, p, out, tab[i, 2], tab[i, 3], tab[i, 4],
                tab[i, 5], opt[i],
            )
        else:
            _hook(
                tab[i, 1], st, t, x, uw, p, out, tab[i, 2], tab[i, 3], tab[i, 4],
                tab[i, 5], opt[i],
            )
"""

_FVEC0 = """
def _fvec0(t, x, u, p, out, tab, opt, uw, xw):
    r = {entry}(t, x, u, p)
{stores}
"""

_YVEC = """
def _yvec(t, x, u, p, out, at):
    r = {yentry}(t, x, u, p)
{ystores}
"""

_NO_YVEC = """
def _yvec(t, x, u, p, out, at):
    pass
"""

#: the dispatcher of a module without effects (an ``outputs`` function)
NO_HOOKS = """
def _hook(code, stage, t, x, u, p, dx, tg, pr, th0, zo, op):
    pass
"""

_KERNEL = """
def _kernel(t, X, U, P, out):
    x = np.empty({nx})
    u = np.empty({nu})
    p = np.empty({npar})
    row = np.empty({nout})
    tab = np.zeros((0, 7), dtype=np.int64)
    opt = np.zeros((0, 1))
    uw = np.empty({nu})
    xw = np.empty({nx})
    for b in range(out.shape[1]):
        for j in range({nx}):
            x[j] = X[j, b]
        for j in range({nu}):
            u[j] = U[j, b]
        for j in range({npar}):
            p[j] = P[j, b]
        _fvec0(t, x, u, p, row, tab, opt, uw, xw)
        for j in range({nout}):
            out[j, b] = row[j]
"""

_INPUTS = """
def _inputs(Useq, b, k, a0, a1, foh, u0, u1):
    for j in range(u0.shape[0]):
        uk = Useq[b, k, j]
        if foh:
            du = Useq[b, k + 1, j] - uk
            u0[j] = uk + a0 * du
            u1[j] = uk + a1 * du
        else:
            u0[j] = uk
            u1[j] = uk


def _stop(x, lim):
    for i in range(lim.shape[0]):
        j = int(lim[i, 0])
        jv = int(lim[i, 3])
        lo = lim[i, 1]
        hi = lim[i, 2]
        if jv >= 0:
            v = x[jv]
            if (x[j] >= hi and v > 0) or (x[j] <= lo and v < 0):
                x[jv] = 0.0 * v
        x[j] = min(max(x[j], lo), hi)
"""

_RK4 = """
def _rk4{sfx}(X0, Useq, P, t, n_sub, h, foh, lim, rec, tab, opt):
    for b in prange(X0.shape[1]):  # members are independent: one per thread
        _rk4_member{sfx}(b, X0, Useq, P, t, n_sub, h, foh, lim, rec, tab, opt)


def _rk4_member{sfx}(b, X0, Useq, P, t, n_sub, h, foh, lim, rec, tab, opt):
    n = X0.shape[0]
    x = np.empty(n)
    xs = np.empty(n)
    p = np.empty(P.shape[0])
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    u0 = np.empty({nu})
    um = np.empty({nu})
    u1 = np.empty({nu})
    uw = np.empty({nu})
    xw = np.empty(n + {nyo})
    h2 = 0.5 * h
    h6 = h / 6.0
    N = rec.shape[1]
    for j in range(P.shape[0]):
        p[j] = P[j, b]
    for j in range(n):
        x[j] = X0[j, b]
    for k in range(N):
        for j in range(n):
            rec[b, k, j] = x[j]
        if k == N - 1:
            break
        for s in range(n_sub):
            t0 = t[k] + s * h
            _inputs(Useq, b, k, s / n_sub, (s + 1) / n_sub, foh, u0, u1)
            _inputs(Useq, b, k, (s + 0.5) / n_sub, (s + 0.5) / n_sub, foh, um, um)
            {fv}(t0, x, u0, p, k1, tab, opt, uw, xw)
            for j in range(n):
                xs[j] = x[j] + h2 * k1[j]
            {fv}(t0 + h2, xs, um, p, k2, tab, opt, uw, xw)
            for j in range(n):
                xs[j] = x[j] + h2 * k2[j]
            {fv}(t0 + h2, xs, um, p, k3, tab, opt, uw, xw)
            for j in range(n):
                xs[j] = x[j] + h * k3[j]
            {fv}(t0 + h, xs, u1, p, k4, tab, opt, uw, xw)
            for j in range(n):
                x[j] = x[j] + h6 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
            _stop(x, lim)
"""

_ROS2 = """
def _inverse(gh, J, W, out):
    # (I - gh J)^-1 by Gauss-Jordan with partial pivoting (n is small)
    n = J.shape[0]
    for i in range(n):
        for j in range(n):
            W[i, j] = (1.0 if i == j else 0.0) - gh * J[i, j]
            out[i, j] = 1.0 if i == j else 0.0
    for c in range(n):
        piv = c
        for r in range(c + 1, n):
            if abs(W[r, c]) > abs(W[piv, c]):
                piv = r
        if piv != c:
            for j in range(n):
                W[c, j], W[piv, j] = W[piv, j], W[c, j]
                out[c, j], out[piv, j] = out[piv, j], out[c, j]
        d = W[c, c]
        for j in range(n):
            W[c, j] = W[c, j] / d
            out[c, j] = out[c, j] / d
        for r in range(n):
            if r != c and W[r, c] != 0.0:
                g = W[r, c]
                for j in range(n):
                    W[r, j] = W[r, j] - g * W[c, j]
                    out[r, j] = out[r, j] - g * out[c, j]


def _column_max(Y, out):
    for j in range(Y.shape[1]):
        m = 0.0
        for b in range(Y.shape[0]):
            m = max(m, abs(Y[b, j]))
        out[j] = m


def _matvec(A, v, out):
    for i in range(v.shape[0]):
        acc = 0.0
        for j in range(v.shape[0]):
            acc += A[i, j] * v[j]
        out[i] = acc
"""

_ROS2_LOOP = """
def _jacobian{sfx}(t0, Y, U0, PT, F0, J, x, f, tab, opt, uw, xw):
    B, n = Y.shape
    for j in range(n):
        ymax = 0.0
        for b in range(B):
            ymax = max(ymax, abs(Y[b, j]))
        for b in range(B):
            d = 1e-7 * max(abs(Y[b, j]), 1e-6 * (ymax + 1e-12))
            if not d > 0:
                d = 1e-12
            for i in range(n):
                x[i] = Y[b, i]
            x[j] = Y[b, j] + d
            {fv}(t0, x, U0[b], PT[b], f, tab, opt, uw, xw)
            for i in range(n):
                v = (f[i] - F0[b, i]) / d
                J[b, i, j] = v if math.isfinite(v) else 0.0


def _ros2{sfx}(
    X0, Useq, P, t, n_sub, h, foh, lim, rec, tab, opt, rtol, halvings, jac_age, gamma
):
    n, B = X0.shape
    N = rec.shape[1]
    Y = np.empty((B, n))
    PT = np.empty((B, P.shape[0]))
    for b in range(B):
        for j in range(n):
            Y[b, j] = X0[j, b]
        for j in range(P.shape[0]):
            PT[b, j] = P[j, b]
    new = np.empty((B, n))
    F0 = np.empty((B, n))
    J = np.zeros((B, n, n))
    U0 = np.empty((B, {nu}))
    U1 = np.empty((B, {nu}))
    x = np.empty(n)
    f = np.empty(n)
    uw = np.empty({nu})
    xw = np.empty(n + {nyo})
    k1 = np.empty(n)
    k2 = np.empty(n)
    err = np.empty((B, n))
    W = np.empty((n, n))
    Minv = np.empty((n, n))
    scale = np.empty(n)
    colmax = np.empty(n)
    _column_max(Y, scale)
    for j in range(n):
        scale[j] = scale[j] + 1e-300
    units = n_sub * 2**halvings
    unit = h / 2**halvings
    level = 0
    age = 0
    calm = 0
    fresh_ok = False
    for k in range(N):
        for b in range(B):
            for j in range(n):
                rec[b, k, j] = Y[b, j]
        if k == N - 1:
            break
        done = 0
        while done < units:
            step = min(2 ** (halvings - level), units - done)
            hh = step * unit
            t0 = t[k] + done * unit
            for b in range(B):
                _inputs(Useq, b, k, done / units, (done + step) / units, foh, U0[b], U1[b])
                {fv}(t0, Y[b], U0[b], PT[b], F0[b], tab, opt, uw, xw)
            if not (fresh_ok and age < jac_age):
                _jacobian{sfx}(t0, Y, U0, PT, F0, J, x, f, tab, opt, uw, xw)
            fresh_ok = True
            age = age + 1 if age < jac_age else 1
            for b in range(B):
                _inverse(gamma * hh, J[b], W, Minv)
                _matvec(Minv, F0[b], k1)
                for i in range(n):
                    x[i] = Y[b, i] + hh * k1[i]
                {fv}(t0 + hh, x, U1[b], PT[b], f, tab, opt, uw, xw)
                for i in range(n):
                    f[i] = f[i] - 2.0 * k1[i]
                _matvec(Minv, f, k2)
                for i in range(n):
                    new[b, i] = Y[b, i] + hh * (1.5 * k1[i] + 0.5 * k2[i])
                    f[i] = 0.5 * hh * (k1[i] + k2[i])
                _matvec(Minv, f, err[b])
            bad = False
            for b in range(B):
                for i in range(n):
                    tol = rtol * (abs(Y[b, i]) + 1e-3 * scale[i])
                    e = err[b, i]
                    if not math.isfinite(e) or abs(e) > tol:
                        bad = True
            if bad and level < halvings:
                level = level + 1
                fresh_ok = False
                age = 0
                calm = 0
                continue
            for b in range(B):
                for i in range(n):
                    Y[b, i] = new[b, i]
                _stop(Y[b], lim)
            _column_max(Y, colmax)
            for j in range(n):
                scale[j] = max(scale[j], colmax[j])
            done += step
            calm += 1
            if calm >= 4 and level > 0:
                level = level - 1
                calm = 0
"""


def loops_source(
    entry: str,
    nout: int,
    nx: int,
    nu: int,
    npar: int,
    outputs: tuple[str, int] | None = None,
) -> str:
    """The source of ``_fvec``, ``_kernel`` and the integrators (``_rk4``, ``_ros2``).

    Each integrator also as ``_rk4_plain`` / ``_ros2_plain``, around the model alone.

    Parameters
    ----------
    entry : str
        The translated model function (``_f0_rhs``), returning a tuple of ``nout``.
    nout, nx, nu, npar : int
        Values returned; states, inputs and parameters.
    outputs : (str, int), optional
        The translated ``outputs`` function and its number of outputs, for sensor
        lags that follow an output (``_yvec``).

    Returns
    -------
    str

    Examples
    --------
    >>> src = loops_source("_f0_rhs", 2, 2, 1, 3)
    >>> names = [s[4 : s.index("(")] for s in src.splitlines() if s.startswith("def ")]
    >>> names[:4], names[-1]
    (['_fvec', '_fvec0', '_yvec', '_kernel'], '_ros2')
    """
    stores = "\n".join(f"    out[{j}] = r[{j}]" for j in range(nout))
    sizes = {"entry": entry, "stores": stores, "nout": nout, "nx": nx, "nu": nu}
    sizes["npar"] = npar
    sizes["nyo"] = outputs[1] if outputs else 0
    yvec = _NO_YVEC
    if outputs:
        ystores = "\n".join(f"    out[at + {j}] = r[{j}]" for j in range(outputs[1]))
        yvec = _YVEC.format(yentry=outputs[0], ystores=ystores)
    parts = [_FVEC.format(**sizes), _FVEC0.format(**sizes), yvec]
    parts += [p.format(**sizes) for p in (_KERNEL, _INPUTS, _ROS2)]
    # each integrator twice: around the model alone (``_rk4_plain``: numba compiles
    # only what a call reaches, so a model without effects never compiles their
    # terms) and around the model with the effects of a table
    for fv, sfx in (("_fvec0", "_plain"), ("_fvec", "")):
        parts += [p.format(**sizes, fv=fv, sfx=sfx) for p in (_RK4, _ROS2_LOOP)]
    return "\n".join(parts)
