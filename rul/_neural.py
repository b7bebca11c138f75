"""A learned RUL model: a small torch LSTM, 1-D CNN or MLP over windows of indicators.

The network reads the last ``window`` samples of the standardised indicators (and,
by default, the unit's age) and regresses the RUL, capped at ``max_rul`` as is usual
on C-MAPSS (a piecewise-linear target: constant early in life, falling to 0 at
failure). Training units are split into ``n_folds`` groups; one network is trained per
fold on the other groups, the networks' mean is the estimate, and the out-of-fold
residuals, binned by the predicted RUL, give the intervals (cross-conformal, so the
intervals are calibrated on units the networks did not see).

Training is seeded (``random_state``) and runs on the CPU with ``n_threads`` threads.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit._optional import require
from pdmkit.errors import DataError
from pdmkit.rul._base import LearnedMixin, Unit, check_fitted, keep_init_args

if TYPE_CHECKING:
    from typing import Self

    from pdmkit.rul._result import RULPrediction


def _network(arch: str, n_inputs: int, window: int, hidden: int):
    torch = require("torch", what="the neural RUL model")
    nn = torch.nn

    class LSTMNet(nn.Module):
        def __init__(self):
            super().__init__()
            self.lstm = nn.LSTM(n_inputs, hidden, batch_first=True)
            self.head = nn.Sequential(nn.Linear(hidden, 32), nn.ReLU(), nn.Linear(32, 1))

        def forward(self, x):
            out, _ = self.lstm(x)
            return self.head(out[:, -1]).squeeze(-1)

    class CNNNet(nn.Module):
        def __init__(self):
            super().__init__()
            self.conv = nn.Sequential(
                nn.Conv1d(n_inputs, hidden, 5, padding=2),
                nn.ReLU(),
                nn.Conv1d(hidden, hidden, 5, padding=2),
                nn.ReLU(),
                nn.Conv1d(hidden, hidden, 5, padding=2),
                nn.ReLU(),
            )
            self.head = nn.Sequential(
                nn.Flatten(),
                nn.Dropout(0.2),
                nn.Linear(hidden * window, 64),
                nn.ReLU(),
                nn.Linear(64, 1),
            )

        def forward(self, x):
            return self.head(self.conv(torch.transpose(x, 1, 2))).squeeze(-1)

    class MLPNet(nn.Module):
        def __init__(self):
            super().__init__()
            self.body = nn.Sequential(
                nn.Flatten(),
                nn.Linear(n_inputs * window, hidden),
                nn.ReLU(),
                nn.Dropout(0.1),
                nn.Linear(hidden, hidden // 2 or 1),
                nn.ReLU(),
                nn.Linear(hidden // 2 or 1, 1),
            )

        def forward(self, x):
            return self.body(x).squeeze(-1)

    return {"lstm": LSTMNet, "cnn": CNNNet, "mlp": MLPNet}[arch]()


_N_BINS = 4  # bins of predicted RUL for the interval offsets

_MALLOC_TUNED = False


def _keep_buffers() -> None:
    """Let glibc's malloc keep freed memory for the next batch (once per process).

    Each training batch allocates and frees the same few-hundred-kB tensors; with
    glibc's defaults the heap's top grows for them and is trimmed back (or they are
    mapped and unmapped) every time, and every batch faults its pages in again: 35-40 %
    of an LSTM training's CPU time was in the kernel. Raising the top pad and the trim
    threshold to 256 MiB and the mmap threshold to 32 MiB (the most glibc allows) keeps
    the memory in the heap: on FD001 the kernel time of a 7 s fit went from 2.8 s to
    0.2 s (glibc's ``MALLOC_TOP_PAD_`` alone did it). The process keeps up to 256 MiB
    of freed heap. Elsewhere than glibc, nothing happens.
    """
    global _MALLOC_TUNED
    if _MALLOC_TUNED:
        return
    _MALLOC_TUNED = True
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        m_trim_threshold, m_top_pad, m_mmap_threshold = -1, -2, -3
        libc.mallopt(m_mmap_threshold, 32 << 20)
        libc.mallopt(m_trim_threshold, 256 << 20)
        libc.mallopt(m_top_pad, 256 << 20)
    except (OSError, AttributeError):  # not glibc
        pass


class _Threads:
    """Set torch's intra-op thread count for a block, then restore it."""

    def __init__(self, n: int):
        self.n = n

    def __enter__(self):
        torch = require("torch", what="the neural RUL model")

        _keep_buffers()
        self.old = torch.get_num_threads()
        torch.set_num_threads(self.n)

    def __exit__(self, *exc):
        torch = require("torch", what="the neural RUL model")

        torch.set_num_threads(self.old)


class NeuralRULModel(LearnedMixin, BaseEstimator):
    """RUL regression by a small LSTM or 1-D CNN over windows of indicators.

    Parameters
    ----------
    features : sequence of str, optional
        Input columns; default every numeric column but the key and label columns
        (``rul``, ``rul_true_final``, ``failed``), constant ones dropped.
    window : int, default 30
        Samples per input window.
    arch : {"lstm", "cnn", "mlp"}, default "lstm"
        ``"mlp"``: the flattened window through two ReLU layers (``hidden`` and
        ``hidden / 2`` units, dropout 0.1): on C-MAPSS FD001 (window 40, hidden 128,
        30 epochs, 5 folds) RMSE 11.5-11.9 over seeds in about 14 s of CPU, where the
        LSTM gave 12.4-13.8 in 40 s.
    hidden : int, default 64
        LSTM hidden size / CNN channels / MLP first layer.
    epochs : int, default 15
    batch_size : int, default 256
    lr : float, default 1e-3
        Adam learning rate (cosine-annealed to 0 over the epochs).
    max_rul : float or None, default 125
        Training targets are ``min(RUL, max_rul)``; predictions lie in ``[0, max_rul]``.
    n_folds : int, default 3
        Networks trained (each without one fold of units); their mean is the estimate
        and their out-of-fold residuals set the intervals. With 1, one network on all
        units and in-sample residuals (too narrow intervals).
    time_feature : bool, default True
        Add the time column (standardised) as an input: useful when every unit's clock
        starts when it is new, as in C-MAPSS.
    level : float, default 0.9
    pad : {"error", "edge"}, default "error"
        A history shorter than ``window`` raises a DataError, or is padded at its start
        with its first row.
    random_state : int, default 0
        Seed of the fold split, the weights and the batches.
    n_threads : int, default 1
        torch threads during ``fit`` and ``predict``.
    unit, time, failed : str
        Key columns.

    Attributes
    ----------
    features_ : list of str
    dropped_ : dict
        Constant features left out.
    models_ : list of torch.nn.Module
    mean_, scale_ : numpy.ndarray
        Input standardisation (time last when ``time_feature``).
    residual_bins_ : pandas.DataFrame
        Per bin of predicted RUL: the edges and the residual quantiles of the intervals.
    history_ : pandas.DataFrame
        Training loss per fold and epoch.
    n_units_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import NeuralRULModel
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u in range(12):
    ...     life = int(rng.integers(60, 100))
    ...     t = np.arange(1, life + 1)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t,
    ...         "x": (t / life) ** 2 + rng.normal(0, 0.05, life)}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> model = NeuralRULModel(window=10, hidden=8, epochs=3, n_folds=2,
    ...                        max_rul=50).fit(train)
    >>> p = model.predict(train[train.unit == 0])
    >>> bool(0 <= p.estimate[0] <= 50 and p.lower[0] <= p.estimate[0] <= p.upper[0])
    True
    """

    _int_settings = (
        ("window", 2),
        ("hidden", 1),
        ("epochs", 1),
        ("batch_size", 1),
        ("n_folds", 1),
        ("n_threads", 1),
    )
    _learner = "network"

    def __init__(
        self,
        features: Sequence[str] | None = None,
        *,
        window: int = 30,
        arch: str = "lstm",
        hidden: int = 64,
        epochs: int = 15,
        batch_size: int = 256,
        lr: float = 1e-3,
        max_rul: float | None = 125.0,
        n_folds: int = 3,
        time_feature: bool = True,
        level: float = 0.9,
        pad: str = "error",
        random_state: int = 0,
        n_threads: int = 1,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    @property
    def _min_history(self):
        return int(self.window) if self.pad == "error" else 1

    def _check_choices(self) -> None:
        """``arch`` and ``pad`` must be among their choices."""
        if self.arch not in ("lstm", "cnn", "mlp"):
            raise ValueError(f"arch must be 'lstm', 'cnn' or 'mlp', got {self.arch!r}")
        if self.pad not in ("error", "edge"):
            raise ValueError(f"pad must be 'error' or 'edge', got {self.pad!r}")

    # ------------------------------------------------------------------ data
    def _inputs(self, u: Unit) -> np.ndarray:
        x = u.x
        if self.time_feature:
            x = np.column_stack([x, u.t])
        return ((x - self.mean_) / self.scale_).astype(np.float32)

    def _pad(self, u: Unit, z: np.ndarray, what: str) -> np.ndarray:
        w = int(self.window)
        if len(z) >= w:
            return z
        if self.pad == "error":
            raise DataError(
                f"{what} unit {u.name!r} has {len(z)} samples; NeuralRULModel(window={w}) "
                f"needs at least {w} - pass pad='edge' (repeat the first row) or a smaller "
                "window"
            )
        return np.concatenate([np.repeat(z[:1], w - len(z), axis=0), z])

    def _windows(self, u: Unit, what="training"):
        """All windows of a unit and the (capped, scaled) RUL at their last samples."""
        w = int(self.window)
        z = self._pad(u, self._inputs(u), what)
        view = np.lib.stride_tricks.sliding_window_view(z, w, axis=0)  # (N, F, w)
        wins = np.ascontiguousarray(np.transpose(view, (0, 2, 1)))
        t_end = np.concatenate([np.full(len(z) - len(u), u.t[0]), u.t])[w - 1 :]
        rul = u.t[-1] - t_end
        return wins, np.minimum(rul, self._cap) / self._cap

    # ------------------------------------------------------------------ training
    def _train(self, X, y, seed, bar=None):
        torch = require("torch", what="the neural RUL model")

        torch.manual_seed(seed)
        net = _network(self.arch, X.shape[2], int(self.window), int(self.hidden))
        opt = torch.optim.Adam(net.parameters(), lr=float(self.lr))
        epochs = int(self.epochs)
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)
        Xt = torch.from_numpy(X)
        yt = torch.from_numpy(y.astype(np.float32))
        gen = torch.Generator().manual_seed(seed)
        losses = []
        bs = int(self.batch_size)
        for _ in range(epochs):
            net.train()
            perm = torch.randperm(len(Xt), generator=gen)
            total = 0.0
            for i in range(0, len(Xt), bs):
                idx = perm[i : i + bs]
                opt.zero_grad()
                loss = torch.nn.functional.mse_loss(net(Xt[idx]), yt[idx])
                loss.backward()
                opt.step()
                total += float(loss.detach()) * len(idx)
            sched.step()
            losses.append(total / len(Xt))
            if bar is not None:
                bar.update(1)
        net.eval()
        return net, losses

    @staticmethod
    def _run(nets, X):
        torch = require("torch", what="the neural RUL model")

        out = np.zeros(len(X))
        with torch.no_grad():
            Xt = torch.from_numpy(X)
            for net in nets:
                parts = [net(Xt[i : i + 4096]).numpy() for i in range(0, len(Xt), 4096)]
                out += np.concatenate(parts) if parts else np.zeros(0)
        return out / len(nets)

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Train the networks on run-to-failure units and calibrate the intervals.

        Returns
        -------
        self

        Raises
        ------
        pdmkit.errors.DataError
            Censored training units; units shorter than ``window`` with
            ``pad="error"``; every feature constant; NaN values.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import NeuralRULModel
        >>> t = pd.DataFrame({"unit": np.repeat([1, 2], 20),
        ...                   "time": np.tile(np.arange(20), 2),
        ...                   "x": np.r_[np.arange(20) / 20, np.arange(20) / 15]})
        >>> NeuralRULModel(window=5, hidden=4, epochs=1, n_folds=2).fit(t).n_units_
        2
        """
        units, level = self._start_fit(table)
        n_folds = min(int(self.n_folds), len(units))
        if int(self.n_folds) > 1 and n_folds < 2:
            raise DataError("cross-conformal intervals need at least 2 training units")
        stacked = np.concatenate(
            [np.column_stack([u.x, u.t]) if self.time_feature else u.x for u in units]
        )
        self.mean_ = stacked.mean(axis=0)
        scale = stacked.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)
        self._cap = (
            float(self.max_rul)
            if self.max_rul is not None
            else float(max(u.t[-1] - u.t[0] for u in units))
        )
        per_unit = [self._windows(u) for u in units]
        rng = np.random.default_rng(self.random_state)
        fold_of = rng.permutation(len(units)) % n_folds
        models, history = [], []
        oof_pred, oof_true = [], []
        from pdmkit._progress import progress_bar

        bar = progress_bar(n_folds * int(self.epochs), desc="neural epochs")
        with _Threads(int(self.n_threads)):
            for f in range(n_folds):
                train_idx = [
                    i for i in range(len(units)) if fold_of[i] != f or n_folds == 1
                ]
                X = np.concatenate([per_unit[i][0] for i in train_idx])
                y = np.concatenate([per_unit[i][1] for i in train_idx])
                net, losses = self._train(X, y, int(self.random_state) * 1000 + f, bar)
                models.append(net)
                history.extend(
                    {"fold": f, "epoch": e + 1, "loss": v} for e, v in enumerate(losses)
                )
                held = [i for i in range(len(units)) if fold_of[i] == f]
                Xh = np.concatenate([per_unit[i][0] for i in held])
                oof_pred.append(self._run([net], Xh))
                oof_true.append(np.concatenate([per_unit[i][1] for i in held]))
        if bar is not None:
            bar.close()
        self.models_ = models
        self.history_ = pd.DataFrame(history)
        pred = np.clip(np.concatenate(oof_pred), 0, 1) * self._cap
        true = np.concatenate(oof_true) * self._cap
        self._calibrate(pred, true, level, _N_BINS)
        self.n_units_ = len(units)
        return self

    # ------------------------------------------------------------------ pickling
    def __getstate__(self):
        state = self.__dict__.copy()
        if "models_" in state:  # the network classes are built lazily: keep weights
            state["models_"] = [
                {k: v.detach().clone() for k, v in net.state_dict().items()}
                for net in state["models_"]
            ]
        return state

    def __setstate__(self, state):
        weights = state.get("models_")
        self.__dict__.update(state)
        if weights is not None:
            torch = require("torch", what="the neural RUL model")

            n_inputs = len(self.features_) + int(bool(self.time_feature))
            shape = (self.arch, n_inputs, int(self.window), int(self.hidden))
            with torch.device("meta"):  # shapes only: a loaded state is untrusted
                declared = {k: v.shape for k, v in _network(*shape).state_dict().items()}
            nets = []
            for w in weights:
                if not isinstance(w, dict) or declared != {
                    k: getattr(v, "shape", None) for k, v in w.items()
                }:
                    raise ValueError(
                        "the stored weights do not have the shapes the model's settings "
                        f"(arch, inputs, window, hidden = {shape}) declare"
                    )
                net = _network(*shape)
                net.load_state_dict(w)
                net.eval()
                nets.append(net)
            self.models_ = nets

    # ------------------------------------------------------------------ prediction
    def _predict_units(self, units):
        X = np.stack(
            [self._pad(u, self._inputs(u), "the")[-int(self.window) :] for u in units]
        )
        with _Threads(int(self.n_threads)):
            est = np.clip(self._run(self.models_, X), 0, 1) * self._cap
        return self._binned_prediction(units, est, self._cap, float(self.level))

    def predict(self, table: pd.DataFrame) -> RULPrediction:
        """Predict the RUL of each unit from its last ``window`` samples.

        Returns
        -------
        RULPrediction

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import NeuralRULModel
        >>> t = pd.DataFrame({"unit": np.repeat([1, 2], 20),
        ...                   "time": np.tile(np.arange(20), 2),
        ...                   "x": np.r_[np.arange(20) / 20, np.arange(20) / 15]})
        >>> m = NeuralRULModel(window=5, hidden=4, epochs=1, n_folds=2).fit(t)
        >>> len(m.predict(t))
        2
        """
        check_fitted(self, "models_")
        return self._predict_units(self._split(table))
