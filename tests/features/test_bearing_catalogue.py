"""Bearings from text (issue 15, "bearing geometry on the CLI"): a small catalogue of
named bearings with published geometry, and KEY=VALUE geometry with units."""

from __future__ import annotations

import numpy as np
import pytest

import pdmkit.features as pf
from pdmkit.errors import DataError

B = pf.BearingGeometry
INCH = 0.0254


def test_geometry_text_with_units_is_converted_to_metres():
    b = B.parse("n_balls=9,ball_d=7.94mm,pitch_d=39.04mm,angle=0")
    assert (b.n_balls, b.contact_angle_deg) == (9, 0.0)
    assert b.ball_diameter == pytest.approx(7.94e-3)
    assert b.pitch_diameter == pytest.approx(39.04e-3)
    inches = B.parse("n=16, d=0.331in, D=2.815in, angle=15.17deg")
    assert inches.ball_diameter == pytest.approx(0.331 * INCH)
    assert inches.pitch_diameter == pytest.approx(2.815 * INCH)
    assert inches.contact_angle_deg == pytest.approx(15.17)
    metres = B.parse("n_balls=9, ball_d=0.00794m, pitch_d=3.904cm")
    assert metres == B(n_balls=9, ball_diameter=0.00794, pitch_diameter=0.03904)


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        ("6205", pf.CWRU_DRIVE_END),
        ("SKF 6205-2RS JEM", pf.CWRU_DRIVE_END),
        ("cwru-de", pf.CWRU_DRIVE_END),
        ("skf6203", pf.CWRU_FAN_END),
        ("6203-2RS", pf.CWRU_FAN_END),
    ],
)
def test_catalogue_names(spec, expected):
    assert B.parse(spec) == expected


def test_cwru_names_give_the_published_multiples_of_running_speed():
    # CWRU Bearing Data Center, "Bearing information": drive end BPFI 5.4152, BPFO
    # 3.5848, FTF 0.39828; fan end 4.9469, 3.0530, 0.3817 times the running speed
    de, fe = B.parse("6205").frequencies(1.0), B.parse("6203").frequencies(1.0)
    assert de["BPFI"] == pytest.approx(5.4152, rel=5e-4)
    assert de["BPFO"] == pytest.approx(3.5848, rel=5e-4)
    assert de["FTF"] == pytest.approx(0.39828, rel=5e-4)
    assert fe["BPFI"] == pytest.approx(4.9469, rel=5e-4)
    assert fe["BPFO"] == pytest.approx(3.0530, rel=5e-4)
    assert fe["FTF"] == pytest.approx(0.3817, rel=5e-4)


def test_ims_rexnord_za_2115_at_2000_rpm():
    # Qiu et al., J. Sound Vib. 289 (2006): BPFO 236.4 Hz, BPFI 296.9 Hz, BSF 139.9 Hz,
    # FTF 14.8 Hz for the IMS rig's Rexnord ZA-2115 at 2000 rpm
    f = B.parse("Rexnord ZA-2115").frequencies(2000 / 60)
    assert f["BPFO"] == pytest.approx(236.4, abs=0.1)
    assert f["BPFI"] == pytest.approx(296.9, abs=0.1)
    assert f["BSF"] == pytest.approx(139.9, abs=0.1)
    assert f["FTF"] == pytest.approx(14.8, abs=0.05)
    assert B.parse("ims") == B.parse("ZA-2115")


def test_catalogue_table_lists_every_name_with_its_source():
    table = B.catalogue()
    assert table["name"].tolist() == [
        "SKF 6205-2RS JEM",
        "SKF 6203-2RS JEM",
        "Rexnord ZA-2115",
    ]
    assert table["source"].str.len().gt(10).all()
    for row in table.itertuples():
        assert B.parse(row.name).n_balls == row.n_balls


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("n_balls=9,ball_d=7.94,pitch_d=39.04mm", r"ball_d='7\.94' has no unit"),
        ("n_balls=9,ball_d=7.94mm", "lacks pitch_d"),
        ("nballs=9,ball_d=7.94mm,pitch_d=39mm", "did you mean 'n_balls'"),
        ("n_balls=9.5,ball_d=7.94mm,pitch_d=39mm", "whole number"),
        ("n_balls=9,ball_d=7.94furlong,pitch_d=39mm", "length with a unit"),
        ("n_balls=9,ball_d=40mm,pitch_d=39mm", "did you swap them"),
        ("n_balls=9,n=8,ball_d=7mm,pitch_d=39mm", "given twice"),
        ("6025", "did you mean '6205'"),
        ("", "catalogue name"),
    ],
)
def test_bad_bearing_text_is_one_clear_error(spec, message):
    with pytest.raises(DataError, match=message):
        B.parse(spec)


def test_envelope_indicators_take_a_bearing_name():
    fs, shaft = 12_000.0, 1797 / 60
    t = np.arange(24_000) / fs
    bpfi = pf.CWRU_DRIVE_END.frequencies(shaft)["BPFI"]
    x = np.exp(-800 * (t % (1 / bpfi))) * np.sin(2 * np.pi * 3000 * t)
    by_name = pf.extract(x, fs, ("envelope",), bearing="6205", shaft_hz=shaft)
    by_object = pf.extract(x, fs, ("envelope",), bearing=pf.CWRU_DRIVE_END, shaft_hz=shaft)
    np.testing.assert_array_equal(by_name.to_numpy(), by_object.to_numpy())
