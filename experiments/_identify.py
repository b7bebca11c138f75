"""The identification workflow: recording -> linear model -> JSON summary + HTML report.

``pdmkit identify DATA.csv --input COL --output COL --structure arx --json OUT.json
--out DIR`` calls :func:`run_identify`. The data are a CSV or Parquet table with one
column for the input and one for the output, and either a ``time`` column (s, uniform)
or a sampling rate given as ``fs``.

New model structures plug in through :data:`IDENTIFY_STRUCTURES`: a function
``(u, y, fs, order, criterion) -> model`` whose model has ``simulate(u)`` and
``to_dict()`` (with at least ``structure``, ``order``, ``poles``,
``natural_frequencies_hz``, ``damping``, ``fit_percent``), and optionally
``frequency_response(f)`` and ``plot(ax)`` (pole map) for the report.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs, check_magnitude, uniform_step
from pdmkit._outputs import OutputRun, to_jsonable
from pdmkit.ensembles import read_table
from pdmkit.errors import DataError, ModelError
from pdmkit.experiments._report import Report
from pdmkit.models._frf import frf_estimate
from pdmkit.models._ident import STRUCTURES, fit_percent, identify

__all__ = [
    "IDENTIFY_STRUCTURES",
    "build_identify_report",
    "identify_summary",
    "parse_order",
    "run_identify",
]


def _linear(structure: str) -> Callable[..., Any]:
    def fit(u, y, fs, order, criterion):
        return identify(u, y, fs, structure, order, criterion)

    fit.__name__ = f"identify_{structure}"
    return fit


def _modes(poles: np.ndarray, fs: float) -> tuple[list[float], list[float]]:
    """Natural frequencies (Hz) and damping ratios of discrete poles (upper half-plane)."""
    from pdmkit.models._ident import modes_from_poles

    fn, zeta, _ = modes_from_poles(poles, fs)
    return [float(v) for v in fn], [float(v) for v in zeta]


class _HammersteinWienerResult:
    """A fitted :class:`~pdmkit.models.HammersteinWiener` in the shape the CLI reports."""

    def __init__(self, model, fs: float):
        self.model, self.fs = model, fs

    def simulate(self, u) -> np.ndarray:
        return self.model.predict(u)

    def frequency_response(self, f) -> np.ndarray:
        """The linear block ``B(q)/F(q)`` at ``f`` Hz (the nonlinearities left out)."""
        q = np.exp(-2j * np.pi * np.asarray(f, dtype=float) / self.fs)  # q^-1 at f
        m = self.model
        b = np.polyval(m.b_[::-1], q) * q**m.nk
        return b / np.polyval(np.r_[1.0, m.f_][::-1], q)

    def to_dict(self) -> dict:
        m = self.model
        fn, zeta = _modes(np.asarray(m.poles_), self.fs)
        return {
            "structure": "hw",
            "order": {"nb": m.nb, "nf": m.nf, "nk": m.nk},
            "poles": [[float(v.real), float(v.imag)] for v in np.atleast_1d(m.poles_)],
            "natural_frequencies_hz": fn,
            "damping": zeta,
            "fit_percent": float(m.fit_percent_),
            "input_nl": str(m.input_nl),
            "output_nl": str(m.output_nl),
            "coefficients": dict(zip(m.coef_names_, map(float, m.coef_), strict=True)),
        }


class _FractionalResult:
    """A fitted fractional-order model in the shape the CLI reports."""

    def __init__(self, fit, fs: float):
        self.fit, self.fs = fit, fs

    def simulate(self, u) -> np.ndarray:
        return self.fit.model.simulate(u, 1.0 / self.fs)

    def frequency_response(self, f) -> np.ndarray:
        return self.fit.model.frequency_response(2 * np.pi * np.asarray(f, dtype=float))

    def to_dict(self) -> dict:
        fit = self.fit
        return {
            "structure": "fractional",
            "order": {"alpha": fit.alpha, "beta": fit.beta},
            "poles": [],  # not a rational model: no poles
            "natural_frequencies_hz": [],
            "damping": [],
            "fit_percent": float(fit.fit_percent),
            "alpha": fit.alpha,
            "beta": fit.beta,
            "a": fit.a,
            "b": fit.b,
            "c": fit.c,
            "error": float(fit.error),
        }


def _order_dict(order, keys: tuple[str, ...], structure: str) -> dict:
    if order is None:
        return {}
    if isinstance(order, int):
        return dict.fromkeys(keys[:2], order)
    unknown = set(order) - set(keys)
    if unknown:
        raise ModelError(
            f"--order for {structure} takes {', '.join(keys)}; got {sorted(unknown)}."
        )
    return dict(order)


def _fit_hw(u, y, fs, order, criterion):
    from pdmkit.models._hammerstein import HammersteinWiener

    opts = _order_dict(order, ("nb", "nf", "nk"), "hw")
    return _HammersteinWienerResult(HammersteinWiener(**opts).fit(u, y), fs)


def _fit_fractional(u, y, fs, order, criterion):
    from pdmkit.models._fractional import fit_fractional_tf

    fixed = _order_dict(order, ("alpha", "beta"), "fractional") or None
    fit = fit_fractional_tf(u, y, fs, domain="time", fixed_orders=fixed)
    return _FractionalResult(fit, fs)


#: Structure name -> ``fit(u, y, fs, order, criterion)``; extend to add structures.
IDENTIFY_STRUCTURES: dict[str, Callable[..., Any]] = {
    **{s: _linear(s) for s in STRUCTURES},
    "hw": _fit_hw,
    "fractional": _fit_fractional,
}


def parse_order(text: str | int | dict | None) -> int | dict | None:
    """Read an order as given on the command line.

    ``"4"`` -> 4 (every polynomial order); ``"na=4,nb=3,nk=1"`` -> a dict; None or
    ``""`` -> None (select by the criterion).

    Examples
    --------
    >>> parse_order("4"), parse_order("na=4, nb=2"), parse_order(None)
    (4, {'na': 4, 'nb': 2}, None)
    """
    if text is None or isinstance(text, int | dict):
        return text
    text = str(text).strip()
    if not text:
        return None
    if "=" not in text:
        try:
            return int(text)
        except ValueError:
            raise ModelError(
                f"--order must be an integer or key=value pairs like 'na=4,nb=3,nk=1'; "
                f"got {text!r}."
            ) from None
    out = {}
    for part in text.split(","):
        key, sep, val = part.partition("=")
        try:
            out[key.strip()] = int(val)
        except ValueError:
            raise ModelError(
                f"--order entry {part.strip()!r} is not key=integer (e.g. 'na=4')."
            ) from None
        if not sep or not key.strip():
            raise ModelError(f"--order entry {part.strip()!r} is not key=integer.")
    return out


def format_fit(percent: float | None, digits: int = 2) -> str:
    """A fit percentage as text; None (a simulation that diverged) said so."""
    if percent is None or not np.isfinite(percent):
        return "undefined (the model's simulation diverges)"
    return f"{percent:.{digits}f} %"


def _column(table: pd.DataFrame, name: str, path, role: str) -> np.ndarray:
    if name not in table.columns:
        raise DataError(
            f"{path}: no {role} column {name!r}; the table has {list(table.columns)}."
        )
    x = pd.to_numeric(table[name], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise DataError(
            f"{path}: column {name!r} has {bad.size} missing or non-numeric value(s), the "
            f"first in row {int(bad[0])}; clean or interpolate them."
        )
    check_magnitude(x, f"{path}: column {name!r}")
    if role in ("input", "output") and x.size and np.ptp(x) == 0:
        raise DataError(
            f"{path}: {role} column {name!r} is constant ({x[0]:g}); there is nothing "
            "to identify from it."
        )
    return x


def _sampling_rate(table: pd.DataFrame, fs, path) -> float:
    if fs is not None:
        return check_fs(fs)
    if "time" not in table.columns:
        raise DataError(
            f"{path}: no 'time' column to take the sampling rate from; add one (s) or "
            "pass fs (--fs)."
        )
    return 1.0 / uniform_step(_column(table, "time", path, "time"), str(path))


def identify_summary(model, **sources: Any) -> dict:
    """JSON summary of an identified model (the keys the CLI promises first).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> from pdmkit.models._ident import arx
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=2000)
    >>> y = signal.lfilter([0, 1.0], [1, -0.9], u)
    >>> list(identify_summary(arx(u, y, 1, 1)))[:6]
    ['structure', 'order', 'poles', 'natural_frequencies_hz', 'damping', 'fit_percent']
    """
    d = model.to_dict()
    keys = (
        "structure",
        "order",
        "poles",
        "natural_frequencies_hz",
        "damping",
        "fit_percent",
    )
    out = {k: d.get(k) for k in keys}
    out.update({k: v for k, v in d.items() if k not in out})
    out["sources"] = {
        k: (os.fspath(v) if v is not None else None) for k, v in sources.items()
    }
    return to_jsonable(out)


def build_identify_report(model, summary: dict, u, y, fs: float, title: str) -> Report:
    """HTML report: summary, modes, pole map, FRF vs H1 estimate, simulation vs data.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> from pdmkit.models._ident import arx
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=1000)
    >>> y = signal.lfilter([0, 0.1], [1, -1.6, 0.9], u)
    >>> m = arx(u, y, 2, 1, fs=100.0)
    >>> rep = build_identify_report(m, identify_summary(m), u, y, 100.0, "demo")
    >>> rep.to_html().count("data:image/png")
    3
    """
    import matplotlib.pyplot as plt

    rep = Report(title)
    rep.add_heading("Summary")
    fn = ", ".join(f"{v:.4g} Hz" for v in summary.get("natural_frequencies_hz") or [])
    rep.add_text(
        f"Structure {summary['structure']} with order {summary['order']}: simulation fit "
        f"{format_fit(summary['fit_percent'])} on the estimation data; modes at "
        f"{fn or 'none'}."
    )
    if hasattr(model, "to_pandas"):
        rep.add_table(model.to_pandas(), caption="Modes", float_format="{:.5g}")
    if hasattr(model, "plot"):
        rep.add_heading("Pole map")
        ax = model.plot()
        rep.add_figure(ax, caption="Poles (x) and zeros (o) in the z-plane")
    if hasattr(model, "frequency_response"):
        rep.add_heading("Frequency response")
        nper = int(min(4096, max(64, 2 ** int(np.log2(max(len(u) // 8, 64))))))
        estimate = frf_estimate(u, y, fs, nperseg=min(nper, len(u)))
        f, h1 = estimate.freq[1:], estimate.H[1:]  # without DC
        g = model.frequency_response(f)
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
        a1.semilogy(f, np.abs(h1), color="0.6", lw=0.8, label="H1 estimate (data)")
        a1.semilogy(f, np.abs(g), color="C0", label="model")
        a1.set_ylabel("|G|")
        a1.legend(loc="best", fontsize="small")
        a2.plot(f, np.degrees(np.unwrap(np.angle(h1))), color="0.6", lw=0.8)
        a2.plot(f, np.degrees(np.unwrap(np.angle(g))), color="C0")
        a2.set_ylabel("phase [deg]")
        a2.set_xlabel("frequency [Hz]")
        rep.add_figure(
            fig,
            caption="Model frequency response over the H1 estimate "
            "(scipy.signal.csd / welch)",
        )
    rep.add_heading("Simulation")
    y_sim = model.simulate(u)
    t = np.arange(len(y)) / fs
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(t, y, color="0.5", lw=0.8, label="measured")
    ax.plot(
        t, y_sim, color="C1", lw=0.8, label=f"simulated (fit {fit_percent(y, y_sim):.1f} %)"
    )
    ax.set_xlabel("time [s]")
    ax.legend(loc="best", fontsize="small")
    rep.add_figure(fig, caption="Simulated vs measured output")
    if hasattr(model, "residual_test"):
        res = model.residual_test(u, y)
        rep.add_json(
            to_jsonable(res),
            caption="Residual tests (Ljung-Box whiteness, input cross-correlation)",
        )
    rep.add_json(summary, caption="summary.json")
    return rep


def run_identify(
    data_path: str | os.PathLike,
    *,
    input: str,
    output: str,
    structure: str = "arx",
    order: int | dict | str | None = None,
    out_dir: str | os.PathLike,
    json_path: str | os.PathLike | None = None,
    fs: float | None = None,
    criterion: str = "aic",
) -> dict:
    """Identify a model from a recording; write ``summary.json`` and ``report.html``.

    Parameters
    ----------
    data_path : path
        CSV or Parquet with the ``input`` and ``output`` columns and a ``time`` column
        (or pass ``fs``).
    input, output : str
        Column names.
    structure : str, default "arx"
        A key of :data:`IDENTIFY_STRUCTURES` (``ar``, ``arx``, ``armax``, ``oe``,
        ``bj``, ``n4sid``; ``hw``: a Hammerstein-Wiener model with a dead zone at the
        input, order ``nb,nf,nk``; ``fractional``: ``1/(a s^alpha + b s^beta + c)``
        fitted in the time domain, ``--order alpha=2,beta=1`` fixes the orders).
    order : int, dict, str or None
        See :func:`parse_order`; None selects it by ``criterion``.
    out_dir : path
        Receives ``summary.json`` and ``report.html`` (with the run's id and warnings),
        both at once and only when everything succeeded; anything else in the folder
        is left as it is (see :mod:`pdmkit._outputs`).
    json_path : path, optional
        Also write the summary here.
    fs : float, optional
        Sampling rate in Hz when the table has no ``time`` column.
    criterion : {"aic", "bic", "mdl"}, default "aic"

    Returns
    -------
    dict
        The summary: ``structure``, ``order``, ``poles`` (``[re, im]`` pairs),
        ``natural_frequencies_hz``, ``damping``, ``fit_percent`` and more.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np, pandas as pd
    >>> from scipy import signal
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=2000)
    >>> y = signal.lfilter([0, 0.1], [1, -1.6, 0.9], u)
    >>> pd.DataFrame({"time": np.arange(2000) / 100.0, "force": u, "acc": y}).to_csv(
    ...     folder / "run.csv", index=False)
    >>> s = run_identify(folder / "run.csv", input="force", output="acc", structure="arx",
    ...                  order="na=2,nb=1", out_dir=folder / "out")
    >>> round(s["natural_frequencies_hz"][0], 2)
    9.07
    >>> sorted(p.name for p in (folder / "out").iterdir())
    ['.pdmkit', 'report.html', 'summary.json']
    """
    if structure not in IDENTIFY_STRUCTURES:
        raise ModelError(
            f"structure must be one of {sorted(IDENTIFY_STRUCTURES)}; got {structure!r}."
        )
    run = OutputRun(out_dir, "identify", inputs=[data_path], json_path=json_path)
    with run:
        summary, rep = _identify(data_path, input, output, structure, order, fs, criterion)
        run.add_report("report.html", rep)
        run.add_json("summary.json", summary)
        run.commit()
    return summary


def _identify(data_path, input, output, structure, order, fs, criterion):
    """(summary, report) of :func:`run_identify`."""
    table = read_table(data_path)
    if len(table) == 0:
        raise DataError(f"{data_path}: the table has no rows.")
    rate = _sampling_rate(table, fs, data_path)
    if structure != "ar" and input == output:
        raise DataError(
            f"{data_path}: --input and --output both name {input!r}; identification "
            "needs the signal that drives the system and the one it responds with."
        )
    y = _column(table, output, data_path, "output")
    u = None if structure == "ar" else _column(table, input, data_path, "input")
    model = IDENTIFY_STRUCTURES[structure](u, y, rate, parse_order(order), criterion)
    summary = identify_summary(model, data=data_path)
    summary.update({"input": input, "output": output, "fs": rate})
    title = f"Identification: {structure} model of {output} from {Path(data_path).name}"
    u_rep = u if u is not None else np.zeros_like(y)
    if u is None:
        rep = Report(title)
        rep.add_table(model.to_pandas(), caption="Modes", float_format="{:.5g}")
        rep.add_figure(model.plot(), caption="Poles of the AR model")
        rep.add_json(summary, caption="summary.json")
    else:
        rep = build_identify_report(model, summary, u_rep, y, rate, title)
    return summary, rep
