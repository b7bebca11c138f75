"""The child-process check of a model file, and the messages it shares with the loader.

A model file is user code. Before :func:`~pdmkit.models.ode.load_model_file` runs it in
pdmkit's own process, :func:`_check_in_child` imports it and evaluates ``rhs`` in a
bare child interpreter (``python -I``, its own session) with a time limit: the child
reads one JSON job line on stdin, reports on a private copy of its stdout one line per
stage and one result line (``ok``, ``exit`` or ``raised``), and is killed with all it
started when the time is up or pdmkit is interrupted. Every failure there becomes a
:class:`~pdmkit.errors.ModelError` that names the file, the stage and the fix.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import signal
import subprocess
import sys
import threading
from typing import Any

import numpy as np

from pdmkit.errors import ModelError

__all__ = ["MODEL_TIMEOUT"]


def _where(origin: str | None) -> str:
    """How messages name the model: ``model file <path>``, or ``model``."""
    return f"model file {origin}" if origin and origin.endswith(".py") else "model"


# --------------------------------------------------------------------------- exit messages
def _exit_status(code: object) -> int:
    """The process exit status ``sys.exit(code)`` would give."""
    if code is None:
        return 0
    return int(code) if isinstance(code, int) else 1


def _exit_message(where: str, code: object, what: str, frame: str = "") -> str:
    said = "" if code is None or isinstance(code, int) else f" with {str(code)[:200]!r}"
    return (
        f"{where} called exit (status {_exit_status(code)}{said}) while {what}{frame}; a "
        "model file must define the model and return, never end the program: remove the "
        "sys.exit / os._exit / quit() call."
    )


# --------------------------------------------------------------------------- child check
#: How many of the data's first samples ``rhs`` is evaluated on before any fit.
_N_FIRST = 5

#: Default time limit (s) for importing a model file and evaluating ``rhs`` in the child.
MODEL_TIMEOUT = 30.0

_STAGES = {
    "start": "starting the Python process that checks it",
    "import": "running the file (its top level)",
    "rhs": "evaluating rhs at the initial state (all inputs 0, then the data's first "
    "input samples)",
    "arrays": "evaluating rhs on numpy arrays at the initial state",
}


def _first_rows(data: Any, n: int = _N_FIRST) -> list[dict[str, float]]:
    """The first ``n`` rows of a table as dicts column -> finite float (others left out)."""
    if data is None:
        return []
    try:
        columns = list(data.columns) if hasattr(data, "columns") else list(data.keys())
    except (AttributeError, TypeError):
        return []
    rows: list[dict[str, float]] = []
    for c in columns:
        if not isinstance(c, str):
            continue
        try:
            col = data[c]
            col = col.iloc[:n] if hasattr(col, "iloc") else col[:n]
            v = np.asarray(col).astype(np.float64)
        except (TypeError, ValueError, KeyError, IndexError):
            continue
        if v.ndim != 1:
            continue
        rows += [{} for _ in range(v.size - len(rows))]
        for i, x in enumerate(v.tolist()):
            if math.isfinite(x):
                rows[i][c] = x
    return rows


# The child: a bare interpreter (no pdmkit, no numpy unless the model imports it) that
# imports the model file and calls rhs with the arguments pdmkit's own check passes,
# then reports on a private copy of its stdout, one line per stage and one result line.
_CHILD = r"""
import json, math, os, sys
from collections.abc import Mapping

_res = os.fdopen(os.dup(1), "w", encoding="utf-8")
os.dup2(2, 1)  # what the model prints goes to stderr, never into the report


def _say(kind, payload=None):
    _res.write(kind + " " + json.dumps(payload) + "\n")
    _res.flush()


def _watch_parent():
    # the parent holds stdin open while it waits: end of file means it is gone
    try:
        while os.read(0, 4096):
            pass
    except OSError:
        pass
    os._exit(70)


def _frame(exc, origin):
    import traceback

    for f in reversed(traceback.extract_tb(exc.__traceback__)):
        if f.filename == origin:
            return [f.lineno, (f.line or "").strip()]
    return None


def _text(obj):
    try:
        return str(obj)[:2000]
    except Exception:
        return "<unprintable>"


def _float(v):
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(v)
    return v


def _n_args(f):
    code = getattr(f, "__code__", None)
    plain = type(f) is type(_float) and not hasattr(f, "__wrapped__")
    if code is not None and plain and not hasattr(f, "__signature__"):
        return (code.co_argcount + code.co_kwonlyargcount + bool(code.co_flags & 4)
                + bool(code.co_flags & 8))
    import inspect

    try:
        return len(inspect.signature(f).parameters)
    except (TypeError, ValueError):
        return 4


