"""Rolling-bearing defect frequencies and envelope analysis (group ``"envelope"``).

A local defect on a race or a ball makes the rolling elements strike it at a fixed rate;
each strike rings the structure's resonances. Band-pass filtering around a resonance,
taking the Hilbert envelope and its spectrum shows lines at the strike rate and its
harmonics (Randall & Antoni, *Rolling element bearing diagnostics - a tutorial*, MSSP
2011). For shaft frequency ``f``, ``n`` balls of diameter ``d`` on pitch diameter ``D``
and contact angle ``phi`` (``r = d / D * cos(phi)``):

- ``FTF = f / 2 * (1 - r)`` (cage, fundamental train frequency)
- ``BPFO = n * f / 2 * (1 - r)`` (ball pass, outer race)
- ``BPFI = n * f / 2 * (1 + r)`` (ball pass, inner race)
- ``BSF = D / (2 d) * f * (1 - r**2)`` (ball spin; a ball defect strikes both races per
  spin revolution, so ball faults show at ``2 * BSF``, reported as ``BSFx2``)
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import numpy as np
import scipy.fft
import scipy.signal
from numpy.typing import ArrayLike

from pdmkit.errors import DataError
from pdmkit.features._common import check_finite, check_fs, from_rows, to_rows

__all__ = [
    "BEARINGS",
    "CWRU_DRIVE_END",
    "CWRU_FAN_END",
    "DEFECT_FREQUENCIES",
    "IMS_ZA_2115",
    "BearingGeometry",
    "EnvelopeSpectrum",
    "bearing_frequencies",
    "envelope_features",
    "envelope_spectrum",
]

_INCH = 0.0254  # m

#: Defect-frequency keys the envelope group reports, in column order.
DEFECT_FREQUENCIES = ("BPFO", "BPFI", "BSFx2", "FTF")


def bearing_frequencies(
    shaft_hz: float,
    n_balls: int,
    ball_diameter: float,
    pitch_diameter: float,
    contact_angle_deg: float = 0.0,
) -> dict[str, float]:
    """Characteristic defect frequencies of a rolling-element bearing.

    Parameters
    ----------
    shaft_hz : float
        Shaft rotation frequency in Hz (rpm / 60), inner race turning, outer race fixed.
    n_balls : int
        Number of rolling elements.
    ball_diameter, pitch_diameter : float
        Rolling-element and pitch diameters, in the same unit (metres inside pdmkit).
    contact_angle_deg : float, default 0
        Contact angle in degrees (0 for a deep-groove ball bearing under radial load).

    Returns
    -------
    dict
        ``BPFO``, ``BPFI``, ``BSF``, ``BSFx2`` (= 2 BSF, the ball-defect strike rate)
        and ``FTF``, in Hz.

    Examples
    --------
    SKF 6205-2RS JEM, the drive-end bearing of the CWRU rig, at 1797 rpm; the CWRU
    Bearing Data Center lists 5.4152, 3.5848, 4.7135 (= 2 BSF) and 0.39828 times the
    shaft speed:

    >>> f = bearing_frequencies(1797 / 60, 9, 0.3126, 1.537)
    >>> {k: round(v, 1) for k, v in f.items()}
    {'BPFO': 107.4, 'BPFI': 162.2, 'BSF': 70.6, 'BSFx2': 141.2, 'FTF': 11.9}
    """
    shaft = float(shaft_hz)
    if not np.isfinite(shaft) or shaft <= 0:
        raise DataError(
            f"shaft_hz must be a positive rotation frequency in Hz, got {shaft_hz!r}"
        )
    _check_geometry(n_balls, ball_diameter, pitch_diameter, contact_angle_deg)
    r = ball_diameter / pitch_diameter * np.cos(np.deg2rad(contact_angle_deg))
    bsf = pitch_diameter / (2.0 * ball_diameter) * shaft * (1.0 - r * r)
    return {
        "BPFO": float(n_balls * shaft / 2.0 * (1.0 - r)),
        "BPFI": float(n_balls * shaft / 2.0 * (1.0 + r)),
        "BSF": float(bsf),
        "BSFx2": float(2.0 * bsf),
        "FTF": float(shaft / 2.0 * (1.0 - r)),
    }


def _check_geometry(n_balls, ball_diameter, pitch_diameter, contact_angle_deg) -> None:
    if (
        isinstance(n_balls, bool)
        or not isinstance(n_balls, int | np.integer)
        or n_balls < 1
    ):
        raise DataError(f"n_balls must be a positive integer, got {n_balls!r}")
    for name, value in (
        ("ball_diameter", ball_diameter),
        ("pitch_diameter", pitch_diameter),
    ):
        if not (
            isinstance(value, int | float | np.number) and np.isfinite(value) and value > 0
        ):
            raise DataError(f"{name} must be a positive length in metres, got {value!r}")
    if ball_diameter >= pitch_diameter:
        raise DataError(
            f"ball_diameter ({ball_diameter}) must be smaller than pitch_diameter "
            f"({pitch_diameter}); did you swap them?"
        )
    if not (np.isfinite(contact_angle_deg) and 0 <= contact_angle_deg < 90):
        raise DataError(
            f"contact_angle_deg must be in [0, 90) degrees, got {contact_angle_deg!r}"
        )


@dataclass(frozen=True)
class BearingGeometry:
    """Geometry of a rolling-element bearing (SI units: metres, degrees for the angle).

    Parameters
    ----------
    n_balls : int
        Number of rolling elements.
    ball_diameter : float
        Rolling-element diameter in m.
    pitch_diameter : float
        Pitch (cage) diameter in m.
    contact_angle_deg : float, default 0
        Contact angle in degrees.

    Examples
    --------
    >>> from pdmkit.features import BearingGeometry
    >>> b = BearingGeometry(n_balls=9, ball_diameter=7.94e-3, pitch_diameter=39.04e-3)
    >>> round(b.frequencies(30.0)["BPFO"], 2)
    107.54
    """

    n_balls: int
    ball_diameter: float
    pitch_diameter: float
    contact_angle_deg: float = 0.0

    def __post_init__(self) -> None:
        _check_geometry(
            self.n_balls, self.ball_diameter, self.pitch_diameter, self.contact_angle_deg
        )

    @classmethod
    def parse(cls, spec: str | BearingGeometry) -> BearingGeometry:
        """A bearing from text: a catalogue name, or its geometry with units.

        ``spec`` is either a name from :meth:`catalogue` (case, spaces and hyphens do
        not matter: ``"6205"``, ``"SKF 6205-2RS JEM"``, ``"cwru-de"``, ``"ZA-2115"``,
        ``"ims"``) or ``KEY=VALUE`` pairs separated by commas:

        - ``n_balls`` (also ``n``, ``balls``, ``n_rollers``): number of rolling
          elements;
        - ``ball_d`` (``ball_diameter``, ``d``) and ``pitch_d`` (``pitch_diameter``,
          ``D``): lengths with a unit, ``mm``, ``cm``, ``m`` or ``in`` (``7.94mm``,
          ``0.3126in``); a bare number is refused, as it could be any of them;
        - ``angle`` (``contact_angle``, ``contact_angle_deg``): degrees, default 0
          (``15.17`` or ``15.17deg``).

        Lengths are converted to metres (SI inside).

        Parameters
        ----------
        spec : str or BearingGeometry
            The text (a BearingGeometry is returned as it is).

        Returns
        -------
        BearingGeometry

        Raises
        ------
        pdmkit.errors.DataError
            An unknown name or key, a length without unit, a missing key, or a
            geometry :class:`BearingGeometry` refuses; the message names the part.

        Examples
        --------
        >>> from pdmkit.features import BearingGeometry
        >>> b = BearingGeometry.parse("n_balls=9,ball_d=7.94mm,pitch_d=39.04mm,angle=0")
        >>> b.n_balls, round(b.ball_diameter, 5), round(b.pitch_diameter, 5)
        (9, 0.00794, 0.03904)
        >>> BearingGeometry.parse("SKF 6205-2RS JEM") == BearingGeometry.parse("6205")
        True
        >>> round(BearingGeometry.parse("ZA-2115").frequencies(2000 / 60)["BPFO"], 1)
        236.4
        """
        if isinstance(spec, BearingGeometry):
            return spec
        if not isinstance(spec, str) or not spec.strip():
            raise DataError(
                f"bearing must be a catalogue name ({', '.join(BEARINGS)}) or "
                f"n_balls=..,ball_d=..mm,pitch_d=..mm[,angle=..]; got {spec!r}"
            )
        if "=" not in spec:
            return _named_bearing(spec)
        return _bearing_from_pairs(spec)

    @staticmethod
    def catalogue():
        """The named bearings :meth:`parse` knows, as a table (lengths in mm).

        Returns
        -------
        pandas.DataFrame
            One row per bearing: ``name``, ``n_balls``, ``ball_d_mm``, ``pitch_d_mm``,
            ``angle_deg``, ``aliases`` and ``source``.

        Examples
        --------
        >>> from pdmkit.features import BearingGeometry
        >>> BearingGeometry.catalogue()[["name", "n_balls"]].to_dict("list")
        {'name': ['SKF 6205-2RS JEM', 'SKF 6203-2RS JEM', 'Rexnord ZA-2115'], 'n_balls': [9, 8, 16]}
        """  # noqa: E501
        import pandas as pd

        return pd.DataFrame(
            [
                {
                    "name": name,
                    "n_balls": b.n_balls,
                    "ball_d_mm": round(b.ball_diameter * 1e3, 4),
                    "pitch_d_mm": round(b.pitch_diameter * 1e3, 4),
                    "angle_deg": b.contact_angle_deg,
                    "aliases": ", ".join(aliases),
                    "source": source,
                }
                for name, (b, aliases, source) in BEARINGS.items()
            ]
        )

    def frequencies(self, shaft_hz: float) -> dict[str, float]:
        """Defect frequencies at a shaft speed (see :func:`bearing_frequencies`).

        Examples
        --------
        >>> from pdmkit.features import CWRU_DRIVE_END
        >>> round(CWRU_DRIVE_END.frequencies(1797 / 60)["BPFI"], 1)
        162.2
        """
        return bearing_frequencies(
            shaft_hz,
            self.n_balls,
            self.ball_diameter,
            self.pitch_diameter,
            self.contact_angle_deg,
        )


#: SKF 6205-2RS JEM deep-groove ball bearing at the drive end of the CWRU test rig
#: (9 balls of 0.3126 in on a 1.537 in pitch diameter; CWRU Bearing Data Center).
CWRU_DRIVE_END = BearingGeometry(
    n_balls=9, ball_diameter=0.3126 * _INCH, pitch_diameter=1.537 * _INCH
)
#: SKF 6203-2RS JEM at the fan end of the CWRU rig (8 balls, 0.2656 in, 1.122 in).
CWRU_FAN_END = BearingGeometry(
    n_balls=8, ball_diameter=0.2656 * _INCH, pitch_diameter=1.122 * _INCH
)
#: Rexnord ZA-2115 double-row roller bearing of the IMS run-to-failure rig (16 rollers
#: per row of 0.331 in on a 2.815 in pitch diameter, contact angle 15.17 deg).
IMS_ZA_2115 = BearingGeometry(
    n_balls=16,
    ball_diameter=0.331 * _INCH,
    pitch_diameter=2.815 * _INCH,
    contact_angle_deg=15.17,
)

#: Named bearings :meth:`BearingGeometry.parse` knows: name -> (geometry, aliases,
#: source). The CWRU pair: CWRU Bearing Data Center, "Bearing information" (ball and
#: pitch diameters in inches; its defect frequencies as multiples of the shaft speed,
#: BPFO 3.5848 drive end and 3.0530 fan end, give 9 and 8 balls). The IMS bearing:
#: J. Lee, H. Qiu, G. Yu, J. Lin, *Bearing data set*, IMS, University of Cincinnati,
#: NASA Prognostics Data Repository (2007), and H. Qiu, J. Lee, J. Lin, G. Yu,
#: *Wavelet filter-based weak signature detection method and its application on
#: rolling element bearing prognostics*, J. Sound Vib. 289 (2006) 1066-1090, which
#: gives BPFO 236.4 Hz, BPFI 296.9 Hz at 2000 rpm.
BEARINGS: dict[str, tuple[BearingGeometry, tuple[str, ...], str]] = {
    "SKF 6205-2RS JEM": (
        CWRU_DRIVE_END,
        ("6205", "6205-2RS", "SKF 6205", "cwru-de", "cwru-drive-end"),
        "CWRU Bearing Data Center (drive end)",
    ),
    "SKF 6203-2RS JEM": (
        CWRU_FAN_END,
        ("6203", "6203-2RS", "SKF 6203", "cwru-fe", "cwru-fan-end"),
        "CWRU Bearing Data Center (fan end)",
    ),
    "Rexnord ZA-2115": (
        IMS_ZA_2115,
        ("ZA-2115", "ZA2115", "ims"),
        "IMS bearing data set readme; Qiu et al., J. Sound Vib. 2006",
    ),
}

#: Metres per unit of a length in a bearing text.
_LENGTH_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": _INCH, '"': _INCH}
_BEARING_KEYS = {
    "n_balls": "n_balls",
    "n": "n_balls",
    "balls": "n_balls",
    "n_rollers": "n_balls",
    "ball_d": "ball_diameter",
    "ball_diameter": "ball_diameter",
    "d": "ball_diameter",
    "pitch_d": "pitch_diameter",
    "pitch_diameter": "pitch_diameter",
    "D": "pitch_diameter",
    "angle": "contact_angle_deg",
    "contact_angle": "contact_angle_deg",
    "contact_angle_deg": "contact_angle_deg",
}


def _squash(name: str) -> str:
    return "".join(ch for ch in name.lower() if ch.isalnum())


def _named_bearing(spec: str) -> BearingGeometry:
    wanted = _squash(spec)
    for name, (geometry, aliases, _) in BEARINGS.items():
        if wanted in {_squash(a) for a in (name, *aliases)}:
            return geometry
    import difflib

    known = [a for name, (_, aliases, _) in BEARINGS.items() for a in (name, *aliases)]
    close = difflib.get_close_matches(spec, known, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise DataError(
        f"unknown bearing {spec!r}{hint} (known: {', '.join(BEARINGS)}); or give its "
        "geometry, e.g. n_balls=9,ball_d=7.94mm,pitch_d=39.04mm,angle=0"
    )


def _bearing_length(key: str, text: str) -> float:
    import re

    m = re.fullmatch(
        r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*(mm|cm|m|in|\")?\s*", text
    )
    if m is None:
        raise DataError(
            f"bearing {key}={text!r}: expected a length with a unit, e.g. 7.94mm, "
            "0.3126in or 0.00794m"
        )
    if m[2] is None:
        raise DataError(
            f"bearing {key}={text!r} has no unit; write {text.strip()}mm, "
            f"{text.strip()}in or {text.strip()}m"
        )
    return float(m[1]) * _LENGTH_UNITS[m[2]]


def _bearing_from_pairs(spec: str) -> BearingGeometry:
    values: dict = {}
    for part in (p.strip() for p in spec.split(",")):
        if not part:
            continue
        key, sep, text = (x.strip() for x in part.partition("="))
        field = _BEARING_KEYS.get(key) or _BEARING_KEYS.get(key.lower())
        if not sep or field is None:
            import difflib

            close = difflib.get_close_matches(key, list(_BEARING_KEYS), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise DataError(
                f"bearing: unknown part {part!r}{hint} (expected n_balls=N, "
                "ball_d=LENGTH, pitch_d=LENGTH and optionally angle=DEGREES)"
            )
        if field in values:
            raise DataError(f"bearing: {key!r} is given twice in {spec!r}")
        if field == "n_balls":
            try:
                values[field] = int(text)
            except ValueError:
                raise DataError(
                    f"bearing {key}={text!r}: expected a whole number of rolling elements"
                ) from None
        elif field == "contact_angle_deg":
            number = text.lower().removesuffix("deg").removesuffix("°").strip()
            try:
                values[field] = float(number)
            except ValueError:
                raise DataError(
                    f"bearing {key}={text!r}: expected a contact angle in degrees"
                ) from None
        else:
            values[field] = _bearing_length(key, text)
    missing = [k for k in ("n_balls", "ball_diameter", "pitch_diameter") if k not in values]
    if missing:
        short = {
            "n_balls": "n_balls",
            "ball_diameter": "ball_d",
            "pitch_diameter": "pitch_d",
        }
        raise DataError(
            f"bearing {spec!r} lacks {', '.join(short[k] for k in missing)}; give "
            "n_balls=N,ball_d=LENGTH,pitch_d=LENGTH[,angle=DEGREES]"
        )
    return BearingGeometry(**values)


@dataclass(frozen=True)
class EnvelopeSpectrum:
    """One-sided amplitude spectrum of the Hilbert envelope.

    Attributes
    ----------
    frequencies : ndarray, shape (n_bins,)
        Bin frequencies in Hz, ``k * fs / n_samples``.
    amplitude : ndarray, shape (..., n_bins)
        Amplitude of each envelope line (a sinusoidal modulation of the envelope with
        amplitude ``a`` shows as ``a``), one row per member.
    fs : float
        Sampling rate of the signal in Hz.
    band : tuple of float or None
        The band-pass applied before the envelope, in Hz.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.features import envelope_spectrum
    >>> fs = 10_000.0
    >>> t = np.arange(10_000) / fs
    >>> x = (1 + 0.5 * np.cos(2 * np.pi * 40 * t)) * np.sin(2 * np.pi * 2000 * t)
    >>> env = envelope_spectrum(x, fs, band=(1000, 3000))
    >>> float(env.frequencies[env.amplitude.argmax()])
    40.0
    """

    frequencies: np.ndarray
    amplitude: np.ndarray
    fs: float
    band: tuple[float, float] | None = None

    def to_pandas(self):
        """Return a DataFrame indexed by frequency, one amplitude column per member.

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.features import envelope_spectrum
        >>> envelope_spectrum(np.random.default_rng(0).normal(size=(2, 64)), 64.0
        ...                   ).to_pandas().shape
        (33, 2)
        """
        import pandas as pd

        amp = np.asarray(self.amplitude)
        index = pd.Index(self.frequencies, name="frequency_hz")
        if amp.ndim == 1:
            return pd.DataFrame({"amplitude": amp}, index=index)
        amp2 = amp.reshape(-1, amp.shape[-1])
        return pd.DataFrame(amp2.T, index=index, columns=pd.RangeIndex(len(amp2)))

    def plot(self, ax=None, *, max_hz: float | None = None, markers: dict | None = None):
        """Plot the envelope spectrum (first member of a batch).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw; a new figure when omitted.
        max_hz : float, optional
            Upper frequency limit of the plot.
        markers : dict of str -> float, optional
            Frequencies to mark with dashed lines, e.g. ``bearing.frequencies(shaft)``.

        Returns
        -------
        matplotlib.axes.Axes

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.features import envelope_spectrum
        >>> env = envelope_spectrum(np.random.default_rng(0).normal(size=256), 256.0)
        >>> env.plot(max_hz=50, markers={"BPFO": 10.0}).get_xlabel()
        'Frequency (Hz)'
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        amp = np.asarray(self.amplitude).reshape(-1, len(self.frequencies))[0]
        ax.plot(self.frequencies, amp, lw=0.8)
        for i, (name, freq) in enumerate((markers or {}).items()):
            ax.axvline(freq, ls="--", lw=0.8, color=f"C{i + 1}", label=name)
        if markers:
            ax.legend(loc="upper right")
        ax.set_xlim(0, max_hz if max_hz is not None else self.frequencies[-1])
        ax.set_xlabel("Frequency (Hz)")
        ax.set_ylabel("Envelope amplitude")
        title = "Envelope spectrum"
        if self.band is not None:
            title += f" (band {self.band[0]:g}-{self.band[1]:g} Hz)"
        ax.set_title(title)
        return ax


