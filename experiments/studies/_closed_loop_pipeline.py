"""The closed-loop study's pipeline (:mod:`._closed_loop`): truth, runs, methods, fits."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from scipy import ndimage, signal

from pdmkit._progress import progress
from pdmkit.errors import ConvergenceWarning
from pdmkit.models.frequency import FRF, amplitude_dependence, fit_frf_params, frf_estimate
from pdmkit.models.ident import (
    KnownController,
    closed_loop_frf,
    direct_identification,
    indirect_identification,
    joint_identification,
)
from pdmkit.models.rigs import BallbotRig, chirp_reference

__all__ = [
    "AMPLITUDES_DEG",
    "SEED_THETA_X",
    "closed_loop_frfs",
    "coherence_edge",
    "fit_theta_x",
    "identify_plant",
    "seed_error",
    "truth",
]

#: the seed's chirp amplitudes (sec. 5: "from 1.5 to 5 degrees")
AMPLITUDES_DEG = (1.5, 2.5, 3.5, 5.0)
#: the seed's identified mass moment of inertia, "confirmed by the design data" (sec. 5)
SEED_THETA_X = 20.31
COHERENCE_MIN = 0.7
#: frequency band (Hz) where identified and true plant FRFs are compared
BAND = (0.3, 10.0)
CHIRP_PERIOD = 20.48


def seed_error(H_meas, H_model, coherence) -> dict:
    """The seed's coherence-weighted error (sec. 3.6): ``eps = eps_mag + eps_phase``.

    ``eps_mag = mean(dA_dB^2 k)``, ``eps_phase = mean((20 log10(1 + |dphi|))^2 k)`` with
    the coherence as the weight ``k_eval`` (``dphi`` in radians, wrapped to +-pi; the
    seed does not give the unit).

    Examples
    --------
    >>> import numpy as np
    >>> seed_error(np.ones(3), np.ones(3), np.ones(3))["eps"]
    0.0
    """
    ratio = np.asarray(H_meas) / np.asarray(H_model)
    d_db = 20 * np.log10(np.abs(ratio))
    d_rad = np.angle(ratio)
    k = np.asarray(coherence, dtype=float)
    mag = float(np.mean(d_db**2 * k))
    phase = float(np.mean((20 * np.log10(1 + np.abs(d_rad))) ** 2 * k))
    return {"eps": mag + phase, "eps_mag": mag, "eps_phase": phase}


# ------------------------------------------------------------------ truth
def truth(rig: BallbotRig) -> dict:
    """The open-loop truth: exact linearisation (plant + drive) and its ZOH sampling."""
    lin = rig.linearize(actuator=True)
    bare = rig.with_params(drive_damping=0.0, rolling_damping=0.0, drive_coulomb=0.0)
    Ad, Bd = rig.discrete_plant()
    return {
        "poles": lin.poles,
        "unstable_pole": float(lin.poles.real.max()),
        "unstable_pole_frictionless": float(bare.linearize().poles.real.max()),
        "closed_form_frictionless": bare.unstable_pole(),
        "Ad": Ad,
        "Bd": Bd,
    }


def plant_frf(rig_truth: dict, freq, fs: float) -> np.ndarray:
    """The true sampled plant ``u -> theta`` at ``freq`` (Hz)."""
    Ad, Bd = rig_truth["Ad"], rig_truth["Bd"]
    z = np.exp(2j * np.pi * np.asarray(freq, dtype=float) / fs)
    eye = np.eye(Ad.shape[0])
    return np.array([np.linalg.solve(zz * eye - Ad, Bd)[1, 0] for zz in z])


# ------------------------------------------------------------------ experiment
def identify_actuator(rig: BallbotRig, seed: int, duration: float = 60.0) -> dict:
    """The drive's lag from a separate FRF measurement (command -> measured torque).

    The command is white noise, the torque is measured with 2 % noise; the first-order
    lag ``1 / (T_m s + 1)`` (sampled with a zero-order hold) is fitted by Nelder-Mead.
    """
    rng = np.random.default_rng(seed + 7)
    fs = rig.fs
    n = round(duration * fs)
    u = 10.0 * rng.standard_normal(n)
    a = np.exp(-1.0 / (fs * rig.actuator_time_constant))
    tau = signal.lfilter([0.0, 1 - a], [1.0, -a], u)
    tau = tau + 0.02 * np.std(tau) * rng.standard_normal(n)
    frf = frf_estimate(u, tau, fs, nperseg=512, fmin=0.2, fmax=0.45 * fs)

    def lag(omega, T_m):
        z = np.exp(1j * omega / fs)
        b = 1 - np.exp(-1.0 / (fs * T_m))
        return b / (z - (1 - b))

    fit = fit_frf_params(lag, {"T_m": 0.05}, frf, method="nelder-mead", coherence_min=0.7)
    return {"T_m": fit.params["T_m"], "true": rig.actuator_time_constant, "fit": fit}


def experiment(rig, controller, amplitudes, seed: int, periods: int) -> object:
    """The closed-loop chirp runs (seed sec. 5)."""
    w = chirp_reference(amplitudes, duration=periods * CHIRP_PERIOD, period=CHIRP_PERIOD)
    return rig.simulate(w, controller=controller, seed=seed, substeps=2)


def closed_loop_frfs(record) -> FRF:
    """``theta / theta_set`` per amplitude (H1, one chirp period per Welch segment)."""
    skip = round(CHIRP_PERIOD * record.fs)  # the first period is the start-up
    return frf_estimate(
        record.reference[:, skip:],
        record.theta[:, skip:],
        record.fs,
        nperseg=skip,
        noverlap=skip // 2,
        amplitudes=record.amplitudes_deg,
        fmin=0.2,
        fmax=30.0,
    )


def coherence_edge(frf: FRF, threshold: float = COHERENCE_MIN) -> list[float]:
    """Per row, the first frequency above 1 Hz with a coherence below ``threshold``.

    The coherence is median-filtered over about 1 Hz first, so single bad lines do not
    count.
    """
    out = []
    df = float(np.median(np.diff(frf.freq)))
    width = max(3, round(1.0 / df) | 1)
    for coh in np.atleast_2d(frf.coherence):
        smooth = ndimage.median_filter(coh, size=width, mode="nearest")
        idx = np.flatnonzero((smooth < threshold) & (frf.freq > 1.0))
        out.append(float(frf.freq[idx[0]]) if idx.size else float(frf.freq[-1]))
    return out


# ------------------------------------------------------------------ the three methods
def _known_controller(controller) -> KnownController:
    """The rig's controller in the ident form: ``u = N w - K x[k - 1]``."""
    return KnownController(
        feedback=np.c_[np.zeros(4), controller.K], feedforward=controller.N
    )


