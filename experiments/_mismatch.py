"""The mismatch-discovery workflow: model file + recording(s) -> JSON summary + HTML report.

``pdmkit mismatch MODEL.py DATA.csv [--validation DATA2.csv] --json OUT.json --out DIR``
calls :func:`run_mismatch`. The model file follows the contract of
:func:`pdmkit.models.ode.load_model_file`; the data are CSV or Parquet tables with a
``time`` column and one column per model input and output.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from pdmkit._outputs import OutputRun, to_jsonable
from pdmkit._plot_signals import axis_label, envelope_note, plot_signal
from pdmkit.ensembles import read_table
from pdmkit.errors import DataError
from pdmkit.experiments._model_units import output_units
from pdmkit.experiments._report import Report
from pdmkit.models.mismatch import (
    ChangeResult,
    MismatchResult,
    diagnose_change,
    discover_mismatch,
)
from pdmkit.models.ode import MODEL_TIMEOUT, load_model_file

__all__ = ["build_mismatch_report", "mismatch_summary", "run_mismatch"]


def mismatch_summary(result: MismatchResult, **sources: Any) -> dict:
    """The JSON summary of a :class:`MismatchResult`.

    The keys the issue fixes come first: ``verdict`` (``effect``, ``target``,
    ``physics``, ``params``), ``located`` (``start``, ``end``, ``share``, best first),
    ``candidates`` (``effect``, ``target``, ``rmse_validation``, ``improvement``,
    ``criterion``, best first) and ``fit`` (``rmse_nominal``, ``rmse_augmented`` on the
    validation part). ``sources`` (file names) and ``diagnostics`` (regions,
    whiteness before/after, timings) follow.

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import example_result
    >>> res = example_result()
    >>> list(mismatch_summary(res))[:4]
    ['verdict', 'located', 'candidates', 'fit']
    """
    d = result.to_dict()
    out = {
        "verdict": d["verdict"],
        "located": d["located"],
        "candidates": d["candidates"],
        "fit": d["fit"],
        "sources": {
            k: (v if v is None or isinstance(v, list) else os.fspath(v))
            for k, v in sources.items()
        },
        "diagnostics": {
            "regions": d["regions"],
            "whiteness": d["whiteness"],
            "timings": d["timings"],
        },
    }
    return to_jsonable(out)


def _verdict_text(summary: dict) -> str:
    v = summary["verdict"]
    fit = summary["fit"]
    r0, r1 = fit["rmse_nominal"], fit["rmse_augmented"]
    if v["effect"] == "none":
        return (
            f"Verdict: none. {v['physics']} Validation RMSE of the re-fitted nominal "
            f"model: {r0:.4g}."
        )
    on = f" on {v['target']}" if v.get("target") else ""
    lead = v.get("headline") or f"{v['effect']}{on}"
    lead = f"Verdict: {lead}."
    text = (
        f"{lead} {v['physics']} Validation RMSE "
        f"{r0:.4g} (nominal, re-fitted) -> {r1:.4g} (augmented), "
        f"{100 * (1 - r1 / r0):.1f} % lower."
    )
    for extra in v.get("also", []):
        text += (
            f" Together with: {extra['effect']} on {extra['target']}. {extra['physics']}"
        )
    return text


def _spectrum_figure(result: MismatchResult, units: dict):
    import matplotlib.pyplot as plt

    spec = result.spectrum
    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(9, 5))
    f = spec.index.to_numpy()
    ax[0].semilogy(f[1:], spec["psd"].to_numpy()[1:], color="C0")
    found = {units.get(o) for o in result.outputs}
    unit = found.pop() if len(found) == 1 else None
    ax[0].set_ylabel(
        f"residual PSD [{unit}²/Hz]"
        if unit
        else "residual PSD [(output)²/Hz]"
        if len(result.outputs) == 1
        else "residual PSD [weighted²/Hz]"
    )
    for c in spec.columns:
        if c.startswith("coherence"):
            ax[1].plot(f, spec[c], label=c)
    ax[1].set_ylim(0, 1.05)
    ax[1].set_ylabel("coherence")
    ax[1].set_xlabel("frequency [Hz]")
    if len(spec.columns) > 1:
        ax[1].legend(loc="best", fontsize="small")
    return fig


def _trace_figure(t, lines, output: str, unit: str | None = None):
    """Measured and simulated traces of one output: ``lines`` of ``(y, colour, label)``."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 1, figsize=(10, 3.5))
    for y, colour, label in lines:
        plot_signal(ax, t, y, color=colour, lw=0.8 if colour == "k" else 1.0, label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(axis_label(output, unit))
    ax.legend(loc="best", fontsize="small")
    return fig


def _values_text(values: dict | None) -> str:
    """Fitted parameters as ``"k = 396.2, c = 4.1"`` ("none" when there are none).

    Examples
    --------
    >>> _values_text({"k": 396.1668550709708, "c": 0.5}), _values_text({})
    ('k = 396.2, c = 0.5', 'none')
    """
    if not values:
        return "none"
    return ", ".join(
        f"{k} = {v:.4g}" if isinstance(v, int | float) else f"{k} = {v}"
        for k, v in values.items()
    )


def _validation_figure(result: MismatchResult, output: str, unit: str | None = None):
    s = result.signals
    j = result.outputs.index(output)
    lines = [
        (s["val_measured"][:, j], "k", "measured"),
        (s["val_nominal"][:, j], "C0", "nominal model"),
    ]
    if s.get("val_augmented") is not None:
        lines.append((s["val_augmented"][:, j], "C3", "augmented model"))
    return _trace_figure(s["val_time"], lines, output, unit)


def _how_fitted(fit: dict) -> str:
    """What pdmkit did to the recording before fitting, in a sentence."""
    said = [
        f"Inputs between samples: {'held' if fit.get('input_hold') == 'zoh' else 'linear'}"
        f" ({fit.get('input_hold')}); "
        + (
            "stiff model: integrated by ROS2 (linearly implicit), steps halved where "
            "its error estimate asks."
            if fit.get("integrator") == "ros2"
            else f"{fit.get('n_sub')} RK4 steps per sample."
        )
    ]
    if (fit.get("decimated") or 1) > 1:
        said.append(
            f"The recordings were decimated by {fit['decimated']} (sampled far faster "
            "than the model and its inputs need; held inputs averaged over the merged "
            "samples)."
        )
    if fit.get("pieces"):
        said.append(
            f"The training record was fitted in {fit['pieces']['n']} pieces of "
            f"{fit['pieces']['samples']} samples, each from its own fitted initial state "
            "(multiple shooting); samples between pieces were not simulated."
        )
    return " ".join(said)


def _whiteness_table(summary: dict) -> pd.DataFrame:
    """The residual tests before and after, one row per model and output."""
    rows = []
    for when, per_out in summary["diagnostics"]["whiteness"].items():
        for o, w in per_out.items():
            row = {
                "model": when,
                "output": o,
                "Ljung-Box p": w["p_value"],
                "ACF outside ±2.58/√N": w["acf_outside"],
                "white": w["white"],
            }
            for u, x in w["inputs"].items():
                row[f"max |xcorr| {u}"] = x["xcorr_max"]
                row[f"lag {u} [samples]"] = x["xcorr_lag"]
            rows.append(row)
    return pd.DataFrame(rows)


def _add_traces(rep: Report, result: MismatchResult, units: dict) -> None:
    """One figure per output (and per output on a separate validation recording)."""
    note = envelope_note(len(result.signals["time"]))
    for o in result.outputs:
        rep.add_figure(
            result.plot(output=o, unit=units.get(o))[0],
            caption=(
                f"{o}: measured (black), re-fitted nominal model (blue), augmented model "
                "(red); below, the residuals. Shaded: the located windows; dashed: start "
                f"of the validation part. {note}"
            ).strip(),
        )
        if "val_time" in result.signals:
            several = result.fit.get("validation", "").endswith("recordings")
            where = (
                "the separate validation recordings, one after another (each from its "
                "own initial state; the time axis continues across them)"
                if several
                else "the separate validation recording"
            )
            rep.add_figure(
                _validation_figure(result, o, units.get(o)),
                caption=f"{o} on {where}. "
                + envelope_note(len(result.signals["val_time"])),
            )


def build_mismatch_report(
    result: MismatchResult, summary: dict, title: str, *, units: dict | None = None
) -> Report:
    """The HTML report of a mismatch discovery (not yet written).

    Sections: the verdict in words and numbers; measured vs nominal vs augmented with
    the residual before / after and the located windows shaded; the located windows;
    the regions of the state / input space where the residual concentrates; the ranked
    candidates; the residual spectrum and coherence; the whiteness tests before and
    after. Every number is also in ``summary.json`` (the report says so, and shows no
    JSON).

    Parameters
    ----------
    result : MismatchResult
        What :func:`~pdmkit.models.mismatch.discover_mismatch` found.
    summary : dict
        Its :func:`mismatch_summary`.
    title : str
        The report's title.
    units : dict, optional
        Output -> unit for the axes (``output_units`` of ``_model_units``); an output
        without one is
        labelled "as recorded".

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import example_result
    >>> res = example_result()
    >>> rep = build_mismatch_report(res, mismatch_summary(res), "demo", units={"h1": "m"})
    >>> html = rep.to_html()
    >>> "Ranked candidates" in html and "<pre>" not in html
    True
    """
    units = dict(units or {})
    rep = Report(title)
    rep.add_heading("Verdict")
    rep.add_text(_verdict_text(summary))
    fit = summary["fit"]
    rep.add_text(
        f"Validation: {fit['validation']}. Training RMSE {fit['rmse_train_nominal']:.4g} "
        f"(nominal) -> {fit['rmse_train_augmented']:.4g} (augmented). Free parameters "
        f"re-estimated: nominal {_values_text(fit['free_nominal'])}; augmented "
        f"{_values_text(fit['free_augmented'])}."
    )
    rep.add_text(_how_fitted(fit))
    rep.add_heading("Measured, nominal and augmented")
    _add_traces(rep, result, units)
    rep.add_heading("Where the mismatch is")
    located = pd.DataFrame(summary["located"])
    if len(located):
        rep.add_table(
            located.rename(
                columns={"start": "start [s]", "end": "end [s]", "share": "share"}
            ),
            caption="Time windows ranked by their share of the nominal "
            "model's residual energy (best first).",
        )
    if len(result.regions):
        rep.add_table(
            result.regions.head(10),
            caption="Regions of the state / input space: share of time, share of residual "
            "energy, and their ratio (enrichment > 1: the mismatch concentrates there).",
        )
    rep.add_figure(
        _spectrum_figure(result, units),
        caption="Spectrum of the nominal residual and its coherence with each input.",
    )
    rep.add_heading("Ranked candidates")
    rep.add_table(
        result.candidates,
        caption="Each candidate fitted with the free parameters and the initial state; "
        "improvement is the relative drop of validation RMSE, criterion the BIC change on "
        "the training part (negative is better), p_value the Diebold-Mariano test against "
        "the nominal model; refit False: screened only.",
    )
    rep.add_heading("Is anything systematic left?")
    whiteness = _whiteness_table(summary)
    if len(whiteness):
        rep.add_table(
            whiteness,
            caption="Residual tests on the validation part, "
            "before (nominal) and after (augmented).",
        )
    rep.add_text(
        "Every number of this report, with the sources and timings, is in summary.json "
        "beside it; the ranked candidates also in candidates.csv."
    )
    return rep


def _read(path: str | os.PathLike, what: str) -> pd.DataFrame:
    table = read_table(path)
    if len(table) == 0:
        raise DataError(f"{path}: the {what} table has no rows.")
    return table


def run_mismatch(
    model_path: str | os.PathLike,
    data_path: str | os.PathLike,
    *,
    validation_path: str | os.PathLike | Sequence[str | os.PathLike] | None = None,
    out_dir: str | os.PathLike,
    json_path: str | os.PathLike | None = None,
    effects: Sequence[str] | None = None,
    model_timeout: float | None = MODEL_TIMEOUT,
    input_hold: str = "auto",
    max_seconds: float | None = None,
    reference_path: str | os.PathLike | None = None,
) -> dict:
    """Explain the mismatch between a model file and a recording; write JSON and HTML.

    The model file is Python code run with your rights; trust it like code you would
    run. It is first imported and ``rhs`` evaluated on the data's first samples in a
    child process limited to ``model_timeout`` seconds (see
    :func:`pdmkit.models.ode.load_model_file`).

    Parameters
    ----------
    model_path : path
        The user's model file (see :func:`pdmkit.models.ode.load_model_file`).
    data_path : path
        CSV or Parquet: ``time`` (s, uniform), the model's inputs and outputs. Without
        ``validation_path`` its last third is the validation part.
    validation_path : path or list of paths, optional
        Recording(s) used for validation only, each from its own re-estimated initial
        state; several are scored together (one RMSE, one significance test over all).
    out_dir : path
        Receives ``report.html``, ``summary.json`` and ``candidates.csv`` (all at once,
        only when everything succeeded); anything else in the folder is left as it is
        (see :mod:`pdmkit._outputs`).
    json_path : path, optional
        Also write the JSON summary here.
    effects : sequence of str, optional
        Only try these candidate effect ids (default: the whole library).
    model_timeout : float or None, default 30
        Seconds the model file may take to import and evaluate ``rhs`` in the child
        check; None loads it in this process only, unchecked.
    input_hold : {"auto", "zoh", "foh"}
        The inputs between samples: held, or straight lines (sampled continuous
        signals); ``"auto"`` decides from the data (see
        :func:`pdmkit.models.mismatch.choose_input_hold`).
    max_seconds : float, optional
        Time budget of the discovery: when it runs out the best verdict so far is
        reported, marked so (see :func:`pdmkit.models.mismatch.discover_mismatch`).
    reference_path : path, optional
        Diagnosis by mismatch: a recording of the machine in its reference (healthy)
        condition. The model's free parameters are fitted on it, then pdmkit finds
        which must move to explain ``data`` and writes them as
        ``changed_parameters`` (see :func:`pdmkit.models.mismatch.diagnose_change`);
        ``validation_path``, ``effects``, ``input_hold`` and ``max_seconds`` do not
        apply.

    Returns
    -------
    dict
        The JSON summary (see :func:`mismatch_summary`).

    Raises
    ------
    pdmkit.errors.ModelError
        The model file is malformed (the message names the file and the problem), did
        not return within ``model_timeout``, called exit, or its ``rhs`` is not finite
        on the data's first samples.
    pdmkit.errors.DataError
        A data file is missing a column, has NaN, or a non-uniform time (the message
        names the file, the column and the row). Nothing is written in either case.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from pdmkit.models.mismatch._cases import generate_concealed_case
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> case = generate_concealed_case("none", 0.2, seed=1, n_samples=300)
    >>> paths = case.write(folder)
    >>> summary = run_mismatch(paths["model"], paths["data"], out_dir=folder / "out",
    ...                        effects=["sensor_offset"])
    >>> summary["verdict"]["effect"], sorted(p.name for p in (folder / "out").iterdir())
    ('none', ['.pdmkit', 'candidates.csv', 'report.html', 'summary.json'])
    """
    if reference_path is not None:
        return _run_diagnosis(
            model_path, data_path, reference_path, out_dir, json_path, model_timeout
        )
    validation_paths = _paths(validation_path)
    inputs = [model_path, data_path, *validation_paths]
    with OutputRun(out_dir, "mismatch", inputs=inputs, json_path=json_path) as run:
        result, summary, title, units = _discover(
            model_path,
            data_path,
            validation_paths,
            effects,
            model_timeout,
            input_hold,
            max_seconds,
        )
        run.add_csv("candidates.csv", result.candidates, index=False)
        report = build_mismatch_report(result, summary, title, units=units)
        run.add_report("report.html", report)
        run.add_json("summary.json", summary)
        run.commit()
    return summary


def _paths(paths) -> list:
    """None, one path or several, as a list."""
    if paths is None:
        return []
    if isinstance(paths, str | os.PathLike):
        return [paths]
    return list(paths)


def _discover(
    model_path, data_path, validation_paths, effects, model_timeout, input_hold, max_seconds
):
    """(result, summary, report title, output units) of :func:`run_mismatch`."""
    data = _read(data_path, "data")
    model = load_model_file(model_path, data=data, model_timeout=model_timeout)
    validation = [_read(v, "validation") for v in validation_paths] or None
    result = discover_mismatch(
        model,
        data,
        validation,
        effects=effects,
        data_name=os.fspath(data_path),
        validation_name=[os.fspath(v) for v in validation_paths],
        input_hold=input_hold,
        max_seconds=max_seconds,
    )
    sources = [os.fspath(v) for v in validation_paths]
    summary = mismatch_summary(
        result,
        model=model_path,
        data=data_path,
        validation=(sources[0] if len(sources) == 1 else sources) or None,
    )
    title = f"Mismatch discovery: {Path(model_path).name} vs {Path(data_path).name}"
    return result, summary, title, output_units(model)


# --------------------------------------------------------------------------- diagnosis
def _diagnosis_figure(result: ChangeResult, j: int, output: str, unit: str | None):
    f = result.fits
    lines = [
        (f["measured"][:, j], "k", "measured"),
        (f["reference"][:, j], "C0", "reference parameters"),
        (f["refitted"][:, j], "C3", "changed parameters refitted"),
    ]
    return _trace_figure(f["time"], lines, output, unit)


def _diagnosis_text(summary: dict) -> str:
    fit = summary["fit"]
    head = (
        f"RMSE on the recording with the reference parameters "
        f"{fit['rmse_reference_params']:.4g}, with every free parameter refitted "
        f"{fit['rmse_refitted']:.4g} (the reference fit on its own recording: "
        f"{fit['rmse_reference']:.4g})."
    )
    if summary["verdict"] == "no change":
        return f"Verdict: no change. No free parameter must move significantly. {head}"
    if summary["verdict"] == "unattributed":
        first = sorted(summary["parameters"], key=lambda r: -r["share"])[:3]
        shares = ", ".join(f"{r['parameter']} {r['share']:.2f}" for r in first)
        return (
            "Verdict: changed, not attributed. Refitting every free parameter lowers "
            "the RMSE markedly, but no single parameter is necessary to the change "
            "(each held, the others make up for it): it is spread over several at "
            "once, or lies outside what the free parameters express (largest shares "
            f"alone: {shares}). " + head
        )
    parts = [
        f"{c['parameter']} {c['reference']:.4g} -> {c['value']:.4g} "
        f"(95 % interval {c['interval'][0]:.4g} to {c['interval'][1]:.4g}; explains "
        f"{100 * c['share']:.0f} % of the mismatch alone; held at its reference value "
        f"with every other refitted, {100 * c.get('necessity', 0.0):.0f} % is left "
        "that its move removes)"
        for c in summary["changed_parameters"]
    ]
    return f"Verdict: changed. {'; '.join(parts)}. {head}"


def _run_diagnosis(model_path, data_path, reference_path, out_dir, json_path, timeout):
    inputs = [model_path, data_path, reference_path]
    with OutputRun(out_dir, "mismatch", inputs=inputs, json_path=json_path) as run:
        reference = _read(reference_path, "reference")
        data = _read(data_path, "data")
        model = load_model_file(model_path, data=reference, model_timeout=timeout)
        result = diagnose_change(model, data, reference)
        d = result.to_dict()
        summary = to_jsonable(
            {
                "mode": "diagnosis",
                "verdict": d["verdict"],
                "changed_parameters": d["changed_parameters"],
                "parameters": d["parameters"],
                "fit": {
                    k: d[k]
                    for k in (
                        "rmse_reference_params",
                        "rmse_refitted",
                        "rmse_reference",
                        "decimated",
                        "outputs",
                    )
                },
                "sources": {
                    "model": os.fspath(model_path),
                    "data": os.fspath(data_path),
                    "reference": os.fspath(reference_path),
                },
            }
        )
        title = (
            f"Diagnosis by mismatch: {Path(data_path).name} against "
            f"{Path(reference_path).name}"
        )
        rep = Report(title)
        rep.add_heading("Verdict")
        rep.add_text(_diagnosis_text(summary))
        rep.add_text(
            f"Model {Path(model_path).name}; its free parameters were fitted on the "
            "reference recording, then refitted on this one: all together, each alone "
            "(the share of the mismatch it explains), and all but each. A parameter "
            "has changed when it is necessary: held at its reference value with every "
            "other refitted, at least 20 % of the mismatch left is what its move "
            "removes, significantly."
        )
        rep.add_heading("Both fits")
        units = output_units(model)
        for j, o in enumerate(result.outputs):
            rep.add_figure(
                _diagnosis_figure(result, j, o, units.get(o)),
                caption=f"{o}: measured (black), the reference parameters (blue), every "
                "free parameter refitted (red). " + envelope_note(len(result.fits["time"])),
            )
        rep.add_heading("Every free parameter")
        rep.add_table(
            result.to_pandas(),
            caption="reference: fitted on the reference recording; value: refitted "
            "alone on this one, with its 95 % interval (low, high); share: the part of "
            "the mismatch it explains alone; necessity: the part of the mismatch left "
            "with it held (every other refitted) that its move removes.",
        )
        # the candidates of a diagnosis: every free parameter, changed or not
        run.add_csv("candidates.csv", result.to_pandas(), index=False)
        run.add_report("report.html", rep)
        run.add_json("summary.json", summary)
        run.commit()
    return summary
