"""Summary and HTML report of the closed-loop identification study."""

from __future__ import annotations

import numpy as np
import pandas as pd

from pdmkit.experiments._report import Report
from pdmkit.experiments.studies._closed_loop_pipeline import (
    BAND,
    COHERENCE_MIN,
    SEED_THETA_X,
    _table,
    coherence_edge,
    plant_frf,
)

__all__ = ["build_closed_loop_report", "closed_loop_summary"]

SEED = "the S-Mobile identification paper"


def closed_loop_summary(result: dict, quick: bool, seed: int) -> dict:
    """The study's ``summary.json``."""
    rig, true = result["rig"], result["truth"]
    methods = _table(result["methods"])
    linear = _table(result["linear_methods"])
    fits = _table(result["seed_fits"])
    dep = result["dependence"]
    real = {}
    for name, check in result["real_data"].items():
        real[name] = (
            None if check is None else {k: v for k, v in check.items() if k != "frf"}
        )
    ctl = result["controller"]
    return {
        "study": "unstable-closed-loop",
        "seed_document": SEED,
        "quick": quick,
        "seed": seed,
        "truth": {
            "poles": [[p.real, p.imag] for p in true["poles"]],
            "unstable_pole": true["unstable_pole"],
            "unstable_pole_frictionless": true["unstable_pole_frictionless"],
            "closed_form_frictionless": true["closed_form_frictionless"],
            "theta_x": rig.body_inertia,
        },
        "controller": {"K": ctl.K, "N": ctl.N, "fs": ctl.fs, "delay_samples": ctl.delay},
        "actuator": {
            "T_m_identified": result["actuator"]["T_m"],
            "T_m_true": result["actuator"]["true"],
        },
        "frf": {
            "amplitudes_deg": result["record"].amplitudes_deg,
            "saturated_share": result["record"].saturated,
            "coherence_edge_hz": coherence_edge(result["frf"]),
            "deviation_db": dep.deviation_db,
            "p_value": dep.p_value,
            "amplitude_dependent": bool(dep.nonlinear),
        },
        "methods": methods.to_dict(orient="records"),
        "linear_control": linear.to_dict(orient="records"),
        "seed_approach": fits.to_dict(orient="records"),
        "real_data": real,
        "seed_comparison": seed_comparison(result).to_dict(orient="records"),
    }


def seed_comparison(result: dict) -> pd.DataFrame:
    """The seed's numbers beside pdmkit's."""
    fits = _table(result["seed_fits"])
    small = fits[fits["amplitude_deg"] == fits["amplitude_deg"].min()]
    edges = coherence_edge(result["frf"])
    amps = result["record"].amplitudes_deg
    rows = [
        (
            "theta_x, mass moment of inertia (sec. 5)",
            f"{SEED_THETA_X}, confirmed by the design data",
            "; ".join(
                f"{r.theta_x:.2f} ({r.theta_x_error_percent:+.1f} %, {r.linearised_at})"
                for r in small.itertuples()
            )
            + f" at {amps.min():.1f} deg; design value {result['rig'].body_inertia}",
            "fitted to theta/theta_set by the coherence-weighted simplex",
        ),
        (
            "excitation (sec. 5)",
            "chirps of 1.5 to 5 degrees on the tilt set-point",
            ", ".join(f"{a:.1f}" for a in amps) + " degrees, periodic log chirps 0.2-25 Hz",
            "",
        ),
        (
            "coherence mask (sec. 5, Fig. 4)",
            ">= 0.7 over the spectrum",
            f">= {COHERENCE_MIN} per line",
            "",
        ),
        (
            "coherence deteriorates from (sec. 5)",
            "about 20 Hz (CAN bus, 100 Hz)",
            ", ".join(f"{e:.1f}" for e in edges) + " Hz per amplitude",
            "here the closed loop rolls off above 5 Hz into the IMU noise",
        ),
        (
            "large amplitudes (sec. 5)",
            "FRF only at low frequencies (the wheels slip)",
            "torque limit reached on "
            + ", ".join(f"{100 * s:.0f} %" for s in result["record"].saturated)
            + " of the samples",
            "",
        ),
        (
            "sampling, dead time (sec. 4-5)",
            "100 Hz; dead time T_t of the CAN transmission",
            "100 Hz; measurements one 10 ms cycle late in the controller",
            "",
        ),
    ]
    return pd.DataFrame(rows, columns=["item", "seed", "pdmkit", "note"])


