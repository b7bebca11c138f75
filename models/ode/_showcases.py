"""Built-in showcase models, shipped as plain model files (``showcases/*.py``).

A mass-spring-damper, two tanks, the Cascaded Tanks benchmark and a reduced
double-acting pneumatic piston: exactly what a user would write, used by the examples,
the tests and mismatch discovery's concealed cases.
"""

from __future__ import annotations

from importlib import resources

from pdmkit.errors import ModelError
from pdmkit.models.ode._modelfile import OdeModel
from pdmkit.models.ode._modelfile_load import load_model_source

__all__ = ["SHOWCASE_NAMES", "showcase_model", "showcase_source"]

#: the built-in showcase model files (plain model files shipped with the package)
_SHOWCASES = resources.files("pdmkit.models.ode") / "showcases"
SHOWCASE_NAMES: tuple[str, ...] = (
    "cascaded_tanks",
    "mass_spring_damper",
    "pneumatic_piston",
    "two_tanks",
)


def showcase_source(name: str) -> str:
    """The model-file text of a built-in showcase model.

    Parameters
    ----------
    name : {"mass_spring_damper", "two_tanks", "cascaded_tanks", "pneumatic_piston"}

    Returns
    -------
    str

    Examples
    --------
    >>> from pdmkit.models.ode import showcase_source
    >>> "def rhs(t, x, u, p):" in showcase_source("two_tanks")
    True
    """
    if name not in SHOWCASE_NAMES:
        raise ModelError(f"unknown showcase {name!r}; choose from {list(SHOWCASE_NAMES)}.")
    return (_SHOWCASES / f"{name}.py").read_text(encoding="utf-8")


def showcase_model(name: str, **params: float) -> OdeModel:
    """A built-in showcase model as an :class:`OdeModel` (nominal values overridable).

    Examples
    --------
    >>> from pdmkit.models.ode import showcase_model
    >>> showcase_model("mass_spring_damper")
    <OdeModel 'mass_spring_damper': states x(position), v(velocity); ...; free k>
    """
    m = load_model_source(showcase_source(name), name=name)
    return m.with_params(**params) if params else m
