"""The designer's settings, checked: what the page sends and what a project file holds.

A saved project is plain JSON: the source, and the settings of each step done. It is
read as untrusted input: at most :data:`MAX_PROJECT_BYTES`, nesting at most 6 deep,
known keys only, each value of the expected type and range. Nothing in it is
evaluated, imported or run; re-opening a project repeats the steps with pdmkit's own
functions.
"""

from __future__ import annotations

import json
from typing import Any

from pdmkit.errors import DataError
from pdmkit.experiments._cli_common import parse_options as read_key_values

__all__ = [
    "FORMAT",
    "MAX_PROJECT_BYTES",
    "check_indicators",
    "check_rank",
    "check_sensors",
    "check_train",
    "parse_options",
    "read_project",
]

FORMAT = "pdmkit-designer-project"
VERSION = 1
MAX_PROJECT_BYTES = 1 << 20
_MAX_DEPTH = 6
MODELS = ("knn", "bagged_trees", "random_forest", "svm", "lda")
SELECTIONS = ("fisher", "kruskal", "anova", "bhattacharyya", "pca", "hand")
#: rankings by class label (the others rank by lifetime: unit and time columns)
CLASS_RANKINGS = ("fisher", "kruskal", "anova", "bhattacharyya", "auc")
RANK_METHODS = (
    *CLASS_RANKINGS,
    "monotonicity",
    "trendability",
    "prognosability",
)


def _text(value: Any, what: str, limit: int = 400) -> str:
    if not isinstance(value, str) or len(value) > limit:
        raise DataError(
            f"{what} must be text of at most {limit} characters; got {value!r:.80}"
        )
    return value


def _texts(value: Any, what: str, limit: int = 2000) -> list[str]:
    if not isinstance(value, list) or len(value) > limit:
        raise DataError(f"{what} must be a list of at most {limit} names")
    return [_text(v, what) for v in value]


