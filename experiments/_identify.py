"""The identification workflow: recording -> linear model -> JSON summary + HTML report.

``pdmkit identify DATA --input COL --output COL --structure arx --json OUT.json
--out DIR`` calls :func:`run_identify`. The data are a CSV or Parquet table with one
column for the input and one for the output, or a MATLAB ``.mat`` / NumPy ``.npz`` file
with one variable for each (a row or column of a 2-D variable is named ``Name2``,
1-based, or ``Name[1]``, 0-based); and either a ``time`` column (s, uniform), a sampling
rate stored in the file (``fs``/``Fs``, or ``Ts``), or ``fs`` given.

The identification checks itself: an order chosen at the edge of its search range
extends the search; poles that are not resonances (real, at Nyquist, cancelled by a
zero, outside ``band``) leave the modes table with their reason; a negative fit or an
unstable model is a warning that names an alternative that fits (e.g. OE from an ARX
start). ``band`` focuses the fit (the same zero-phase band-pass on input and output
leaves the transfer function unchanged and weights the fit to the band) and decimates
the record (anti-aliased, :func:`scipy.signal.decimate`) when the band lies far below
Nyquist.

New model structures plug in through :data:`IDENTIFY_STRUCTURES`: a function
``(u, y, fs, order, criterion) -> model`` whose model has ``simulate(u)`` and
``to_dict()`` (with at least ``structure``, ``order``, ``poles``,
``natural_frequencies_hz``, ``damping``, ``fit_percent``), and optionally
``frequency_response(f)`` and ``plot(ax)`` (pole map) for the report.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._outputs import OutputRun, to_jsonable
from pdmkit.errors import ConvergenceWarning, DataError, DataWarning, ModelError
from pdmkit.experiments._identify_report import (
    _mode_rows,
    build_identify_report,
    format_fit,
    modes_table,
)
from pdmkit.experiments._records import read_record
from pdmkit.experiments._report import Report
from pdmkit.models.frequency import fit_fractional_tf
from pdmkit.models.ident import (
    STRUCTURES,
    HammersteinWiener,
    identify,
    modes_from_poles,
    n4sid,
    oe,
    physical_modes,
)

__all__ = [
    "IDENTIFY_STRUCTURES",
    "build_identify_report",
    "decimate_record",
    "identify_summary",
    "parse_band",
    "parse_order",
    "read_record",
    "run_identify",
]


def _linear(structure: str) -> Callable[..., Any]:
    def fit(u, y, fs, order, criterion):
        return identify(u, y, fs, structure, order, criterion)

    fit.__name__ = f"identify_{structure}"
    return fit


def _modes(poles: np.ndarray, fs: float) -> tuple[list[float], list[float]]:
    """Natural frequencies (Hz) and damping ratios of discrete poles (upper half-plane)."""
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

    opts = _order_dict(order, ("nb", "nf", "nk"), "hw")
    return _HammersteinWienerResult(HammersteinWiener(**opts).fit(u, y), fs)


def _fit_fractional(u, y, fs, order, criterion):

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


def parse_band(text: str | tuple | list | None) -> tuple[float, float] | None:
    """Read ``--band F1,F2`` (Hz) as a pair ``(F1, F2)`` with ``0 <= F1 < F2``.

    Examples
    --------
    >>> parse_band("2,15"), parse_band(None)
    ((2.0, 15.0), None)
    """
    if text is None or (isinstance(text, str) and not text.strip()):
        return None
    parts = text.split(",") if isinstance(text, str) else list(text)
    try:
        f1, f2 = (float(p) for p in parts)
    except (TypeError, ValueError):
        raise DataError(
            f"--band must be two frequencies in Hz, 'F1,F2' (e.g. '2,15'); got {text!r}."
        ) from None
    if not (math.isfinite(f1) and math.isfinite(f2) and 0 <= f1 < f2):
        raise DataError(f"--band needs 0 <= F1 < F2 (Hz); got F1={f1:g}, F2={f2:g}.")
    return f1, f2


# --------------------------------------------------------------------------- prepare
#: Automatic decimation keeps the band's upper edge below this fraction of Nyquist.
AUTO_DECIMATE_EDGE = 0.4
#: ... and at least this many samples.
AUTO_DECIMATE_MIN_SAMPLES = 2000


def _stages(q: int) -> list[int]:
    """Factors of ``q`` of at most 10 each (decimate's IIR filter wants q <= 13)."""
    out = []
    while q > 13:
        d = next((d for d in range(10, 1, -1) if q % d == 0), None)
        if d is None:
            break
        out.append(d)
        q //= d
    return [*out, q] if q > 1 else out


def decimate_record(x: np.ndarray, q: int) -> np.ndarray:
    """Anti-aliased decimation by ``q`` (:func:`scipy.signal.decimate`, zero phase).

    Factors above 13 run in stages of at most 10 (scipy's advice for its order-8
    Chebyshev filter).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(4000) / 400.0
    >>> x = np.sin(2 * np.pi * 5 * t) + np.sin(2 * np.pi * 150 * t)  # 150 Hz aliases
    >>> xd = decimate_record(x, 8)                                   # fs 50 Hz
    >>> ref = np.sin(2 * np.pi * 5 * t[::8])
    >>> bool(np.max(np.abs(xd - ref)[50:-50]) < 0.02)
    True
    """
    from scipy import signal

    for d in _stages(int(q)):
        x = signal.decimate(x, d, zero_phase=True)
    return x


def _auto_factor(fs: float, band, n: int) -> int:
    if band is None:
        return 1
    q = int(np.floor(AUTO_DECIMATE_EDGE * fs / 2.0 / band[1]))
    q = min(q, n // AUTO_DECIMATE_MIN_SAMPLES)
    return q if q >= 2 else 1


def _prepare(u, y, fs: float, band, decimate) -> tuple:
    """Decimate and band-focus a record; returns (u, y, fs, uf, yf, notes)."""
    from scipy import signal

    notes: dict[str, Any] = {}
    n = y.size
    if decimate is not None:
        if isinstance(decimate, bool) or int(decimate) != decimate or decimate < 1:
            raise DataError(f"--decimate must be an integer >= 1; got {decimate!r}.")
        q, automatic = int(decimate), False
    else:
        q, automatic = _auto_factor(fs, band, n), True
    if q > 1:
        if n // q < 100:
            raise DataError(
                f"--decimate {q} leaves {n // q} of {n} samples; too few to identify."
            )
        y = decimate_record(y, q)
        u = None if u is None else decimate_record(u, q)
        why = (
            f"automatically, the band's upper edge {band[1]:g} Hz being far below the "
            f"Nyquist frequency {fs / 2:g} Hz"
            if automatic
            else "as asked (--decimate)"
        )
        notes["decimation"] = {
            "factor": q,
            "automatic": automatic,
            "fs_before": fs,
            "fs": fs / q,
            "method": "scipy.signal.decimate (order-8 Chebyshev I, zero phase)",
            "note": f"decimated by {q} {why}: {fs:g} Hz -> {fs / q:g} Hz, "
            f"{n} -> {y.size} samples.",
        }
        fs = fs / q
    nyq = fs / 2.0
    uf, yf = u, y
    if band is not None:
        f1, f2 = band
        if f2 >= nyq:
            raise DataError(
                f"--band {f1:g},{f2:g}: the upper edge must lie below the Nyquist "
                f"frequency {nyq:g} Hz (after decimation)."
            )
        if f1 > 0 and f2 < 0.95 * nyq:
            sos = signal.butter(4, [f1, f2], "bandpass", fs=fs, output="sos")
            kind = f"band-pass {f1:g}-{f2:g} Hz"
        elif f1 > 0:
            sos = signal.butter(4, f1, "highpass", fs=fs, output="sos")
            kind = f"high-pass {f1:g} Hz"
        else:
            sos = signal.butter(4, f2, "lowpass", fs=fs, output="sos")
            kind = f"low-pass {f2:g} Hz"
        yf = signal.sosfiltfilt(sos, y - y.mean())
        uf = None if u is None else signal.sosfiltfilt(sos, u - u.mean())
        notes["band"] = {
            "band_hz": [f1, f2],
            "prefilter": f"Butterworth order 4 {kind}, zero phase "
            "(scipy.signal.sosfiltfilt), applied to input and output alike",
            "note": f"fit and modes focus on {f1:g}-{f2:g} Hz: input and output "
            f"filtered alike ({kind}); the fit is measured on the filtered output.",
        }
    return u, y, fs, uf, yf, notes


# --------------------------------------------------------------------------- checks
def _poles_zeros(model) -> tuple[np.ndarray, np.ndarray] | None:
    if hasattr(model, "poles") and hasattr(model, "zeros"):
        return np.asarray(model.poles), np.asarray(model.zeros)
    if isinstance(model, _HammersteinWienerResult):
        return np.atleast_1d(np.asarray(model.model.poles_)), np.zeros(0)
    return None


def _n_poles(model) -> int:
    pz = _poles_zeros(model)
    return int(pz[0].size) if pz is not None else 0


def _is_stable(model) -> bool:
    pz = _poles_zeros(model)
    return pz is None or pz[0].size == 0 or bool(np.max(np.abs(pz[0])) < 1.0)


def _alternative(u, y, fs, structure: str, model) -> dict | None:
    """The best of OE (started from ARX, Steiglitz-McBride) and N4SID with as many poles.

    Kept when it is stable and fits positively; None if neither does.
    """
    n = max(2, min(_n_poles(model), 40))
    tries = []
    if structure != "oe":
        tries.append(("oe", f"nb={n},nf={n},nk=1", lambda: oe(u, y, n, n, 1, fs=fs)))
    if structure != "n4sid":
        tries.append(("n4sid", str(n), lambda: n4sid(u, y, n, fs=fs)))
    best = None
    for name, order, fit in tries:
        try:
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                m = fit()
        except (DataError, ModelError, np.linalg.LinAlgError, ValueError):
            continue
        fp = float(m.fit_percent)
        if not (np.isfinite(fp) and fp > 0 and m.is_stable):
            continue
        if best is None or fp > best["fit_percent"]:
            best = {
                "structure": name,
                "order": order,
                "fit_percent": fp,
                "options": f"--structure {name} --order {order}",
            }
    return best


def _check_model(model, summary: dict, u, y, fs, structure: str) -> list[str]:
    """Warnings on the identified model (negative fit, unstable, overflow)."""
    found = []
    fp = summary.get("fit_percent")
    fit_bad = fp is None or not np.isfinite(fp) or fp < 1.0  # no better than the mean
    unstable = not _is_stable(model)
    if not (fit_bad or unstable) or u is None:
        if fit_bad:
            found.append(
                f"the model's fit is {format_fit(fp, 1)}: no better than the output's "
                "mean; do not read its modes as the system's."
            )
        return found
    alt = _alternative(u, y, fs, structure, model)
    if alt is not None:
        hint = (
            f"an {alt['structure'].upper()} model ({alt['options']}) is stable and fits "
            f"{alt['fit_percent']:.1f} %"
            + (" (OE is started from an ARX estimate)" if alt["structure"] == "oe" else "")
        )
    else:
        hint = (
            "neither OE (from an ARX start) nor N4SID with as many poles did better; "
            "try --band to focus on the modes, --decimate, or another order"
        )
    what = []
    if unstable:
        what.append("is unstable (a pole on or outside the unit circle)")
    if fit_bad and (fp is None or not np.isfinite(fp)):
        what.append("has no fit (its simulation diverges), worse than the output's mean")
    elif fit_bad:
        than = "worse than" if fp < 0 else "no better than"
        what.append(f"fits {format_fit(fp, 1)}, {than} the output's mean")
    found.append(f"the {structure.upper()} model {' and '.join(what)}: {hint}.")
    summary["alternative"] = alt
    return found


# --------------------------------------------------------------------------- summary
def identify_summary(model, *, band=None, **sources: Any) -> dict:
    """JSON summary of an identified model (the keys the CLI promises first).

    ``natural_frequencies_hz`` and ``damping`` list the resonances only
    (:func:`pdmkit.models.ident._model.physical_modes`): real poles, poles at Nyquist,
    poles cancelled by a zero and (with ``band``) modes outside the band go to
    ``not_modes``, each with its ``reason``.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> from pdmkit.models.ident import arx
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=2000)
    >>> y = signal.lfilter([0, 1.0], [1, -0.9], u)
    >>> s = identify_summary(arx(u, y, 1, 1))
    >>> list(s)[:6]
    ['structure', 'order', 'poles', 'natural_frequencies_hz', 'damping', 'fit_percent']
    >>> s["natural_frequencies_hz"], s["not_modes"][0]["reason"]
    ([], 'real pole (no oscillation)')
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
    pz = _poles_zeros(model)
    fs = d.get("fs", getattr(model, "fs", None))
    if pz is not None and fs:
        modes, dropped = physical_modes(pz[0], pz[1], fs, band=band)
        out["natural_frequencies_hz"] = modes["natural_frequency_hz"].tolist()
        out["damping"] = modes["damping"].tolist()
        out["modes"] = _mode_rows(modes)
        out["not_modes"] = _mode_rows(dropped)
    info = getattr(model, "info", None) or {}
    if "order_search" in info:
        out["order_search"] = dict(info["order_search"])
    out["sources"] = {
        k: (os.fspath(v) if v is not None else None) for k, v in sources.items()
    }
    return to_jsonable(out)


# --------------------------------------------------------------------------- run
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
    band: str | tuple[float, float] | None = None,
    decimate: int | None = None,
) -> dict:
    """Identify a model from a recording; write ``summary.json`` and ``report.html``.

    Parameters
    ----------
    data_path : path
        CSV or Parquet with the ``input`` and ``output`` columns and a ``time`` column
        (or pass ``fs``); or a ``.mat``/``.npz`` file (see :func:`read_record`).
    input, output : str
        Column (or variable) names.
    structure : str, default "arx"
        A key of :data:`IDENTIFY_STRUCTURES` (``ar``, ``arx``, ``armax``, ``oe``,
        ``bj``, ``n4sid``; ``hw``: a Hammerstein-Wiener model with a dead zone at the
        input, order ``nb,nf,nk``; ``fractional``: ``1/(a s^alpha + b s^beta + c)``
        fitted in the time domain, ``--order alpha=2,beta=1`` fixes the orders).
    order : int, dict, str or None
        See :func:`parse_order`; None selects it by ``criterion`` from 1..10, and
        searches further while the best order is the largest tried
        (``summary["order_search"]``).
    out_dir : path
        Receives ``summary.json`` and ``report.html`` (with the run's id and warnings),
        both at once and only when everything succeeded; anything else in the folder
        is left as it is (see :mod:`pdmkit._outputs`).
    json_path : path, optional
        Also write the summary here.
    fs : float, optional
        Sampling rate in Hz when the file does not give one.
    criterion : {"aic", "bic", "mdl"}, default "aic"
    band : "F1,F2" or (float, float), optional
        Band of interest in Hz: input and output are band-pass filtered alike (zero
        phase) before the fit, the fit is measured there, modes outside it are left
        out of the modes table, and the record is decimated automatically when the
        band's upper edge lies below ``0.4 x`` Nyquist.
    decimate : int, optional
        Decimate by this factor first (anti-aliased, :func:`decimate_record`);
        ``1`` turns the automatic decimation off.

    Returns
    -------
    dict
        The summary: ``structure``, ``order``, ``poles`` (``[re, im]`` pairs),
        ``natural_frequencies_hz``, ``damping`` (resonances only), ``fit_percent``,
        ``modes``, ``not_modes`` (with ``reason``), ``order_search``,
        ``decimation``, ``band``, ``checks`` and ``warnings`` (what went wrong, and
        what to do instead) and more.

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
    band = parse_band(band)
    run = OutputRun(out_dir, "identify", inputs=[data_path], json_path=json_path)
    with run:
        summary, rep = _identify(
            data_path, input, output, structure, order, fs, criterion, band, decimate
        )
        run.add_report("report.html", rep)
        run.add_json("summary.json", summary)
        run.commit()
    return summary


def _fit_quietly(structure, u, y, rate, order, criterion):
    """Fit; the order search's own warnings (every candidate's) are not the user's."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        if order is None:
            warnings.simplefilter("ignore", ConvergenceWarning)
            warnings.simplefilter("ignore", RuntimeWarning)
        return IDENTIFY_STRUCTURES[structure](u, y, rate, order, criterion)


def _identify(data_path, input, output, structure, order, fs, criterion, band, decimate):
    """(summary, report) of :func:`run_identify`."""
    if structure != "ar" and input == output:
        raise DataError(
            f"{data_path}: --input and --output both name {input!r}; identification "
            "needs the signal that drives the system and the one it responds with."
        )
    u, y, rate = read_record(data_path, None if structure == "ar" else input, output, fs)
    u, y, rate, uf, yf, notes = _prepare(u, y, rate, band, decimate)
    model = _fit_quietly(structure, uf, yf, rate, parse_order(order), criterion)
    summary = identify_summary(model, band=band, data=data_path)
    summary.update({"input": input, "output": output, "fs": rate, **notes})
    checks = []
    if isinstance(model.__dict__.get("info"), dict):
        moved = model.info.get("stabilised_poles", 0)
        if moved:
            checks.append(
                f"{moved} unstable pole(s) of the N4SID model were reflected into the "
                "unit circle; a lower order or an OE model may describe the data better."
            )
    search = summary.get("order_search") or {}
    if search.get("at_edge"):
        checks.append(search["note"])
    if structure == "fractional":
        orders = [summary.get("alpha"), summary.get("beta")]
        edge = [o for o in orders if o is not None and (o >= 2.99 or o <= 0.011)]
        if edge:
            checks.append(
                f"a fractional order ({', '.join(f'{o:.3g}' for o in edge)}) lies at "
                "the bound of its range 0.01..3: the structure 1/(a s^alpha + b s^beta "
                "+ c) does not describe these data well."
            )
    checks += _check_model(model, summary, uf, yf, rate, structure)
    if summary.get("modes") == [] and summary.get("not_modes"):
        checks.append(
            "no pole of the model is a resonance"
            + (" in the band" if band is not None else "")
            + f" ({len(summary['not_modes'])} left out, see not_modes)."
        )
    for text in checks:
        warnings.warn(text, DataWarning, stacklevel=3)
    summary["checks"] = checks
    summary["warnings"] = list(checks)
    summary = to_jsonable(summary)
    title = f"Identification: {structure} model of {output} from {Path(data_path).name}"
    if u is None:
        rep = Report(title)
        modes = pd.DataFrame(
            summary.get("modes") or [], columns=["frequency_hz", "damping"]
        )
        rep.add_table(
            modes_table(modes[["frequency_hz", "damping"]]),
            caption="Modes",
            float_format="{:.5g}",
        )
        if summary.get("not_modes"):
            rep.add_table(
                modes_table(summary["not_modes"]),
                caption="Poles that are not modes, and why",
                float_format="{:.5g}",
            )
        rep.add_figure(model.plot(), caption="Poles of the AR model")
        rep.add_text("Every number of this report is in summary.json beside it.")
    else:
        rep = build_identify_report(
            model,
            summary,
            u,
            y,
            rate,
            title,
            band=band,
            fit_data=(uf, yf),
        )
    return summary, rep
