"""Checks and wording of the RUL workflow: the cap, the time unit, the warnings.

What a model cannot say about its own answers: whether a cap applies and why
(:func:`resolve_cap`), which time unit the numbers are in (:func:`default_time_unit`),
whether the data support the model's settings (:func:`sample_checks`), whether the
test units resemble the training units and end the way lives end
(:func:`input_checks`), and what each interval means (:func:`interval_checks`,
:func:`describe_rul`). Every warning goes through :func:`warn`: shown, collected into
the run's JSON ``warnings`` and kept for the report.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from pdmkit.errors import DataError

#: The RUL cap a named dataset's literature uses, and why (applied unless told).
CAP_CONVENTIONS = {
    "cmapss-fd001": (
        125.0,
        "the C-MAPSS literature's convention: RUL taken as at most 125 cycles, a "
        "piecewise-linear target",
    ),
}
#: Time unit of each named dataset's time column.
DATASET_TIME_UNITS = {
    "cmapss-fd001": "cycles",
    "pneumatic-leak": "cycles",
    "nasa-battery": "cycles",
}
#: Training units below which a learned model (boosting, neural) is warned about.
FEW_UNITS = 10
#: Test units below which the headline RMSE is warned about.
FEW_TEST_UNITS = 5


def resolve_cap(rul_cap, key) -> tuple[float | None, str]:
    """The cap to use and where it comes from.

    Where: ``"asked"``, the dataset's convention, or ``"none"``.
    """
    if isinstance(rul_cap, str):
        if rul_cap.lower() not in ("convention", "auto"):
            raise DataError(
                f"rul_cap must be a positive number, None (no cap) or 'convention' "
                f"(the named dataset's, else none), got {rul_cap!r}"
            )
        if key in CAP_CONVENTIONS:
            value, why = CAP_CONVENTIONS[key]
            return value, f"dataset convention: {why}"
        return None, "none"
    if rul_cap is None:
        return None, "none"
    if isinstance(rul_cap, bool) or not isinstance(rul_cap, int | float | np.number):
        raise DataError(f"rul_cap must be a positive number or None, got {rul_cap!r}")
    value = float(rul_cap)
    if not (np.isfinite(value) and value > 0):
        raise DataError(f"rul_cap must be a positive finite number, got {rul_cap!r}")
    return value, "asked"


def default_time_unit(key, table: pd.DataFrame | None = None) -> str:
    """``cycles`` for a named dataset or a ``cycle`` column, else seconds."""
    if key in DATASET_TIME_UNITS:
        return DATASET_TIME_UNITS[key]
    if table is not None and "time" not in table.columns and "cycle" in table.columns:
        return "cycles"
    return "s"


def cap_text(cap: float | None, unit: str, source: str) -> str:
    """One phrase for the summary line and the report."""
    if cap is None:
        return "no RUL cap"
    why = "asked" if source == "asked" else source.removeprefix("dataset convention: ")
    return f"RUL cap {cap:g} {unit} ({why})"


def warn(message: str, found: list) -> None:
    """Warn (collected into the run's JSON) and keep the message for the report."""
    found.append(message)
    warnings.warn(message, UserWarning, stacklevel=3)


def sample_checks(model, estimator, calibrate, n_train, n_test, found) -> None:
    """Warnings for settings that too few units cannot support."""
    inner = getattr(estimator, "model", estimator)
    k = getattr(inner, "k", None)
    if (
        isinstance(k, int | np.integer)
        and model in ("similarity", "residual", "pairwise", "hash")
        and n_train < 2 * k
    ):
        warn(
            f"{n_train} training units for k={k} nearest neighbours: the RUL "
            f"distribution is that of {min(k, n_train)} units, nearly the whole fleet "
            f"(pass --option k=N with N well below {n_train}, or give more units)",
            found,
        )
    if model in ("neural", "boosting") and n_train < FEW_UNITS:
        warn(
            f"a learned model ({model}) on {n_train} training units: too few to learn "
            f"a fleet's degradation from (at least {FEW_UNITS} advised); its intervals "
            "come from these same few units held out in turn",
            found,
        )
    folds = getattr(estimator, "n_folds", None) if calibrate else None
    if folds is not None and n_train < 2 * int(folds):
        warn(
            f"{folds}-fold calibration on {n_train} training units: each fold holds out "
            f"{max(1, n_train // int(folds))} unit(s), so the interval factors rest on "
            f"{n_train} held-out lives (use fewer folds or more units)",
            found,
        )
    if n_test < FEW_TEST_UNITS:
        warn(
            f"the scores come from {n_test} test unit(s): an RMSE from so few units "
            "says little about the model's accuracy (it is one or a few errors)",
            found,
        )


def input_checks(train, test, cols, unit_label, found) -> tuple[pd.Series, dict]:
    """Out-of-distribution scores of the test units and shut-down endings, warned."""
    usable = [c for c in cols if c in train.columns and c in test.columns]
    scores = ood_check(train, test, usable, found)
    return scores, ending_checks({"training": train, "test": test}, usable, found)


def ood_check(train, test, usable, found) -> pd.Series:
    """Each test unit's out-of-distribution score; the units beyond the threshold warned."""
    from pdmkit.rul import OOD_THRESHOLD, ood_scores

    scores = ood_scores(train, test, usable) if usable else pd.Series(dtype=float)
    far = scores[scores > OOD_THRESHOLD]
    if len(far):
        shown = ", ".join(f"{u} ({v:.1f})" for u, v in far.sort_values()[::-1][:5].items())
        warn(
            f"{len(far)} of {len(scores)} test units lie outside the training data "
            f"(out-of-distribution score above {OOD_THRESHOLD:g}, i.e. beyond 99 % of "
            f"the training rows: {shown}): the model extrapolates there; their "
            "predictions and intervals are not to be trusted",
            found,
        )
    return scores


def ending_checks(tables: dict, usable, found) -> dict:
    """Units whose last rows look like a shut-down, per named table, warned."""
    from pdmkit.rul import shutdown_endings

    endings = {}
    for part, table in tables.items():
        flagged = shutdown_endings(table, usable) if usable else pd.DataFrame()
        if len(flagged):
            first = flagged.iloc[0]
            names = ", ".join(map(str, flagged["unit"].head(6)))
            warn(
                f"{len(flagged)} {part} unit(s) end in rows that look like a shut-down "
                f"({names}; e.g. {first['unit']}: last {first['rows']} row(s) "
                f"{first['kind']} in {first['column']!r} against a level of "
                f"{first['history_level']:.3g} before): a model reads them as the end "
                "of life; drop those rows",
                found,
            )
            endings[part] = flagged.to_dict(orient="records")
    return endings


def interval_checks(pred, cap, unit_label, found) -> tuple[np.ndarray, dict]:
    """A note per unit on what its interval means, and warnings for the fleet."""
    est, up = pred.estimate, pred.upper
    notes = np.array(pred.extra.get("note", [""] * len(pred)), dtype=object)
    notes = np.where(pd.isna(notes), "", notes).astype(object)
    unanswered = np.isnan(est)
    beyond = ~np.isfinite(up) & ~unanswered
    at_cap = np.zeros(len(pred), bool) if cap is None else (up >= cap - 1e-9) & ~unanswered
    notes[beyond & (notes == "")] = "upper bound beyond the horizon"
    notes[at_cap] = f"upper bound at the cap {cap:g}" if cap is not None else ""
    notes[unanswered & (notes == "")] = "no estimate"
    n = len(pred)
    counts = {
        "upper_at_cap": int(at_cap.sum()),
        "upper_beyond_horizon": int(beyond.sum()),
        "no_estimate": int(unanswered.sum()),
    }
    if at_cap.any():
        warn(
            f"{int(at_cap.sum())} of {n} upper bounds sit at the RUL cap "
            f"{cap:g} {unit_label}: the model's answers are cut there, the true upper "
            "bound is higher (run without a cap to see it)",
            found,
        )
    if beyond.any():
        warn(
            f"{int(beyond.sum())} of {n} units have an upper bound beyond the model's "
            "horizon (the model cannot rule out that they never fail)",
            found,
        )
    if unanswered.any():
        warn(
            f"{int(unanswered.sum())} of {n} units get no estimate "
            f"({notes[unanswered][0]}: the model cannot time a crossing it did not "
            "see); they are left out of the scores",
            found,
        )
    return notes, counts


def describe_rul(row, level: float, time_unit: str = "") -> str:
    """One line for one unit's RUL: the estimate, its interval, and what it means.

    An upper bound of ``inf`` reads "beyond the horizon"; a unit without an estimate
    says why (``row["note"]``); an upper bound at the cap says so.

    Parameters
    ----------
    row : mapping
        ``unit``, ``time``, ``rul``, ``lower``, ``upper`` and optionally ``note``.
    level : float
        Level of the interval.
    time_unit : str, optional

    Returns
    -------
    str

    Examples
    --------
    >>> from pdmkit.experiments._rul import describe_rul
    >>> row = {"unit": 7, "time": 120.0, "rul": 35.0, "lower": 20.0,
    ...        "upper": float("inf"), "note": "upper bound beyond the horizon"}
    >>> describe_rul(row, 0.9, "h")
    'unit 7 at time 120 h: RUL 35.0 h (90 % interval 20.0 h to beyond the horizon)'
    """
    u = f" {time_unit}" if time_unit else ""
    head = f"unit {row['unit']} at time {float(row['time']):g}{u}: "
    note = str(row.get("note") or "")
    pct = f"{100 * float(level):g} %"
    rul, lower, upper = (float(row[k]) for k in ("rul", "lower", "upper"))
    if np.isnan(rul):
        return head + f"no RUL estimate ({note or 'the model gives none'})"
    top = "beyond the horizon" if not np.isfinite(upper) else f"{upper:.1f}{u}"
    text = head + f"RUL {rul:.1f}{u} ({pct} interval {lower:.1f}{u} to {top})"
    if note and note not in ("upper bound beyond the horizon",):
        text += f"; {note}"
    return text


def model_keys(pipeline) -> tuple[str, str | None]:
    """The unit and time columns the (fitted) model reads."""
    inner = getattr(pipeline, "model", pipeline)
    inner = getattr(inner, "model_", inner)
    keys = getattr(inner, "_keys", None)
    if keys is not None:
        return keys[0], keys[1]
    return getattr(inner, "unit", "unit"), getattr(inner, "time", None)


def rename_keys(table, where, pairs) -> pd.DataFrame:
    """Rename user key columns (``given -> wanted``) with errors naming ``where``."""
    for given, wanted, flag in pairs:
        if given is None or given == wanted:
            continue
        if given not in table.columns:
            raise DataError(
                f"{where}: {flag} {given!r} is not a column (columns: "
                f"{list(table.columns)[:12]})"
            )
        if wanted in table.columns:
            raise DataError(
                f"{where}: {flag} {given!r} would become {wanted!r}, but the table "
                f"already has a column {wanted!r}; rename or drop it"
            )
        table = table.rename(columns={given: wanted})
    return table
