"""Linearisation of pdmkit ODE models at an operating point (torch autograd).

``dx/dt = f(t, x, u)`` near ``(x0, u0)``: ``A = df/dx``, ``B = df/du``, outputs ``y = C x``
(the measured states), ``D = 0``. The S-Mobile paper linearises its ball-balancing robot
at the quasi-stable point to fit physical parameters to measured FRFs; the poles of ``A``
are the model's natural frequencies and damping there.

:func:`linearize` takes a user :class:`~pdmkit.models.ode.OdeModel` (the model-file
contract ``rhs(t, x, u, p)`` with dicts), or any function ``fun(t, x, *args)`` on a
state vector, such as the pneumatic twin's :func:`pdmkit.models.piston_rhs` (its input, the
valve command, is a function of time, so only ``A`` is returned there).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from pdmkit._optional import require
from pdmkit.errors import ModelError
from pdmkit.models.ode._modelfile import OdeModel

if TYPE_CHECKING:
    import control
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["LinearModel", "linearize"]


@dataclass
class LinearModel:
    """A linearised model ``dx = A dx + B du``, ``dy = C dx + D du``.

    Attributes
    ----------
    A, B, C, D : ndarray
    x0, u0 : ndarray
        Operating point.
    state_names, input_names, output_names : list of str
    f0 : ndarray
        ``f(x0, u0)``; zero at an equilibrium.


    Examples
    --------
    >>> from pdmkit.models import linearize, showcase_model
    >>> lin = linearize(showcase_model("mass_spring_damper"), {"x": 0.0, "v": 0.0},
    ...                 {"F": 0.0})
    >>> lin.A.tolist(), lin.B.ravel().tolist()  # m = 1 kg, c = 4 N s/m, k = 400 N/m
    ([[0.0, 1.0], [-400.0, -4.0]], [0.0, 1.0])
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    x0: np.ndarray
    u0: np.ndarray
    state_names: list
    input_names: list
    output_names: list
    f0: np.ndarray

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (rad/s)."""
        return np.linalg.eigvals(self.A)

    @property
    def is_equilibrium(self) -> bool:
        """``f(x0, u0)`` is (numerically) zero."""
        scale = max(1.0, float(np.max(np.abs(self.A)) * np.max(np.abs(self.x0), initial=1)))
        return bool(np.max(np.abs(self.f0), initial=0.0) <= 1e-9 * scale)

    def frequency_response(self, omega: ArrayLike) -> np.ndarray:
        """``C (j omega I - A)^-1 B + D``, shape ``(n_out, n_in, n_omega)``."""
        w = np.asarray(omega, float).reshape(-1)
        n = self.A.shape[0]
        out = np.empty((self.C.shape[0], self.B.shape[1], w.size), dtype=complex)
        for i, wi in enumerate(w):
            out[:, :, i] = self.C @ np.linalg.solve(1j * wi * np.eye(n) - self.A, self.B)
            out[:, :, i] += self.D
        return out

    def to_control(self) -> control.StateSpace:
        """A :class:`control.StateSpace`."""
        import control

        return control.ss(self.A, self.B, self.C, self.D)

    def to_pandas(self) -> pd.DataFrame:
        """Poles with natural frequency (rad/s) and damping ratio."""
        p = self.poles
        wn = np.abs(p)
        with np.errstate(invalid="ignore", divide="ignore"):
            zeta = np.where(wn > 0, -p.real / wn, np.nan)
        return pd.DataFrame({"real": p.real, "imag": p.imag, "wn_rad_s": wn, "zeta": zeta})

    def plot(self, ax: Axes | None = None) -> Axes:
        """Pole map; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        p = self.poles
        ax.plot(p.real, p.imag, "x")
        ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel("real (1/s)")
        ax.set_ylabel("imag (rad/s)")
        return ax


def _vec(values, names, what) -> np.ndarray:
    if isinstance(values, Mapping):
        unknown = set(values) - set(names)
        if unknown:
            raise ModelError(
                f"{what} names unknown entries {sorted(unknown)}; known: {names}."
            )
        return np.array([float(values.get(k, 0.0)) for k in names])
    arr = np.asarray(values, dtype=float).reshape(-1)
    if arr.size != len(names):
        raise ModelError(
            f"{what} must have {len(names)} entries ({names}); got {arr.size}."
        )
    return arr