def _int(value: Any, what: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise DataError(
            f"{what} must be an integer from {low} to {high}; got {value!r:.40}"
        )
    return int(value)


def _choice(value: Any, what: str, choices: tuple) -> Any:
    if value not in choices:
        raise DataError(f"{what} must be one of {list(choices)}; got {value!r:.40}")
    return value


def _filter(value: Any) -> dict[str, list[str]]:
    if value is None:
        return {}
    if not isinstance(value, dict) or len(value) > 200:
        raise DataError("filter must map condition names to lists of allowed values")
    return {
        _text(k, "filter column"): _texts(v, f"filter[{k!r}]") for k, v in value.items()
    }


def parse_options(text: str) -> dict[str, Any]:
    r"""Group options from ``KEY=VALUE`` words, as ``pdmkit --option`` reads them.

    Values read as JSON where they parse (numbers, lists, true/false, null), else text.
    ``bearing`` is a bearing spec (a catalogue name such as 6205, or its geometry).
    The words come from a file pdmkit did not write, so they are read with the checks
    for untrusted input of :func:`pdmkit.experiments._cli_common.parse_options`.

    Examples
    --------
    >>> parse_options("nperseg=512 n_peaks=3\nbands=[[0,100],[100,500]]")
    {'nperseg': 512, 'n_peaks': 3, 'bands': [[0, 100], [100, 500]]}
    >>> parse_options("nperseg")
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: each option takes KEY=VALUE, e.g. nperseg=512; got 'nperseg'
    """
    _text(text, "options", 4000)
    words = text.replace(",\n", "\n").split()
    return read_key_values(words, "each option", "nperseg=512", untrusted=True)


def check_indicators(raw: Any) -> dict:
    """The settings of the Indicators step (signals, groups, options, filter).

    Examples
    --------
    >>> check_indicators({"signals": ["DE"], "groups": ["stats"], "options": ""})["groups"]
    ['stats']
    """
    if not isinstance(raw, dict):
        raise DataError("indicator settings must be an object")
    from pdmkit.features import GROUPS

    groups = _texts(raw.get("groups", []), "groups", 20)
    unknown = [g for g in groups if g not in GROUPS]
    if unknown or not groups:
        raise DataError(f"groups must be among {list(GROUPS)}; got {groups}")
    options_text = _text(raw.get("options", ""), "options", 4000)
    parse_options(options_text)
    scope = _choice(raw.get("scope", "all"), "scope", ("all", "filtered"))
    return {
        "signals": _texts(raw.get("signals", []), "signals", 200),
        "groups": groups,
        "options": options_text,
        "scope": scope,
        "filter": _filter(raw.get("filter")),
    }


def check_rank(raw: Any) -> dict:
    """The settings of the ranking (method; unit and order for the prognostic ones).

    Examples
    --------
    >>> check_rank({"method": "anova"})
    {'method': 'anova', 'unit': None, 'order': None}
    """
    if not isinstance(raw, dict):
        raise DataError("ranking settings must be an object")
    unit, order = raw.get("unit") or None, raw.get("order") or None
    return {
        "method": _choice(raw.get("method", "fisher"), "method", RANK_METHODS),
        "unit": None if unit is None else _text(unit, "unit"),
        "order": None if order is None else _text(order, "order"),
    }


def check_train(raw: Any) -> dict:
    """The settings of the classifier (selection, top-k or hand-picked, model, split).

    Examples
    --------
    >>> check_train({"model": "knn", "top_k": 5})["selection"]
    'fisher'
    """
    if not isinstance(raw, dict):
        raise DataError("training settings must be an object")
    test_size = raw.get("test_size", 0.25)
    if isinstance(test_size, bool) or not isinstance(test_size, int | float):
        raise DataError(f"test_size must be a number in (0, 1); got {test_size!r:.40}")
    if not 0.0 < float(test_size) < 1.0:
        raise DataError(f"test_size must be a number in (0, 1); got {test_size!r}")
    selection = _choice(raw.get("selection", "fisher"), "selection", SELECTIONS)
    features = _texts(raw.get("features", []), "features")
    if selection == "hand" and not features:
        raise DataError("pick at least one indicator by hand (or choose a top-k selection)")
    return {
        "selection": selection,
        "top_k": _int(raw.get("top_k", 5), "top_k", 1, 500),
        "features": features,
        "model": _choice(raw.get("model", "knn"), "model", MODELS),
        "test_size": float(test_size),
        "seed": _int(raw.get("seed", 0), "seed", 0, 2**31 - 1),
    }


def check_sensors(raw: Any) -> dict:
    """The settings of the sensors-by-cost view (model, top-k, costs as KEY=VALUE).

    Examples
    --------
    >>> check_sensors({"costs": "DE=500 FE=500"})["costs"]
    {'DE': 500.0, 'FE': 500.0}
    """
    if not isinstance(raw, dict):
        raise DataError("sensor settings must be an object")
    costs = {}
    for key, value in parse_options(raw.get("costs", "") or "").items():
        if isinstance(value, bool) or not isinstance(value, int | float) or value < 0:
            raise DataError(f"cost of {key!r} must be a number >= 0; got {value!r:.40}")
        costs[key] = float(value)
    return {
        "model": _choice(raw.get("model", "knn"), "model", MODELS),
        "top_k": _int(raw.get("top_k", 5), "top_k", 1, 500),
        "costs": costs,
        "seed": _int(raw.get("seed", 0), "seed", 0, 2**31 - 1),
    }


def _depth(node: Any, level: int = 0) -> int:
    if isinstance(node, dict):
        return max([level + 1, *(_depth(v, level + 1) for v in node.values())])
    if isinstance(node, list):
        return max([level + 1, *(_depth(v, level + 1) for v in node)])
    return level


def read_project(blob: bytes | str) -> dict:
    """Check a saved project and return its settings (nothing in it is run).

    Parameters
    ----------
    blob : bytes or str
        The project file's content (JSON, at most 1 MiB).

    Returns
    -------
    dict
        ``source`` ({kind, value}), ``data`` (view settings), and the settings of the
        steps done: ``indicators``, ``rank``, ``train``, ``sensors`` (each or None).

    Raises
    ------
    pdmkit.errors.DataError
        Too large, not JSON, too deeply nested, not a designer project, or a setting
        out of its range (the message names it).

    Examples
    --------
    >>> p = read_project('{"format": "pdmkit-designer-project", "version": 1, '
    ...                  '"source": {"kind": "dataset", "value": "cwru"}}')
    >>> p["source"], p["train"]
    ({'kind': 'dataset', 'value': 'cwru'}, None)
    >>> read_project('{"format": "x"}')
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: not a pdmkit designer project (format 'x'); ...
    """
    if len(blob) > MAX_PROJECT_BYTES:
        raise DataError(f"the project is {len(blob)} bytes; at most {MAX_PROJECT_BYTES}")
    try:
        raw = json.loads(blob)
    except (ValueError, UnicodeDecodeError) as exc:
        raise DataError(f"the project is not JSON ({exc})") from None
    if not isinstance(raw, dict) or raw.get("format") != FORMAT:
        found = raw.get("format") if isinstance(raw, dict) else type(raw).__name__
        raise DataError(
            f"not a pdmkit designer project (format {found!r}); save one from the page's "
            "Export step"
        )
    if _depth(raw) > _MAX_DEPTH:
        raise DataError(f"the project nests deeper than {_MAX_DEPTH} levels")
    if raw.get("version") != VERSION:
        raise DataError(
            f"project version {raw.get('version')!r}; this pdmkit reads {VERSION}"
        )
    from pdmkit.experiments.designer._source import SOURCE_KINDS

    source = raw.get("source")
    if not isinstance(source, dict):
        raise DataError("the project names no source {kind, value}")
    kind = _choice(source.get("kind"), "source kind", SOURCE_KINDS)
    value = source.get("value")
    value = _texts(value, "member files") if kind == "members" else _text(value, "source")
    data = raw.get("data") or {}
    if not isinstance(data, dict):
        raise DataError("data settings must be an object")
    steps = {
        "indicators": check_indicators,
        "rank": check_rank,
        "train": check_train,
        "sensors": check_sensors,
    }
    out = {"source": {"kind": kind, "value": value}, "data": _check_data(data)}
    for name, check in steps.items():
        out[name] = None if raw.get(name) is None else check(raw[name])
    return out


def _check_data(data: dict) -> dict:
    kind = _choice(data.get("kind", "signal"), "plot kind", ("signal", "spectrum"))
    by, signal = data.get("by"), data.get("signal")
    return {
        "filter": _filter(data.get("filter")),
        "by": None if by is None else _text(by, "colour by"),
        "signal": None if signal is None else _text(signal, "signal"),
        "kind": kind,
        "label": None if data.get("label") is None else _text(data["label"], "label"),
    }


def project_json(source: dict, data: dict, steps: dict) -> str:
    """The project file's text.

    Examples
    --------
    >>> text = project_json({"kind": "dataset", "value": "cwru"}, {}, {"rank": None})
    >>> read_project(text)["source"]["value"]
    'cwru'
    """
    return json.dumps(
        {"format": FORMAT, "version": VERSION, "source": source, "data": data, **steps},
        indent=2,
    )
