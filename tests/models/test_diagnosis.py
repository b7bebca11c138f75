"""Diagnostic masks (band, delay, hysteresis) and the binary diagnostic matrix."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.diagnosis._masks import DiagnosticMask, DiagnosticMatrix


def test_no_alarm_on_a_stationary_record_of_1e5_samples():
    rng = np.random.default_rng(0)
    history = 50.0 + 0.2 * rng.normal(size=10_000)
    record = 50.0 + 0.2 * rng.normal(size=100_000)
    mask = DiagnosticMask(k=5.0, hysteresis=1.0, delay=10).fit(history)
    # self-tuned centre and spread match the generating Gaussian
    assert mask.centre_ == pytest.approx(50.0, abs=0.01)
    assert mask.spread_ == pytest.approx(0.2, rel=0.03)
    res = mask.evaluate(record)
    assert not res.any_alarm
    # single-sample excursions beyond a 4-sigma band do occur in 1e5 samples
    # (expected 2 * norm.sf(4) * 1e5 = 6.3), the 10-sample delay absorbs them
    tight = DiagnosticMask(k=4.0, delay=10).fit(history).evaluate(record)
    expected = 2 * stats.norm.sf(4.0) * record.size
    assert np.count_nonzero(tight.symptom) == pytest.approx(expected, abs=4 * expected**0.5)
    assert not tight.any_alarm


@pytest.mark.parametrize("delay", [0, 5, 50])
def test_alarm_rises_within_the_delay_after_a_step(delay):
    rng = np.random.default_rng(1)
    x = 50.0 + 0.2 * rng.normal(size=20_000)
    t_step = 12_000
    x[t_step:] += 2.0  # 10 sigma
    mask = DiagnosticMask(k=5.0, delay=delay).fit(x[:5000])
    res = mask.evaluate(x)
    assert res.onsets.tolist() == [t_step + delay]
    assert res.alarm[t_step + delay :].all() and not res.alarm[:t_step].any()


def test_hysteresis_stops_chatter_near_the_limit():
    rng = np.random.default_rng(2)
    # a quantity that settles right on the upper limit 1.0
    x = np.r_[np.zeros(500), 1.0 + 0.05 * rng.normal(size=2000)]
    plain = DiagnosticMask(upper=1.0, delay=2).evaluate(x)
    hyst = DiagnosticMask(upper=1.0, hysteresis=0.3, delay=2).evaluate(x)
    assert plain.onsets.size > 20
    assert hyst.onsets.size == 1
    # and the hysteretic alarm clears once the value is back well inside
    y = np.r_[x, np.zeros(100)]
    out = DiagnosticMask(upper=1.0, hysteresis=0.3, delay=2).evaluate(y)
    assert not out.alarm[-90:].any()
    assert list(out.to_pandas().columns) == ["time", "value", "symptom", "alarm"]


def test_static_lower_limit_and_errors():
    res = DiagnosticMask(lower=0.0).evaluate(np.array([1.0, -1.0, 1.0]))
    assert res.symptom.tolist() == [0, -1, 0] and res.onsets.tolist() == [1]
    with pytest.raises(NotFittedError):
        DiagnosticMask().evaluate(np.zeros(5))
    with pytest.raises(ModelError, match="lower"):
        DiagnosticMask(lower=2.0, upper=1.0).fit()
    with pytest.raises(DataError, match="at least 10"):
        DiagnosticMask().fit(np.zeros(3))


def test_diagnostic_matrix_isolates_and_names_conflicts():
    table = pd.DataFrame(
        [[1, 0, 0], [1, 1, 0], [0, 0, 1]],
        index=["unbalance", "misalignment", "looseness"],
        columns=["f1", "zeta1", "f2"],
    )
    dm = DiagnosticMatrix(table)
    got = dm.diagnose(pd.DataFrame({"f1": [1, 0, 1], "zeta1": [0, 0, 1], "f2": [0, 1, 1]}))
    assert got.tolist() == ["unbalance", "looseness", "unknown"]
    # mask symptoms are signed; any nonzero counts as present
    assert dm.diagnose([-1, 1, 0]).tolist() == ["misalignment"]
    with pytest.raises(ModelError, match="'unbalance' and 'crack' share"):
        DiagnosticMatrix({"unbalance": [1, 0], "crack": [1, 0], "wear": [0, 1]})
    with pytest.raises(ModelError, match="no symptom"):
        DiagnosticMatrix({"a": [0, 0], "b": [1, 0]})
    with pytest.raises(ModelError, match="only 0 and 1"):
        DiagnosticMatrix({"a": [2, 0]})
    with pytest.raises(DataError, match="3 symptoms"):
        dm.diagnose([1, 0])
