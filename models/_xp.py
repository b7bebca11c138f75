"""A tiny array-namespace shim: the same model code runs on numpy arrays and torch tensors.

Only the handful of operations the models need are provided. Every function accepts
Python floats as well as arrays of the chosen backend, so parameters may be plain
numbers while the states are arrays (the fast path in numpy) or tensors (the
differentiable path in torch).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["NumpyNamespace", "TorchNamespace", "get_namespace", "is_torch"]


def is_torch(x: Any) -> bool:
    """True when ``x`` is a torch tensor (without importing torch when unused)."""
    mod = type(x).__module__
    return mod.startswith("torch") and hasattr(x, "detach")


class NumpyNamespace:
    """numpy back end (float64)."""

    name = "numpy"
    exp = staticmethod(np.exp)
    log = staticmethod(np.log)
    sqrt = staticmethod(np.sqrt)
    tanh = staticmethod(np.tanh)
    abs = staticmethod(np.abs)
    maximum = staticmethod(np.maximum)
    minimum = staticmethod(np.minimum)
    floor = staticmethod(np.floor)
    pi = math.pi

    where = staticmethod(np.where)
    sign = staticmethod(np.sign)

    @staticmethod
    def relu(a):
        return np.maximum(a, 0.0)

    @staticmethod
    def step(a):
        """Heaviside step as a boolean mask (multiplies like 1.0 / 0.0)."""
        return a > 0

    @staticmethod
    def sum0(a):
        """Sum over the first axis."""
        return np.add.reduce(a, axis=0)

    @staticmethod
    def rowsum3(a):
        """(6, ...) -> (2, ...): sums of rows 0-2 and rows 3-5."""
        return np.add.reduce(a.reshape(2, 3, *a.shape[1:]), axis=1)

    @staticmethod
    def rows(values, shape):
        """Stack values (arrays of ``shape`` or scalars) as rows of a new array."""
        out = np.empty((len(values), *shape))
        for i, v in enumerate(values):
            out[i] = v
        return out

    @staticmethod
    def clip(a, lo, hi):
        return np.minimum(np.maximum(a, lo), hi)

    @staticmethod
    def asarray(a):
        return np.asarray(a, dtype=np.float64)

    @staticmethod
    def broadcast(value, n: int):
        return np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)).copy()

    @staticmethod
    def stack(arrays, axis=0):
        return np.stack(arrays, axis=axis)

    @staticmethod
    def concat(arrays, axis=0):
        return np.concatenate(arrays, axis=axis)

    @staticmethod
    def to_numpy(a):
        return np.asarray(a, dtype=np.float64)

    @staticmethod
    def softplus(a, w):
        """Softplus of width ``w``: a smooth ``max(a, 0)``."""
        return w * np.logaddexp(0.0, a / w)

    @staticmethod
    def sigmoid(a):
        return 0.5 * (1.0 + np.tanh(0.5 * a))

    @staticmethod
    def take(a, idx):
        """``a[i, idx[i, j]]`` for a 2-D ``a`` (gather along axis 1)."""
        return np.take_along_axis(a, idx, axis=1)

    @staticmethod
    def bcast(a, shape):
        """A read-only broadcast view of ``a`` with ``shape``."""
        return np.broadcast_to(np.asarray(a, dtype=np.float64), shape)

    @staticmethod
    def isfinite_all(a) -> bool:
        return bool(np.isfinite(a).all())


class TorchNamespace:
    """torch back end (float64, autograd preserved)."""

    name = "torch"
    pi = math.pi

    def __init__(self) -> None:
        import torch

        self.torch = torch
        self.dtype = torch.float64

    def _t(self, a):
        if isinstance(a, self.torch.Tensor):
            return a
        return self.torch.as_tensor(a, dtype=self.dtype)

    def exp(self, a):
        return self.torch.exp(self._t(a))

    def log(self, a):
        return self.torch.log(self._t(a))

    def sqrt(self, a):
        return self.torch.sqrt(self._t(a))

    def tanh(self, a):
        return self.torch.tanh(self._t(a))

    def abs(self, a):
        return self.torch.abs(self._t(a))

    def floor(self, a):
        return self.torch.floor(self._t(a))

    def maximum(self, a, b):
        return self.torch.maximum(self._t(a), self._t(b))

    def minimum(self, a, b):
        return self.torch.minimum(self._t(a), self._t(b))

    def where(self, cond, a, b):
        return self.torch.where(self._t(cond).bool(), self._t(a), self._t(b))

    def relu(self, a):
        return self.torch.clamp(self._t(a), min=0.0)

    def sign(self, a):
        return self.torch.sign(self._t(a))

    def step(self, a):
        return self._t(a) > 0

    def clip(self, a, lo, hi):
        return self.torch.minimum(self.torch.maximum(self._t(a), self._t(lo)), self._t(hi))

    def asarray(self, a):
        return self._t(a).to(self.dtype)

    def sum0(self, a):
        return a.sum(dim=0)

    def rowsum3(self, a):
        return a.reshape(2, 3, *a.shape[1:]).sum(dim=1)

    def rows(self, values, shape):
        return self.torch.stack([self._t(v).to(self.dtype).expand(shape) for v in values])

    def broadcast(self, value, n: int):
        return self._t(value).to(self.dtype).expand(n).clone()

    def stack(self, arrays, axis=0):
        return self.torch.stack([self._t(a) for a in arrays], dim=axis)

    def concat(self, arrays, axis=0):
        return self.torch.cat([self._t(a) for a in arrays], dim=axis)

    @staticmethod
    def to_numpy(a):
        if hasattr(a, "detach"):
            return a.detach().cpu().numpy().astype(np.float64)
        return np.asarray(a, dtype=np.float64)

    def softplus(self, a, w):
        return w * self.torch.nn.functional.softplus(self._t(a) / w)

    def sigmoid(self, a):
        return self.torch.sigmoid(self._t(a))

    def take(self, a, idx):
        return self.torch.gather(a, 1, self.torch.as_tensor(idx, device=a.device))

    def bcast(self, a, shape):
        return self.asarray(a).expand(*shape)

    def isfinite_all(self, a) -> bool:
        return bool(self.torch.isfinite(self._t(a)).all())


_NUMPY = NumpyNamespace()


def get_namespace(*values: Any):
    """Return the torch namespace if any value is a torch tensor, else numpy's.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._xp import get_namespace
    >>> get_namespace(np.ones(3), 2.0).name
    'numpy'
    """
    for v in values:
        if is_torch(v):
            return TorchNamespace()
    return _NUMPY
