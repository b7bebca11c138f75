"""Real-data checks of the closed-loop study: EMPS (closed loop) and the F-16 (two levels).

- **EMPS** (Janot, Gautier & Brunot 2019): a prismatic joint measured in closed loop;
  the control voltage is ``vir = kv (kp (qg - qm) - dqm/dt)`` with the gains in the
  file, the force ``gtau vir``, and the published rigid-body model ``M qm'' + Fv qm' +
  Fc sign(qm') = gtau vir`` with ``M = 95.1 kg``, ``Fv = 203.5 N s/m``, ``Fc = 20.4 N``.
  The plant ``vir -> qm`` is identified directly, indirectly (the known controller
  removed) and from the cross-spectra with the reference; ``M`` and ``Fv`` are read off
  each by fitting ``gtau / (M s^2 + Fv s)`` to its FRF between 0.5 and 20 Hz.
- **F-16 ground vibration test** (Noel & Schoukens 2017): the same multisine force at
  two levels; the FRF ``force -> acceleration 2`` changes with the level (nonlinear
  joints), which :func:`pdmkit.models.frequency.amplitude_dependence` tests with the
  coherence >= 0.7 mask.
"""

from __future__ import annotations

import warnings

import numpy as np

from pdmkit._config import data_dir
from pdmkit.ensembles import load_emps, read_mat
from pdmkit.errors import ConvergenceWarning
from pdmkit.models.frequency import FRF, amplitude_dependence, fit_frf_params, frf_estimate
from pdmkit.models.ident import (
    KnownController,
    closed_loop_frf,
    direct_identification,
    indirect_identification,
)

__all__ = ["EMPS_PUBLISHED", "emps_check", "f16_check"]

#: Janot et al. 2019, the IDIM-LS model of the estimation data
EMPS_PUBLISHED = {"M": 95.1, "Fv": 203.5, "Fc": 20.4}
EMPS_BAND = (0.5, 20.0)


def _mass_friction(freq, H, gtau, coherence=None) -> dict:
    """``M`` and ``Fv`` of ``gtau / (M s^2 + Fv s)`` fitted to an FRF."""

    def rigid(omega, M, Fv):
        s = 1j * omega
        return gtau / (M * s**2 + Fv * s)

    fit = fit_frf_params(rigid, {"M": 50.0, "Fv": 100.0}, FRF(freq, H, coherence))
    return {"M": fit.params["M"], "Fv": fit.params["Fv"], "rms_db": fit.rms_db}


def emps_check(folder=None) -> dict | None:
    """The EMPS plant from closed-loop data; None when the data set is absent."""
    folder = data_dir("emps") if folder is None else folder
    if not folder.is_dir():
        return None
    e = load_emps()
    fs, kp, kv, gtau = e["fs"], e["kp"], e["kv"], e["gtau"]
    qm, qg, vir = e["qm"], e["qg"], e["vir"]
    controller = KnownController(
        feedback=[[kv * kp + kv * fs, -kv * fs]], feedforward=kv * kp
    )
    explained = 1 - np.var(vir - controller.apply(qg, qm)) / np.var(vir)
    f = np.linspace(*EMPS_BAND, 100)
    rows = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        direct = direct_identification(vir, qm, fs, nk=1)
        indirect = indirect_identification(qg, qm, fs, controller)
    for name, model in (("direct", direct), ("indirect", indirect)):
        rows[name] = _mass_friction(f, model.frequency_response(f)[:, 0], gtau)
    nonpar = closed_loop_frf(
        qg, vir, qm, fs, nperseg=4096, fmin=EMPS_BAND[0], fmax=EMPS_BAND[1]
    )
    keep = nonpar.coherence >= 0.7
    rows["cross-spectra S_ry/S_ru"] = _mass_friction(
        nonpar.freq[keep], nonpar.H[keep], gtau, nonpar.coherence[keep]
    )
    for row in rows.values():
        row["M_error_percent"] = 100 * (row["M"] / EMPS_PUBLISHED["M"] - 1)
        row["Fv_error_percent"] = 100 * (row["Fv"] / EMPS_PUBLISHED["Fv"] - 1)
    return {
        "published": EMPS_PUBLISHED,
        "controller_variance_explained": float(explained),
        "estimates": rows,
        "frf": {
            "freq": f,
            "direct": direct.frequency_response(f)[:, 0],
            "indirect": indirect.frequency_response(f)[:, 0],
            "gtau": gtau,
        },
    }


def f16_check(folder=None) -> dict | None:
    """Amplitude dependence of the F-16 FRF at two force levels; None without the data."""
    folder = data_dir("f16_gvt") if folder is None else folder
    files = [
        folder / "F16Data_FullMSine_Level1.mat",
        folder / "F16Data_FullMSine_Level2_Validation.mat",
    ]
    if not all(p.is_file() for p in files):
        return None
    u, y = [], []
    fs = None
    for path in files:
        d = read_mat(path)
        fs = float(np.squeeze(d["Fs"]))
        u.append(np.asarray(d["Force"], dtype=float).ravel())
        y.append(np.asarray(d["Acceleration"], dtype=float)[1].ravel())
    n = min(map(len, u))
    U, Y = np.array([x[:n] for x in u]), np.array([x[:n] for x in y])
    rms = np.std(U, axis=1)
    frf = frf_estimate(U, Y, fs, nperseg=8192, amplitudes=rms, fmin=2.0, fmax=15.0)
    dep = amplitude_dependence(frf, coherence_min=0.7)
    band = (frf.freq > 6.5) & (frf.freq < 8.0)
    peaks = [float(frf.freq[band][np.argmax(np.abs(row[band]))]) for row in frf.H]
    return {
        "force_rms_n": rms.tolist(),
        "deviation_db": dep.deviation_db.tolist(),
        "p_value": dep.p_value.tolist(),
        "nonlinear": bool(dep.nonlinear),
        "peak_near_7hz": peaks,
        "coherence_share_above_0.7": np.mean(frf.coherence >= 0.7, axis=1).tolist(),
        "frf": frf,
    }
