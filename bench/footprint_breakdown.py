#!/usr/bin/env python3
"""Where imucal's text goes in one footprint program: its functions grouped by part, as a
Markdown table. The share is the program's text minus the baseline program's (the same I/O
without imucal, bench/footprint/footprint.cpp), as bench/footprint_parts.sh reports it; the C
library and compiler-runtime row is what the program links beyond the baseline's.

  bench/footprint_parts.sh m4f:-Os     # builds build/footprint/m4f-Os
  bench/footprint_breakdown.py build/footprint/m4f-Os/bench/imucal_footprint_parts3 \
      build/footprint/m4f-Os/bench/imucal_footprint_baseline [arm-none-eabi-]
"""
import re
import subprocess
import sys

# First match wins; a symbol's demangled name is matched.
PARTS = [
    ("Eigen's out-of-line code (expression templates GCC did not inline)", r"^(\S+ )?Eigen::"),
    ("streaming calibrator: stream checks, initial rest, stillness, blocks, moves, poses",
     r"imucal::(Calibrator<|InitialRestWindow|PoseCollection|PoseStore|MoveStore|SampleBlock|"
     r"DelayLine|GyroSegment|FullScale|RateWatch|ClockResetWatch|StillnessDetector|"
     r"TemperatureMean|SolveSequence|judge_quality|coverage)"),
    ("accelerometer solver: pose checks, start, LM problem, covariance",
     r"imucal::(AccelSolver|check_poses|fit_ellipsoid|\(anonymous namespace\)::params_from_quadric|"
     r"accel_)"),
    ("gyro solver: the chained residuals, input uncertainty",
     r"imucal::(GyroProblem|GyroSolver|GyroInputUncertainty|rodrigues_coefficients|gyro_)"),
    ("normal equations and Levenberg-Marquardt", r"imucal::(NormalEquations|LevenbergMarquardt|detail::(ldlt|ne_))"),
    ("magnetometer: collector, ellipsoid solve, alignment",
     r"imucal::(Mag(Calibrator|Collector|Settings)|mag_(solve|align)|"
     r"\(anonymous namespace\)::(AlignProblem|calibrated_coverage|settings_valid))"),
    ("temperature: rest monitor, bias-against-temperature fit",
     r"imucal::(TemperatureFit|RestMonitor|\(anonymous namespace\)::finish_bias)"),
    ("record, its codec and bounds, the flash store",
     r"imucal::(RecordStore|CalibrationRecord|encode_record|decode_record|make_record|record_|crc32|"
     r"[a-z_]+_bound|Bound|bounds::|TemperatureBias|TemperatureModel|MagCalibration|SimNorFlash|"
     r"to_string|\(anonymous namespace\)::(Reader|Writer|Guard|kMagic|record_|read_|write_|"
     r"[a-z_]+_ok|all_of_finite|bias_to_float))"),
    ("corrector", r"imucal::Corrector"),
    ("elementary functions (log2, exp2, sin and cos)", r"imucal::detail::"),
    ("the program's own calls (main, static construction)", r"^(main|_GLOBAL__sub_I_main)$"),
]


def symbols(elf, nm):
    out = subprocess.run([nm, "-S", "-t", "d", "--defined-only", elf], capture_output=True,
                         text=True, check=True).stdout
    sizes = {}
    for line in out.splitlines():
        f = line.split(None, 3)
        if len(f) == 4 and f[2] in "TtWw":
            sizes[(f[0], f[3])] = int(f[1])  # aliases (same address and name) once
    names = subprocess.run(["c++filt"], input="\n".join(n for _, n in sizes), capture_output=True,
                           text=True, check=True).stdout.splitlines()
    by_address = {}
    for ((address, _), size), name in zip(sizes.items(), names):
        by_address.setdefault(address, (size, name))  # constructor aliases C1/C2 once
    return list(by_address.values())


def text_size(elf, prefix):
    out = subprocess.run([prefix + "size", elf], capture_output=True, text=True, check=True).stdout
    return int(out.splitlines()[1].split()[0])


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    elf, baseline = sys.argv[1], sys.argv[2]
    prefix = sys.argv[3] if len(sys.argv) > 3 else "arm-none-eabi-"
    nm = prefix + "nm"
    share = text_size(elf, prefix) - text_size(baseline, prefix)
    base_names = {name: size for size, name in symbols(baseline, nm)}
    totals = {label: 0 for label, _ in PARTS}
    runtime = 0
    for size, name in symbols(elf, nm):
        label = next((lab for lab, rx in PARTS if re.search(rx, name)), None)
        if label is None and "imucal::" not in name:
            runtime += size - base_names.get(name, 0)
            continue
        key = label or "other imucal code"
        totals[key] = totals.get(key, 0) + size
    rows = sorted(((v, k) for k, v in totals.items() if v), reverse=True)
    rows.append((runtime, "C library and compiler runtime beyond the baseline's"))
    rows.append((share - sum(v for v, _ in rows),
                 "constants, tables and alignment (text not in a function symbol)"))
    print(f"| part ({elf.split('/')[-1]}) | text (B) | share |")
    print("| --- | ---: | ---: |")
    for v, k in rows:
        print(f"| {k} | {v:,} | {100.0 * v / share:.0f} % |")
    print(f"| imucal's share | {share:,} | 100 % |")


if __name__ == "__main__":
    main()