def identify_plant(
    record, run: int, controller, rig_truth: dict, orders=None
) -> list[dict]:
    """Direct, indirect and joint estimates of one run, against the truth.

    ``orders`` (``{"indirect": nx, "joint": nx}``) fixes the closed-loop model orders;
    by default each is taken from the subspace singular values.
    """
    orders = orders or {}
    fs = record.fs
    skip = round(CHIRP_PERIOD * fs)
    r = record.reference[run, skip:]
    u = record.command[run, skip:]
    X = record.states[run, skip:]
    f = np.linspace(*BAND, 60)
    G_true = plant_frf(rig_truth, f, fs)
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        models = {
            "direct": direct_identification(u, X[:, 1], fs, nk=1),
            "indirect": indirect_identification(
                r,
                X,
                fs,
                _known_controller(controller),
                order=orders.get("indirect"),
                horizon=10,
            ),
            "joint": joint_identification(
                r, u, X, fs, order=orders.get("joint"), horizon=10
            ),
        }
    for method, m in models.items():
        G = m.frequency_response(f)
        G = G[:, 0] if method == "direct" else G[:, 1]
        pole = float(m.unstable_poles[0]) if m.unstable_poles.size else float("nan")
        inner = m.info.get("model") or m.info.get("loop")
        rows.append(
            {
                "method": method,
                "amplitude_deg": float(record.amplitudes_deg[run]),
                "saturated_share": float(record.saturated[run]),
                "order": dict(inner.orders) if inner is not None else {},
                "unstable_pole": pole,
                "error_percent": 100 * (pole / rig_truth["unstable_pole"] - 1),
                "frf_error_db": float(np.median(np.abs(20 * np.log10(np.abs(G / G_true))))),
                "model": m,
            }
        )
    return rows


