# SPDX-License-Identifier: MIT
"""Builds the imucal Python package (docs/python.md):

    python3 -m venv --system-site-packages .venv
    .venv/bin/pip install --no-build-isolation .

The sources are the ones CMake compiles, read from its lists: the library's parts from
cmake/imucal_parts.cmake (with its private definitions and options: C++17, EIGEN_NO_MALLOC, no
exceptions, no RTTI), the command's pieces from tools/CMakeLists.txt (imucal_cli), then the
pybind11 module python/imucal_module.cpp as imucal._imucal. Eigen 3.4 and nlohmann/json come
from the system (EIGEN3_INCLUDE_DIR names another Eigen); IMUCAL_BUILD_JOBS sets the parallel
compiles (default: every CPU).
"""
import os
import re
from pathlib import Path

from pybind11.setup_helpers import ParallelCompile, Pybind11Extension, build_ext
from setuptools import setup

ROOT = Path(__file__).resolve().parent
CXX_FLAGS = ["-std=c++17", "-fvisibility=hidden", "-g0"]


def cmake_text(path):
    """A CMake file without its comments."""
    return re.sub(r"#[^\n]*", "", (ROOT / path).read_text())


def cmake_sets(path):
    """The variables a CMake file set()s: name -> list of values."""
    return {m[1]: m[2].split() for m in re.finditer(r"\bset\(\s*(\w+)([^)]*)\)", cmake_text(path))}


def existing(paths, where):
    missing = [p for p in paths if not (ROOT / p).is_file()]
    if not paths or missing:
        raise SystemExit(f"setup.py: the sources read from {where} are not all there: "
                         f"{missing or 'none found'}")
    return paths


def version():
    text = (ROOT / "include/imucal/version.hpp").read_text()
    return re.search(r'#define IMUCAL_VERSION_STRING "([^"]+)"', text)[1]


def eigen_include():
    candidates = [os.environ.get("EIGEN3_INCLUDE_DIR", ""), "/usr/include/eigen3",
                  "/usr/local/include/eigen3", "/opt/homebrew/include/eigen3"]
    for c in candidates:
        if c and (Path(c) / "Eigen" / "Core").is_file():
            return c
    raise SystemExit("setup.py: Eigen 3.4 not found (Debian: libeigen3-dev; or set "
                     "EIGEN3_INCLUDE_DIR to the folder that holds Eigen/Core)")


parts = cmake_sets("cmake/imucal_parts.cmake")
library_sources = existing(
    [s for part in parts["IMUCAL_PARTS"] for s in parts["IMUCAL_PART_SOURCES_" + part]],
    "cmake/imucal_parts.cmake")
cli = re.search(r"add_library\(\s*imucal_cli\s+STATIC([^)]*)\)", cmake_text("tools/CMakeLists.txt"))
cli_sources = existing(["tools/" + s for s in cli[1].split()] if cli else [],
                       "tools/CMakeLists.txt (imucal_cli)")
# imucal's own programs (the command, the module) are compiled with the library's definitions
# too, as CMake's imucal_dev gives them: a dynamic Eigen allocation aborts.
definitions = [(d, None) for d in parts["IMUCAL_PRIVATE_DEFINITIONS"]]
include_dirs = parts["IMUCAL_INCLUDE_DIRS"] + [eigen_include()]
program_include_dirs = include_dirs + ["tools/imucal", "sim/include"]
BUILD = "build/python"  # beside the CMake presets' folders, out of the sources
# What every object depends on besides its source: setuptools compiles a library again when one
# of these (or one of its sources) is newer than its objects, and the module when one of these or
# a library's source is newer than it. A change of CFLAGS is not seen: remove build/python then.
DEPENDS = sorted({str(p.relative_to(ROOT)) for pattern in (
    "include/**/*.hpp", "ports/include/**/*.hpp", "lib/*.hpp", "tools/imucal/*.hpp",
    "sim/include/**/*.hpp") for p in ROOT.glob(pattern)}) + [
    "setup.py", "cmake/imucal_parts.cmake", "tools/CMakeLists.txt"]
os.makedirs(BUILD, exist_ok=True)

ParallelCompile("IMUCAL_BUILD_JOBS").install()
setup(
    version=version(),
    package_dir={"": "python"},
    packages=["imucal"],
    package_data={"imucal": ["py.typed", "*.pyi"]},
    # Static libraries linked into the module, in link order (the command's pieces use the
    # library).
    libraries=[
        ("imucal_cli", {"sources": cli_sources, "obj_deps": {"": DEPENDS}, "macros": definitions,
                        "include_dirs": list(program_include_dirs), "cflags": CXX_FLAGS}),
        ("imucal_library", {"sources": library_sources, "obj_deps": {"": DEPENDS},
                            "macros": definitions,
                            "include_dirs": list(include_dirs),
                            "cflags": CXX_FLAGS + parts["IMUCAL_PRIVATE_OPTIONS"]}),
    ],
    ext_modules=[Pybind11Extension("imucal._imucal", ["python/imucal_module.cpp"],
                                   depends=DEPENDS + library_sources + cli_sources,
                                   include_dirs=list(program_include_dirs),
                                   define_macros=definitions, cxx_std=17)],
    cmdclass={"build_ext": build_ext},
    options={"build": {"build_base": BUILD}, "egg_info": {"egg_base": BUILD}},
    zip_safe=False,
)