# ------------------------------------------------------------------ figures
def _fig_frfs(result):
    import matplotlib.pyplot as plt

    frf, rig, ctl = result["frf"], result["rig"], result["controller"]
    fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    model = rig.tilt_response(frf.freq, ctl)
    for i, amp in enumerate(frf.amplitudes):
        H, coh = frf.H[i], frf.coherence[i]
        ok = coh >= COHERENCE_MIN
        mag = np.where(ok, 20 * np.log10(np.abs(H)), np.nan)
        ph = np.where(ok, np.degrees(np.unwrap(np.angle(H))), np.nan)
        ax1.semilogx(frf.freq, mag, lw=1, label=f"{amp:.1f} deg")
        ax2.semilogx(frf.freq, ph, lw=1)
        ax3.semilogx(frf.freq, coh, lw=0.8)
    ax1.semilogx(frf.freq, 20 * np.log10(np.abs(model)), "k--", lw=1, label="linear model")
    ax2.semilogx(frf.freq, np.degrees(np.unwrap(np.angle(model))), "k--", lw=1)
    ax3.axhline(COHERENCE_MIN, color="C3", ls="--", lw=1)
    ax1.set_ylabel("|theta/theta_set| [dB]")
    ax2.set_ylabel("phase [deg]")
    ax3.set_ylabel("coherence")
    ax3.set_xlabel("frequency [Hz]")
    ax1.legend(fontsize="small", ncol=3)
    fig.tight_layout()
    return fig


def _fig_poles(result):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4))
    p = result["truth"]["poles"]
    ax.plot(p.real, p.imag, "ko", mfc="none", ms=9, label="truth (exact linearisation)")
    marks = {"direct": "x", "indirect": "+", "joint": "1"}
    amp0 = result["methods"][0]["amplitude_deg"]
    for row in result["methods"]:
        if row["amplitude_deg"] != amp0:
            continue
        s = row["model"].poles_s
        s = s[(s.real > -60) & (np.abs(s.imag) < 60)]
        ax.plot(
            s.real,
            s.imag,
            marks[row["method"]],
            ms=9,
            label=f"{row['method']} ({amp0:g} deg)",
        )
    fits = [r for r in result["seed_fits"] if r["amplitude_deg"] == amp0]
    for r in fits[:1]:
        ax.axvline(
            r["unstable_pole"], color="C3", ls=":", label="seed's approach, unstable pole"
        )
    ax.axvline(0, color="k", lw=0.5)
    ax.set_xlim(-60, 15)
    ax.set_xlabel("real [1/s]")
    ax.set_ylabel("imag [rad/s]")
    ax.legend(fontsize="x-small")
    fig.tight_layout()
    return fig


def _fig_plant(result):
    import matplotlib.pyplot as plt

    fs = result["record"].fs
    f = np.linspace(0.2, 20, 300)
    G = plant_frf(result["truth"], f, fs)
    fig, ax = plt.subplots(figsize=(8, 3.6))
    ax.loglog(f, np.abs(G), "k", lw=2, label="truth")
    amp0 = result["methods"][0]["amplitude_deg"]
    for row in result["methods"]:
        if row["amplitude_deg"] != amp0:
            continue
        H = row["model"].frequency_response(f)
        H = H[:, 0] if row["method"] == "direct" else H[:, 1]
        ax.loglog(f, np.abs(H), lw=1, label=row["method"])
    npar = result["nonparametric"]
    ok = npar.coherence >= COHERENCE_MIN
    ax.loglog(npar.freq[ok], np.abs(npar.H[ok]), ".", ms=3, label="S_r,theta / S_r,u")
    ax.axvspan(*BAND, color="0.9", zorder=0)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|theta / u| [rad / N m]")
    ax.legend(fontsize="small", ncol=3)
    fig.tight_layout()
    return fig