def linearize(
    model: OdeModel | Callable[..., Any],
    x0: Mapping[str, float] | ArrayLike,
    u0: Mapping[str, float] | ArrayLike | None = None,
    *,
    params: Mapping[str, float] | None = None,
    t: float = 0.0,
    args: tuple = (),
) -> LinearModel:
    """Jacobians of a model at an operating point, by torch autograd.

    Parameters
    ----------
    model : OdeModel or callable
        An :class:`~pdmkit.models.ode.OdeModel` (``rhs(t, x, u, p)`` with dicts),
        or ``fun(t, x, *args) -> dx/dt`` on a 1-D state tensor (e.g.
        :func:`pdmkit.models.piston_rhs` with ``args=(PneumaticParams(),)``).
    x0 : dict or array_like
        Operating-point state (dict by state name for an OdeModel; missing states 0).
    u0 : dict or array_like, optional
        Operating-point input (OdeModel only; default zeros).
    params : dict, optional
        Parameter values overriding the OdeModel's nominal ones.
    t : float
        Time at which ``rhs`` is evaluated.
    args : tuple
        Extra arguments of a plain ``fun``.

    Returns
    -------
    LinearModel
        ``B``/``D`` have zero columns for a plain ``fun``; ``C`` selects the OdeModel's
        outputs (identity for a plain ``fun``).

    Examples
    --------
    >>> import torch
    >>> from pdmkit.models.ode._modelfile import OdeModel
    >>> from pdmkit.models.ode._linearize import linearize
    >>> pend = OdeModel({"th": "angle", "w": "angular_velocity"}, {"T": "torque"}, ["th"],
    ...                 {"g": 9.81, "l": 0.5},
    ...                 lambda t, x, u, p: {"th": x["w"],
    ...                     "w": -p["g"] / p["l"] * torch.sin(x["th"]) + u["T"]})
    >>> lin = linearize(pend, {"th": 0.0, "w": 0.0}, {"T": 0.0})
    >>> [round(float(v), 3) for v in sorted(lin.poles.imag)]
    [-4.429, 4.429]
    """
    torch = require("torch", what="linearize (torch autograd)")

    dtype = torch.float64
    if isinstance(model, OdeModel):
        sn, un = model.state_names, model.input_names
        xv = _vec(x0, sn, "x0")
        uv = _vec({} if u0 is None else u0, un, "u0") if un else np.zeros(0)
        p = dict(model.params)
        if params:
            unknown = set(params) - set(p)
            if unknown:
                raise ModelError(f"params names unknown parameters {sorted(unknown)}.")
            p.update({k: float(v) for k, v in params.items()})
        pt = {k: torch.tensor(v, dtype=dtype) for k, v in p.items()}

        def f(x, u):
            xd = {k: x[i] for i, k in enumerate(sn)}
            ud = {k: u[i] for i, k in enumerate(un)}
            out = model.derivatives(xd, ud, pt, t=t)  # checks keys, names rhs errors
            return torch.stack(
                [torch.as_tensor(out[k], dtype=dtype) + 0.0 * x.sum() for k in sn]
            )

        C = np.zeros((len(model.outputs), len(sn)))
        for i, o in enumerate(model.outputs):
            C[i, sn.index(o)] = 1.0
        outs = list(model.outputs)
    elif callable(model):
        xv = np.asarray(x0, dtype=float).reshape(-1)
        uv = np.zeros(0)
        sn = [f"x{i}" for i in range(xv.size)]
        un = []

        def f(x, u):
            return torch.as_tensor(model(t, x, *args), dtype=dtype).reshape(-1)

        C = np.eye(xv.size)
        outs = sn
    else:
        raise ModelError(
            f"model must be an OdeModel or a function fun(t, x, *args); got "
            f"{type(model).__name__}."
        )
    xt = torch.tensor(xv, dtype=dtype)
    ut = torch.tensor(uv, dtype=dtype)
    f0 = f(xt, ut).detach().numpy()
    if not np.all(np.isfinite(f0)):
        raise ModelError(f"rhs is not finite at the operating point x0={xv}, u0={uv}.")
    A = torch.autograd.functional.jacobian(lambda x: f(x, ut), xt).numpy()
    if uv.size:
        B = torch.autograd.functional.jacobian(lambda u: f(xt, u), ut).numpy()
    else:
        B = np.zeros((xv.size, 0))
    A = np.asarray(A, float).reshape(xv.size, xv.size)
    B = np.asarray(B, float).reshape(xv.size, uv.size)
    return LinearModel(
        A, B, C, np.zeros((C.shape[0], uv.size)), xv, uv, list(sn), list(un), outs, f0
    )
