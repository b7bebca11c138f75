"""Sensor costs: read from a TOML file (:func:`load_sensor_costs`) or given as a mapping.

The costs that :func:`pdmkit.experiments.compare_sensors` sets the sensors' accuracy
against; pdmkit ships the seed thesis' table 9.1 (CZK) as its default file.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from pdmkit.errors import DataError, DataNotFoundError

__all__ = ["SensorCosts", "load_sensor_costs"]


class SensorCosts(dict):
    """Sensor name -> cost: a plain ``dict`` that also remembers its currency and file.

    Attributes
    ----------
    currency : str or None
        Currency or unit of the costs, when the file says.
    source : str or None
        The file the costs were read from.

    Examples
    --------
    >>> costs = SensorCosts({"DE": 3500.0}, currency="CZK")
    >>> costs["DE"], costs.currency, isinstance(costs, dict)
    (3500.0, 'CZK', True)
    """

    def __init__(self, *args: Any, currency: str | None = None, source: str | None = None):
        super().__init__(*args)
        self.currency = currency
        self.source = source

    def __repr__(self) -> str:
        return f"SensorCosts({dict.__repr__(self)}, currency={self.currency!r})"


def _default_costs_file() -> Path:
    """The costs file shipped with pdmkit (the seed's table 9.1, CZK)."""
    return Path(str(resources.files("pdmkit.experiments") / "data" / "sensor_costs.toml"))


def _number(value: Any) -> float | None:
    """``value`` as a float when it is an int or a float (not a bool), else None."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value)


def load_sensor_costs(path: str | os.PathLike | None = None) -> SensorCosts:
    """Read sensor costs from a TOML file.

    Parameters
    ----------
    path : path-like, optional
        The TOML file; default: the file shipped with pdmkit
        (``pdmkit/experiments/data/sensor_costs.toml``), which holds the seven costed
        sensor types of the seed thesis' table 9.1 (CZK) and placeholder costs for the
        CWRU accelerometers ``DE``, ``FE``, ``BA``.

        Format::

            currency = "CZK"          # optional
            [costs]
            Flow = 6000               # total cost of the sensor
            Acc = { unit_cost = 3500, count = 2 }   # installed twice: 7000

    Returns
    -------
    SensorCosts
        A ``dict`` sensor name -> total cost (float), with ``.currency`` and
        ``.source``.

    Raises
    ------
    DataNotFoundError
        The file does not exist.
    DataError
        The file is not valid TOML, lacks a ``[costs]`` table, or a cost is not a
        finite number >= 0 (the message names the file and the key).

    Examples
    --------
    >>> costs = load_sensor_costs()
    >>> costs["Acc"], costs["Mics"], costs["Flow"], costs.currency
    (7000.0, 1500.0, 6000.0, 'CZK')
    """
    if path is None:
        path = _default_costs_file()
    path = Path(path)
    data = _read_toml(path)
    where = f"sensor cost file {str(path)!r}"
    unknown = sorted(set(data) - {"costs", "currency"})
    if unknown:
        raise DataError(
            f"{where}: unknown top-level key(s) {unknown}; expected 'currency' and a "
            "[costs] table (sensor = cost)"
        )
    costs = data.get("costs")
    if not isinstance(costs, dict):
        raise DataError(
            f"{where}: no [costs] table; write the costs as\n[costs]\nSensorName = 1200"
        )
    currency = data.get("currency")
    if currency is not None and not isinstance(currency, str):
        raise DataError(
            f"{where}: 'currency' must be a string such as \"EUR\"; got {currency!r}"
        )
    out = SensorCosts(currency=currency, source=str(path))
    for name, value in costs.items():
        out[str(name)] = _cost_entry(value, f"{where}, key costs.{name}")
    return out


def _read_toml(path: Path) -> dict:
    """The TOML file at ``path``, read (a missing or invalid file is named)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise ModuleNotFoundError(
                "reading sensor costs needs tomllib (Python >= 3.11) or the tomli "
                "package on Python 3.10: pip install tomli"
            ) from None
    if not path.is_file():
        raise DataNotFoundError(
            f"sensor cost file {str(path)!r} not found; pass the path of a TOML file "
            "with a [costs] table, or None for pdmkit's default costs"
        )
    try:
        with open(path, "rb") as handle:
            return tomllib.load(handle)
    except tomllib.TOMLDecodeError as exc:
        raise DataError(
            f"sensor cost file {str(path)!r} is not valid TOML: {exc}"
        ) from None


def _cost_entry(value: Any, key: str) -> float:
    """One sensor's total cost: a number, or ``{unit_cost, count}`` (checked)."""
    if isinstance(value, dict):
        extra = sorted(set(value) - {"unit_cost", "count"})
        if extra or "unit_cost" not in value:
            raise DataError(
                f"{key}: a table entry needs 'unit_cost' (and optionally 'count'); "
                f"got keys {sorted(value)}"
            )
        unit = _number(value["unit_cost"])
        count = value.get("count", 1)
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise DataError(f"{key}: count must be a positive integer; got {count!r}")
        if unit is None:
            raise DataError(
                f"{key}: unit_cost must be a number; got {value['unit_cost']!r}"
            )
        cost = unit * count
    else:
        cost = _number(value)
        if cost is None:
            raise DataError(
                f"{key}: the cost must be a number (or {{ unit_cost = ..., count = ... "
                f"}}); got {value!r} ({type(value).__name__})"
            )
    if not math.isfinite(cost) or cost < 0:
        raise DataError(f"{key}: the cost must be finite and >= 0; got {cost!r}")
    return cost


def _resolve_costs(costs: Any) -> tuple[Mapping[str, float], str | None, str]:
    """``compare_sensors``' ``costs``: (sensor -> cost, currency, where they came from)."""
    if costs is None:
        loaded = load_sensor_costs()
        return loaded, loaded.currency, "pdmkit's default sensor_costs.toml"
    if isinstance(costs, str | os.PathLike):
        loaded = load_sensor_costs(costs)
        return loaded, loaded.currency, str(costs)
    if isinstance(costs, Mapping):
        for name, value in costs.items():
            number = _number(value) if not isinstance(value, np.number) else float(value)
            if number is None:
                raise DataError(
                    f"costs[{name!r}] must be a number; got {value!r} "
                    f"({type(value).__name__})"
                )
        return (
            costs,
            getattr(costs, "currency", None),
            getattr(costs, "source", None) or ("the costs given"),
        )
    raise TypeError(
        "costs must be a mapping sensor -> cost, the path of a TOML file, or None; got "
        f"{type(costs).__name__}"
    )
