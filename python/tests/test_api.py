# SPDX-License-Identifier: MIT
"""The package's own API: what it refuses and how it says so, its defaults against the command's,
the results as arrays equal to the JSON, pose means asked for explicitly, its version, and that
the package under test is the installed one where the test says so."""
import importlib.metadata
import os
import re
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import imucal
from support import SOURCE, TOOL, bundled_arrays, command_json, read_csv, same_results


@pytest.fixture(scope="module")
def bundled():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    result = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag, **settings)
    return result, (t, acc, gyro, temp, mag, settings)


def test_readings_without_times_are_refused_saying_what_to_pass():
    """acc alone without t or rate is not read as one pose mean per row unless asked for."""
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    for call in (lambda: imucal.calibrate(acc, **settings),
                 lambda: imucal.calibrate(acc, gyro, **settings),
                 lambda: imucal.calibrate(acc, gyro, temp=temp, mag=mag, **settings)):
        with pytest.raises(ValueError, match=r"give t= .* or rate= .*poses=True"):
            call()
    with pytest.raises(ValueError, match=r"give t= .* or rate= "):
        imucal.noise(acc[:2000], gyro[:2000])


def test_pose_means_asked_for_give_the_streams_accelerometer(bundled):
    """poses=True: the rests' means the stream found, given as pose means, give the stream's
    accelerometer parameters (the solve is the same; its float rounding aside)."""
    result, (t, acc, gyro, temp, mag, settings) = bundled
    units = {k: v for k, v in settings.items() if k.startswith("accel_") or k == "gravity"}
    stream = imucal.calibrate(acc, t=t, initial_rest=settings["initial_rest"], **units)
    assert stream.accelerometer is not None and len(stream.poses) >= 20
    from_means = imucal.calibrate(stream.poses.mean, poses=True, **units)
    assert from_means.json["parts"]["mode"] == "poses"
    assert len(from_means.poses) == len(stream.poses)
    assert from_means.accelerometer is not None
    diff = np.abs(from_means.accelerometer.values - stream.accelerometer.values)
    assert np.all(diff < 0.01 * stream.accelerometer.sigma), diff / stream.accelerometer.sigma
    for extra in (dict(t=t[:len(stream.poses)]), dict(rate=100.0),
                  dict(gyro=gyro[:len(stream.poses)])):
        with pytest.raises(ValueError, match="poses=True takes acc alone.*" + list(extra)[0]):
            imucal.calibrate(stream.poses.mean, poses=True, **extra, **units)


def test_errors_name_the_keyword_arguments():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    options = dict(settings, gravity=12.0)
    with pytest.raises(ValueError, match=r"^gravity: 12\.0 is outside 9\.7 \.\. 9\.9"):
        imucal.calibrate(acc, gyro, t=t, **options)
    with pytest.raises(ValueError, match=r"^accel_unit: expected one of counts g mps2"):
        imucal.calibrate(acc, gyro, t=t, **dict(settings, accel_unit="furlongs"))
    with pytest.raises(ValueError, match=r"mag_unit counts needs .*mag_lsb_per_ut"):
        imucal.calibrate(acc, gyro, t=t, mag=mag, **dict(settings, mag_lsb_per_ut=None))
    with pytest.raises(TypeError, match="gravityy"):
        imucal.calibrate(acc, gyro, t=t, gravityy=9.81)  # type: ignore[call-arg]


def test_what_the_command_refuses_raises_with_the_reason():
    with pytest.raises(ValueError, match="no readings"):
        imucal.calibrate()
    with pytest.raises(ValueError, match="no readings"):
        imucal.noise(t=np.arange(10.0))
    with pytest.raises(ValueError, match=r"acc: expected shape \(N, 3\)"):
        imucal.calibrate(np.zeros((10, 2)), rate=100.0)
    with pytest.raises(ValueError, match="gyro: 9 rows, expected 10"):
        imucal.calibrate(np.zeros((10, 3)), np.zeros((9, 3)), rate=100.0)
    with pytest.raises(ValueError, match="accel_range: expected"):
        imucal.calibrate(np.zeros((10, 3)), rate=100.0, accel_range=(1.0, 2.0, 3.0))  # type: ignore
    with pytest.raises(ValueError, match="not a valid record"):
        imucal.decode_record(b"\x00\x01\x02")
    with pytest.raises(ValueError, match="not a valid record"):
        imucal.Corrector(b"")


def write_without_settings(src, dst):
    """The CSV without its `# imucal:` settings: what the command reads with its defaults."""
    with open(src) as f, open(dst, "w") as out:
        out.writelines(line for line in f if not line.startswith("#"))


def test_the_defaults_are_the_commands():
    """Every keyword argument's default is the command's: a simulated SI recording calibrated
    with neither options nor settings gives the same JSON (configuration included) both ways;
    the noise of its initial rest too."""
    with tempfile.TemporaryDirectory() as d:
        simulated, plain = os.path.join(d, "sim.csv"), os.path.join(d, "plain.csv")
        subprocess.run([TOOL, "simulate", "-o", simulated, "--units", "si", "--seed", "3"],
                       check=True, stdout=subprocess.DEVNULL)
        write_without_settings(simulated, plain)
        t, acc, gyro, temp, mag, _ = read_csv(plain)
        py = imucal.calibrate(acc, gyro, t=t, temp=temp, mag=mag)
        same_results(py.json, command_json("calibrate", [plain], {}))
        rest = os.path.join(d, "rest.csv")
        with open(plain) as f, open(rest, "w") as out:
            out.writelines(f.readlines()[:801])  # the header and 8 s of the initial rest
        n = imucal.noise(acc[:800], gyro[:800], t=t[:800])
        cmd = command_json("noise", [rest], {})
    assert {k: v for k, v in n.json.items() if k != "file"} == \
        {k: v for k, v in cmd.items() if k != "file"}
    assert n.accelerometer is not None and n.accelerometer.unit == "m/s^2"
    assert n.gyroscope is not None and n.gyroscope.unit == "rad/s"


