"""The pneumatic twin (the seed rig's machine) against the rig's own healthy recordings.

For each healthy recording ``data11_1_{1,2,3}.csv`` of the seed rig (10 s at 1 kHz,
fault code 1100001, 6.25 kg, 6 bar; ``/work/shared/data/pneumatic_rig``, see its
README) the twin is simulated with the recording's own valve program (the switching
instants of ``outValveWP``), its load (``data11_settings.json``) and supply, on the seed
rig's machine (:func:`pdmkit.ensembles._pneumatic_rig.seed_rig_machine`, the knobs at
their mark, which the machine's coefficients are identified for; the rig's healthy
code has throttles 4 and 2, small dampers upper 4 and bottom 6), twice: as the
calibrated seed study records it (``identified="params_m"``, the author's
``params.m``: before) and re-identified from these recordings at the rig's true
supply (``identified="recordings"``, :data:`SEED_RIG_RECORDED_PARAMS`: after), with
noise-free
sensors. Printed per recording: the RMSE of ``LeverPosition`` (mm), ``FlowExtrusion``
and ``FlowContraction`` (l/min and % of the recording's range of that flow) and
``AirPressure`` (bar; the twin models the supply reservoir), and the timing of the up
stroke (lever 1 mm above the bottom, at 190 mm) and of the down stroke (back within
1 mm of the bottom). A figure of measured vs twin (position, both flows; up and down
stroke) is written as png.

Usage::

    .venv/bin/python benchmarks/twin_vs_rig.py [--data DIR] [--figure out.png]
        [--json out.json] [--machine {both,params_m,recordings}]

About 15-25 s on a 2-core machine (one batched simulation of 3 recordings x 2
machines). The figure goes to ``docs/img/twin_vs_rig.png`` by default.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd

DEFAULT_DATA = os.environ.get("PDMKIT_PNEUMATIC_RIG", "/work/shared/data/pneumatic_rig")
RECORDINGS = ("data11_1_1", "data11_1_2", "data11_1_3")
SIGNALS = ("LeverPosition", "FlowExtrusion", "FlowContraction", "AirPressure")
#: targets of issue 29, item 7
TARGET_POSITION_MM = 2.0
TARGET_FLOW_PERCENT = 15.0


def read_recording(data: Path, name: str) -> tuple[pd.DataFrame, dict]:
    """One recording and its settings (``data11_settings.json``)."""
    frame = pd.read_csv(data / f"{name}.csv")
    settings = json.loads((data / "data11_settings.json").read_text())[name]
    return frame, settings


def valve_program(frame: pd.DataFrame) -> dict[str, float]:
    """The twin's valve program from the recorded command ``outValveWP`` (0/1).

    One up command: ``cycle_start`` at its rising edge, held for ``cycle_duty *
    cycle_period`` (to its falling edge); the period is twice the recording, so the
    command does not come back within it.
    """
    t = frame["time"].to_numpy()
    wp = frame["outValveWP"].to_numpy() > 0.5
    rise = np.flatnonzero(~wp[:-1] & wp[1:]) + 1
    fall = np.flatnonzero(wp[:-1] & ~wp[1:]) + 1
    if rise.size != 1 or fall.size != 1 or fall[0] <= rise[0]:
        raise SystemExit("expected one up command (outValveWP 0 -> 1 -> 0) per recording")
    period = 2.0 * float(t[-1] + t[1] - t[0])
    return {
        "cycle_start": float(t[rise[0]]),
        "cycle_period": period,
        "cycle_duty": float(t[fall[0]] - t[rise[0]]) / period,
    }


MACHINES = {
    "params_m": "seed rig machine as the calibrated study records it (params.m)",
    "recordings": "seed rig machine re-identified from these recordings",
}


def twin_params(
    frames: list[pd.DataFrame],
    settings: list[dict],
    supply_bar: float,
    machines=tuple(MACHINES),
):
    """Batched parameters: one member per recording and machine (machine-major)."""
    from pdmkit.ensembles._pneumatic_rig import seed_rig_machine
    from pdmkit.models import PneumaticParams

    n = len(frames)
    programs = [valve_program(f) for f in frames]
    cols = {
        "mass_load": np.array([float(s["Settings.Load"]) for s in settings]),
        "p_supply": np.full(n, 101325.0 + supply_bar * 1e5),
        **{k: np.array([p[k] for p in programs]) for k in programs[0]},
    }
    parts = [seed_rig_machine(dict(cols), n, identified=m) for m in machines]
    nominal = PneumaticParams()
    merged = {}
    for key in dict.fromkeys(k for p in parts for k in p):
        values = [p.get(key, getattr(nominal, key)) for p in parts]
        if all(np.ndim(v) == 0 for v in values) and len(set(values)) == 1:
            merged[key] = values[0]  # sensor-physics constants: one number
        else:
            merged[key] = np.concatenate([np.broadcast_to(v, (n,)) for v in values])
    return PneumaticParams(**merged)


def simulate_twin(params, t_end: float, fs: float) -> dict[str, np.ndarray]:
    """Noise-free readings of the twin's sensors, (n_members, n_samples) each."""
    from pdmkit.models import SensorSpec, simulate_piston

    r = simulate_piston(
        params,
        t_end=t_end,
        fs=fs,
        sensors=list(SIGNALS),
        sensor_specs={name: SensorSpec() for name in SIGNALS},
        progress=False,
    )
    return {name: np.asarray(r.outputs[name]) for name in SIGNALS}


