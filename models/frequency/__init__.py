"""pdmkit.models.frequency: frequency responses and the models fitted to them.

Rational and grey-box fits, reduction and fractional-order models.

The frequency-domain path of Khatkhate, Ray & Keller (2007), with swept-sine FRFs of a
mass-beam rig, an ``invfreqz`` rational fit and balanced reduction; of the S-Mobile paper,
with FRFs at several excitation amplitudes filtered by coherence and physical parameters
fitted with a coherence-weighted error; and the fractional-order models of the
fractional-calculus paper:

- :func:`frf_estimate` (H1 with coherence), :func:`amplitude_dependence`,
  :func:`frf_comparison` and :func:`align_phase` (model vs data on the same branch);
- :func:`fit_tf`: rational transfer functions in ``s`` or ``z`` (``invfreqs`` /
  ``invfreqz``);
- :func:`fit_frf_params`: physical parameters of a user FRF function;
- :func:`hankel_singular_values`, :func:`balanced_truncation`;
- :class:`FractionalTF`, :func:`fit_fractional_tf`, :func:`fit_fractional_frf`,
  :func:`fit_fractional_simplex` (the fractional-calculus paper's Nelder-Mead on
  ``|G_EETF - G|``),
  :func:`gl_simulate`, :func:`oustaloup`, :class:`FractionalConditionClassifier`.

Frequencies are in Hz in the public arguments (``freq``).

Examples
--------
>>> import numpy as np
>>> from scipy import signal
>>> from pdmkit.models.frequency import frf_estimate
>>> rng = np.random.default_rng(0)
>>> u = rng.standard_normal(20000)
>>> y = signal.lfilter([0.2], [1, -0.8], u)
>>> frf = frf_estimate(u, y, fs=100.0, nperseg=512)
>>> round(float(abs(frf.H[0])), 1)  # the static gain 0.2 / (1 - 0.8)
1.0
"""

from pdmkit.models.frequency._fractional import (
    FractionalTF,
    gl_simulate,
    gl_weights,
    model_distance,
    oustaloup,
)
from pdmkit.models.frequency._fractional_classify import FractionalConditionClassifier
from pdmkit.models.frequency._fractional_fit import (
    FractionalFit,
    fit_fractional_frf,
    fit_fractional_tf,
)
from pdmkit.models.frequency._fractional_simplex import fit_fractional_simplex
from pdmkit.models.frequency._frf import (
    FRF,
    AmplitudeDependence,
    align_phase,
    amplitude_dependence,
    frf_comparison,
    frf_estimate,
)
from pdmkit.models.frequency._greybox import GreyBoxFit, fit_frf_params
from pdmkit.models.frequency._rational import TFFit, fit_tf
from pdmkit.models.frequency._reduction import (
    ReducedModel,
    balanced_truncation,
    hankel_singular_values,
)

__all__ = [
    "FRF",
    "AmplitudeDependence",
    "FractionalConditionClassifier",
    "FractionalFit",
    "FractionalTF",
    "GreyBoxFit",
    "ReducedModel",
    "TFFit",
    "align_phase",
    "amplitude_dependence",
    "balanced_truncation",
    "fit_fractional_frf",
    "fit_fractional_simplex",
    "fit_fractional_tf",
    "fit_frf_params",
    "fit_tf",
    "frf_comparison",
    "frf_estimate",
    "gl_simulate",
    "gl_weights",
    "hankel_singular_values",
    "model_distance",
    "oustaloup",
]
