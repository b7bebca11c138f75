"""The registry of indicator groups: one :class:`FeatureGroup` object per group.

A group says, in one place, everything :func:`pdmkit.features.extract`, the command
line's ``--option`` checks and help, and the resumable runs need to know about it: its
options (one spelling, with their defaults), how it checks them against the data, the
names of the indicators it computes and how it computes them for a chunk of members.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from pdmkit._checks import check_int
from pdmkit.errors import DataError
from pdmkit.features._ar import (
    AR_DEFAULT_ORDER,
    _ar_feature_rows,
    ar_feature_names,
    resolve_ar_options,
)
from pdmkit.features._cycle import (
    CYCLE_LEVELS,
    EVENT_WINDOWS,
    _cycle_feature_rows,
    cycle_feature_names,
    resolve_cycle_options,
)
from pdmkit.features._envelope import (
    _envelope_feature_rows,
    envelope_feature_names,
    resolve_envelope_options,
)
from pdmkit.features._model_features import (
    MODEL_GROUP_OPTIONS,
    _model_feature_rows,
    model_feature_names,
    resolve_model_options,
)
from pdmkit.features._spectral import (
    _spectral_rows,
    resolve_spectral_options,
    spectral_feature_names,
)
from pdmkit.features._stats import (
    HARMONIC_FEATURES,
    STATS_FEATURES,
    _harmonic_rows,
    _stats_rows,
)

__all__ = [
    "FEATURE_GROUPS",
    "GROUPS",
    "FeatureGroup",
    "check_group_options",
    "check_groups",
    "group_of_option",
]

#: ``resolve(given options, n_samples, n_members, fs) -> settings``
Resolver = Callable[[dict, int, int, float], dict]
#: ``compute(chunk (members, samples), fs, settings, rows of the chunk) -> {name: values}``
Computer = Callable[[np.ndarray, float, dict, slice], Mapping[str, np.ndarray]]


@dataclass(frozen=True)
class FeatureGroup:
    """One group of condition indicators: its options, its indicators, its computation.

    Parameters
    ----------
    name : str
        The group's name (``"stats"``, ``"spectral"``, ...): the middle part of its
        columns ``<signal>/<group>/<Feature>``.
    description : str
        One line: what the group measures.
    options : mapping
        The keyword options :func:`~pdmkit.features.extract` takes for this group, with
        their defaults; each option name belongs to exactly one group.
    resolve : callable
        ``resolve(given, n_samples, n_members, fs) -> settings``: checks the options
        given (a subset of ``options``) against the data and returns the settings
        :attr:`feature_names` and :attr:`compute` use.
    feature_names : callable
        ``feature_names(settings) -> list of str``: the indicators, in column order.
    compute : callable
        ``compute(x, fs, settings, rows) -> {feature: array (members,)}`` for a chunk
        ``x`` of shape ``(members, samples)``; ``rows`` is the chunk's slice of all
        members (for per-member settings such as one shaft speed per member).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.features import FEATURE_GROUPS
    >>> group = FEATURE_GROUPS["stats"]
    >>> settings = group.resolve({}, 1000, 2, 100.0)
    >>> group.feature_names(settings)[:3]
    ['Mean', 'Std', 'RMS']
    >>> x = np.ones((2, 1000))
    >>> group.compute(x, 100.0, settings, slice(0, 2))["RMS"]
    array([1., 1.])
    """

    name: str
    description: str
    options: Mapping[str, object]
    resolve: Resolver = field(repr=False)
    feature_names: Callable[[dict], list[str]] = field(repr=False)
    compute: Computer = field(repr=False)


# --------------------------------------------------------------------------- groups
def _resolve_harmonic(given: dict, n_samples: int, n_members: int, fs: float) -> dict:
    return {"n_harmonics": check_int(given.get("n_harmonics", 6), "n_harmonics", minimum=2)}


def _resolve_spectral(given: dict, n_samples: int, n_members: int, fs: float) -> dict:
    return resolve_spectral_options(n_samples, fs, name="signals", **given)


def _one_or_per_member(value: np.ndarray, option: str, n_members: int) -> None:
    if value.ndim == 1 and value.size != n_members:
        raise DataError(
            f"{option} has {value.size} values but signals has {n_members} members; "
            "pass one value, or one per member"
        )


def _resolve_envelope(given: dict, n_samples: int, n_members: int, fs: float) -> dict:
    resolved = resolve_envelope_options(
        fs,
        bearing=given.get("bearing"),
        shaft_hz=given.get("shaft_hz"),
        band=given.get("envelope_band"),
        tolerance=given.get("tolerance", 0.02),
        n_harmonics=given.get("envelope_harmonics", 3),
    )
    _one_or_per_member(resolved["shaft_hz"], "shaft_hz", n_members)
    return resolved


def _compute_envelope(x: np.ndarray, fs: float, settings: dict, rows: slice):
    if settings["shaft_hz"].ndim == 1:
        settings = {**settings, "shaft_hz": settings["shaft_hz"][rows]}
    return _envelope_feature_rows(x, fs, settings)


def _resolve_cycle(given: dict, n_samples: int, n_members: int, fs: float) -> dict:
    resolved = resolve_cycle_options(
        fs,
        period=given.get("cycle_period"),
        start=given.get("cycle_start", 0.0),
        phases=given.get("cycle_phases", (0.0, 0.5)),
        levels=given.get("cycle_levels", CYCLE_LEVELS),
        n_windows=given.get("cycle_windows", 8),
        event_windows=given.get("event_windows", EVENT_WINDOWS),
        prefix="cycle_",
    )
    for name in ("period", "start"):
        _one_or_per_member(resolved[name], f"cycle_{name}", n_members)
    return resolved


def _cycle_names(settings: dict) -> list[str]:
    return cycle_feature_names(
        settings["phases"],
        settings["levels"],
        settings["n_windows"],
        settings["event_windows"],
    )


def _compute_cycle(x: np.ndarray, fs: float, settings: dict, rows: slice):
    per_member = {
        name: settings[name][rows] if settings[name].ndim == 1 else settings[name]
        for name in ("period", "start")
    }
    return _cycle_feature_rows(x, fs, {**settings, **per_member})


def _model_group(name: str, description: str) -> FeatureGroup:
    def resolve(given: dict, n_samples: int, n_members: int, fs: float) -> dict:
        return resolve_model_options(name, n_members, n_samples, **given)

    def compute(x: np.ndarray, fs: float, settings: dict, rows: slice):
        return _model_feature_rows(name, x, fs, settings, rows)

    return FeatureGroup(
        name,
        description,
        MODEL_GROUP_OPTIONS[name],
        resolve,
        lambda settings: model_feature_names(name, settings),
        compute,
    )


_GROUP_LIST = (
    FeatureGroup(
        "stats",
        "time-domain statistics: mean, RMS, peak, kurtosis, crest/shape factors",
        {},
        lambda given, n_samples, n_members, fs: {},
        lambda settings: list(STATS_FEATURES),
        lambda x, fs, settings, rows: _stats_rows(x),
    ),
    FeatureGroup(
        "harmonic",
        "SINAD, SNR and THD in dB, as MATLAB computes them",
        {"n_harmonics": 6},
        _resolve_harmonic,
        lambda settings: list(HARMONIC_FEATURES),
        lambda x, fs, settings, rows: _harmonic_rows(x, fs, settings["n_harmonics"]),
    ),
    FeatureGroup(
        "spectral",
        "Welch-spectrum peaks, band powers and spectral shape",
        {
            "nperseg": None,
            "noverlap": None,
            "bands": None,
            "n_peaks": 5,
            "detrend": "constant",
            "frange": None,
            "welch": "scipy",
        },
        _resolve_spectral,
        lambda settings: spectral_feature_names(settings["n_peaks"], settings["bands"]),
        lambda x, fs, settings, rows: _spectral_rows(x, fs, settings),
    ),
    FeatureGroup(
        "envelope",
        "envelope-spectrum amplitudes at the bearing defect frequencies",
        {
            "bearing": None,
            "shaft_hz": None,
            "envelope_band": None,
            "tolerance": 0.02,
            "envelope_harmonics": 3,
        },
        _resolve_envelope,
        lambda settings: envelope_feature_names(settings["n_harmonics"]),
        _compute_envelope,
    ),
    FeatureGroup(
        "cycle",
        "per-stroke transitions, events and phase windows of a cyclic machine",
        {
            "cycle_period": None,
            "cycle_start": 0.0,
            "cycle_phases": (0.0, 0.5),
            "cycle_levels": CYCLE_LEVELS,
            "cycle_windows": 8,
            "event_windows": EVENT_WINDOWS,
        },
        _resolve_cycle,
        _cycle_names,
        _compute_cycle,
    ),
    FeatureGroup(
        "ar",
        "natural frequencies and damping of an AR model's poles, its fit",
        {"ar_order": AR_DEFAULT_ORDER},
        lambda given, n_samples, n_members, fs: resolve_ar_options(
            given.get("ar_order", AR_DEFAULT_ORDER), n_samples
        ),
        lambda settings: ar_feature_names(settings["order"]),
        lambda x, fs, settings, rows: _ar_feature_rows(x, fs, settings),
    ),
    _model_group("frf", "H1 frequency response from an input, and a rational fit to it"),
    _model_group("hw", "Hammerstein-Wiener model coefficients from an input"),
    _model_group("fractional", "fractional-order transfer function from an input"),
)

#: Every indicator group, by name, in the order :func:`extract` documents them.
FEATURE_GROUPS: dict[str, FeatureGroup] = {g.name: g for g in _GROUP_LIST}
#: The group names.
GROUPS: tuple[str, ...] = tuple(FEATURE_GROUPS)
_OPTION_GROUP = {opt: g.name for g in _GROUP_LIST for opt in g.options}
if len(_OPTION_GROUP) != sum(len(g.options) for g in _GROUP_LIST):  # pragma: no cover
    raise RuntimeError("an option name belongs to two feature groups")


# --------------------------------------------------------------------------- checks
def group_of_option(option: str) -> str:
    """Return the name of the group that takes ``option``.

    Examples
    --------
    >>> from pdmkit.features import group_of_option
    >>> group_of_option("ar_order")
    'ar'
    """
    try:
        return _OPTION_GROUP[option]
    except KeyError:
        raise DataError(f"{option!r} is no option of any feature group") from None


def check_groups(groups: str | Sequence[str]) -> tuple[str, ...]:
    """Return ``groups`` as a tuple of known group names (repeats dropped, order kept).

    Raises
    ------
    pdmkit.errors.DataError
        An unknown group (naming the known ones), or no group at all.

    Examples
    --------
    >>> from pdmkit.features import check_groups
    >>> check_groups(["stats", "spectral", "stats"])
    ('stats', 'spectral')
    """
    if isinstance(groups, str):
        groups = (groups,)
    try:
        groups = tuple(groups)
    except TypeError:
        raise DataError(
            f"groups must be a sequence of group names from {list(GROUPS)}, got {groups!r}"
        ) from None
    unknown = [g for g in groups if g not in FEATURE_GROUPS]
    if unknown:
        raise DataError(f"unknown feature group(s) {unknown}; known groups: {list(GROUPS)}")
    if not groups:
        raise DataError(f"groups is empty; pick at least one of {list(GROUPS)}")
    return tuple(dict.fromkeys(groups))


def check_group_options(
    groups: Sequence[str], options: Mapping[str, object], where: str = "extract()"
) -> None:
    """Check that every option names an option of one of ``groups``.

    Parameters
    ----------
    groups : sequence of str
        The groups being computed.
    options : mapping
        Keyword options, as :func:`~pdmkit.features.extract` takes them.
    where : str
        What the options were given to, for the message.

    Raises
    ------
    TypeError
        An option of no group (the message suggests the closest name and lists the
        options of every group), as Python does for an unknown keyword argument.
    pdmkit.errors.DataError
        An option of a group that is not in ``groups``.

    Examples
    --------
    >>> from pdmkit.features import check_group_options
    >>> check_group_options(["ar"], {"ar_ordr": 12})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    TypeError: extract(): unknown keyword argument(s) 'ar_ordr' (did you mean ...
    """
    unknown = [k for k in options if k not in _OPTION_GROUP]
    if unknown:
        hints = []
        for k in unknown:
            close = difflib.get_close_matches(k, list(_OPTION_GROUP), n=1)
            hints.append(f"{k!r} (did you mean {close[0]!r}?)" if close else repr(k))
        allowed = "; ".join(
            f"{g.name}: {', '.join(g.options) or '(none)'}" for g in _GROUP_LIST
        )
        raise TypeError(
            f"{where}: unknown keyword argument(s) {', '.join(hints)}. "
            f"Options by group: {allowed}"
        )
    stray = [k for k in options if _OPTION_GROUP[k] not in groups]
    if stray:
        needs = sorted({_OPTION_GROUP[k] for k in stray})
        raise DataError(
            f"option(s) {stray} belong to group(s) {needs}, which are not in "
            f"groups={list(groups)}; add the group or drop the option"
        )
