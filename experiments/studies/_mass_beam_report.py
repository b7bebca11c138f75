"""The HTML report of ``pdmkit study mass-beam``: the paper's numbers beside pdmkit's."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from pdmkit.experiments._report import Report

__all__ = ["build_report"]


def _fmt(x, unit="", digits=1) -> str:
    return "not detected" if not math.isfinite(x) else f"{x:.{digits}f}{unit}"


def build_report(summary: dict, parts: dict) -> Report:
    """The study's report from its summary and the objects behind it."""
    rep = Report("Study: fatigue anomaly of the mass-beam rig")
    rep.add_text(
        "Khatkhate, Ray & Keller (Applied Mathematical Modelling 31, 2007) "
        "models a three-mass beam rig, identifies it, and detects the fatigue crack "
        "growing in its specimens from the displacement of mass 3 with symbolic "
        "dynamics, comparing it with PCA, an RBF network and a multilayer perceptron "
        "(section 6, figure 7). This report runs that protocol on pdmkit's simulated "
        "rig and puts the seed's published numbers beside pdmkit's. A simulation is "
        "a hypothesis, not the seed's rig: where the numbers differ the text says by "
        "how much and why."
    )
    _physics_section(rep, parts)
    _fatigue_section(rep, parts)
    _measures_section(rep, summary, parts)
    _sfnn_section(rep, parts)
    _real_section(rep, parts)
    _differences(rep, summary, parts)
    rep.add_heading("summary.json")
    rep.add_json(summary)
    _summary_box(rep, summary, parts)
    return rep


def _short(name: str) -> str:
    return name.replace("SDF, ", "").replace(" partition", "")


def _summary_box(rep: Report, summary: dict, parts: dict) -> None:
    phys = parts["physics"]
    w = phys["lumped, effective masses"].to_numpy()
    fe = phys["beam mass distributed (FE)"].to_numpy()
    bare = phys["lumped, table 1 masses"].to_numpy()
    anchor = rep.anchor("3. Anomaly measures on the same run (seed figure 7)")
    lines = [
        (
            "Resonances",
            f"system 1 {w[0]:.2f} rad/s (seed 73.3); system 2 {w[1]:.1f} / {w[2]:.1f} "
            f"(seed 28.9 / 87.8) with effective masses calibrated to them; table 1's "
            f"bare masses give {bare[1]:.1f} / {bare[2]:.1f}, with the beams' mass "
            f"distributed (FE) {fe[1]:.1f} / {fe[2]:.1f}",
            "1-the-rig-s-physics-seed-section-3",
        )
    ]
    for key, label in (("raw", "as recorded"), ("unit_rms", "scaled to unit RMS")):
        t = parts["variants"][key]["table"].set_index("measure")
        times = ", ".join(
            f"{_short(k)} {_fmt(v, ' min', 0)}" for k, v in t["detected at (min)"].items()
        )
        fa = max(t["false alarms on new nominal repeats"])
        lines.append(
            (
                f"Detection, files {label}",
                f"{times}; false alarms on new nominal repeats at most {100 * fa:.0f} % "
                "(seed: SFNN and WS within 16 min, MLP after 24 min)",
                anchor,
            )
        )
    if parts["femto"] is not None:
        lines.append(
            (
                "Real recording",
                "the same measures on PRONOSTIA bearing 1_1 (run to failure)",
                "5-real-recording-pronostia-bearing-1-1-run-to-failure",
            )
        )
    rep.add_summary_box(lines)


def _physics_section(rep: Report, parts: dict) -> None:
    fe = parts["physics"]["beam mass distributed (FE)"].to_numpy()
    d_low, d_up = 100 * (fe[1] / 28.9 - 1), 100 * (fe[2] / 87.8 - 1)
    rep.add_heading("1. The rig's physics (seed section 3)")
    rep.add_text(
        "System 1 (mass m3 on the steel beam, Castigliano's stiffness, eq. 2-3) comes "
        "from table 1 alone. For system 2 the seed gives neither the beam lengths L1-L3 "
        "nor how it lumps the beams' mass; with table 1's bare masses (1.0 and 0.615 "
        "kg) its equations (the flexibility constants a1-a4, eq. 8) give the column "
        "'lumped, table 1 masses'. pdmkit's default rig uses effective masses m1 = "
        "1.952 kg and m2 = 0.503 kg, calibrated so that the lumped model gives the "
        "seed's 28.9 and 87.8 rad/s: those two agree by construction, not as a check. "
        "The independent check is the last column: the same beams as Euler-Bernoulli "
        "finite elements with their own mass distributed (steel 7850 kg/m^3, "
        f"aluminium 2700 kg/m^3) and the bare masses: {d_up:+.1f} % from the seed's "
        f"upper mode and {d_low:+.1f} % from its lower one. The seed's measured "
        "resonances (section 5) are 71 and 91 rad/s."
    )
    rep.add_table(
        parts["physics"],
        caption="Resonances (rad/s): Khatkhate et al. beside pdmkit's models",
        float_format="{:.2f}",
    )
    rep.add_figure(parts["rig"].plot(), caption="Receptances of the rig (2 % damping)")