def _plan(ns, rows):
    # rhs's arguments as pdmkit's own checks pass them; None when the contract is too
    # broken for pdmkit to get as far as calling rhs (it then says so without calling it)
    try:
        rhs, states, params = ns["rhs"], ns["STATES"], ns["PARAMS"]
        inputs, initial = ns.get("INPUTS", {}), ns.get("INITIAL")
        initial = {} if initial is None else initial
        maps = (states, inputs, params, initial)
        if not callable(rhs) or not all(isinstance(m, Mapping) for m in maps):
            return None
        if _n_args(rhs) != 4:
            return None
        x0 = {k: _float(initial.get(k, 0.0)) for k in states}
        p = {k: _float(v) for k, v in params.items()}
        names = list(inputs)
    except Exception:
        return None
    used = [r for r in rows if all(k in r for k in names)]
    calls = [(0.0, {k: 0.0 for k in names})]
    calls += [(r.get("time", 0.0), {k: r[k] for k in names}) for r in used]
    return rhs, x0, p, names, calls, used


def _main():
    job = json.loads(sys.stdin.buffer.readline())
    sys.stdin = open(os.devnull)  # input() in the model ends at once
    import _thread

    _thread.start_new_thread(_watch_parent, ())
    sys.path[:] = job["path"]
    origin = job["origin"]
    stage, plan, fn_name = "import", None, "rhs"
    _say("stage", stage)
    try:
        ns = {"__name__": "pdmkit_user_model", "__file__": origin}
        exec(compile(job["source"], origin, "exec"), ns)
        plan = _plan(ns, job["rows"])
        if plan is not None:
            rhs, x0, p, names, calls, used = plan
            stage = "rhs"
            _say("stage", stage)
            out = ns.get("outputs")
            fns = [rhs] + ([out] if callable(out) and _n_args(out) == 4 else [])
            for fn_name, f in zip(("rhs", "outputs"), fns):
                for t, u in calls:
                    f(t, dict(x0), u, dict(p))
            np = sys.modules.get("numpy")
            if np is not None:  # numpy is loaded anyway: pdmkit's batches too
                stage = "arrays"
                _say("stage", stage)
                batches = [(3, 0.0, {k: np.zeros(3) for k in names})]
                if used:
                    u = {k: np.array([r[k] for r in used]) for k in names}
                    batches.append((len(used), used[0].get("time", 0.0), u))
                for fn_name, f in zip(("rhs", "outputs"), fns):
                    for n, t, u in batches:
                        xb = {k: np.full(n, v) for k, v in x0.items()}
                        pb = {k: np.full(n, v) for k, v in p.items()}
                        try:
                            f(t, xb, u, pb)
                        except (TypeError, ValueError, ArithmeticError):
                            # written for numbers: pdmkit calls it once per member
                            for i in range(n):
                                f(t, {k: float(v[i]) for k, v in xb.items()},
                                  {k: float(v[i]) for k, v in u.items()},
                                  {k: float(v[i]) for k, v in pb.items()})
    except SystemExit as exc:
        code = exc.code
        said = None if code is None or isinstance(code, int) else _text(code)
        status = 0 if code is None else code if isinstance(code, int) else 1
        _say("exit", {"stage": stage, "code": said if said is not None else status,
                      "frame": _frame(exc, origin)})
    except BaseException as exc:
        _say("raised", {"stage": stage, "fn": fn_name, "type": type(exc).__name__,
                        "message": _text(exc), "frame": _frame(exc, origin)})
    else:
        _say("ok", {"called_rhs": plan is not None})
    _res.close()
    os._exit(0)