# ------------------------------------------------------------------ the seed's approach
def fit_theta_x(frf: FRF, row: int, rig, controller, T_m: float, at_rate: bool) -> dict:
    """The seed's grey-box step: ``theta_x`` fitted to one measured ``theta/theta_set``.

    The model is the closed loop of the linearised plant with the known controller and
    the separately identified drive lag; ``at_rate`` linearises at the seed's angular
    velocity at the zero crossing, ``A(omega) theta_set omega`` (eq. 11), else at rest.
    """
    H = np.atleast_2d(frf.H)[row]
    coh = np.atleast_2d(frf.coherence)[row]
    keep = frf.freq <= 20.0
    data = FRF(frf.freq[keep], H[keep], coh[keep])
    amp = np.radians(float(frf.amplitudes[row]))
    # eq. 11, on a 0.05 rad/s grid (one discretisation per distinct rate)
    rates = np.abs(H[keep]) * amp * 2 * np.pi * frf.freq[keep] if at_rate else 0.0
    rates = np.round(np.asarray(rates) / 0.05) * 0.05
    base = rig.with_params(actuator_time_constant=T_m)

    def model(omega, theta_x):
        trial = base.with_params(
            body_inertia=max(theta_x, rig.body_mass * rig.com_height**2 * 1.001)
        )
        return trial.tilt_response(omega / (2 * np.pi), controller, rates)

    start = 1.3 * SEED_THETA_X
    fit = fit_frf_params(
        model,
        {"theta_x": start},
        data,
        coherence_min=COHERENCE_MIN,
        method="nelder-mead",
    )
    theta_x = fit.params["theta_x"]
    fitted = base.with_params(body_inertia=theta_x)
    mask = coh[keep] >= COHERENCE_MIN
    err = seed_error(H[keep][mask], fit.H_model[mask], coh[keep][mask])
    return {
        "amplitude_deg": float(frf.amplitudes[row]),
        "linearised_at": "eq. 11 rate" if at_rate else "rest",
        "theta_x_start": start,
        "theta_x": theta_x,
        "theta_x_error_percent": 100 * (theta_x / rig.body_inertia - 1),
        "unstable_pole": float(fitted.linearize().poles.real.max()),
        "rms_db": fit.rms_db,
        "rms_deg": fit.rms_deg,
        **err,
        "fit": fit,
    }


def _study(seed: int, quick: bool) -> dict:
    """Everything but the real-data checks and the report."""
    rig = BallbotRig()
    ctl = rig.controller()
    true = truth(rig)
    actuator = identify_actuator(rig, seed)
    amps = (AMPLITUDES_DEG[0], AMPLITUDES_DEG[-1]) if quick else AMPLITUDES_DEG
    periods = 3 if quick else 5
    record = experiment(rig, ctl, amps, seed, periods)
    frf = closed_loop_frfs(record)
    dependence = amplitude_dependence(frf, coherence_min=COHERENCE_MIN)
    rows = []
    orders = None
    for run in progress(range(len(amps)), desc="closed-loop identification"):
        rows += identify_plant(record, run, ctl, true, orders)
        # the orders the first run's singular values chose serve the others
        orders = orders or {r["method"]: r["order"].get("nx") for r in rows[1:]}
    # control experiment: the same plant without Coulomb friction and torque limit
    linear_rig = rig.with_params(drive_coulomb=0.0, torque_limit=1e4)
    linear_rec = experiment(linear_rig, ctl, amps[:1], seed + 1, periods)
    linear_rows = identify_plant(linear_rec, 0, ctl, true, orders)
    seed_rows = []
    for row in progress(range(len(amps)), desc="seed's grey-box fit"):
        for at_rate in (False, True):
            seed_rows.append(fit_theta_x(frf, row, rig, ctl, actuator["T_m"], at_rate))
    return {
        "rig": rig,
        "controller": ctl,
        "truth": true,
        "actuator": actuator,
        "record": record,
        "frf": frf,
        "dependence": dependence,
        "methods": rows,
        "linear_methods": linear_rows,
        "seed_fits": seed_rows,
        "nonparametric": closed_loop_frf(
            record.reference[0, round(CHIRP_PERIOD * record.fs) :],
            record.command[0, round(CHIRP_PERIOD * record.fs) :],
            record.theta[0, round(CHIRP_PERIOD * record.fs) :],
            record.fs,
            nperseg=round(CHIRP_PERIOD * record.fs),
            fmin=0.2,
            fmax=30.0,
        ),
    }


def _table(rows: list[dict]) -> pd.DataFrame:
    """Rows without the model objects."""
    return pd.DataFrame(
        [{k: v for k, v in r.items() if k not in ("model", "fit")} for r in rows]
    )
