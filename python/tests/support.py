# SPDX-License-Identifier: MIT
"""What the package's tests share: where the sources, the command and the recordings are, the
command's JSON for the same input, and the recordings as arrays.

IMUCAL_SOURCE: the clone (default: two folders up); IMUCAL_TOOL: the imucal command (default
build/host/tools/imucal); IMUCAL_XSENS_DIR: the Xsens recording (default beside the clone);
IMUCAL_REQUIRE_XSENS=ON: its absence fails the tests that need it."""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

SOURCE = os.path.abspath(
    os.environ.get("IMUCAL_SOURCE") or os.path.join(os.path.dirname(__file__), "..", ".."))
TOOL = os.environ.get("IMUCAL_TOOL") or os.path.join(SOURCE, "build", "host", "tools", "imucal")
XSENS = os.environ.get("IMUCAL_XSENS_DIR") or os.path.join(SOURCE, "..", "shared", "data", "xsens")
BUNDLED = os.path.join(SOURCE, "data", "simulated_imu.csv")
XSENS_OPTIONS = dict(accel_unit="counts", accel_lsb_per_g=4070.0, accel_zero=32768.0,
                     gyro_unit="counts", gyro_lsb_per_dps=83.2522, gravity=9.81744)

sys.path.insert(0, os.path.join(SOURCE, "tools"))
import read_record  # noqa: E402,F401  (tools/read_record.py: the record read by Python alone)


def command_args(options, flags=()):
    """The command line for keyword options, as a user would type them."""
    args = list(flags)
    for key, value in options.items():
        args += ["--" + key.replace("_", "-"), str(value)]
    return args


def command_json(subcommand, files, options, flags=(), extra=()):
    """What `imucal SUBCOMMAND FILES --json` writes, with the same options."""
    if subcommand == "calibrate":
        extra = [*extra, "--quiet"]
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "run.json")
        subprocess.run([TOOL, subcommand, *files, *command_args(options, flags), *extra, "--json",
                        out], stdout=subprocess.DEVNULL, check=False)
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


def read_csv(path):
    """An imucal CSV as arrays (t, acc, gyro, temp, mag: None where absent) and its
    `# imucal:` settings as keyword options (numbers as floats)."""
    settings = {}
    with open(path) as f:
        lines = f.readlines()
    for line in lines:
        if line.startswith("# imucal:"):
            for kv in line[len("# imucal:"):].split():
                k, v = kv.split("=", 1)
                try:
                    settings[k.replace("-", "_")] = float(v)
                except ValueError:
                    settings[k.replace("-", "_")] = v
    rows = [line for line in lines if not line.startswith("#")]
    names = rows[0].strip().split(",")
    values = np.loadtxt(rows[1:], delimiter=",")
    data = {name: values[:, k] for k, name in enumerate(names)}

    def columns(*keys):
        return np.column_stack([data[k] for k in keys]) if keys[0] in data else None

    return (data["t"], columns("ax", "ay", "az"), columns("gx", "gy", "gz"), data.get("temp"),
            columns("mx", "my", "mz"), settings)


def bundled_arrays():
    return read_csv(BUNDLED)


def xsens_files():
    """The Xsens recording's two imu_tk files; skips (or fails, where it is required) without."""
    files = [os.path.join(XSENS, n) for n in ("xsens_acc.mat", "xsens_gyro.mat")]
    if not os.path.exists(files[0]):
        if os.environ.get("IMUCAL_REQUIRE_XSENS") == "ON":
            pytest.fail("the xsens recording is missing: " + files[0])
        pytest.skip("the xsens recording is not beside the clone")
    return files
