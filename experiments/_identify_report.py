"""The report of an identification: the summary's text and figures, as HTML."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from pdmkit._plot_signals import MAX_POINTS, axis_label, envelope_note, plot_signal
from pdmkit.experiments._report import Report
from pdmkit.models.frequency import frf_comparison
from pdmkit.models.ident import (
    fit_percent,
)

__all__ = ["build_identify_report", "format_fit", "format_hz", "modes_table"]


def format_fit(percent: float | None, digits: int = 2) -> str:
    """A fit percentage as text; None (a simulation that diverged) said so.

    Examples
    --------
    >>> format_fit(81.234), format_fit(None)
    ('81.23 %', "undefined (the model's simulation diverges)")
    """
    if percent is None or not np.isfinite(percent):
        return "undefined (the model's simulation diverges)"
    return f"{percent:.{digits}f} %"


def format_hz(values, digits: int = 4) -> str:
    """Frequencies as ``"5.18 Hz, 6.63 Hz"``; a missing (None, NaN) value is ``"?"``.

    Examples
    --------
    >>> format_hz([5.181, None, float("nan")])
    '5.181 Hz, ? Hz, ? Hz'
    """
    out = []
    for v in values or []:
        ok = v is not None and isinstance(v, int | float) and math.isfinite(v)
        out.append(f"{v:.{digits}g} Hz" if ok else "? Hz")
    return ", ".join(out)


def _mode_rows(table: pd.DataFrame) -> list[dict]:
    return [
        {
            "frequency_hz": r.natural_frequency_hz,
            "damping": r.damping,
            "pole": [r.pole_real, r.pole_imag],
            **({"reason": r.reason} if "reason" in table.columns else {}),
        }
        for r in table.itertuples()
    ]


# --------------------------------------------------------------------------- report
def _frf_figure(model, u, y, fs: float, band, names=("input", "output")):
    """Magnitude, phase (model aligned to the data's branch) and coherence, log axis."""
    import matplotlib.pyplot as plt

    cmp = frf_comparison(u, y, fs, model.frequency_response, band=band)
    f = cmp["freq"]
    fig, (a1, a2, a3) = plt.subplots(
        3, 1, figsize=(7, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 2, 1.3]}
    )
    a1.loglog(f, np.abs(cmp["H"]), color="0.55", lw=0.8, label="H1 estimate (data)")
    a1.loglog(f, np.abs(cmp["G"]), color="C0", label="model")
    a1.set_ylabel(f"|G| [{names[1]} per {names[0]}]")
    a1.legend(loc="best", fontsize="small")
    a2.semilogx(f, cmp["phase_data_deg"], color="0.55", lw=0.8)
    a2.semilogx(f, cmp["phase_model_deg"], color="C0")
    a2.set_ylabel("phase [deg]")
    a3.semilogx(f, cmp["coherence"], color="C2", lw=0.8)
    a3.set_ylim(0, 1.05)
    a3.set_ylabel("coherence")
    a3.set_xlabel("frequency [Hz]")
    a1.set_xlim(f[0], f[-1])
    from matplotlib.ticker import LogLocator, ScalarFormatter

    for ax in (a1, a2, a3):
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    a3.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    a3.xaxis.set_major_formatter(ScalarFormatter())
    a3.xaxis.set_minor_formatter(ScalarFormatter() if f[-1] / f[0] < 10 else "")
    return fig, cmp


