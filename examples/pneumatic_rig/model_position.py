"""The rig's model (model_numpy.py) with the lever position as its only output.

Model files are Python code, run with your rights: this one runs model_numpy.py beside it.
"""

import pathlib

_here = pathlib.Path(__file__).resolve().parent / "model_numpy.py"
exec(compile(_here.read_text(), str(_here), "exec"))

OUTPUTS = {"LeverPosition": "position"}
_all_outputs = outputs  # noqa: F821 (defined by model_numpy.py)


def outputs(t, x, u, p):
    """The lever's encoder alone."""
    return {"LeverPosition": _all_outputs(t, x, u, p)["LeverPosition"]}
