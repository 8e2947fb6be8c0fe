# SPDX-License-Identifier: MIT
"""The imucal Python package against the imucal command: the same calibration, bit for bit in the
JSON, on the bundled recording and on the Xsens recording; the noise; the record codec and the
corrector; the memory calibrate() keeps."""
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import imucal
from support import (BUNDLED, TOOL, XSENS_OPTIONS, bundled_arrays, command_json, read_record,
                     same_results, xsens_files)


def test_bundled_recording_as_the_command_gives_it():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    py = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    same_results(py.json, command_json("calibrate", [BUNDLED], {}))
    assert py.usable and py.json["usable"]
    assert py.quality == "good"
    assert "quality" in py.summary
    assert py.record is not None


def test_xsens_recording_as_the_command_gives_it():
    files = xsens_files()
    a, g = np.loadtxt(files[0]), np.loadtxt(files[1])
    assert a.shape == g.shape and np.array_equal(a[:, 0], g[:, 0])
    for double in (False, True):
        py = imucal.calibrate(a[:, 1:], g[:, 1:], t=a[:, 0], double=double, **XSENS_OPTIONS)
        cmd = command_json("calibrate", files, XSENS_OPTIONS, ["--double"] if double else [])
        same_results(py.json, cmd)
        assert py.usable and len(py.poses) >= 38


def test_noise_of_the_xsens_initial_rest_as_the_command_gives_it():
    files = xsens_files()
    a, g = np.loadtxt(files[0])[:4000], np.loadtxt(files[1])[:4000]  # 40 s of the initial rest
    units = dict(accel_unit="counts", accel_lsb_per_g=4070.0, gyro_unit="counts",
                 gyro_lsb_per_dps=83.2522)
    py = imucal.noise(a[:, 1:], g[:, 1:], t=a[:, 0], **units)
    with tempfile.TemporaryDirectory() as d:
        parts = []
        for name, x in (("acc.txt", a), ("gyro.txt", g)):
            parts.append(os.path.join(d, name))
            np.savetxt(parts[-1], x, fmt="%.9g")
        yaml = os.path.join(d, "imu.yaml")
        cmd = command_json("noise", parts, units, extra=["--kalibr", yaml])
        with open(yaml) as f:
            cmd_yaml = f.read()
    for key in cmd:
        if key != "file":
            assert py.json[key] == cmd[key], key
    assert py.kalibr is not None
    assert py.kalibr.split("\n")[1:] == cmd_yaml.split("\n")[1:]  # the file named aside
    assert py.gyroscope is not None
    n = py.gyroscope.white_noise_N
    assert np.all(n.value > 0) and np.all(n.sigma < n.value) and np.all(n.significant)


def test_record_and_corrector_apply_the_calibration():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    py = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    assert py.record is not None and py.accelerometer is not None
    rec = imucal.decode_record(py.record)
    assert rec.quality == "good" and rec.accelerometer is not None and rec.gyroscope is not None
    assert rec.magnetometer and rec.temperature_model
    np.testing.assert_allclose(rec.accelerometer.values, py.accelerometer.values, rtol=1e-6)
    assert rec.accelerometer.names == imucal.ACCEL_PARAMETERS
    # The corrector turns every pose's mean into gravity's magnitude (the poses' residual).
    corrector = imucal.Corrector(py.record)
    a_cal, w_cal = corrector.apply(acc, gyro, temp=temp)
    assert a_cal.shape == acc.shape and w_cal.shape == gyro.shape
    g = float(settings.get("gravity", 9.80665))
    norms = [np.linalg.norm(a_cal[(t >= b) & (t <= e)].mean(axis=0))
             for b, e in zip(py.poses.t_begin_s, py.poses.t_end_s)]
    rms = math.sqrt(np.mean((np.array(norms) - g) ** 2))
    assert rms < 3 * py.json["accelerometer"]["residual_mps2"]["pose_rms_after"] + 1e-4


def test_parameter_names_are_the_librarys_everywhere():
    """The library's names (kAccelParamNames, kGyroParamNames) are the JSON's keys, in order, and
    tools/read_record.py, which cannot include the header, has the same lists."""
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    py = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    assert len(imucal.ACCEL_PARAMETERS) == 9 and len(imucal.GYRO_PARAMETERS) == 12
    assert list(py.json["accelerometer"]["parameters"]) == list(imucal.ACCEL_PARAMETERS)
    assert list(py.json["gyroscope"]["parameters"]) == list(imucal.GYRO_PARAMETERS)
    assert read_record.ACCEL_NAMES == list(imucal.ACCEL_PARAMETERS)
    assert read_record.GYRO_NAMES == list(imucal.GYRO_PARAMETERS)
    rec = read_record.read_record(py.record)
    assert list(rec["accelerometer"]["params"]) == list(imucal.ACCEL_PARAMETERS)
    assert rec["quality"] == 3 and py.quality == "good"


MEMORY_SCRIPT = r"""
import sys
import numpy as np
import imucal

def status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    raise KeyError(key)

acc, gyro, n = np.load(sys.argv[1]), np.load(sys.argv[2]), int(sys.argv[3])
reps = -(-n // len(acc))
acc, gyro = np.tile(acc, (reps, 1))[:n].copy(), np.tile(gyro, (reps, 1))[:n].copy()
with open("/proc/self/clear_refs", "w") as f:  # the peak from here on
    f.write("5")
before = status("VmRSS")
r = imucal.calibrate(acc, gyro, rate=100, memory=16, accel_unit="counts", gyro_unit="counts",
                     accel_lsb_per_g=4069.76, accel_zero=32768, gyro_lsb_per_dps=83.2522,
                     gravity=9.81, initial_rest=10)
print(status("VmHWM") - before, r.json["input"]["samples"])
"""


def peak_growth(n, tmp):
    """The peak memory calibrate() adds over n samples (arrays made before it), in bytes."""
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    files = [os.path.join(tmp, name) for name in ("acc.npy", "gyro.npy")]
    np.save(files[0], acc)
    np.save(files[1], gyro)
    out = subprocess.run([sys.executable, "-c", MEMORY_SCRIPT, *files, str(n)], check=True,
                         capture_output=True, text=True).stdout.split()
    assert int(out[1]) == n
    return int(out[0])


def test_calibrate_memory_does_not_grow_with_the_samples():
    """The arrays are read where they are, as the command reads a file: the memory calibrate()
    adds is bounded by memory= (16 MB) and does not grow with the sample count (the bundled
    recording's readings repeated to 1 M and 4 M samples, its time from rate=)."""
    if not os.access("/proc/self/clear_refs", os.W_OK):
        pytest.skip("no /proc/self/clear_refs to measure a peak from")
    with tempfile.TemporaryDirectory() as tmp:
        small, large = peak_growth(1_000_000, tmp), peak_growth(4_000_000, tmp)
    per_sample = (large - small) / 3_000_000
    print("peak growth: %.1f MB at 1 M samples, %.1f MB at 4 M: %.2f bytes a sample"
          % (small / 1e6, large / 1e6, per_sample))
    assert per_sample < 2, "calibrate() keeps %.1f bytes a sample" % per_sample
    assert large < (16 + 40) * 1e6


def test_the_command_is_there():
    """The comparisons above need the command: its absence is a failure, not a skip."""
    assert os.access(TOOL, os.X_OK), "the imucal command is not at " + TOOL
