"""pdmkit.models.ident: linear and block-oriented system identification from records.

Polynomial models by least squares (:func:`ar`, :func:`arx`) and by prediction-error
minimisation (:func:`armax`, :func:`oe`, :func:`bj`), state-space models by subspace
identification (:func:`n4sid`), the order by AIC/BIC/MDL (:func:`select_order`,
:func:`identify`, which grows its search past the edge of the range); every one returns
an :class:`IdentifiedModel` (poles, :func:`physical_modes`, simulation, prediction,
residual tests). Recursive ARX with pole tracking over time (:class:`RecursiveARX`,
:func:`track_poles`; from the rotor-diagnostics monograph) and Hammerstein-Wiener models
(:class:`HammersteinWiener`; Voronin's thesis, section 8.2). Identification in closed
loop, as the S-Mobile paper does it: :func:`direct_identification`,
:func:`indirect_identification` (the :class:`KnownController` removed),
:func:`joint_identification` and the nonparametric :func:`closed_loop_frf`, each plant a
:class:`ClosedLoopModel`. Ljung, *System Identification*, 2nd ed., 1999.

Examples
--------
>>> import numpy as np
>>> from scipy import signal
>>> from pdmkit.models.ident import arx
>>> rng = np.random.default_rng(0)
>>> u = rng.standard_normal(2000)
>>> y = signal.lfilter([0, 0.5], [1, -1.5, 0.7], u)
>>> np.round(arx(u, y, 2, 1, 1).A, 3).tolist()
[1.0, -1.5, 0.7]
"""

from pdmkit.models.ident._arx import ar, arx
from pdmkit.models.ident._closed_loop import (
    ClosedLoopModel,
    KnownController,
    closed_loop_frf,
    direct_identification,
    indirect_identification,
    joint_identification,
)
from pdmkit.models.ident._hammerstein import (
    DeadZone,
    HammersteinWiener,
    Identity,
    PiecewiseLinear,
    Polynomial,
    Saturation,
    nonlinearity,
)
from pdmkit.models.ident._model import (
    CANCEL_TOL,
    CRITERIA,
    IdentifiedModel,
    fit_percent,
    modes_from_poles,
    physical_modes,
)
from pdmkit.models.ident._order import STRUCTURES, OrderSelection, identify, select_order
from pdmkit.models.ident._pem import armax, bj, oe
from pdmkit.models.ident._recursive import (
    PoleTracks,
    RecursiveARX,
    smooth_tracks,
    track_poles,
)
from pdmkit.models.ident._statespace import ss_predict, ss_simulate
from pdmkit.models.ident._subspace import n4sid, stabilise_matrix

__all__ = [
    "CANCEL_TOL",
    "CRITERIA",
    "STRUCTURES",
    "ClosedLoopModel",
    "DeadZone",
    "HammersteinWiener",
    "IdentifiedModel",
    "Identity",
    "KnownController",
    "OrderSelection",
    "PiecewiseLinear",
    "PoleTracks",
    "Polynomial",
    "RecursiveARX",
    "Saturation",
    "ar",
    "armax",
    "arx",
    "bj",
    "closed_loop_frf",
    "direct_identification",
    "fit_percent",
    "identify",
    "indirect_identification",
    "joint_identification",
    "modes_from_poles",
    "n4sid",
    "nonlinearity",
    "oe",
    "physical_modes",
    "select_order",
    "smooth_tracks",
    "ss_predict",
    "ss_simulate",
    "stabilise_matrix",
    "track_poles",
]
