"""pdmkit.models.ode: user ODE models written as plain Python model files.

A model file states ``STATES`` (with their kinds), ``INPUTS``, ``OUTPUTS``, ``PARAMS``
and ``rhs(t, x, u, p)`` (the contract of ``docs/model_files.md``). Model files are
code: :func:`load_model_file` imports one in a child process with a time limit first,
then in this process; :func:`load_model_source` loads text you wrote yourself.
An :class:`OdeModel` is simulated batched (members on the first axis, numpy or torch
with autograd) by :func:`simulate_ode`; :func:`integrate_batch` is the same integrator
with *augmentations*: added terms that follow the hook protocol of
:class:`pdmkit.models.mismatch.Candidate` (what mismatch discovery fits).
:func:`linearize` gives ``A, B, C, D`` at an operating point by automatic
differentiation; :func:`showcase_model` loads the built-in example model files.

Examples
--------
>>> import numpy as np
>>> from pdmkit.models.ode import showcase_model, simulate_ode
>>> msd = showcase_model("mass_spring_damper")
>>> t = np.arange(100) * 0.01
>>> r = simulate_ode(msd, t, inputs={"F": np.ones(100)})
>>> r.outputs["x"].shape
(1, 100)
"""

from pdmkit.models.ode._compiled_effects import register_effects
from pdmkit.models.ode._linearize import LinearModel, linearize
from pdmkit.models.ode._modelfile import KINDS, OdeModel
from pdmkit.models.ode._modelfile_child import MODEL_TIMEOUT
from pdmkit.models.ode._modelfile_load import load_model_file, load_model_source
from pdmkit.models.ode._response import ResponseData
from pdmkit.models.ode._showcases import SHOWCASE_NAMES, showcase_model, showcase_source
from pdmkit.models.ode._simulate import (
    DERIVATIVE_ATTACH,
    PARAMETER_ATTACH,
    integrate_batch,
    runs_compiled,
    simulate_ode,
    stable_substeps,
    state_jacobians,
)

__all__ = [
    "DERIVATIVE_ATTACH",
    "KINDS",
    "MODEL_TIMEOUT",
    "PARAMETER_ATTACH",
    "SHOWCASE_NAMES",
    "LinearModel",
    "OdeModel",
    "ResponseData",
    "integrate_batch",
    "linearize",
    "load_model_file",
    "load_model_source",
    "register_effects",
    "runs_compiled",
    "showcase_model",
    "showcase_source",
    "simulate_ode",
    "stable_substeps",
    "state_jacobians",
]
