#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The Python package as a user installs it: a fresh virtual environment that sees the system's
# packages (numpy, pybind11, setuptools, wheel, pytest, mypy: Debian's), `pip install
# --no-build-isolation --no-index .` into it, then the package's tests (python/tests) run from
# outside the clone against the installed package, with the `imucal` command to compare with.
#   tools/test_python.sh
# Environment: PYTHON (default /usr/bin/python3, Debian's, where its packages are), IMUCAL_TOOL
# (default build/host/tools/imucal, built with the host preset if missing), IMUCAL_REQUIRE_XSENS
# (ON: a missing Xsens recording fails the tests that need it). With ccache installed, the
# compiles go through it (/usr/lib/ccache).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
python=${PYTHON:-/usr/bin/python3}
tool=${IMUCAL_TOOL:-$root/build/host/tools/imucal}
if [ ! -x "$tool" ]; then
  echo "test_python.sh: building the imucal command for the comparisons ($tool)"
  cmake --preset host >/dev/null
  cmake --build build/host --target imucal_tool
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$python" -m venv --system-site-packages "$work/venv"
[ -d /usr/lib/ccache ] && command -v ccache >/dev/null && export PATH="/usr/lib/ccache:$PATH"
log="$work/pip.log"
if ! "$work/venv/bin/pip" install --no-build-isolation --no-index --no-cache-dir -v . >"$log" 2>&1; then
  cat "$log"
  exit 1
fi
grep -E "^Successfully installed|^  Created wheel" "$log" | sed 's/ size=.*//'

cd "$work"  # away from the sources: `import imucal` finds the installed package only
PYTHONDONTWRITEBYTECODE=1 IMUCAL_EXPECT_INSTALLED=1 IMUCAL_REQUIRE_MYPY=1 IMUCAL_SOURCE="$root" \
  IMUCAL_TOOL="$tool" "$work/venv/bin/python" -m pytest -q -rs -p no:cacheprovider \
  "$root/python/tests"