def build_identify_report(
    model, summary: dict, u, y, fs: float, title: str, *, band=None, fit_data=None
) -> Report:
    """HTML report: summary, modes, pole map, FRF vs H1 estimate, simulation vs data.

    The FRF figure shows magnitude, phase and coherence (Welch, as
    :func:`scipy.signal.coherence`) on a log frequency axis over ``band`` (default
    the first non-zero line to Nyquist); the model's phase is unwrapped and moved by
    whole turns onto the data's branch at the first frequency
    (:func:`pdmkit.models.frequency.frf_comparison`). ``fit_data`` is the ``(u, y)`` the
    model was fitted to (band-filtered with a band; default ``u, y``): the simulation
    and residual tests use it.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> from pdmkit.models.ident import arx
    >>> from pdmkit.experiments._identify import identify_summary
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=1000)
    >>> y = signal.lfilter([0, 0.1], [1, -1.6, 0.9], u)
    >>> m = arx(u, y, 2, 1, fs=100.0)
    >>> rep = build_identify_report(m, identify_summary(m), u, y, 100.0, "demo")
    >>> rep.to_html().count("data:image/png")
    3
    """
    rep = Report(title)
    rep.add_heading("Summary")
    fn = format_hz(summary.get("natural_frequencies_hz"))
    text = (
        f"Structure {summary['structure']} with order {_text(summary['order'])}: "
        f"simulation fit "
        f"{format_fit(summary['fit_percent'])} on the estimation data"
        f"{' (filtered to the band)' if band is not None else ''}; modes at "
        f"{fn or 'none'}."
    )
    for key in ("decimation", "band", "order_search"):
        note = (summary.get(key) or {}).get("note")
        if note:
            text += " " + note[0].upper() + note[1:]
    rep.add_text(text)
    for w in summary.get("checks") or []:
        rep.add_text("Warning: " + w)
    if summary.get("modes") is not None:
        modes = modes_table(summary["modes"])
        if len(modes):
            rep.add_table(modes, caption="Modes", float_format="{:.5g}")
        else:
            rep.add_text("No resonance among the poles (see the table below).")
        dropped = modes_table(summary.get("not_modes") or [])
        if len(dropped):
            rep.add_table(
                dropped,
                caption="Poles that are not modes, and why",
                float_format="{:.5g}",
            )
    elif hasattr(model, "to_pandas"):
        rep.add_table(model.to_pandas(), caption="Modes", float_format="{:.5g}")
    if hasattr(model, "plot"):
        rep.add_heading("Pole map")
        ax = model.plot()
        rep.add_figure(ax, caption="Poles (x) and zeros (o) in the z-plane")
    if hasattr(model, "frequency_response"):
        rep.add_heading("Frequency response")
        names = (summary.get("input") or "input", summary.get("output") or "output")
        fig, _ = _frf_figure(model, u, y, fs, band, names)
        rep.add_figure(
            fig,
            caption="Model frequency response over the H1 estimate (scipy.signal.csd / "
            "welch) with the coherence; model phase on the data's branch",
        )
    rep.add_heading("Simulation")
    u_ref, y_ref = (u, y) if fit_data is None else fit_data
    with np.errstate(all="ignore"):
        y_sim = model.simulate(u_ref)
        fit_now = fit_percent(y_ref, y_sim)
    rep.add_figure(
        _simulation_figure(y_ref, y_sim, fs, fit_now, summary.get("output") or "output"),
        caption="Simulated vs measured output"
        + (" (both filtered to the band)" if band is not None else "")
        + ". "
        + envelope_note(len(y_ref)),
    )
    if hasattr(model, "residual_test"):
        with np.errstate(all="ignore"):
            res = model.residual_test(u_ref, y_ref)
        if set(res.get("inputs") or {}) == {"u"} and summary.get("input"):
            res = {**res, "inputs": {summary["input"]: res["inputs"]["u"]}}
        rep.add_table(
            _residual_table(res),
            caption="Residual tests: whiteness of the one-step prediction errors "
            "(Ljung-Box) and their cross-correlation with the input",
        )
    rep.add_table(_model_table(summary), caption="The model")
    rep.add_text("Every number of this report is in summary.json beside it.")
    return rep


def _simulation_figure(y_ref, y_sim, fs: float, fit_now, output: str):
    """Measured and simulated output; a long record also in a detail of its start."""
    import matplotlib.pyplot as plt

    y_ref, y_sim = np.asarray(y_ref, float), np.asarray(y_sim, float)
    t = np.arange(len(y_ref)) / fs
    detail = len(y_ref) > MAX_POINTS
    fig, axes = plt.subplots(
        2 if detail else 1, 1, figsize=(9, 5.6 if detail else 3), squeeze=False
    )
    axes = axes[:, 0]
    sim_label = f"simulated (fit {format_fit(fit_now, 1)})"
    plot_signal(axes[0], t, y_ref, color="0.45", lw=0.8, label="measured")
    plot_signal(axes[0], t, y_sim, color="C1", lw=0.8, label=sim_label)
    if detail:
        k = MAX_POINTS // 4
        axes[0].axvspan(t[0], t[k - 1], color="C2", alpha=0.2, lw=0, label="detail below")
        axes[1].plot(t[:k], y_ref[:k], color="0.45", lw=0.8)
        axes[1].plot(t[:k], y_sim[:k], color="C1", lw=0.8)
        axes[1].set_title(f"detail: the first {k} samples", fontsize="small")
    for ax in axes:
        ax.set_ylabel(axis_label(output))
    axes[0].legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    return fig


