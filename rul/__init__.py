"""Remaining-useful-life models and prognostic metrics (see the RUL issue; not yet built).

The prognostic indicator rankings (monotonicity, trendability, prognosability) already
live in :mod:`pdmkit.features`.
"""

__all__: list[str] = []