_main()
"""


def _check_timeout(model_timeout: Any) -> float | None:
    if model_timeout is None:
        return None
    ok = isinstance(model_timeout, numbers.Real) and not isinstance(model_timeout, bool)
    if not ok or not (0 < model_timeout < math.inf):
        raise ModelError(
            "model_timeout (--model-timeout) must be a positive number of seconds, e.g. "
            f"30; got {model_timeout!r}."
        )
    return float(model_timeout)


def _kill_child(proc: subprocess.Popen) -> None:
    """Kill the child and everything in its session (it started one of its own)."""
    if os.name == "posix":
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    try:
        proc.kill()
    except OSError:
        pass
    proc.wait()


def _frame_text(frame: Any) -> str:
    if not frame:
        return ""
    line, code = frame
    return f" (line {line}:{f' `{code}`' if code else ''})"


def _check_in_child(
    source: str, origin: str, rows: list[dict[str, float]], timeout: float
) -> None:
    """Import the file and evaluate ``rhs`` in a child process with a time limit.

    Raises :class:`ModelError` when it does not return in time (the child and what it
    started are killed), calls exit, crashes or raises.
    """
    where = _where(origin)
    if not sys.executable:
        raise ModelError(
            f"{where}: cannot start a Python process to check it (sys.executable is "
            "empty); pass model_timeout=None to load it in this process unchecked."
        )
    job = {
        "source": source,
        "origin": origin,
        "path": [p for p in sys.path if isinstance(p, str)],
        "rows": rows,
    }
    lines, timed_out, rc = _run_child(where, job, timeout)
    stage, result = _child_report(lines)
    what = _STAGES.get(stage, stage)
    if stage == "rhs" and not rows:
        what = "evaluating rhs at the initial state with all inputs 0"
    if timed_out:
        raise ModelError(
            f"{where} did not return within {timeout:g} s while {what}; look there for "
            "an endless loop or a call that waits (input(), a lock, a network request). "
            "If the file is only slow, give it more time: --model-timeout SECONDS on "
            "the command line, model_timeout= in Python."
        )
    if result is None:
        raise ModelError(_no_result_message(where, what, stage, rc))
    _raise_reported_failure(where, what, *result)


def _run_child(where: str, job: dict, timeout: float) -> tuple[list[bytes], bool, Any]:
    """Start the child, send it the job, wait up to ``timeout``; kill it if still there.

    Returns the lines it wrote on its report channel, whether it timed out, and its
    exit status.
    """
    extra: dict[str, Any] = (
        {"start_new_session": True}
        if os.name == "posix"
        else {"creationflags": getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0)}
    )
    cmd = [sys.executable, "-I", "-W", "ignore::SyntaxWarning", "-c", _CHILD]
    try:
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, **extra)
    except OSError as exc:
        raise ModelError(
            f"{where}: cannot start the Python process that checks it ({exc})."
        ) from exc
    lines: list[bytes] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    timed_out = False
    try:
        try:
            proc.stdin.write(json.dumps(job).encode("utf-8") + b"\n")
            proc.stdin.flush()
        except OSError:
            pass  # the child is gone already; its exit status says why
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            timed_out = True
    finally:
        if proc.poll() is None:  # timed out, or this process was interrupted
            _kill_child(proc)
        try:
            proc.stdin.close()
        except OSError:
            pass
        reader.join(5.0)
        if not reader.is_alive():
            proc.stdout.close()
    return list(lines), timed_out, proc.returncode


def _child_report(lines: list[bytes]) -> tuple[str, tuple[str, Any] | None]:
    """The last stage the child reached and its result line ``(kind, payload)``, if any."""
    stage, result = "start", None
    for raw in lines:
        kind, _, text = raw.decode("utf-8", "replace").partition(" ")
        try:
            payload = json.loads(text)
        except ValueError:
            continue
        if kind == "stage":
            stage = payload
        elif kind in ("ok", "exit", "raised"):
            result = (kind, payload)
    return stage, result


def _no_result_message(where: str, what: str, stage: str, rc: Any) -> str:
    """Why a child that wrote no result line ended: a signal, a failed start, an exit."""
    if rc is not None and rc < 0:
        try:
            sig = signal.Signals(-rc).name
        except ValueError:
            sig = str(-rc)
        return (
            f"{where}: the Python process checking it was killed by signal {sig} "
            f"while {what} (a crash in compiled code it calls, or memory exhausted)."
        )
    if stage == "start":
        return (
            f"{where}: the Python process that checks it ({sys.executable}) ended "
            f"with status {rc} before running the file; see its message above, or "
            "pass model_timeout=None to load the file in this process unchecked."
        )
    return _exit_message(where, 0 if rc is None else rc, what)


def _raise_reported_failure(where: str, what: str, kind: str, info: Any) -> None:
    """Raise for a child that reported an exit or an exception (``ok``: return)."""
    frame = _frame_text(info.get("frame"))
    if kind == "exit":
        raise ModelError(_exit_message(where, info.get("code"), what, frame))
    if kind == "raised":
        if info.get("stage") == "import":
            raise ModelError(
                f"{where}: running the file raised {info['type']}: {info['message']}"
                f"{frame}."
            )
        raise ModelError(
            f"{where}: {info.get('fn', 'rhs')} raised {info['type']}: "
            f"{info['message']}{frame} "
            f"while {what}. rhs and outputs may use arithmetic, numpy's element-wise "
            "functions, or math / if / max on plain numbers (docs/mismatch.md, 'The model "
            "file')."
        )