def _fatigue_section(rep: Report, parts: dict) -> None:
    run = parts["fatigue"]
    rep.add_heading("2. The fatigue run (seed section 6)")
    rep.add_text(
        "Shaker 1 drives system 1 with the seed's sine (0.85 V, 11.39 Hz = 71.6 rad/s, "
        "just below the 73.2 rad/s resonance; 10 N/V assumed) plus 3 % broadband force "
        "noise, a 0.5 % gain drift from file to file and LVDT noise of 0.05 mm, "
        "sampled every 2 ms. The specimen cracks from both edges of its 8.43 mm hole "
        "(table 1, 22.2 mm wide): Paris' law (exponent 3.7, aluminium) on the "
        "net-section stress, which grows with the displacement amplitude, the "
        "cracked section holding 5 % of the system's compliance when whole, a 1 mm "
        "crack at the start and the Paris constant set so the specimen breaks at 40 "
        "min (the seed's estimated service life). As the stiffness falls the "
        "resonance moves toward the excitation, the amplitude grows and the crack "
        "speeds itself up. None of these numbers is in the seed except the sine, the "
        f"2-min files and the life; {len(run.time_min)} files of "
        f"{parts['record_seconds']:.0f} s are recorded (the seed's files are 2 min)."
    )
    rep.add_figure(run.plot(), caption="Stiffness loss and crack length over the run")
    rep.add_table(
        run.to_pandas(),
        caption="The files: crack, stiffness and amplitude",
        float_format="{:.4g}",
    )


def _measures_figure(parts: dict):
    import matplotlib.pyplot as plt

    run = parts["fatigue"]
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5))
    keep = run.time_min <= 32.0
    for row, (key, label) in enumerate(
        (("raw", "as recorded"), ("unit_rms", "each file scaled to unit RMS"))
    ):
        v = parts["variants"][key]
        levels = v["table"].set_index("measure")["alarm level"]
        for name, s in v["scored"].items():
            ref = np.max(s["files"][keep]) or 1.0
            axes[row, 0].plot(
                run.time_min[keep], s["files"][keep] / ref, "o-", ms=3, label=name
            )
            axes[row, 1].semilogy(  # file 1 is the reference (measure 0)
                run.time_min[1:], s["files"][1:] / levels[name], "o-", ms=3, label=name
            )
        axes[row, 0].set_title(
            f"{label}: normalised as figure 7 (largest to 32 min = 1)", fontsize=10
        )
        axes[row, 0].axvline(16, color="k", ls=":", lw=1)
        axes[row, 0].axvline(24, color="k", ls="--", lw=1)
        axes[row, 0].set_ylabel("measure / its largest value")
        axes[row, 1].axhline(1, color="k", lw=1)
        axes[row, 1].set_title(f"{label}: over the alarm level", fontsize=10)
        axes[row, 1].set_ylabel("measure / alarm level")
    for ax in axes[1]:
        ax.set_xlabel("time (min)")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def _measures_section(rep: Report, summary: dict, parts: dict) -> None:
    rep.add_heading("3. Anomaly measures on the same run (seed figure 7)")
    rep.add_text(
        "Every measure is fitted on the first file (the nominal condition at 2 min, "
        "as in the seed) and scores all files. Its alarm level is the largest value "
        f"it gives on {parts['repeats']} nominal repeats (the rig at the first file's "
        "stiffness with new noise and shaker drift); a measure detects the anomaly at "
        "the first file from which two files in a row exceed it; its false alarms are "
        f"counted on {parts['repeats']} more nominal repeats. The remaining life is "
        "measured against the seed's 32 min. The seed gives times only for SFNN, WS "
        "and the MLP (section 6). In the left plots the dotted line is 16 min (the "
        "seed's SFNN/WS detection), the dashed one 24 min (its MLP)."
    )
    rep.add_text(
        "The seed does not say whether its files were scaled. The measures are run "
        "twice: on the displacement as recorded (top row, first table), where a change "
        "of amplitude counts and so does the shaker's drift, and on each file divided "
        "by its RMS (bottom row, second table), where only the shape of the motion "
        "counts (the breathing crack's asymmetry, the response to the force noise)."
    )
    rep.add_figure(_measures_figure(parts), caption="Anomaly measures over the run")
    for key, label in (("raw", "as recorded"), ("unit_rms", "scaled to unit RMS")):
        rep.add_table(
            parts["variants"][key]["table"],
            caption=f"Files {label}: detection, false alarms and monotonicity of each "
            "measure (pdmkit) beside Khatkhate et al.'s statements",
            float_format="{:.3g}",
        )


