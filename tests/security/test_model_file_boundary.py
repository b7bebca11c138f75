"""The model-file boundary of `pdmkit mismatch`: a model file is code, run with a limit.

A model file is Python by design, so it may do anything its user can. What pdmkit
promises (docs/mismatch.md, "Model files are code") is the boundary around its first
load: the file is imported and ``rhs`` evaluated on the data's first samples in a child
process with a time limit, so a hang becomes an error within the limit (the child and
what it started are killed), an exit becomes a one-line error with a non-zero status
instead of a silent success, and an exception names the file and the line. A file that
writes at import is allowed to (it is code) and its top level runs twice: once in the
child check, once in pdmkit's process.
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import ModelError
from pdmkit.experiments._cli import main
from pdmkit.models import load_model_file

TANKS = """
STATES = {"h1": "level", "h2": "level"}
INPUTS = {"u": "voltage"}
OUTPUTS = ["h1", "h2"]
PARAMS = {"b": 0.0016, "k1": 0.015, "k2": 0.015}
FREE = ["b"]
INITIAL = {"h1": 0.1, "h2": 0.1}


def rhs(t, x, u, p):
    q1 = p["k1"] * abs(x["h1"]) ** 0.5
    q2 = p["k2"] * abs(x["h2"]) ** 0.5
    return {"h1": p["b"] * u["u"] - q1, "h2": q1 - q2}