def test_results_are_the_json_as_arrays(bundled):
    py, _ = bundled
    j = py.json
    assert (py.usable, py.quality, py.quality_reason, list(py.advice)) == \
        (j["usable"], j["quality"], j["quality_reason"], j["advice"])
    for part, names in ((py.accelerometer, imucal.ACCEL_PARAMETERS),
                        (py.gyroscope, imucal.GYRO_PARAMETERS)):
        assert part is not None and part.names == names
        key = "accelerometer" if names is imucal.ACCEL_PARAMETERS else "gyroscope"
        entries = j[key]["parameters"]
        assert part.values.dtype == np.float64 and part.values.shape == (len(names),)
        assert list(part.values) == [entries[n]["value"] for n in names]
        assert list(part.sigma) == [entries[n]["sigma"] for n in names]
        assert part["s_x"] == entries["s_x"]["value"]
        with pytest.raises(ValueError):
            part.values[0] = 0.0  # read-only
    with pytest.raises(KeyError, match="s_w"):
        py.accelerometer["s_w"]  # type: ignore[index]
    m, jm = py.magnetometer, j["magnetometer"]
    assert m is not None
    assert m.soft_iron.shape == (3, 3) and m.soft_iron.tolist() == jm["soft_iron"]
    assert m.hard_iron.tolist() == [jm["hard_iron"][a]["value"] for a in "xyz"]
    assert m.hard_iron_sigma.tolist() == [jm["hard_iron"][a]["sigma"] for a in "xyz"]
    assert (m.field_ut, m.quality) == (jm["field_ut"], jm["quality"])
    tm, jt = py.temperature, j["temperature"]
    assert tm is not None and (tm.order, tm.reference_c) == (jt["order"], jt["reference_c"])
    for bias, key in ((tm.accelerometer, "accelerometer"), (tm.gyroscope, "gyroscope")):
        assert bias is not None and bias.coefficients.shape == (tm.order + 1, 3)
        assert bias.coefficients[1].tolist() == [jt[key]["b1"][a]["value"] for a in "xyz"]
        assert bias.sigma[0].tolist() == [jt[key]["b0"][a]["sigma"] for a in "xyz"]
    poses = j["poses"]
    assert len(py.poses) == len(poses) and py.poses.mean.shape == (len(poses), 3)
    assert py.poses.mean.tolist() == [p["mean"] for p in poses]
    assert py.poses.t_begin_s.tolist() == [p["t_begin_s"] for p in poses]
    assert py.poses.samples.tolist() == [p["samples"] for p in poses]
    assert py.poses.residual_after_mps2.tolist() == [p["residual_after_mps2"] for p in poses]
    assert "summary" not in repr(py) and "Calibration(usable=True" in repr(py)


def test_parts_not_in_the_input_are_none(bundled):
    _, (t, acc, gyro, temp, mag, settings) = bundled
    accel_only = {k: v for k, v in settings.items() if not k.startswith(("mag_", "gyro_"))}
    py = imucal.calibrate(acc, t=t, **accel_only)
    assert py.accelerometer is not None
    assert py.gyroscope is None and py.magnetometer is None and py.temperature is None


def test_noise_results_are_the_json_as_arrays():
    t, acc, gyro, temp, mag, settings = bundled_arrays()
    units = {k: v for k, v in settings.items() if k in ("accel_unit", "accel_lsb_per_g",
                                                         "gyro_unit", "gyro_lsb_per_dps")}
    n = imucal.noise(acc[:900], t=t[:900], **units)  # the initial rest: 10 s
    assert n.gyroscope is None and n.accelerometer is not None
    ja = n.json["accelerometer"]
    points = ja["allan_deviation"]
    assert n.accelerometer.tau_s.tolist() == [p["tau"] for p in points]
    assert n.accelerometer.adev.shape == (len(points), 3)
    assert n.accelerometer.adev_hi.tolist() == [p["adev_hi"] for p in points]
    w = n.accelerometer.white_noise_N
    assert w.value.tolist() == [a["white_noise_N"]["value"] for a in ja["axes"]]
    assert w.significant.dtype == np.bool_
    assert (n.samples, n.duration_s, n.rate_hz) == \
        (n.json["samples"], n.json["duration_s"], n.json["rate_hz"])


def version_in_header():
    with open(os.path.join(SOURCE, "include", "imucal", "version.hpp")) as f:
        return re.search(r'#define IMUCAL_VERSION_STRING "([^"]+)"', f.read())[1]


def test_the_version_is_the_librarys(bundled):
    py, _ = bundled
    assert imucal.__version__ == version_in_header() == "0.1.0"
    assert py.json["imucal"] == imucal.__version__
    if os.environ.get("IMUCAL_EXPECT_INSTALLED"):
        assert importlib.metadata.version("imucal") == imucal.__version__


def test_the_package_under_test_is_the_installed_one():
    """tools/test_python.sh installs the package and says so: then it is the one imported, not
    the sources, with its stub and typing marker beside it."""
    where = os.path.dirname(os.path.abspath(imucal.__file__))
    assert os.path.isfile(os.path.join(where, "py.typed"))
    assert os.path.isfile(os.path.join(where, "_imucal.pyi"))
    if not os.environ.get("IMUCAL_EXPECT_INSTALLED"):
        return
    assert where.startswith(os.path.abspath(sys.prefix)), (where, sys.prefix)
    assert not where.startswith(SOURCE + os.sep), where
    assert "site-packages" in where
