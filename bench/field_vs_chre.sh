#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Field calibrators side by side on every simulated life (bench/field/README.md): each life runs
# through every estimator this build has (imucal's when bench/field/imucal_estimator.cpp exists,
# Android's CHRE when its sources are in ../shared/peers/chre-calibration, the oracle) and the
# tables of field.md section 7's metrics are written as markdown and JSON.
#   bench/field_vs_chre.sh [--long] [--seed N] [--out DIR] [field_bench options...]
# Default: two days per life (about a minute of one core); --long: fourteen days per life.
# Needs the host build's field_bench (cmake --build build/host --target field_bench).
set -euo pipefail
cd "$(dirname "$0")/.."
bench="${IMUCAL_FIELD_BENCH:-build/host/bench/field_bench}"
length=(--days 2)
seed=1
out=build/field
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --long) length=(--days 14) ;;
    --seed) seed="$2"; shift ;;
    --out) out="$2"; shift ;;
    *) extra+=("$1") ;;
  esac
  shift
done
[ -x "$bench" ] || { echo "field_vs_chre: build it first: cmake --build build/host --target field_bench"; exit 1; }
mkdir -p "$out"
"$bench" --list
"$bench" --life all "${length[@]}" --seed "$seed" ${extra[@]+"${extra[@]}"} \
  --markdown "$out/field_vs_chre.md" --json "$out/field_vs_chre.json"
echo "field_vs_chre: $out/field_vs_chre.md, $out/field_vs_chre.json"
