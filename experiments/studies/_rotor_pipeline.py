"""The rotor study's pipeline (:mod:`._rotor_fdi`): symptoms, masks, matrix, runs."""

from __future__ import annotations

import numpy as np
import pandas as pd

from pdmkit._progress import progress
from pdmkit.experiments.studies._rotor_symptoms import (
    line_prominence,
    mode_frequencies,
    rls_theta,
    smooth_frame,
    tune_masks,
)
from pdmkit.models.diagnosis import DiagnosticMatrix, ParityEquations
from pdmkit.models.ident import select_order
from pdmkit.models.rigs import ROTOR_FAULTS, RotorRig

__all__ = [
    "FORGETTING_FACTORS",
    "ROTOR_MATRIX",
    "SYMPTOMS",
    "diagnose_record",
    "evaluate",
    "isolation_table",
    "reference_modes",
    "rotor_quantities",
]

#: the seed's circular buffer (samples at 256 Hz, sec. 4.2.1)
SEED_BUFFER = 256
#: forgetting factors the study runs at (see the module docstring)
FORGETTING_FACTORS = (
    0.99,
    (SEED_BUFFER - 1) / (SEED_BUFFER + 1),
    1 - 1 / SEED_BUFFER,
    0.998,
)

#: symptom -> (quantity, side of its mask, floor of the mask's spread)
SYMPTOMS: dict[str, tuple[str, str, float]] = {
    "1X up": ("1X line [dB]", "upper", 0.3),
    "2X up": ("2X line [dB]", "upper", 0.3),
    "bending f up": ("bending frequency [Hz]", "upper", 0.1),
    "parity #2->#4 up": ("parity #2->#4", "upper", 0.08),
    "parity #1->#3 up": ("parity #1->#3", "upper", 0.08),
}

#: the binary diagnostic matrix (faults x symptoms in the order of SYMPTOMS)
ROTOR_MATRIX: dict[str, list[int]] = {
    "unbalance": [1, 0, 0, 0, 0],
    "misalignment": [0, 1, 0, 0, 0],
    "rub": [0, 0, 1, 1, 1],
    "looseness": [0, 0, 0, 1, 0],
}

#: where each row comes from
MATRIX_SOURCES = {
    "unbalance": "a dominant 1X component means an excessive unbalance (seed sec. 1.3); "
    "the excitation changes, not the path, so the parity relations (notched at 1X, "
    "2X) stay",
    "misalignment": "a forced vibration (seed Table 2); its 2X component is the textbook "
    "signature (not stated in the seed); the bearing preload hardly moves the modes",
    "rub": "'abrupt increase of free frequency vibration ... caused by occasional "
    "contacts' (seed sec. 5.1); contact changes both transmission paths",
    "looseness": "looseness changes the vertical support (seed sec. 2.6): only the "
    "vertical channel-to-channel relation breaks",
}

#: synchronous lines a rotor's AR model must hold (seed sec. 4.3.1: 0.5X is a mode here)
SYNCHRONOUS_ORDERS = (1, 2, 3)
MIN_HOLD_S = 3.0  # a verdict must hold this long (s) to count
FS = 256.0


# ------------------------------------------------------------------ the pipeline
def reference_modes(rig: RotorRig, fs: float = FS) -> tuple[list[float], int]:
    """Healthy natural frequencies below Nyquist (close pairs merged) and the bending one.

    Returns the frequencies (Hz) and the index of the least damped mode (the shaft's
    bending mode, the one a rub stiffens).
    """
    modes = rig.modes()
    modes = modes[modes["frequency_hz"] < 0.45 * fs]
    freqs, damps = [], []
    for f, z in zip(modes["frequency_hz"], modes["damping"], strict=True):
        if freqs and f < 1.03 * freqs[-1]:
            damps[-1] = min(damps[-1], z)
            continue
        freqs.append(float(f))
        damps.append(float(z))
    return freqs, int(np.argmin(damps))


def rotor_quantities(record, setup: dict, forgetting: float) -> pd.DataFrame:
    """The five symptom quantities of a record, per sample (before smoothing)."""
    na, speed, fs = setup["na"], record.speed_hz, record.fs
    refs, bend = setup["references"], setup["bending"]
    lines1, lines2, bending = [], [], []
    for ch in ("ch3", "ch4"):
        theta = rls_theta(record.channel(ch), na, forgetting, fs)
        lines1.append(line_prominence(theta, speed, fs))
        lines2.append(line_prominence(theta, 2 * speed, fs))
        bending.append(mode_frequencies(theta, fs, refs, speed, every=4)[:, bend])
    parity = setup["parity"]
    parity.forgetting = forgetting
    ratio = parity.residuals(record.channels / setup["scale"]).ratio
    names = [q for q, _, _ in SYMPTOMS.values()]
    return pd.DataFrame(
        np.column_stack(
            [
                np.maximum(*lines1),
                np.maximum(*lines2),
                np.maximum(*bending),
                ratio[:, 0],
                ratio[:, 1],
            ]
        ),
        columns=names,
    )


