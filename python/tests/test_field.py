# SPDX-License-Identifier: MIT
"""imucal.field(): the field calibrator over arrays, as `imucal field` runs it over the file; its
results as arrays equal to the JSON; a device record as the prior; what it refuses."""
import numpy as np
import pytest

import imucal
from support import BUNDLED, bundled_arrays, command_json


@pytest.fixture(scope="module")
def bundled():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    result = imucal.field(acc, gyro, t=t, temp=temp, mag=mag, gyro_zero=32768, **settings)
    return result, (t, acc, gyro, temp, mag, settings)


def test_field_is_the_command(bundled):
    """The same run as `imucal field FILE --gyro-zero 32768`: every result equal (the input's
    description and where the settings came from aside)."""
    py, _ = bundled
    cmd = command_json("field", [BUNDLED], {"gyro_zero": 32768})
    for key in cmd:
        if key == "configuration":
            assert {k: v for k, v in py.json[key].items() if k != "from_files"} == \
                {k: v for k, v in cmd[key].items() if k != "from_files"}
        elif key != "input":
            assert py.json[key] == cmd[key], key


def test_results_are_the_json_as_arrays(bundled):
    """The gyro bias, the accelerometer's and the magnetometer's hard iron as arrays equal to the
    JSON; the counts and the timeline as the JSON has them."""
    py, _ = bundled
    j = py.json
    assert py.gyro_bias.published and py.gyro_bias.published == j["gyro_bias"]["published"]
    assert np.array_equal(py.gyro_bias.value, j["gyro_bias"]["value"])
    assert np.all(py.gyro_bias.sigma == j["gyro_bias"]["sigma"])
    assert py.accel_bias is not None and py.mag_hard_iron is not None
    assert np.array_equal(py.accel_bias.sigma, j["accel_bias"]["sigma"])
    assert np.array_equal(py.mag_hard_iron.value, j["mag_hard_iron"]["value"])
    assert py.mag_hard_iron.unit == "counts"
    assert py.counts == j["counts"] and py.counts["taken"] > 0
    assert py.gyro_matrix.names == imucal.GYRO_PARAMETERS[:9]
    assert py.gyro_matrix_published == j["gyro_matrix"]["published"]
    assert py.gyro_matrix["s_x"] == j["gyro_matrix"]["parameters"]["s_x"]["value"]
    assert py.timeline == j["timeline"] and len(py.timeline) == j["events"]
    assert "gyro bias published" in py.summary
    with pytest.raises(ValueError):
        py.gyro_bias.value[0] = 0.0  # read-only


def test_a_device_record_is_the_prior(bundled):
    """calibrate()'s record as the prior: the gyro bias is the record's from the first sample (no
    first publication), and what the recording says agrees with it within 3 combined sigma."""
    _, (t, acc, gyro, temp, mag, settings) = bundled
    cal = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    assert cal.record is not None
    run = imucal.field(acc, gyro, t=t, temp=temp, mag=mag, gyro_zero=32768, prior=cal.record,
                       **settings)
    assert run.json["configuration"]["prior_status"] == "ok"
    assert all(e["reason"] != "first" for e in run.timeline if e["sensor"] == "gyro")
    assert run.gyro_bias.published
    with pytest.raises(ValueError, match="prior: not a valid record"):
        imucal.field(acc, gyro, t=t, prior=b"not a record", gyro_zero=32768, **settings)


def test_what_the_command_refuses_raises_with_the_reason():
    """Missing times, an option of calibrate's that says nothing to the field calibrator."""
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    with pytest.raises(ValueError, match=r"give t= .* or rate= "):
        imucal.field(acc, gyro)
    with pytest.raises(ValueError, match="gyro_lsb_per_dps"):
        imucal.field(acc, gyro, t=t, gyro_unit="counts", accel_unit="counts")