def _fig_seed_fit(result):
    import matplotlib.pyplot as plt

    fits = [r for r in result["seed_fits"] if r["linearised_at"] == "rest"]
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for i, r in enumerate(fits):
        fit = r["fit"]
        ok = np.atleast_2d(fit.weight)[0] > 0
        ax.semilogx(
            fit.freq[ok],
            20 * np.log10(np.abs(np.atleast_2d(fit.H)[0][ok])),
            ".",
            ms=3,
            color=f"C{i}",
            label=f"measured {r['amplitude_deg']:.1f} deg",
        )
        ax.semilogx(
            fit.freq,
            20 * np.log10(np.abs(fit.H_model)),
            "-",
            lw=1,
            color=f"C{i}",
            label=f"fit theta_x = {r['theta_x']:.2f}",
        )
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|theta/theta_set| [dB]")
    ax.legend(fontsize="x-small", ncol=2)
    fig.tight_layout()
    return fig


def _fig_f16(check):
    import matplotlib.pyplot as plt

    frf = check["frf"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4), gridspec_kw={"width_ratios": [2, 1]})
    for ax, lim in zip(axes, ((2.0, 15.0), (6.6, 8.0)), strict=True):
        for i, rms in enumerate(frf.amplitudes):
            ok = (
                (frf.coherence[i] >= COHERENCE_MIN)
                & (frf.freq >= lim[0])
                & (frf.freq <= lim[1])
            )
            ax.semilogy(
                frf.freq,
                np.where(ok, np.abs(frf.H[i]), np.nan),
                lw=1,
                label=f"force {rms:.1f} N RMS",
            )
        ax.set_xlim(*lim)
        ax.set_xlabel("frequency [Hz]")
    axes[0].set_ylabel("|acc 2 / force|")
    axes[1].set_title("the joint mode near 7.3 Hz", fontsize="small")
    axes[0].legend(fontsize="small")
    fig.tight_layout()
    return fig


def _fig_run(record, seconds: float = 20.48):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3))
    n = round(seconds * record.fs)
    for i, amp in enumerate(record.amplitudes_deg):
        ax.plot(
            record.time[:n],
            np.degrees(record.theta[i, :n]),
            lw=0.7,
            label=f"theta, set-point {amp:.1f} deg",
        )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("tilt [deg]")
    ax.legend(fontsize="x-small", ncol=2, loc="upper right")
    fig.tight_layout()
    return fig


def _add_real_data(rep: Report, result: dict) -> None:
    emps, f16 = result["real_data"]["emps"], result["real_data"]["f16"]
    rep.add_heading("Real data")
    if emps is None:
        rep.add_text("EMPS is not in the data folder (PDMKIT_DATA); its check was skipped.")
    else:
        table = pd.DataFrame(emps["estimates"]).T
        table.loc["published (Janot et al. 2019)"] = [
            emps["published"]["M"],
            emps["published"]["Fv"],
            np.nan,
            0,
            0,
        ]
        rep.add_text(
            "EMPS, a positioning system measured in closed loop with the controller "
            "vir = kv (kp (qg - qm) - dqm/dt) (kp, kv from the file; it explains "
            f"{100 * emps['controller_variance_explained']:.2f} % of the variance of vir). "
            "M and Fv fitted to each identified plant's FRF between 0.5 and 20 Hz."
        )
        rep.add_table(
            table,
            caption="EMPS mass (kg) and viscous friction (N s/m)",
            float_format="{:.4g}",
        )
    if f16 is None:
        rep.add_text("The F-16 ground vibration test is not in the data folder; skipped.")
    else:
        rep.add_text(
            "F-16 ground vibration test, the same multisine at two force levels: the FRF "
            f"depends on the level (deviation {f16['deviation_db'][0]:.2f} dB, p = "
            f"{f16['p_value'][0]:.2g}; peak near 7 Hz at "
            + " and ".join(f"{p:.2f}" for p in f16["peak_near_7hz"])
            + " Hz)."
        )
        rep.add_figure(_fig_f16(f16), caption="F-16 FRFs with the coherence >= 0.7 mask")