"""
RHS_BODY = '    q1 = p["k1"] * abs(x["h1"]) ** 0.5\n'


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A clean two-tank recording (forward Euler of the model above, 2 s steps)."""
    n, dt = 300, 2.0
    u = np.where((np.arange(n) // 40) % 2 == 0, 6.0, 3.0)
    h = np.empty((n, 2))
    h1 = h2 = 0.1
    for i in range(n):
        h[i] = h1, h2
        q1, q2 = 0.015 * np.sqrt(h1), 0.015 * np.sqrt(h2)
        h1, h2 = h1 + dt * (0.0016 * u[i] - q1), h2 + dt * (q1 - q2)
    path = tmp_path_factory.mktemp("rec") / "data.csv"
    table = pd.DataFrame({"time": np.arange(n) * dt, "u": u, "h1": h[:, 0], "h2": h[:, 1]})
    table.to_csv(path, index=False)
    return path


def _model(tmp_path, text: str, name: str = "model.py"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _with_rhs_line(line: str) -> str:
    """TANKS with ``line`` as the first statement of rhs."""
    return TANKS.replace(RHS_BODY, f"    {line}\n{RHS_BODY}")


def _mismatch(tmp_path, model, data, *extra) -> tuple[int, float]:
    out = tmp_path / "out"
    args = ["mismatch", model, data, "--effects", "sensor_offset", "--out", out]
    args += ["--json", tmp_path / "verdict.json", *extra]
    start = time.perf_counter()
    code = main([str(a) for a in args])
    return code, time.perf_counter() - start


def _gone(pid: int, wait: float = 5.0) -> bool:
    """Whether a process has ended (a zombie waiting for its reaper counts as ended)."""
    deadline = time.monotonic() + wait
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] == "Z":
                    return True
        except (FileNotFoundError, IndexError):
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)


def _assert_failed_cleanly(tmp_path, code, capsys, needle):
    err = capsys.readouterr().err
    assert code != 0
    lines = err.strip().splitlines()
    assert len(lines) == 1, err  # one line, no traceback
    assert "error:" in lines[0] and needle in lines[0]
    assert "verdict" not in err  # no success message
    assert not (tmp_path / "out" / "report.html").exists()
    assert not (tmp_path / "verdict.json").exists()
    return lines[0]


def test_the_plain_model_file_runs(tmp_path, recording, capsys):
    code, _ = _mismatch(tmp_path, _model(tmp_path, TANKS), recording)
    assert code == 0
    assert "verdict:" in capsys.readouterr().err
    assert (tmp_path / "out" / "report.html").is_file()


@pytest.mark.skipif(sys.platform == "win32", reason="process groups and /proc are POSIX")
def test_a_hanging_model_file_is_stopped_within_the_timeout(tmp_path, recording, capsys):
    pids = tmp_path / "pids.txt"
    text = (
        "import os, subprocess, sys\n"
        "sleep = [sys.executable, '-c', 'import time; time.sleep(120)']\n"
        "helper = subprocess.Popen(sleep)\n"
        f"open({str(pids)!r}, 'w').write(f'{{os.getpid()}} {{helper.pid}}')\n"
        "while True:\n"
        "    pass\n" + TANKS
    )
    code, took = _mismatch(
        tmp_path, _model(tmp_path, text), recording, "--model-timeout", "2"
    )
    line = _assert_failed_cleanly(tmp_path, code, capsys, "did not return within 2 s")
    assert "model.py" in line and "running the file" in line and "--model-timeout" in line
    assert 2.0 <= took < 12.0
    # the child and the process it started are killed: nothing is left running
    child, helper = (int(p) for p in pids.read_text().split())
    assert child != os.getpid()
    assert _gone(child) and _gone(helper)


def test_an_rhs_that_hangs_is_reported_with_its_stage(tmp_path, recording):
    path = _model(tmp_path, _with_rhs_line("while u['u'] > 5.0: pass"))
    data = pd.read_csv(recording)
    start = time.perf_counter()
    with pytest.raises(ModelError, match=r"model.py did not return within 2 s while "
                       r"evaluating rhs.*first input samples"):  # fmt: skip
        load_model_file(path, data=data, model_timeout=2)
    assert time.perf_counter() - start < 12.0


@pytest.mark.parametrize(
    ("call", "status"),
    [
        ("import sys; sys.exit(0)", 0),
        ("import os; os._exit(0)", 0),
        ("quit()", 0),
        ("raise SystemExit(3)", 3),
    ],
)
def test_exit_at_import_is_a_one_line_error_not_a_success(
    tmp_path, recording, capsys, call, status
):
    code, _ = _mismatch(tmp_path, _model(tmp_path, call + "\n" + TANKS), recording)
    line = _assert_failed_cleanly(
        tmp_path, code, capsys, f"model.py called exit (status {status}) while running"
    )
    if "os._exit" not in call:  # a SystemExit has a traceback: its line is shown
        assert "(line 1:" in line


def test_exit_in_rhs_on_the_data_is_caught_by_the_child(tmp_path, recording, capsys):
    # the second sample of the data has u = 6 and t = 2 s: only the data reach this line
    text = _with_rhs_line("import sys\n    if t > 1.0: sys.exit(0)")
    code, _ = _mismatch(tmp_path, _model(tmp_path, text), recording)
    line = _assert_failed_cleanly(tmp_path, code, capsys, "called exit (status 0)")
    assert "evaluating rhs" in line and "(line 12:" in line


def test_exit_in_rhs_during_the_fit_is_an_error_not_a_success(tmp_path, recording, capsys):
    # beyond the first samples (t > 100 s) only the in-process fit gets here
    text = _with_rhs_line("import sys\n    if t > 100.0: sys.exit(0)")
    code, _ = _mismatch(tmp_path, _model(tmp_path, text), recording)
    line = _assert_failed_cleanly(tmp_path, code, capsys, "called exit (status 0)")
    assert "while pdmkit was evaluating rhs" in line


def test_a_model_file_that_writes_a_file_at_import_runs(tmp_path, recording, capsys):
    log = tmp_path / "imported.txt"
    text = f"open({str(log)!r}, 'a').write('imported\\n')\n" + TANKS
    code, _ = _mismatch(tmp_path, _model(tmp_path, text), recording)
    assert code == 0 and "verdict:" in capsys.readouterr().err
    # documented: it is code, so it may; its top level ran in the child check and then
    # in pdmkit's process
    assert log.read_text().splitlines() == ["imported", "imported"]


def test_exceptions_name_the_file_and_the_line(tmp_path, recording):
    data = pd.read_csv(recording)
    path = _model(tmp_path, "x = 1\nraise RuntimeError('boom')\n" + TANKS)
    with pytest.raises(ModelError, match=r"model.py: running the file raised "
                       r"RuntimeError: boom \(line 2:"):  # fmt: skip
        load_model_file(path, data=data)
    # raises only on the data's inputs (u > 5), never at inputs 0
    path = _model(tmp_path, _with_rhs_line("assert u['u'] < 5.0, 'pump too fast'"))
    with pytest.raises(ModelError, match=r"model.py: rhs raised AssertionError: pump "
                       r"too fast \(line 11:.*first input samples"):  # fmt: skip
        load_model_file(path, data=data)


def test_rhs_is_checked_finite_on_the_first_samples(tmp_path, recording):
    # u * 1e308 * 1e308 is 0 at inputs 0 and inf at u = 6 (no exception in Python)
    text = TANKS.replace('p["b"] * u["u"] - q1', 'p["b"] * u["u"] * 1e308 * 1e308 - q1')
    path = _model(tmp_path, text)
    data = pd.read_csv(recording)
    with pytest.raises(ModelError, match=r"derivative of 'h1' is inf at the initial "
                       r"state .* input sample 0 \(time 0 s, u=6\)"):  # fmt: skip
        load_model_file(path, data=data)
    load_model_file(path)  # inputs 0 only: finite


def test_prints_and_input_do_not_break_or_block_the_check(tmp_path):
    path = _model(tmp_path, "print('hello from the model')\n" + TANKS)
    assert load_model_file(path, model_timeout=10).outputs == ["h1", "h2"]
    path = _model(tmp_path, "answer = input('size? ')\n" + TANKS)
    start = time.perf_counter()
    with pytest.raises(ModelError, match="running the file raised EOFError"):
        load_model_file(path, model_timeout=10)
    assert time.perf_counter() - start < 5.0


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf"), "30", True])
def test_the_timeout_must_be_a_positive_number(tmp_path, bad):
    with pytest.raises(ModelError, match="model_timeout"):
        load_model_file(_model(tmp_path, TANKS), model_timeout=bad)


def test_the_help_says_a_model_file_is_code(capsys):
    with pytest.raises(SystemExit):
        main(["mismatch", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "MODEL_FILE is Python code, run with your rights" in text
    assert "Trust it like code you would run" in text
    assert "--model-timeout SECONDS" in text
