"""The imucal Python package against the imucal command: the same calibration, bit for bit in the
JSON, on the bundled recording and on the Xsens recording; the record codec and the corrector."""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import imucal

SOURCE = os.environ.get("IMUCAL_SOURCE", os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(SOURCE, "tools"))
import read_record  # noqa: E402  (tools/read_record.py: the record read by Python alone)
TOOL = os.environ.get("IMUCAL_TOOL", os.path.join(SOURCE, "build", "host", "tools", "imucal"))
XSENS = os.environ.get("IMUCAL_XSENS_DIR", os.path.join(SOURCE, "..", "shared", "data", "xsens"))
BUNDLED = os.path.join(SOURCE, "data", "simulated_imu.csv")
XSENS_OPTIONS = dict(accel_unit="counts", accel_lsb_per_g=4070, accel_zero=32768,
                     gyro_unit="counts", gyro_lsb_per_dps=83.2522, gravity=9.81744)


def command_json(files, options, flags=()):
    """What `imucal calibrate FILES --json` writes, with the same options."""
    args = list(flags)
    for key, value in options.items():
        args += ["--" + key.replace("_", "-"), str(value)]
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "run.json")
        subprocess.run([TOOL, "calibrate", *files, *args, "--quiet", "--json", out],
                       stdout=subprocess.DEVNULL, check=False)
        with open(out) as f:
            return json.load(f)


def same_results(py, cmd):
    """Every result of the run equal; the input's description (files, format, columns) aside."""
    for key in cmd:
        if key == "configuration":  # the settings come as options, not from the file's comments
            assert {k: v for k, v in py[key].items() if k != "from_files"} == \
                {k: v for k, v in cmd[key].items() if k != "from_files"}
        elif key != "input":
            assert py[key] == cmd[key], key
    for key in ("samples", "t_first_s", "t_last_s", "rate_hz", "stream_events"):
        assert py["input"][key] == cmd["input"][key], key


def bundled_arrays():
    settings = {}
    with open(BUNDLED) as f:
        for line in f:
            if line.startswith("# imucal:"):
                for kv in line[len("# imucal:"):].split():
                    k, v = kv.split("=", 1)
                    settings[k.replace("-", "_")] = v
    with open(BUNDLED) as f:
        lines = [line for line in f if not line.startswith("#")]
    names = lines[0].strip().split(",")
    values = np.loadtxt(lines[1:], delimiter=",")
    data = {name: values[:, k] for k, name in enumerate(names)}
    t = data["t"]
    acc = np.column_stack([data[n] for n in ("ax", "ay", "az")])
    gyro = np.column_stack([data[n] for n in ("gx", "gy", "gz")])
    temp = data["temp"] if "temp" in names else None
    mag = np.column_stack([data[n] for n in ("mx", "my", "mz")]) if "mx" in names else None
    return t, acc, gyro, temp, mag, settings


def test_bundled_recording_as_the_command_gives_it():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    py = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    cmd = command_json([BUNDLED], {})
    same_results(py, cmd)
    assert py["usable"]
    assert py["quality"] == "good"
    assert "quality" in py["summary"]
    assert py["record"] is not None


def test_xsens_recording_as_the_command_gives_it():
    acc_file, gyro_file = (os.path.join(XSENS, n) for n in ("xsens_acc.mat", "xsens_gyro.mat"))
    if not os.path.exists(acc_file):
        if os.environ.get("IMUCAL_REQUIRE_XSENS") == "ON":
            pytest.fail("the xsens recording is missing: " + acc_file)
        pytest.skip("the xsens recording is not beside the clone")
    a, g = np.loadtxt(acc_file), np.loadtxt(gyro_file)
    assert a.shape == g.shape and np.array_equal(a[:, 0], g[:, 0])
    for double in (False, True):
        py = imucal.calibrate(a[:, 1:], g[:, 1:], t=a[:, 0], double=double, **XSENS_OPTIONS)
        cmd = command_json([acc_file, gyro_file], XSENS_OPTIONS, ["--double"] if double else [])
        same_results(py, cmd)
        assert py["usable"] and len(py["poses"]) >= 38