def diagnose_record(smoothed: pd.DataFrame, masks: dict, matrix, warmup: int, fs: float):
    """Alarms, the matrix's verdict per sample and the run's verdict."""
    alarms = np.column_stack(
        [
            masks[s].evaluate(smoothed[q].to_numpy()).alarm
            for s, (q, _, _) in SYMPTOMS.items()
        ]
    )
    alarms[:warmup] = False
    labels = matrix.diagnose(alarms)
    found, counts = np.unique(labels[labels != "normal"], return_counts=True)
    verdict = "normal"
    if counts.size and counts.max() >= MIN_HOLD_S * fs:
        verdict = str(found[np.argmax(counts)])
    return alarms, labels, verdict


def _setup(rig: RotorRig, reference, quick: bool) -> dict:
    """Order selection, parity relations and reference modes from the healthy record."""
    scale = 1e-6  # work in micrometres (better conditioned normal equations)
    orders = range(2, 25, 2) if quick else range(2, 31, 2)
    selection = {}
    for ch in ("ch3", "ch4"):
        y = reference.channel(ch) / scale
        sel = {
            c: select_order(None, y, "ar", orders, c, fs=reference.fs)
            for c in ("aic", "mdl")
        }
        selection[ch] = sel
    refs, bend = reference_modes(rig, reference.fs)
    # the seed's rule (sec. 4.3.1): two poles per spectral component watched, here the
    # modes below Nyquist and the 1X, 2X, 3X lines; MDL may choose more, never fewer
    na_rule = 2 * (len(refs) + len(SYNCHRONOUS_ORDERS))
    na_mdl = int(max(sel["mdl"].best_order["na"] for sel in selection.values()))
    na = max(na_mdl, na_rule)
    parity = ParityEquations(
        [(1, 3), (0, 2)],
        notch=(rig.speed_hz, 2 * rig.speed_hz),
        names=["#1", "#2", "#3", "#4"],
    ).fit(reference.channels / scale, reference.fs)
    return {
        "na": na,
        "na_mdl": na_mdl,
        "na_rule": na_rule,
        "selection": selection,
        "parity": parity,
        "references": refs,
        "bending": bend,
        "scale": scale,
    }


def _runs_plan(seed: int, quick: bool) -> list[tuple[str | None, int]]:
    n_healthy, n_fault = (1, 1) if quick else (2, 2)
    plan = [(None, seed + 1 + i) for i in range(n_healthy)]
    for j, fault in enumerate(ROTOR_FAULTS):
        plan += [(fault, seed + 11 + 10 * j + i) for i in range(n_fault)]
    return plan


def _delays(record, alarms, labels, verdict, warmup):
    """Seconds from the onset to the first alarm and to the verdict (NaN if none)."""
    if record.onset is None:
        return float("nan"), float("nan")
    k0 = max(round(record.onset * record.fs), warmup)
    first = np.flatnonzero(alarms[k0:].any(axis=1))
    right = np.flatnonzero(labels[k0:] == verdict)
    det = first[0] / record.fs if first.size else float("nan")
    iso = right[0] / record.fs if right.size and verdict != "normal" else float("nan")
    return float(det), float(iso)


def evaluate(rig, setup, records, reference, forgetting_factors) -> dict:
    """Run the pipeline on every record at every forgetting factor.

    The quantities, alarms and labels of the forgetting factor nearest the seed's
    buffer (``keep``) are kept for the report.
    """
    keep = min(forgetting_factors, key=lambda x: abs(x - (1 - 1 / SEED_BUFFER)))
    matrix = DiagnosticMatrix(ROTOR_MATRIX, symptoms=list(SYMPTOMS))
    rows, kept, masks_kept = [], {}, {}
    for lam in progress(forgetting_factors, desc="forgetting factors"):
        memory = 1.0 / (1.0 - lam)
        warmup = int(max(5 * reference.fs, 5 * memory))
        ref_q = smooth_frame(rotor_quantities(reference, setup, lam))
        masks = tune_masks(ref_q.iloc[warmup:], SYMPTOMS, delay=round(memory))
        for rec in records:
            q = smooth_frame(rotor_quantities(rec, setup, lam))
            alarms, labels, verdict = diagnose_record(q, masks, matrix, warmup, rec.fs)
            det, iso = _delays(rec, alarms, labels, verdict, warmup)
            truth = rec.fault or "normal"
            rows.append(
                {
                    "forgetting": lam,
                    "memory_samples": memory,
                    "fault": truth,
                    "seed": rec.info["seed"],
                    "verdict": verdict,
                    "correct": verdict == truth,
                    "detection_delay_s": det,
                    "isolation_delay_s": iso,
                    "symptoms_raised": [
                        s for s, a in zip(SYMPTOMS, alarms.any(0), strict=True) if a
                    ],
                }
            )
            if abs(lam - keep) < 1e-9:
                kept[(truth, rec.info["seed"])] = (q, alarms, labels)
        if abs(lam - keep) < 1e-9:
            masks_kept, warmup_kept = masks, warmup
    return {
        "runs": pd.DataFrame(rows),
        "kept": kept,
        "kept_forgetting": keep,
        "masks": masks_kept,
        "warmup": warmup_kept,
        "matrix": matrix,
    }


def isolation_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Share of runs isolated correctly, per fault (rows) and forgetting factor."""
    table = runs.pivot_table(
        index="fault", columns="forgetting", values="correct", aggfunc="mean"
    )
    order = ["normal", *ROTOR_FAULTS]
    table = table.reindex([f for f in order if f in table.index])
    table.columns = [f"lambda={c:.4g}" for c in table.columns]
    return table