def build_closed_loop_report(result: dict, summary: dict) -> Report:
    """The HTML report: the seed's numbers beside pdmkit's."""
    rep = Report("Closed-loop identification of an unstable system")
    rep.add_text(
        "The seed's S-Mobile method on pdmkit's planar ballbot: an unstable, "
        "under-actuated plant under a known state feedback, excited by chirps on its "
        "tilt set-point, identified in closed loop three ways and by the seed's "
        "coherence-weighted grey-box fit, all against the exact linearisation."
    )
    methods = _table(result["methods"])
    fits = _table(result["seed_fits"])
    true = summary["truth"]
    best = methods.loc[methods["method"] != "direct", "error_percent"].abs().min()
    rep.add_summary_box(
        [
            ("Unstable pole (truth)", f"{true['unstable_pole']:.3f} rad/s", "truth"),
            (
                "Closed-loop methods",
                f"best indirect/joint error {best:.1f} %; direct is biased by the feedback",
                "identified-in-closed-loop",
            ),
            (
                "theta_x (seed 20.31)",
                ", ".join(f"{v:.2f}" for v in fits["theta_x"]),
                "the-seed-s-approach",
            ),
            ("Run time", f"{summary['wall_s']} s wall, {summary['cpu_s']} s CPU", None),
        ]
    )
    rep.add_heading("The seed beside pdmkit")
    rep.add_table(seed_comparison(result), caption=f"{SEED} and pdmkit")
    rep.add_heading("Truth")
    rep.add_text(
        f"Exact linearisation (complex step) at upright: unstable pole "
        f"{true['unstable_pole']:.4f} rad/s; without drive and rolling friction "
        f"{true['unstable_pole_frictionless']:.4f} rad/s against the closed form "
        f"sqrt(m g l M11 / det M) = {true['closed_form_frictionless']:.4f} rad/s. Drive "
        f"lag identified separately: T_m = {summary['actuator']['T_m_identified']:.4f} s "
        f"(true {summary['actuator']['T_m_true']})."
    )
    rep.add_figure(
        _fig_run(result["record"]),
        caption="The tilt during the first chirp period of each run",
    )
    rep.add_heading("Amplitude-dependent FRFs")
    rep.add_figure(
        _fig_frfs(result),
        caption="theta/theta_set per chirp amplitude, lines with "
        f"coherence < {COHERENCE_MIN} left out (cf. seed Fig. 4)",
    )
    rep.add_table(
        pd.DataFrame(
            {
                k: summary["frf"][k]
                for k in (
                    "amplitudes_deg",
                    "saturated_share",
                    "coherence_edge_hz",
                    "deviation_db",
                    "p_value",
                )
            }
        ),
        caption="Per amplitude: torque limit reached, coherence edge, deviation from the "
        "largest amplitude",
        float_format="{:.3g}",
    )
    _add_methods(rep, result, summary)
    _add_real_data(rep, result)
    rep.add_json(
        {k: v for k, v in summary.items() if k != "seed_comparison"},
        caption="summary.json",
    )
    return rep


def _add_methods(rep, result, summary) -> None:
    """The three closed-loop methods and the seed's approach."""
    methods = _table(result["methods"])
    fits = _table(result["seed_fits"])
    rep.add_heading("Identified in closed loop")
    rep.add_table(
        methods,
        caption="Unstable pole and plant FRF error (median |dB| over "
        f"{BAND[0]}-{BAND[1]} Hz) against the truth",
        float_format="{:.4g}",
    )
    rep.add_table(
        _table(result["linear_methods"]),
        float_format="{:.4g}",
        caption="Control experiment: no Coulomb friction, no torque limit",
    )
    rep.add_figure(_fig_poles(result), caption="Poles: truth and estimates")
    rep.add_figure(_fig_plant(result), caption="Plant u -> theta: truth and estimates")
    rep.add_heading("The seed's approach")
    rep.add_table(
        fits,
        caption="theta_x fitted to theta/theta_set (start 1.3 x 20.31), seed's error eps",
        float_format="{:.4g}",
    )
    rep.add_figure(
        _fig_seed_fit(result),
        caption="Measured and fitted closed-loop FRFs (cf. seed Fig. 6)",
    )
