"""Model-based condition indicators: groups ``"frf"``, ``"hw"`` and ``"fractional"``.

Each group fits a model from the member's *input* and *output* records and reports
its parameters as indicators:

- ``frf`` - H1 frequency response with coherence
  (:func:`pdmkit.models.frequency.frf_estimate`) and a rational fit
  (:func:`~pdmkit.models.frequency.fit_tf`): resonance and gains (Khatkhate et al. 2007);
- ``hw`` - Hammerstein-Wiener coefficients
  (:class:`~pdmkit.models.ident._hammerstein.HammersteinWiener`; Voronin's thesis, 8.2.1);
- ``fractional`` - ``1/(a s^alpha + b s^beta + c)`` fitted to the empirical transfer
  function (:func:`~pdmkit.models.frequency.fit_fractional_tf`).

Public functions take ``u, y`` (1-D for one member or 2-D ``(members, samples)``; a
1-D ``u`` is shared by all members) and return a DataFrame with columns
``<group>/<Name>``. For :func:`pdmkit.features.extract`, which sees one signal, the
helpers ``resolve_model_options``, ``model_feature_names`` and ``_model_feature_rows``
take the input through the option ``<group>_input``. A member whose fit fails gets NaN
indicators and a :class:`~pdmkit.errors.ConvergenceWarning` naming it.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from pdmkit.errors import ConvergenceWarning, DataError
from pdmkit.features._common import check_fs
from pdmkit.models import (
    HammersteinWiener,
    fit_fractional_tf,
    fit_tf,
    frf_estimate,
    nonlinearity,
)

__all__ = [
    "FRACTIONAL_FEATURES",
    "FRF_FEATURES",
    "fractional_features",
    "frf_features",
    "hw_feature_names",
    "hw_features",
    "model_feature_names",
    "resolve_model_options",
]

FRF_FEATURES = (
    "PeakFreq",
    "PeakGainDb",
    "LowGainDb",
    "HighGainDb",
    "MeanCoherence",
    "Wn",
    "Zeta",
    "FitPercent",
)
FRACTIONAL_FEATURES = ("A", "Alpha", "B", "Beta", "C", "Error")

#: Options of each model group (defaults), as the registry ``FEATURE_GROUPS`` lists them.
MODEL_GROUP_OPTIONS: dict[str, dict[str, object]] = {
    "frf": {
        "frf_input": None,
        "frf_nperseg": None,
        "frf_fmin": None,
        "frf_fmax": None,
        "frf_order": 2,
    },
    "hw": {
        "hw_input": None,
        "hw_input_nl": None,
        "hw_output_nl": "saturation",
        "hw_nb": 2,
        "hw_nf": 2,
        "hw_nk": 1,
        "hw_initial": "steady",
    },
    "fractional": {
        "fractional_input": None,
        "fractional_nperseg": None,
        "fractional_fmax": None,
    },
}


def _member_inputs(u, n_members: int, n_samples: int, option: str) -> np.ndarray:
    """The input signal as ``(n_members, n_samples)``.

    One row per member, or one array shared by all (broadcast). ``option`` names the
    argument in the errors.
    """
    if u is None:
        raise DataError(
            f"model-based indicators need the input signal; pass {option}= (one array "
            "shared by all members, or one row per member)."
        )
    u = np.asarray(u, dtype=float)
    if u.ndim == 1:
        u = np.broadcast_to(u, (n_members, u.size))
    if u.shape != (n_members, n_samples):
        raise DataError(
            f"{option} has shape {u.shape}; expected ({n_samples},) or "
            f"({n_members}, {n_samples}): one input sample per output sample."
        )
    return u


def _pair(u, y, name: str) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[None, :]
    if y.ndim != 2:
        raise DataError(
            f"{name}: y must be (n_samples,) or (members, samples); got {y.shape}."
        )
    return _member_inputs(u, *y.shape, f"{name}_input"), y


def _warn_failed(group: str, failed: list[int], err: str) -> None:
    if failed:
        shown = ", ".join(map(str, failed[:8])) + (" ..." if len(failed) > 8 else "")
        warnings.warn(
            f"{group}: the model fit failed for member row(s) {shown} ({err}); their "
            "indicators are NaN.",
            ConvergenceWarning,
            stacklevel=3,
        )


# ----------------------------------------------------------------------------- frf
def frf_features(
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    *,
    nperseg: int | None = None,
    fmin: float | None = None,
    fmax: float | None = None,
    order: int = 2,
) -> pd.DataFrame:
    """FRF indicators per member (group ``"frf"``).

    ``PeakFreq`` (Hz) and ``PeakGainDb``: the largest H1 magnitude in the band;
    ``LowGainDb`` / ``HighGainDb``: magnitude at the lowest / highest frequency;
    ``MeanCoherence``; ``Wn`` (rad/s) and ``Zeta``: the least damped pole pair of a
    rational fit with ``order`` poles (:func:`~pdmkit.models.frequency.fit_tf`, weighted by
    coherence), ``FitPercent`` of that fit.

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.features._model_features import frf_features
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(2, 8192))
    >>> bz, az = ss.bilinear([400.0], [1.0, 4.0, 400.0], fs=200.0)  # wn = 20 rad/s
    >>> y = ss.lfilter(bz, az, u, axis=-1)
    >>> t = frf_features(u, y, fs=200.0, nperseg=1024, fmax=20.0)
    >>> np.round(t["frf/Wn"].to_numpy(), 0).tolist()
    [20.0, 20.0]
    """
    fs = check_fs(fs)
    u, y = _pair(u, y, "frf")
    rows, failed, last = [], [], ""
    for i in range(y.shape[0]):
        try:
            frf = frf_estimate(u[i], y[i], fs, nperseg=nperseg, fmin=fmin or 0.0, fmax=fmax)
            f, H, coh = frf.freq, frf.H, frf.coherence
            pos = f > 0
            f, H, coh = f[pos], H[pos], coh[pos]
            mag = 20 * np.log10(np.abs(H) + 1e-300)
            k = int(np.argmax(mag))
            fit = fit_tf(f, H, nb=max(order - 2, 0), na=order, weight=coh)
            p = fit.poles
            p = p[np.abs(p) > 0]
            zeta = -p.real / np.abs(p)
            j = int(np.argmin(zeta)) if p.size else 0
            rows.append(
                [
                    f[k],
                    mag[k],
                    mag[0],
                    mag[-1],
                    float(np.mean(coh)),
                    float(np.abs(p[j])) if p.size else np.nan,
                    float(zeta[j]) if p.size else np.nan,
                    fit.fit_percent,
                ]
            )
        except (ValueError, np.linalg.LinAlgError) as exc:
            failed.append(i)
            last = str(exc)
            rows.append([np.nan] * len(FRF_FEATURES))
    _warn_failed("frf", failed, last)
    return pd.DataFrame(rows, columns=[f"frf/{n}" for n in FRF_FEATURES])


# ----------------------------------------------------------------------------- hw
def _camel(name: str) -> str:
    return "".join(part[:1].upper() + part[1:] for part in name.split("_"))


def hw_feature_names(
    input_nl: str | None = None,
    output_nl: str | None = "saturation",
    nb: int = 2,
    nf: int = 2,
) -> list[str]:
    """Indicator names of the ``hw`` group for a model structure.

    Examples
    --------
    >>> from pdmkit.features._model_features import hw_feature_names
    >>> hw_feature_names()
    ['B0', 'B1', 'F1', 'F2', 'OutLower', 'OutUpper', 'FitPercent']
    """
    names = [f"in_{k}" for k in nonlinearity(input_nl, "input_nl").param_names]
    names += [f"b{i}" for i in range(nb)] + [f"f{i + 1}" for i in range(nf)]
    names += [f"out_{k}" for k in nonlinearity(output_nl, "output_nl").param_names]
    return [_camel(n) for n in names] + ["FitPercent"]


def hw_features(
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    *,
    input_nl: str | None = None,
    output_nl: str | None = "saturation",
    nb: int = 2,
    nf: int = 2,
    nk: int = 1,
    initial: str = "steady",
) -> pd.DataFrame:
    """Hammerstein-Wiener coefficients per member (group ``"hw"``; Voronin, 8.2.1).

    One :class:`~pdmkit.models.ident._hammerstein.HammersteinWiener` per member; the
    indicators are its coefficients (input nonlinearity, ``B``, ``F``, output
    nonlinearity) and ``FitPercent``. The default structure suits a two-level command
    and a bounded stroke: no input nonlinearity, output saturation, records starting at
    rest under their first command (``initial="steady"``). ``fs`` is only checked (the
    model is in samples); decimate first so that the dynamics span a few samples.

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.features._model_features import hw_features
    >>> u = np.sign(np.sin(np.linspace(0, 12, 600)))
    >>> y = np.clip(ss.lfilter([0, 0.2], [1, -0.9], u), -1.5, 1.5)
    >>> t = hw_features(u, y, fs=100.0, nb=1, nf=1)
    >>> round(float(t["hw/F1"].iloc[0]), 2), round(float(t["hw/OutUpper"].iloc[0]), 2)
    (-0.9, 1.5)
    """
    check_fs(fs)
    u, y = _pair(u, y, "hw")
    names = hw_feature_names(input_nl, output_nl, nb, nf)
    rows, failed, last = [], [], ""
    for i in range(y.shape[0]):
        try:
            m = HammersteinWiener(
                input_nl, output_nl, nb=nb, nf=nf, nk=nk, initial=initial
            ).fit(u[i], y[i])
            rows.append([*m.coef_, m.fit_percent_])
        except (ValueError, np.linalg.LinAlgError) as exc:
            failed.append(i)
            last = str(exc)
            rows.append([np.nan] * len(names))
    _warn_failed("hw", failed, last)
    return pd.DataFrame(rows, columns=[f"hw/{n}" for n in names])


# ----------------------------------------------------------------------------- fractional
def fractional_features(
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    *,
    nperseg: int | None = None,
    fmax: float | None = None,
) -> pd.DataFrame:
    """Fractional-model parameters per member (group ``"fractional"``).

    ``A, Alpha, B, Beta, C`` of ``1/(a s^alpha + b s^beta + c)`` fitted to the member's
    empirical transfer function (:func:`~pdmkit.models.frequency.fit_fractional_tf`,
    frequency domain), and the relative fit ``Error``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FractionalTF
    >>> from pdmkit.features._model_features import fractional_features
    >>> u = np.random.default_rng(0).normal(size=4000)
    >>> y = FractionalTF.seed004(0.05, 1.5, 0.2, 0.5, 1.0).simulate(u, 0.01)
    >>> t = fractional_features(u, y, fs=100.0)
    >>> round(float(t["fractional/Alpha"].iloc[0]), 1)
    1.5
    """
    fs = check_fs(fs)
    u, y = _pair(u, y, "fractional")
    rows, failed, last = [], [], ""
    for i in range(y.shape[0]):
        try:
            fit = fit_fractional_tf(u[i], y[i], fs, nperseg=nperseg, fmax=fmax)
            rows.append([fit.a, fit.alpha, fit.b, fit.beta, fit.c, fit.error])
        except (ValueError, np.linalg.LinAlgError) as exc:
            failed.append(i)
            last = str(exc)
            rows.append([np.nan] * len(FRACTIONAL_FEATURES))
    _warn_failed("fractional", failed, last)
    return pd.DataFrame(rows, columns=[f"fractional/{n}" for n in FRACTIONAL_FEATURES])


# ------------------------------------------------------------------ extract hooks
def resolve_model_options(group: str, n_members: int, n_samples: int, **given) -> dict:
    """Check a model group's options for :func:`pdmkit.features.extract`.

    ``<group>_input`` is required: an array ``(n_samples,)`` shared by all members or
    ``(n_members, n_samples)``. Returns the settings without the group prefix.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.features._model_features import resolve_model_options
    >>> s = resolve_model_options("hw", 3, 100, hw_input=np.zeros(100))
    >>> s["input"].shape, s["nb"]
    ((3, 100), 2)
    """
    if group not in MODEL_GROUP_OPTIONS:
        raise DataError(
            f"unknown model group {group!r}; known: {list(MODEL_GROUP_OPTIONS)}."
        )
    opts = {**MODEL_GROUP_OPTIONS[group], **given}
    unknown = set(given) - set(MODEL_GROUP_OPTIONS[group])
    if unknown:
        raise DataError(f"{group}: unknown options {sorted(unknown)}.")
    settings = {k[len(group) + 1 :]: v for k, v in opts.items()}
    u = _member_inputs(settings["input"], n_members, n_samples, f"{group}_input")
    settings["input"] = u
    return settings


def model_feature_names(group: str, settings: dict) -> list[str]:
    """Indicator names (without the group prefix) for resolved settings."""
    if group == "frf":
        return list(FRF_FEATURES)
    if group == "fractional":
        return list(FRACTIONAL_FEATURES)
    return hw_feature_names(
        settings["input_nl"], settings["output_nl"], settings["nb"], settings["nf"]
    )


def _model_feature_rows(
    group: str, x: np.ndarray, fs: float, settings: dict, rows: slice
) -> dict[str, np.ndarray]:
    """Rows ``rows`` of a model group for ``extract``: name -> values."""
    compute = {"frf": frf_features, "hw": hw_features, "fractional": fractional_features}
    options = {k: v for k, v in settings.items() if k != "input"}
    df = compute[group](settings["input"][rows], x, fs, **options)
    return {c.split("/", 1)[1]: df[c].to_numpy() for c in df.columns}