def _rmse(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def _first(t, mask) -> float:
    i = np.flatnonzero(mask)
    return float(t[i[0]]) if i.size else float("nan")


def timing(t, x, program) -> dict[str, float]:
    """Up-stroke start (1 mm), 190 mm and down-stroke end (1 mm) times, s."""
    up = program["cycle_start"]
    down = up + program["cycle_duty"] * program["cycle_period"]
    after_up = (t >= up) & (t < down)
    return {
        "lift_off_s": _first(t, after_up & (x > 1e-3)),
        "at_190mm_s": _first(t, after_up & (x > 0.190)),
        "bottom_s": _first(t, (t >= down) & (x < 1e-3)),
    }


def compare(frame: pd.DataFrame, twin: dict[str, np.ndarray], row: int) -> dict:
    """RMSE per signal and the strokes' timing of one recording."""
    t = frame["time"].to_numpy()
    out: dict = {}
    out["position_mm"] = 1e3 * _rmse(twin["LeverPosition"][row], frame["LeverPosition"])
    for name in ("FlowExtrusion", "FlowContraction"):
        meas = frame[name].to_numpy()
        rmse = _rmse(twin[name][row], meas)
        out[f"{name}_lpm"] = rmse
        out[f"{name}_percent_of_range"] = 100.0 * rmse / float(np.ptp(meas))
    out["AirPressure_bar"] = _rmse(twin["AirPressure"][row], frame["AirPressure"])
    program = valve_program(frame)
    out["rig_timing"] = timing(t, frame["LeverPosition"].to_numpy(), program)
    out["twin_timing"] = timing(t, twin["LeverPosition"][row], program)
    return out


def figure(frames, twin, names, machines, path: Path) -> None:
    """Measured vs twin: position and both flows, up and down stroke."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = (
        ("LeverPosition", 1e3, "LeverPosition, mm"),
        ("FlowExtrusion", 1.0, "FlowExtrusion, l/min"),
        ("FlowContraction", 1.0, "FlowContraction, l/min"),
    )
    windows = (
        (0.8, 4.2, "up stroke (valve up at 1.0 s)"),
        (5.8, 8.0, "down stroke (valve down at 6.0 s)"),
    )
    style = {
        "params_m": ("0.45", ":", "twin, params.m machine (before)"),
        "recordings": ("tab:red", "-", "twin, re-identified machine (after)"),
    }
    fig, axes = plt.subplots(len(rows), 2, figsize=(12, 8.5), sharex="col")
    colors = ("tab:blue", "tab:cyan", "tab:green")
    n = len(names)
    for (signal, scale, label), ax_row in zip(rows, axes, strict=True):
        for (lo, hi, title), ax in zip(windows, ax_row, strict=True):
            for k, (frame, name) in enumerate(zip(frames, names, strict=True)):
                t = frame["time"].to_numpy()
                m = (t >= lo) & (t <= hi)
                ax.plot(
                    t[m],
                    frame[signal].to_numpy()[m] * scale,
                    color=colors[k],
                    lw=0.8,
                    alpha=0.8,
                    label=f"rig {name}",
                )
            for j, machine in enumerate(machines):
                color, ls, text = style[machine]
                # the recordings' valve programs agree within a sample: the first's twin
                ax.plot(
                    t[m],
                    twin[signal][j * n][m] * scale,
                    color=color,
                    ls=ls,
                    lw=1.4,
                    label=text,
                )
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
            if signal == "LeverPosition":
                ax.set_title(title)
    axes[0, 0].legend(fontsize=7, loc="lower right")
    for ax in axes[-1]:
        ax.set_xlabel("time, s")
    fig.suptitle(
        "pdmkit pneumatic twin (seed rig machine, the rig's valve program, "
        "6.25 kg, 6 bar) vs the rig's healthy recordings data11_1_1..3",
        fontsize=10,
    )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=DEFAULT_DATA, help="folder of data11_1_*.csv")
    ap.add_argument("--supply-bar", type=float, default=6.0, help="gauge supply, bar")
    ap.add_argument("--figure", default="docs/img/twin_vs_rig.png", help="png to write")
    ap.add_argument("--json", default=None, help="write the results here")
    ap.add_argument(
        "--machine",
        choices=("both", *MACHINES),
        default="both",
        help="the seed rig machine(s) to simulate (default: both, before and after)",
    )
    args = ap.parse_args(argv)

    data = Path(args.data)
    loaded = [read_recording(data, name) for name in RECORDINGS]
    frames = [f for f, _ in loaded]
    settings = [s for _, s in loaded]
    t = frames[0]["time"].to_numpy()
    fs = 1.0 / float(t[1] - t[0])
    t_end = len(t) / fs

    machines = tuple(MACHINES) if args.machine == "both" else (args.machine,)
    params = twin_params(frames, settings, args.supply_bar, machines)
    t0 = time.perf_counter()
    twin = simulate_twin(params, t_end, fs)
    wall = time.perf_counter() - t0
    print(
        f"twin vs rig: {len(RECORDINGS)} recordings x {len(machines)} machines simulated "
        f"in {wall:.1f} s (RMSE over 10 s at 1 kHz; flows also in % of the recording's "
        "range)"
    )
    out: dict = {"simulate_seconds": wall}
    n = len(RECORDINGS)
    for j, machine in enumerate(machines):
        results = {
            name: compare(f, twin, j * n + k)
            for k, (name, f) in enumerate(zip(RECORDINGS, frames, strict=True))
        }
        print(f"\n[{machine}] {MACHINES[machine]}")
        print(
            f"{'recording':<11} {'position':>9} {'FlowExtrusion':>20} "
            f"{'FlowContraction':>20} {'AirPressure':>11}"
        )
        for name, r in results.items():
            print(
                f"{name:<11} {r['position_mm']:7.2f}mm "
                f"{r['FlowExtrusion_lpm']:7.2f} l/min "
                f"{r['FlowExtrusion_percent_of_range']:5.1f} % "
                f"{r['FlowContraction_lpm']:7.2f} l/min "
                f"{r['FlowContraction_percent_of_range']:5.1f} % "
                f"{r['AirPressure_bar']:7.3f} bar"
            )
        print("timing (s)   lift-off rig/twin   190 mm rig/twin   bottom rig/twin")
        for name, r in results.items():
            a, b = r["rig_timing"], r["twin_timing"]
            print(
                f"{name:<11} {a['lift_off_s']:8.3f} {b['lift_off_s']:7.3f}   "
                f"{a['at_190mm_s']:7.3f} {b['at_190mm_s']:7.3f}   "
                f"{a['bottom_s']:7.3f} {b['bottom_s']:7.3f}"
            )
        worst_pos = max(r["position_mm"] for r in results.values())
        worst_flow = max(
            max(r["FlowExtrusion_percent_of_range"], r["FlowContraction_percent_of_range"])
            for r in results.values()
        )
        ok = worst_pos <= TARGET_POSITION_MM and worst_flow <= TARGET_FLOW_PERCENT
        print(
            f"worst position {worst_pos:.2f} mm (target <= {TARGET_POSITION_MM:g}), worst "
            f"flow {worst_flow:.1f} % of range (target <= {TARGET_FLOW_PERCENT:g}): "
            f"{'met' if ok else 'NOT met'}"
        )
        out[machine] = {"recordings": results, "targets_met": ok}
    if args.figure:
        figure(frames, twin, RECORDINGS, machines, Path(args.figure))
        print(f"figure: {args.figure}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
