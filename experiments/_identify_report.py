"""The report of an identification: the summary's text and figures, as HTML."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from pdmkit._outputs import to_jsonable
from pdmkit.experiments._report import Report
from pdmkit.models.frequency import frf_comparison
from pdmkit.models.ident import (
    fit_percent,
)

__all__ = ["build_identify_report", "format_fit", "format_hz"]


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
def _frf_figure(model, u, y, fs: float, band):
    """Magnitude, phase (model aligned to the data's branch) and coherence, log axis."""
    import matplotlib.pyplot as plt

    cmp = frf_comparison(u, y, fs, model.frequency_response, band=band)
    f = cmp["freq"]
    fig, (a1, a2, a3) = plt.subplots(
        3, 1, figsize=(7, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 2, 1.3]}
    )
    a1.loglog(f, np.abs(cmp["H"]), color="0.55", lw=0.8, label="H1 estimate (data)")
    a1.loglog(f, np.abs(cmp["G"]), color="C0", label="model")
    a1.set_ylabel("|G|")
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
    import matplotlib.pyplot as plt

    rep = Report(title)
    rep.add_heading("Summary")
    fn = format_hz(summary.get("natural_frequencies_hz"))
    text = (
        f"Structure {summary['structure']} with order {summary['order']}: simulation fit "
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
        modes = pd.DataFrame(summary["modes"])
        if len(modes):
            rep.add_table(
                modes.drop(columns="pole"), caption="Modes", float_format="{:.5g}"
            )
        else:
            rep.add_text("No resonance among the poles (see the table below).")
        dropped = pd.DataFrame(summary.get("not_modes") or [])
        if len(dropped):
            rep.add_table(
                dropped.drop(columns="pole"),
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
        fig, _ = _frf_figure(model, u, y, fs, band)
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
    t = np.arange(len(y_ref)) / fs
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(t, y_ref, color="0.5", lw=0.8, label="measured")
    ax.plot(t, y_sim, color="C1", lw=0.8, label=f"simulated (fit {format_fit(fit_now, 1)})")
    ax.set_xlabel("time [s]")
    ax.legend(loc="best", fontsize="small")
    rep.add_figure(
        fig,
        caption="Simulated vs measured output"
        + (" (both filtered to the band)" if band is not None else ""),
    )
    if hasattr(model, "residual_test"):
        with np.errstate(all="ignore"):
            res = model.residual_test(u_ref, y_ref)
        rep.add_json(
            to_jsonable(res),
            caption="Residual tests (Ljung-Box whiteness, input cross-correlation)",
        )
    rep.add_json(summary, caption="summary.json")
    return rep
