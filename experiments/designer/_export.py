"""The designer's work as a ``pdmkit`` command line and as a Python script.

Both call the functions the page called, with the same settings, on the whole data
set (or the members the filter kept), so they reproduce its feature table, ranking and
held-out accuracy. The script also writes the fitted pipeline as a ``.pdmkit`` file
(:func:`pdmkit.save_model`: nothing in it runs code when loaded).
"""

from __future__ import annotations

import shlex
from typing import Any

from pdmkit.errors import DataError
from pdmkit.experiments.designer._project import parse_options
from pdmkit.experiments.designer._source import DATASET_LOADERS

__all__ = ["bearing_spec", "command_lines", "python_script"]


def bearing_spec(value: Any) -> str:
    """A bearing as the text ``--bearing`` and the page read.

    Examples
    --------
    >>> from pdmkit.features import CWRU_DRIVE_END
    >>> bearing_spec(CWRU_DRIVE_END)
    '6205'
    >>> bearing_spec("n_balls=8,ball_d=6.75mm,pitch_d=28.5mm,angle=0")
    'n_balls=8,ball_d=6.75mm,pitch_d=28.5mm,angle=0'
    """
    if isinstance(value, str):
        return value
    from pdmkit.features import CWRU_DRIVE_END, CWRU_FAN_END

    if value == CWRU_DRIVE_END:
        return "6205"
    if value == CWRU_FAN_END:
        return "6203"
    return (
        f"n_balls={value.n_balls},ball_d={value.ball_diameter * 1e3:.6g}mm,"
        f"pitch_d={value.pitch_diameter * 1e3:.6g}mm,angle={value.contact_angle_deg:g}"
    )


def _option_text(value: Any) -> str:
    import json

    return value if isinstance(value, str) else json.dumps(value, separators=(",", ":"))


def _source_args(source) -> list[str]:
    if source.kind == "dataset":
        return ["--dataset", str(source.value)]
    if source.kind == "ensemble":
        return ["--ensemble", str(source.value)]
    if source.kind == "members":
        reading = []
        for key, value in getattr(source, "reading", {}).items():
            reading += [
                "--" + key.replace("_", "-"),
                f"{value:g}" if isinstance(value, float) else str(value),
            ]
        return ["--members", *map(str, source.value), *reading]
    return ["--features", str(source.value)]


def _option_args(source, indicators: dict) -> list[str]:
    """``--option`` / ``--bearing`` words giving exactly the page's group options."""
    options = parse_options(indicators["options"])
    args: list[str] = []
    bearing, shaft = options.pop("bearing", None), options.pop("shaft_hz", None)
    if bearing is not None:
        args += ["--bearing", bearing_spec(bearing), "--shaft-hz", _option_text(shaft)]
    for key, value in options.items():
        args += ["--option", f"{key}={_option_text(value)}"]
    # the dataset's own defaults the page left out: set back to the extractor's
    from pdmkit.features import extract

    defaults = source.default_options
    for key in defaults:
        if key in ("bearing", "shaft_hz") or key in options:
            continue
        try:  # only the options of the groups chosen (the CLI applies those)
            extract([0.0] * 64, fs=64.0, groups=indicators["groups"], **{key: None})
        except (TypeError, DataError):
            continue
        args += ["--option", f"{key}=null"]
    return args


def command_lines(session) -> dict:
    """The ``pdmkit`` commands that redo the session's steps, and what they cannot.

    Returns
    -------
    dict
        ``commands`` (list of command lines) and ``notes`` (list of lines).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.experiments.designer._session import Session
    >>> from pdmkit.experiments.designer._source import Source
    >>> ens = Ensemble({"v": np.zeros((2, 64))}, fs=64.0, conditions={"fault": ["a", "b"]})
    >>> command_lines(Session(Source.from_ensemble(ens, "members", ["a.csv", "b.csv"])))
    {'commands': [], 'notes': ['compute the indicators first (step 2)']}
    """
    ind = session.settings["indicators"]
    source = session.source
    if ind is None and source.kind != "features":
        return {"commands": [], "notes": ["compute the indicators first (step 2)"]}
    base = _source_args(source)
    notes = []
    if ind is not None:
        base += ["--groups", *ind["groups"], "--signals", *ind["signals"]]
        base += _option_args(source, ind)
        if ind["scope"] == "filtered" and any(ind["filter"].values()):
            notes.append(
                "the command line takes all members; the indicators were computed on the "
                "filtered ones: use the script (it applies the filter)"
            )
    if session.label is not None:
        base += ["--label", session.label]
    out = ["--out", "results/designer"]
    commands = []
    if source.kind != "features":
        commands.append(["pdmkit", "features", *base, *out[:1], out[1] + "/features"])
    rank = session.settings["rank"]
    if rank is not None:
        extra = ["--method", rank["method"]]
        extra += ["--unit", rank["unit"]] if rank["unit"] else []
        extra += ["--order", rank["order"]] if rank["order"] else []
        commands.append(["pdmkit", "rank", *base, *extra, "--out", out[1] + "/rank"])
    train = session.settings["train"]
    if train is not None:
        if train["selection"] == "hand":
            notes.append("hand-picked indicators have no command-line form: use the script")
        else:
            extra = ["--model", train["model"], "--top-k", str(train["top_k"])]
            extra += ["--selection", train["selection"]]
            extra += [
                "--test-size",
                f"{train['test_size']:g}",
                "--seed",
                str(train["seed"]),
            ]
            commands.append(
                ["pdmkit", "classify", *base, *extra, "--out", out[1] + "/classify"]
            )
    return {"commands": [shlex.join(c) for c in commands], "notes": notes}


