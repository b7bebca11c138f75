"""A Simulink Design Optimization session of the thesis's rig, as a pdmkit CSV.

The thesis author's repository (github.com/xvoron/thesis) keeps one parameter-estimation
session per fault code in ``models/sessions/mesv_<code>.mat``: a MATLAB object
(``sldodialogs.data.SessionData``) whose experiment ``Exp`` holds the recording it was
estimated on. Its two input signals are the valve's commands (``u1`` = outValveHP,
``u2`` = outValveWP) and its outputs the lever's position and velocity and, where
the session held them, both flow meters; each a ``timeseries`` at 1 kHz.

``../../shared/data/pneumatic_rig/session_<code>.csv`` were made from five of them; this
script reads the others the same way (it reproduces ``session_1100220.csv``: the lever
position to 5e-10 m, every column to 5e-8).
Four more codes are in that repository: 1100223 (upper damper), 1100817 (bottom
damper), 1101608 (throttle 2), 1103204 (throttle 1). They are MATLAB files from the
web: mat-io reads them as data, nothing in them runs.

Usage::

    python examples/pneumatic_rig/sdo_session.py mesv_1100223.mat session_1100223.csv
"""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd

#: the session's names of the valve commands -> the rig's
INPUT_NAMES = {"u1": "outValveHP", "u2": "outValveWP"}


def _times(series) -> np.ndarray:
    """A timeseries' sample times: stored, or uniform from its start and increment."""
    p = series.properties
    t = np.ravel(np.asarray(p["Time_"], dtype=float))
    if t.size:
        return t
    info = p["TimeInfo"]
    info = info.properties if hasattr(info, "properties") else info
    t = np.ravel(np.asarray(info["Time_"], dtype=float))
    if t.size:
        return t
    n = int(np.ravel(info["Length"])[0])
    start, step = (float(np.ravel(info[k])[0]) for k in ("Start_", "Increment_"))
    return start + step * np.arange(n)


def _signals(signals) -> dict:
    """``{name: timeseries}`` of a Simulink signal array (or one signal)."""
    items = signals.flat if isinstance(signals, np.ndarray) else [signals]
    out = {}
    for signal in items:
        props = signal.properties
        name = str(np.ravel(props["Name"])[0]) if np.size(props["Name"]) else ""
        out[name or str(np.ravel(props["PropagatedName"])[0])] = props["Values"]
    return out


def session_frame(path: str) -> pd.DataFrame:
    """The recording of a session file: ``time``, the valve commands, the outputs."""
    import matio

    session = matio.load_from_mat(path)["SDOSessionData"].properties["Data"]
    workspace = session["Workspace"].flat[0]["LocalWorkspace"].flat[0]
    exp = workspace["Exp"]
    exp = exp.flat[0] if isinstance(exp, np.ndarray) else exp
    found = {
        **_signals(exp.properties["InputData"]),
        **_signals(exp.properties["OutputData"]),
    }
    columns, time = {}, None
    for name, series in found.items():
        t = _times(series)
        if time is None:
            time = t
        elif t.shape != time.shape or not np.allclose(t, time):
            raise SystemExit(f"{path}: signal {name} has other sample times")
        columns[INPUT_NAMES.get(name, name)] = np.ravel(
            np.asarray(series.properties["Data_"], dtype=float)
        )
    return pd.DataFrame({"time": time, **columns})


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__.split("Usage::")[1])
    session_frame(sys.argv[1]).to_csv(sys.argv[2], index=False)