def _check_band(band, fs: float) -> tuple[float, float] | None:
    if band is None:
        return None
    try:
        lo, hi = (float(v) for v in band)
    except (TypeError, ValueError):
        raise DataError(
            f"band must be a (lo, hi) pair in Hz or None, got {band!r}"
        ) from None
    nyq = fs / 2.0
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise DataError(f"band {band!r}: expected 0 <= lo < hi in Hz")
    if lo >= nyq:
        raise DataError(
            f"band {band!r}: its lower edge must lie below the Nyquist frequency "
            f"{nyq:g} Hz (fs={fs:g} Hz)"
        )
    return lo, hi


def _envelope_rows(
    x: np.ndarray, fs: float, band: tuple[float, float] | None, order: int = 4
) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and one-sided envelope amplitude spectrum of each row."""
    n = x.shape[1]
    if band is not None:
        lo, hi = band
        nyq = fs / 2.0
        if lo > 0 and hi < nyq:
            sos = scipy.signal.butter(
                order, (lo, hi), btype="bandpass", fs=fs, output="sos"
            )
        elif lo > 0:
            sos = scipy.signal.butter(order, lo, btype="highpass", fs=fs, output="sos")
        elif hi < nyq:
            sos = scipy.signal.butter(order, hi, btype="lowpass", fs=fs, output="sos")
        else:
            sos = None
        if sos is not None:
            padlen = min(3 * (2 * len(sos) + 1), n - 1)
            x = scipy.signal.sosfiltfilt(sos, x, axis=1, padlen=padlen)
    env = np.abs(scipy.signal.hilbert(x, axis=1))
    env -= env.mean(axis=1, keepdims=True)
    spec = np.abs(scipy.fft.rfft(env, axis=1)) / n
    if n % 2 == 0:
        spec[:, 1:-1] *= 2.0
    else:
        spec[:, 1:] *= 2.0
    return np.fft.rfftfreq(n, 1.0 / fs), spec


def envelope_spectrum(
    x: ArrayLike,
    fs: float,
    band: tuple[float, float] | None = None,
    *,
    axis: int = -1,
) -> EnvelopeSpectrum:
    """Envelope spectrum: band-pass, Hilbert envelope, amplitude spectrum.

    Parameters
    ----------
    x : array_like
        Signal samples along ``axis`` (1-D, or 2-D ``(members, samples)``).
    fs : float
        Sampling rate in Hz.
    band : (lo, hi), optional
        Band in Hz to keep before the envelope (4th-order Butterworth, zero phase); pick
        a structural resonance that the bearing impacts excite. ``lo = 0`` means
        low-pass, ``hi >= fs/2`` high-pass. Default: no filter.
    axis : int, default -1
        Axis holding the samples.

    Returns
    -------
    EnvelopeSpectrum
        ``.frequencies`` (Hz) and ``.amplitude`` (batch shape + bins); the envelope's mean
        is removed, so the DC line is 0.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.features import envelope_spectrum
    >>> fs = 20_000.0
    >>> t = np.arange(20_000) / fs
    >>> x = np.sin(2 * np.pi * 3000 * t) * (1 + np.cos(2 * np.pi * 100 * t))
    >>> env = envelope_spectrum(x, fs)
    >>> round(float(env.amplitude[env.frequencies == 100.0][0]), 2)
    1.0
    """
    fs = check_fs(fs)
    band = _check_band(band, fs)
    rows, batch_shape = to_rows(x, axis, "x")
    check_finite(rows, "x")
    freqs, spec = _envelope_rows(rows, fs, band)
    amp = spec[0] if batch_shape == () else spec.reshape(*batch_shape, spec.shape[1])
    return EnvelopeSpectrum(frequencies=freqs, amplitude=amp, fs=fs, band=band)


def envelope_feature_names(n_harmonics: int = 3) -> list[str]:
    """Column names of the envelope group, in table order."""
    return [f"{d}_{h}" for d in DEFECT_FREQUENCIES for h in range(1, n_harmonics + 1)]


def resolve_envelope_options(
    fs: float,
    *,
    bearing=None,
    shaft_hz=None,
    band=None,
    tolerance: float = 0.02,
    n_harmonics: int = 3,
) -> dict:
    """Validate the envelope options; return them resolved."""
    if bearing is None or shaft_hz is None:
        missing = [
            n for n, v in (("bearing", bearing), ("shaft_hz", shaft_hz)) if v is None
        ]
        raise DataError(
            f"the envelope group needs the bearing geometry and the shaft speed; missing "
            f"{' and '.join(missing)}. Pass bearing=BearingGeometry(...) (e.g. "
            "pdmkit.features.CWRU_DRIVE_END) and shaft_hz=rpm / 60"
        )
    if isinstance(bearing, str):
        bearing = BearingGeometry.parse(bearing)
    if not callable(getattr(bearing, "frequencies", None)):
        raise DataError(
            "bearing must be a pdmkit.features.BearingGeometry, got "
            f"{type(bearing).__name__}"
        )
    shaft = np.asarray(shaft_hz, dtype=float)
    if shaft.ndim > 1 or not np.all(np.isfinite(shaft)) or np.any(shaft <= 0):
        raise DataError(
            "shaft_hz must be a positive shaft frequency in Hz (a number, or one per "
            f"member), got {shaft_hz!r}"
        )
    if not (isinstance(tolerance, Real) and 0 <= tolerance < 0.5):
        raise DataError(
            "tolerance must be the half-width of each band as a fraction of its centre "
            f"frequency, in [0, 0.5), got {tolerance!r}"
        )
    if isinstance(n_harmonics, bool) or not isinstance(n_harmonics, int) or n_harmonics < 1:
        raise DataError(
            f"envelope n_harmonics must be a positive integer, got {n_harmonics!r}"
        )
    return {
        "bearing": bearing,
        "shaft_hz": shaft,
        "band": _check_band(band, fs),
        "tolerance": float(tolerance),
        "n_harmonics": n_harmonics,
    }


def _envelope_feature_rows(
    x: np.ndarray, fs: float, options: dict
) -> dict[str, np.ndarray]:
    m = x.shape[0]
    freqs, spec = _envelope_rows(x, fs, options["band"])
    shaft = np.broadcast_to(options["shaft_hz"], (m,))
    if shaft.shape != (m,):
        raise DataError(f"shaft_hz has {options['shaft_hz'].size} values for {m} members")
    df = freqs[1] - freqs[0] if len(freqs) > 1 else fs
    # defect frequencies scale with the shaft speed: compute them at 1 Hz once
    per_hz = options["bearing"].frequencies(1.0)
    out = {}
    for name in DEFECT_FREQUENCIES:
        for h in range(1, options["n_harmonics"] + 1):
            centre = h * per_hz[name] * shaft  # (m,)
            half = np.maximum(options["tolerance"] * centre, df)
            if np.all(centre == centre[0]):  # one speed for all: slice the bins once
                sel = np.abs(freqs - centre[0]) <= half[0]
                amp = spec[:, sel].max(axis=1) if sel.any() else np.full(m, np.nan)
            else:
                sel = np.abs(freqs[None, :] - centre[:, None]) <= half[:, None]
                amp = np.where(sel, spec, -np.inf).max(axis=1)
                amp = np.where(np.isfinite(amp), amp, np.nan)
            out[f"{name}_{h}"] = np.where(centre <= fs / 2.0, amp, np.nan)
    return out


def envelope_features(
    x: ArrayLike,
    fs: float,
    bearing: BearingGeometry,
    shaft_hz: float,
    *,
    band: tuple[float, float] | None = None,
    tolerance: float = 0.02,
    n_harmonics: int = 3,
    axis: int = -1,
) -> dict[str, np.ndarray | float]:
    """Envelope-spectrum amplitude at the bearing defect frequencies and harmonics.

    For each defect frequency ``F`` in ``BPFO, BPFI, BSFx2, FTF`` and each harmonic
    ``h = 1..n_harmonics`` the feature ``<F>_<h>`` is the largest envelope-spectrum
    amplitude within ``h F (1 +- tolerance)`` (at least the nearest bin on each side).
    A band above ``fs/2`` gives NaN.

    Parameters
    ----------
    x : array_like
        Signal samples along ``axis`` (1-D, or 2-D ``(members, samples)``).
    fs : float
        Sampling rate in Hz.
    bearing : BearingGeometry
        The monitored bearing, e.g. :data:`CWRU_DRIVE_END`.
    shaft_hz : float or array_like
        Shaft speed in Hz (rpm / 60): one number, or one per member.
    band : (lo, hi), optional
        Band-pass (Hz) applied before the envelope; see :func:`envelope_spectrum`.
    tolerance : float, default 0.02
        Half-width of each band as a fraction of its centre frequency (slip and speed
        errors move the lines by a percent or two).
    n_harmonics : int, default 3
        Harmonics per defect frequency.
    axis : int, default -1
        Axis holding the samples.

    Returns
    -------
    dict of str -> float or ndarray
        ``BPFO_1..BPFO_n, BPFI_1.., BSFx2_1.., FTF_1..``.

    Examples
    --------
    Impacts at the inner-race rate of the CWRU drive-end bearing, ringing a 3 kHz
    resonance:

    >>> import numpy as np
    >>> from pdmkit.features import CWRU_DRIVE_END, envelope_features
    >>> fs, shaft = 12_000.0, 1797 / 60
    >>> t = np.arange(24_000) / fs
    >>> bpfi = CWRU_DRIVE_END.frequencies(shaft)["BPFI"]
    >>> ring = np.exp(-800 * (t % (1 / bpfi))) * np.sin(2 * np.pi * 3000 * t)
    >>> f = envelope_features(ring, fs, CWRU_DRIVE_END, shaft, band=(2000, 4000))
    >>> max(("BPFO_1", "BPFI_1", "BSFx2_1", "FTF_1"), key=f.get)
    'BPFI_1'
    """
    fs = check_fs(fs)
    options = resolve_envelope_options(
        fs,
        bearing=bearing,
        shaft_hz=shaft_hz,
        band=band,
        tolerance=tolerance,
        n_harmonics=n_harmonics,
    )
    rows, batch_shape = to_rows(x, axis, "x")
    check_finite(rows, "x")
    shaft = options["shaft_hz"]
    if shaft.ndim == 1:
        if shaft.size != rows.shape[0]:
            raise DataError(
                f"shaft_hz has {shaft.size} values but x has {rows.shape[0]} members; "
                "pass one speed, or one per member"
            )
    out = _envelope_feature_rows(rows, fs, options)
    return {k: from_rows(v, batch_shape) for k, v in out.items()}