def _yes(flag) -> str:
    return "—" if flag is None else ("yes" if flag else "no")


def _residual_table(res: dict) -> pd.DataFrame:
    """The residual tests as sentences: test, result, passed.

    Examples
    --------
    >>> res = {"max_lag": 25, "ljung_box_q": 30.5, "p_value": 0.2, "bound": 0.01,
    ...        "acf_outside": 0.04, "acf_max": 0.02, "white": True,
    ...        "inputs": {"u": {"xcorr_max": 0.003, "xcorr_lag": -3,
    ...                         "xcorr_outside": 0.0, "uncorrelated": True}}}
    >>> _residual_table(res)["passed"].tolist()
    ['yes', 'yes']
    """
    rows = [
        {
            "test": f"residual is white (Ljung-Box, lags 1-{res.get('max_lag')})",
            "result": f"Q = {res.get('ljung_box_q', float('nan')):.4g}, p = "
            f"{res.get('p_value', float('nan')):.3g}; "
            f"{100 * res.get('acf_outside', float('nan')):.0f} % of the "
            f"autocorrelations outside ±{res.get('bound', float('nan')):.3g} "
            f"(largest {res.get('acf_max', float('nan')):.3g})",
            "passed": _yes(res.get("white")),
        }
    ]
    for name, x in (res.get("inputs") or {}).items():
        rows.append(
            {
                "test": f"residual uncorrelated with input {name}",
                "result": f"largest |cross-correlation| "
                f"{x.get('xcorr_max', float('nan')):.3g} at lag {x.get('xcorr_lag')} "
                f"samples; {100 * x.get('xcorr_outside', float('nan')):.0f} % of the "
                "lags outside the bound",
                "passed": _yes(x.get("uncorrelated")),
            }
        )
    return pd.DataFrame(rows)


def _model_table(summary: dict) -> pd.DataFrame:
    """The fitted model's facts from the summary, one row each (absent ones left out).

    Examples
    --------
    >>> _model_table({"structure": "oe", "order": {"nb": 2, "nf": 2, "nk": 1},
    ...               "fs": 500.0, "fit_percent": 95.123}).to_dict("records")[1]
    {'': 'order', 'value': 'nb=2, nf=2, nk=1'}
    """
    fields = {
        "structure": ("structure", None),
        "order": ("order", None),
        "input": ("input", None),
        "output": ("output", None),
        "fs": ("sampling rate", "Hz"),
        "fit_percent": ("simulation fit", "%"),
        "n_params": ("parameters", None),
        "noise_variance": ("noise variance", None),
        "aic": ("AIC", None),
        "bic": ("BIC", None),
    }
    rows = []
    for key, (name, unit) in fields.items():
        value = summary.get(key)
        if value is None or value == {}:
            continue
        rows.append({"": name, "value": _text(value) + (f" {unit}" if unit else "")})
    return pd.DataFrame(rows, columns=["", "value"])


def _text(value) -> str:
    """A summary value as a reader writes it: ``nb=2, nf=2``, ``0.03``, ``[1, 2]``.

    Examples
    --------
    >>> _text({"na": 2, "nb": 1}), _text(0.0300000001), _text(4)
    ('na=2, nb=1', '0.03', '4')
    """
    if isinstance(value, dict):
        return ", ".join(f"{k}={_text(x)}" for k, x in value.items())
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


#: Column names of the modes tables, as a reader reads them.
_MODE_COLUMNS = {
    "frequency_hz": "frequency [Hz]",
    "damping": "damping ratio",
    "natural_frequency_hz": "frequency [Hz]",
}


def modes_table(rows) -> pd.DataFrame:
    """Modes (or poles that are not modes) as the report shows them.

    Examples
    --------
    >>> modes_table([{"frequency_hz": 40.0, "damping": 0.03, "pole": [0.8, 0.4]}])
       frequency [Hz]  damping ratio
    0            40.0           0.03
    """
    table = pd.DataFrame(rows)
    if "pole" in table.columns:
        table = table.drop(columns="pole")
    return table.rename(columns=_MODE_COLUMNS)