def test_noise_of_the_xsens_initial_rest_as_the_command_gives_it():
    acc_file, gyro_file = (os.path.join(XSENS, n) for n in ("xsens_acc.mat", "xsens_gyro.mat"))
    if not os.path.exists(acc_file):
        pytest.skip("the xsens recording is not beside the clone")
    a, g = np.loadtxt(acc_file)[:4000], np.loadtxt(gyro_file)[:4000]  # 40 s of the initial rest
    units = dict(accel_unit="counts", accel_lsb_per_g=4070, gyro_unit="counts",
                 gyro_lsb_per_dps=83.2522)
    py = imucal.noise(a[:, 1:], g[:, 1:], t=a[:, 0], **units)
    with tempfile.TemporaryDirectory() as d:
        files = []
        for name, x in (("acc.txt", a), ("gyro.txt", g)):
            files.append(os.path.join(d, name))
            np.savetxt(files[-1], x, fmt="%.9g")
        args = [a for k, v in units.items() for a in ("--" + k.replace("_", "-"), str(v))]
        out, yaml = os.path.join(d, "noise.json"), os.path.join(d, "imu.yaml")
        subprocess.run([TOOL, "noise", *files, *args, "--json", out, "--kalibr", yaml],
                       stdout=subprocess.DEVNULL, check=True)
        with open(out) as f:
            cmd = json.load(f)
        with open(yaml) as f:
            cmd_yaml = f.read()
    for key in cmd:
        if key != "file":
            assert py[key] == cmd[key], key
    assert py["kalibr"].split("\n")[1:] == cmd_yaml.split("\n")[1:]  # the file named aside
    n = py["gyroscope"]["axes"][0]["white_noise_N"]
    assert n["value"] > 0 and n["sigma"] < n["value"]


def test_record_and_corrector_apply_the_calibration():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    py = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    rec = imucal.decode_record(py["record"])
    assert rec["quality"] == "good"
    p = py["accelerometer"]["parameters"]
    params = [p[k]["value"] for k in imucal.ACCEL_PARAMETERS]
    for got, want in zip(rec["accelerometer"]["parameters"], params):
        assert math.isclose(got, want, rel_tol=1e-6, abs_tol=1e-6 * max(1.0, abs(want)))
    # The corrector turns every pose's mean into gravity's magnitude (the poses' residual).
    corrector = imucal.Corrector(py["record"])
    a_cal, w_cal = corrector.apply(acc, gyro, temp=temp)
    assert a_cal.shape == acc.shape and w_cal.shape == gyro.shape
    g = float(settings.get("gravity", 9.80665))
    norms = []
    for pose in py["poses"]:
        inside = (t >= pose["t_begin_s"]) & (t <= pose["t_end_s"])
        norms.append(np.linalg.norm(a_cal[inside].mean(axis=0)))
    rms = math.sqrt(np.mean((np.array(norms) - g) ** 2))
    assert rms < 3 * py["accelerometer"]["residual_mps2"]["pose_rms_after"] + 1e-4


def test_parameter_names_are_the_librarys_everywhere():
    """The library's names (kAccelParamNames, kGyroParamNames) are the JSON's keys, in order, and
    tools/read_record.py, which cannot include the header, has the same lists."""
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    py = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    assert len(imucal.ACCEL_PARAMETERS) == 9 and len(imucal.GYRO_PARAMETERS) == 12
    assert list(py["accelerometer"]["parameters"]) == list(imucal.ACCEL_PARAMETERS)
    assert list(py["gyroscope"]["parameters"]) == list(imucal.GYRO_PARAMETERS)
    assert read_record.ACCEL_NAMES == list(imucal.ACCEL_PARAMETERS)
    assert read_record.GYRO_NAMES == list(imucal.GYRO_PARAMETERS)
    rec = read_record.read_record(py["record"])
    assert list(rec["accelerometer"]["params"]) == list(imucal.ACCEL_PARAMETERS)
    assert rec["quality"] == 3 and py["quality"] == "good"


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
print(status("VmHWM") - before, r["input"]["samples"])
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


def test_what_the_command_refuses_raises_with_the_reason():
    with pytest.raises(ValueError, match="no time column"):
        imucal.calibrate(np.zeros((10, 3)), np.zeros((10, 3)))
    with pytest.raises(ValueError, match="expected shape"):
        imucal.calibrate(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="rows"):
        imucal.calibrate(np.zeros((10, 3)), np.zeros((9, 3)), rate=100)
    with pytest.raises(ValueError, match="not a valid record"):
        imucal.decode_record(b"\x00\x01\x02")
