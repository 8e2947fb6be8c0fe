#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""Checks imucal's Zephyr module as far as a machine without Zephyr allows:

1. zephyr/module.yml against Zephyr's module schema (module_schema.yml) with pykwalify, and the
   CMakeLists.txt and Kconfig it names exist, as Zephyr's scripts/zephyr_module.py checks them;
2. zephyr/Kconfig parsed by kconfiglib (Zephyr's Kconfig implementation) inside Kconfig.zephyr,
   without warnings, for several prj.conf fragments: which parts each selects, and that a value
   the module refuses (no C++, C++11) is reported as Zephyr's build reports it;
3. zephyr/CMakeLists.txt run with each resulting .config (CMakeLists.txt here stands in for
   Zephyr's functions): the library's sources are exactly the selected parts'
   (cmake/imucal_parts.cmake), IMUCAL_FLOAT_ONLY follows its option, and with the default parts
   tests/consumer/main.cpp builds against the library and runs.

  /usr/bin/python3 tests/zephyr/check_module.py    (Debian's python3-pykwalify, python3-kconfiglib)
"""
import os
import pathlib
import re
import subprocess
import sys

import kconfiglib
import pykwalify.core
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]
HERE = ROOT / "tests" / "zephyr"
WORK = ROOT / "build" / "zephyr-module"

# (name, prj.conf lines, parts expected (None: a value is refused, which stops Zephyr's build),
# float only, build the app)
BASE = ["CONFIG_CPP=y", "CONFIG_STD_CPP17=y", "CONFIG_IMUCAL=y"]
SCENARIOS = [
    ("defaults", BASE, ["core", "calibrator", "store"], True, True),
    ("temperature", BASE + ["CONFIG_IMUCAL_TEMPERATURE=y", "CONFIG_IMUCAL_STORE=n"],
     ["core", "calibrator", "temperature"], True, False),
    ("temperature_selects_calibrator", BASE + ["CONFIG_IMUCAL_TEMPERATURE=y",
                                               "CONFIG_IMUCAL_CALIBRATOR=n"], None, True, False),
    ("everything_double", BASE + ["CONFIG_IMUCAL_MAGNETOMETER=y", "CONFIG_IMUCAL_TEMPERATURE=y",
                                  "CONFIG_IMUCAL_FLOAT_ONLY=n"],
     ["core", "calibrator", "magnetometer", "temperature", "store"], False, False),
    ("load_and_apply", BASE + ["CONFIG_IMUCAL_CALIBRATOR=n"], ["core", "store"], True, False),
    ("cpp11", ["CONFIG_CPP=y", "CONFIG_IMUCAL=y"], None, True, False),
    ("no_cpp", ["CONFIG_IMUCAL=y"], None, True, False),
]


def fail(message):
    print(f"zephyr module: {message}")
    sys.exit(1)


def check_module_yml():
    meta = yaml.safe_load((ROOT / "zephyr" / "module.yml").read_text())
    schema = yaml.safe_load((HERE / "module_schema.yml").read_text())
    pykwalify.core.Core(source_data=meta, schema_data=schema).validate(raise_exception=True)
    build = meta.get("build", {})
    if not (ROOT / build.get("cmake", "zephyr") / "CMakeLists.txt").is_file():
        fail(f"build.cmake {build.get('cmake')!r} holds no CMakeLists.txt")
    kconfig = ROOT / build.get("kconfig", "zephyr/Kconfig")
    if not kconfig.is_file():
        fail(f"build.kconfig {build.get('kconfig')!r} is not a file")
    print(f"module.yml: valid against Zephyr's schema; name {meta.get('name')}, "
          f"cmake {build.get('cmake')}/CMakeLists.txt, kconfig {build.get('kconfig')}")
    return kconfig


def part_sources():
    text = (ROOT / "cmake" / "imucal_parts.cmake").read_text()
    return {m.group(1): m.group(2).split()
            for m in re.finditer(r"^set\(IMUCAL_PART_SOURCES_(\w+) ([^)]*)\)", text, re.M)}


def run_kconfig(kconfig_file, name, lines):
    os.environ["IMUCAL_MODULE_KCONFIG"] = str(kconfig_file)
    kconf = kconfiglib.Kconfig(str(HERE / "Kconfig.zephyr"), warn_to_stderr=False)
    if kconf.warnings:
        fail("Kconfig warnings:\n" + "\n".join(kconf.warnings))
    if "IMUCAL" not in kconf.syms or kconf.syms["IMUCAL"].nodes == []:
        fail("zephyr/Kconfig defines no IMUCAL")
    fragment = WORK / f"{name}.conf"
    fragment.write_text("\n".join(lines) + "\n")
    kconf.load_config(str(fragment))
    if kconf.warnings:
        fail(f"{name}: Kconfig warnings:\n" + "\n".join(kconf.warnings))
    # Zephyr's kconfig.py stops the build when an assigned value does not hold.
    refused = []
    for line in lines:
        symbol, value = line[len("CONFIG_"):].split("=")
        if kconf.syms[symbol].str_value != value:
            refused.append(f"{symbol}={value} (got {kconf.syms[symbol].str_value})")
    dotconfig = WORK / f"{name}.config"
    kconf.write_config(str(dotconfig))
    return kconf, refused, dotconfig


def main():
    WORK.mkdir(parents=True, exist_ok=True)
    kconfig_file = check_module_yml()
    sources = part_sources()
    for name, lines, parts, float_only, build_app in SCENARIOS:
        kconf, refused, dotconfig = run_kconfig(kconfig_file, name, lines)
        if parts is None:
            if not refused:
                fail(f"{name}: accepted, but the module should refuse it")
            print(f"{name}: refused as Zephyr's build would: {', '.join(refused)}")
            continue
        if refused:
            fail(f"{name}: values not taken: {', '.join(refused)}")
        if kconf.syms["REQUIRES_FULL_LIBCPP"].str_value != "y":
            fail(f"{name}: the full C++ library (Eigen's <cmath>, <limits>) is not required")
        build = WORK / name
        configure = ["cmake", "-S", str(HERE), "-B", str(build), "-G", "Ninja",
                     f"-DIMUCAL_DOTCONFIG={dotconfig}", f"-DIMUCAL_SOURCE_DIR={ROOT}"]
        if build_app:
            configure.append(f"-DIMUCAL_APP={ROOT / 'tests' / 'consumer' / 'main.cpp'}")
        subprocess.run(configure, check=True, stdout=subprocess.DEVNULL)
        report = (build / "module_report.txt").read_text().split("\n")
        got = sorted(line.split(" ", 1)[1] for line in report if line.startswith("source "))
        want = sorted(s for p in parts for s in sources[p])
        if got != want:
            fail(f"{name}: sources {got}, expected {want} (parts {parts})")
        definitions = {line.split(" ", 1)[1] for line in report if line.startswith("definition ")}
        if ("IMUCAL_FLOAT_ONLY" in definitions) != float_only or \
                "EIGEN_NO_MALLOC" not in definitions:
            fail(f"{name}: definitions {sorted(definitions)}")
        print(f"{name}: parts {' '.join(parts)}: {len(got)} sources, "
              f"{'float only' if float_only else 'float and double'}")
        if build_app:
            subprocess.run(["cmake", "--build", str(build)], check=True, stdout=subprocess.DEVNULL)
            out = subprocess.run([str(build / "app")], check=True, capture_output=True, text=True)
            print(f"{name}: tests/consumer/main.cpp built with the module's library and ran: "
                  + out.stdout.strip().splitlines()[-1])
    print("zephyr module: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