def _sfnn_section(rep: Report, parts: dict) -> None:
    rep.add_heading("4. Partitions: symbolic false nearest neighbours")
    rep.add_text(
        "The SFNN partition (Kennel & Buhl 2003, the seed's reference 15) moves the "
        "cell boundaries of the maximum-entropy partition to where the fewest "
        "points whose symbolic words agree lie far apart in the delay embedding "
        "(words of 5 symbols, 3 delays of a quarter period, 10 % of the signal's "
        "standard deviation). Below, the fraction of such false neighbours of each "
        "partition on the nominal file; the test suite checks the search on the "
        "logistic map, whose generating partition (the critical point 0.5) is known."
    )
    rep.add_table(
        parts["sfnn"],
        caption="SFNN fraction of the three partitions",
        float_format="{:.3f}",
    )


def _real_section(rep: Report, parts: dict) -> None:
    femto = parts["femto"]
    rep.add_heading("5. Real recording: PRONOSTIA bearing 1_1, run to failure")
    if femto is None:
        rep.add_text(
            "The shared data folder (PDMKIT_DATA) has no femto_pronostia_bearing1_1 "
            "raw snapshots here; this section is left out."
        )
        return
    import matplotlib.pyplot as plt

    rep.add_text(
        "No recording of the seed's rig is public. The closest real case in the shared "
        "data is an accelerated bearing run to failure (Nectoux et al., PHM 2012): 60 "
        "of its 2803 horizontal-vibration snapshots (every 56th, then the last ten), "
        "2560 samples at 25.6 kHz each. The same measures are fitted on the first "
        "snapshot, the alarm level is their largest value on the next ten (early, "
        "healthy life), and the table gives the first snapshot (of 2803) from which "
        "two in a row exceed it."
    )
    fig, ax = plt.subplots(figsize=(8, 4))
    rows = []
    for name, v in femto["scored"].items():
        ax.semilogy(
            femto["snapshot"],
            np.maximum(v["scores"] / v["alarm level"], 1e-3),
            ".-",
            label=name,
        )
        rows.append(
            {
                "measure": name,
                "first snapshot above the level": v["first snapshot above (2 in a row)"],
                "life used then (%)": 100
                * v["first snapshot above (2 in a row)"]
                / femto["n_total"],
                "last snapshot / level": float(v["scores"][-1] / v["alarm level"]),
            }
        )
    ax.axhline(1, color="k", lw=1)
    ax.set_xlabel("snapshot (of 2803)")
    ax.set_ylabel("measure / alarm level")
    ax.legend(fontsize=7)
    rep.add_figure(fig, caption="Anomaly measures over the bearing's life")
    rep.add_table(
        pd.DataFrame(rows), caption="PRONOSTIA bearing 1_1", float_format="{:.3g}"
    )


def _differences(rep: Report, summary: dict, parts: dict) -> None:
    rep.add_heading("6. Where pdmkit differs from the seed, and why")
    texts = []
    for key, label in (("raw", "as recorded"), ("unit_rms", "scaled to unit RMS")):
        t = parts["variants"][key]["table"].set_index("measure")["detected at (min)"]
        sf, ws, mlp = t["SDF, SFNN partition"], t["SDF, wavelet space"], t["MLP"]
        order = ", ".join(
            f"{_short(k)} {_fmt(v, '', 0)}" for k, v in t.sort_values().items()
        )
        texts.append(
            f"Files {label}: SFNN {_fmt(sf, ' min', 0)} and WS {_fmt(ws, ' min', 0)} "
            f"against the seed's 'within 16 min' (SFNN {_gap(sf, 16.0, 'later')}); MLP "
            f"{_fmt(mlp, ' min', 0)} against 'more than 24 min'. Order (min): {order}."
        )
    rep.add_text("\n\n".join(texts))
    raw = parts["variants"]["raw"]["table"]["detected at (min)"].dropna()
    span = f"{raw.min():.0f}-{raw.max():.0f} min" if len(raw) else "no detection"
    rep.add_text(
        "Why they differ. In this rig the crack first shows as a larger displacement "
        "amplitude (the resonance moves toward the excitation). On the files as "
        "recorded every measure sees that amplitude once it exceeds the spread that the "
        f"0.5 % shaker drift gives the nominal repeats: their detections span {span}, "
        "and the PCA and network measures, which follow the amplitude, are not the late "
        "ones. Scaled to unit RMS, only the waveform is left: the breathing crack's "
        "asymmetry (a softer half-cycle) and the changed response to the force noise. "
        "That is where the partitions matter and where the seed's ordering (symbolic "
        "dynamics first, the MLP last, PCA weak) can appear. The seed's rig differs "
        "(resonance measured at 71 rad/s, crack growth not reported), and Chin et al. "
        "(2005) give the details of its PCA and network measures, which the seed does "
        "not reprint; pdmkit's are defined in docs/study_mass_beam.md (PCA: "
        "eigenvalue-weighted principal directions of delay windows; RBF and MLP: "
        "one-step predictors trained on the nominal file, measure = change of their "
        "prediction error)."
    )


def _gap(value: float, seed_value: float, word: str) -> str:
    if not math.isfinite(value):
        return "never"
    d = value - seed_value
    return "within it" if d <= 0 else f"{d:.0f} min {word}"
