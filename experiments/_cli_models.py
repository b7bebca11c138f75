"""The model commands: ``identify`` (a linear model from a record), ``mismatch``."""

from __future__ import annotations

import argparse
from pathlib import Path

from pdmkit.experiments._cli_common import add_output_options, positive_seconds, say

__all__ = ["IDENTIFY_CHOICES", "add_parsers"]


#: ``identify --structure`` choices shown by ``--help``, named here so that the help
#: does not import the models (a test checks they are ``IDENTIFY_STRUCTURES``' keys)
IDENTIFY_CHOICES = ("ar", "arx", "armax", "oe", "bj", "n4sid", "hw", "fractional")


def _cmd_mismatch(args: argparse.Namespace) -> int:
    from pdmkit.experiments._mismatch import run_mismatch

    effects = None
    if args.effects:
        effects = [e.strip() for e in args.effects.split(",") if e.strip()]
    summary = run_mismatch(
        args.model_file,
        args.data,
        validation_path=args.validation,
        out_dir=args.out,
        json_path=args.json,
        effects=effects,
        model_timeout=args.model_timeout,
        input_hold=args.input_hold,
        max_seconds=args.max_seconds,
        reference_path=args.reference,
    )
    if args.reference is not None:
        changed = summary["changed_parameters"]
        said = (
            ", ".join(
                f"{c['parameter']} {c['reference']:.4g} -> {c['value']:.4g}"
                for c in changed
            )
            or "no free parameter moved significantly"
        )
        say(f"diagnosis: {summary['verdict']} ({said}). See {args.out}/report.html")
        return 0
    verdict = summary["verdict"]
    say(f"verdict: {verdict['headline']}. {verdict['physics']} See {args.out}/report.html")
    return 0


def _cmd_identify(args: argparse.Namespace) -> int:
    from pdmkit.experiments._identify import run_identify
    from pdmkit.experiments._identify_report import format_fit, format_hz

    summary = run_identify(
        args.data,
        input=args.input,
        output=args.output,
        structure=args.structure,
        order=args.order,
        out_dir=args.out,
        json_path=args.json,
        fs=args.fs,
        criterion=args.criterion,
        band=args.band,
        decimate=args.decimate,
    )
    for key in ("decimation", "band", "order_search"):
        part = summary.get(key) or {}
        if part.get("note") and not part.get("at_edge"):  # at the edge: a warning
            say(part["note"])
    modes = format_hz(summary.get("natural_frequencies_hz"))
    dropped = len(summary.get("not_modes") or [])
    say(
        f"{summary['structure']} {summary['order']}: fit "
        f"{format_fit(summary.get('fit_percent'), 1)}"
        f"{' in the band' if summary.get('band') else ''}"
        f"{'; modes ' + modes if modes else ''}"
        f"{f' ({dropped} pole(s) that are not modes in not_modes)' if dropped else ''}"
        f"; see {args.out}/report.html"
    )
    return 0


def add_parsers(sub: argparse._SubParsersAction) -> None:
    """Register ``identify`` and ``mismatch``."""
    _add_identify_parser(sub)
    _add_mismatch_parser(sub)


def _add_identify_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify",
        help="identify a model (poles, resonances, damping) from an input/output record",
        description="Identify a linear (ar, arx, armax, oe, bj, n4sid), "
        "Hammerstein-Wiener (hw) or fractional-order model from a CSV/Parquet table "
        "or a .mat/.npz file.",
    )
    p.add_argument(
        "data", type=Path, metavar="DATA", help="CSV, Parquet, .mat or .npz recording"
    )
    p.add_argument(
        "--input", required=True, help="input column (.mat/.npz: variable, e.g. Force)"
    )
    p.add_argument(
        "--output",
        required=True,
        help="output column (.mat/.npz: variable; Acceleration2 = 2nd row of a 2-D one)",
    )
    p.add_argument(
        "--structure",
        default="arx",
        metavar="{" + ",".join(IDENTIFY_CHOICES) + "}",
        help="model structure (default arx); checked by the workflow, which also "
        "knows structures added to pdmkit.experiments._identify.IDENTIFY_STRUCTURES",
    )
    p.add_argument(
        "--order", default=None, help="4, or na=4,nb=3,nk=1 (default: by --criterion)"
    )
    p.add_argument(
        "--criterion",
        default="aic",
        choices=["aic", "bic", "mdl"],
        help="order selection criterion when --order is not given (default aic)",
    )
    p.add_argument("--fs", type=float, help="sampling rate (Hz) when there is no time")
    p.add_argument(
        "--band",
        metavar="F1,F2",
        help="band of interest in Hz: fit and modes focus on it (decimates "
        "automatically when it lies far below Nyquist)",
    )
    p.add_argument(
        "--decimate",
        type=int,
        metavar="N",
        help="decimate by N first (anti-aliased); 1 turns automatic decimation off",
    )
    add_output_options(p, "results/identify")
    p.set_defaults(func=_cmd_identify)


def _add_mismatch_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "mismatch",
        help="locate and explain where a model file and a recording differ",
        description="Fit MODEL_FILE to DATA, locate the residual, try the candidate "
        "physics and name the effect the model left out. MODEL_FILE is Python code, run "
        "with your rights: it can do anything you can (read, write and delete files, "
        "start programs). Trust it like code you would run. It is first imported and "
        "its rhs evaluated on DATA's first samples in a child process limited to "
        "--model-timeout seconds (a hang or an exit there is an error), then run in "
        "this process.",
    )
    p.add_argument(
        "model_file",
        type=Path,
        metavar="MODEL_FILE",
        help="model file (.py): Python code, run with your rights",
    )
    p.add_argument("data", type=Path, metavar="DATA", help="CSV or Parquet recording")
    p.add_argument(
        "--validation",
        type=Path,
        nargs="+",
        metavar="VALIDATION",
        help="recording(s) for validation only, each from its own initial state "
        "(default: the last third of DATA)",
    )
    p.add_argument(
        "--reference",
        type=Path,
        metavar="HEALTHY",
        help="diagnosis by mismatch: fit the model's free parameters on this healthy "
        "recording, then report which must change to explain DATA "
        "(changed_parameters in the JSON)",
    )
    p.add_argument(
        "--effects", help="comma-separated candidate effect ids to try (default: all)"
    )
    p.add_argument(
        "--model-timeout",
        type=float,
        default=30.0,
        metavar="SECONDS",
        help="time limit for importing MODEL_FILE and evaluating its rhs in the child "
        "check (default 30)",
    )
    p.add_argument(
        "--input-hold",
        default="auto",
        choices=["auto", "zoh", "foh"],
        help="the inputs between samples: zoh held (steps, a digital controller), foh "
        "straight lines (sampled continuous signals); auto (default) decides from the "
        "data: held when most samples repeat the one before",
    )
    p.add_argument(
        "--max-seconds",
        type=positive_seconds,
        default=None,
        metavar="SECONDS",
        help="time budget: when it runs out the fits stop, the optional stages (pairs, "
        "data-driven terms) are skipped and the best verdict so far is reported, marked "
        "as such (default: no limit)",
    )
    add_output_options(p, "results/mismatch")
    p.set_defaults(func=_cmd_mismatch)