def _load_lines(source) -> list[str]:
    if source.kind == "dataset":
        name, args = DATASET_LOADERS[str(source.value)]
        return [f"from pdmkit.ensembles import {name}", "", f"ensemble = {name}({args})"]
    if source.kind == "ensemble":
        return [f"ensemble = {str(source.value)!r}  # an on-disk ensemble, read in batches"]
    if source.kind == "members":
        reading = "".join(f", {k}={v!r}" for k, v in getattr(source, "reading", {}).items())
        return [
            "from pdmkit.ensembles import read_members",
            "",
            f"ensemble = read_members({[str(v) for v in source.value]!r}{reading})",
        ]
    return [
        "from pdmkit.ensembles import read_table",
        "",
        f"table = read_table({str(source.value)!r})",
        'if table.index.name is None and "member" in table.columns:',
        '    table = table.set_index("member")',
    ]


def _features_lines(session) -> list[str]:
    ind = session.settings["indicators"]
    if ind is None:
        return []
    options = parse_options(ind["options"])
    words = [f"signals={ind['signals']!r}", f"groups={tuple(ind['groups'])!r}"]
    lines = []
    for key, value in options.items():
        if key == "bearing":
            lines.append(f"bearing = BearingGeometry.parse({bearing_spec(value)!r})")
            words.append("bearing=bearing")
        else:
            words.append(f"{key}={value!r}")
    lines.append(
        "table = extract_ensemble(\n    ensemble,\n    " + ",\n    ".join(words) + ",\n)"
    )
    if session.label is not None:
        lines.append(f"table = table[table[{session.label!r}].notna()]")
    if ind["scope"] == "filtered":
        for column, allowed in ind["filter"].items():
            if allowed:
                lines.append(
                    f"table = table[table[{column!r}].astype(str).isin({list(allowed)!r})]"
                )
    return lines


def python_script(session) -> str:
    """A Python script that redoes the session's steps on the whole data set.

    It prints the held-out accuracy as ``held-out accuracy 0.9876`` and writes
    ``features.parquet``, ``ranking.csv`` and ``model.pdmkit`` beside itself (into
    the folder it is run from).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.experiments.designer._session import Session
    >>> from pdmkit.experiments.designer._source import Source
    >>> ens = Ensemble({"v": np.zeros((2, 64))}, fs=64.0, conditions={"fault": ["a", "b"]})
    >>> session = Session(Source.from_ensemble(ens, "members", ["a.csv"]))
    >>> python_script(session).strip()
    '# compute the indicators first (step 2)'
    """
    source = session.source
    load = _load_lines(source)
    imports = [line for line in load if line.startswith("from ")]
    features = _features_lines(session)
    names = ["rank_features"]
    if session.settings["indicators"] is not None:
        names = ["extract_ensemble", *names]
    if any("BearingGeometry" in line for line in features):
        names = ["BearingGeometry", *names]
    lines = [
        '"""Exported by pdmkit designer: the feature table, ranking and classifier of the',
        f'session on {source.describe()}."""',
        "",
        "import pdmkit",
        *sorted([*imports, f"from pdmkit.features import {', '.join(names)}"]),
        "from pdmkit.experiments import classify",
        "",
        *[line for line in load if line and not line.startswith("from ")],
        *features,
        "table.to_parquet('features.parquet')",
        "features = [c for c in table.columns if '/' in str(c)]",
        f"label = {session.label!r}",
    ]
    rank = session.settings["rank"]
    if rank is not None:
        if rank["method"] in ("kruskal", "anova"):
            call = (
                f"rank_features(table, table[label], method={rank['method']!r}, "
                "features=features)"
            )
        else:
            call = (
                f"rank_features(table, method={rank['method']!r}, features=features, "
                f"unit={rank['unit']!r}, time={rank['order']!r})"
            )
        lines += [
            f"ranking = {call}.to_pandas()",
            "ranking.to_csv('ranking.csv', index=False)",
        ]
        lines += ["print(ranking.head(10).to_string(index=False))"]
    train = session.settings["train"]
    if train is not None:
        selection = train["selection"]
        if selection == "hand":
            lines.append(f"features = {train['features']!r}")
            selection = None
        lines += [
            "result = classify(",
            "    table,",
            "    label,",
            "    features=features,",
            f"    model={train['model']!r},",
            f"    top_k={train['top_k']!r},",
            f"    selection={selection!r},",
            f"    test_size={train['test_size']!r},",
            f"    random_state={train['seed']!r},",
            ")",
            "print(f'selected indicators: {result.features}')",
            "print(f'held-out accuracy {result.accuracy:.4f}')",
            "pdmkit.save_model(result.pipeline, 'model.pdmkit')",
        ]
    if session.settings["indicators"] is None and source.kind != "features":
        return "# compute the indicators first (step 2)\n"
    return "\n".join(lines) + "\n"
