#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Where imucal's text goes in one footprint program: its functions grouped by part, as a
Markdown table. The share is the program's text minus the baseline program's (the same I/O
without imucal, bench/footprint/footprint.cpp), as bench/footprint_parts.sh reports it. Every
function is counted by its size in the program minus its size in the baseline (main, the C
library); the rows sum to the share.

  bench/footprint_parts.sh m4f:-Os     # builds build/footprint/m4f-Os
  bench/footprint_breakdown.py build/footprint/m4f-Os/bench/imucal_footprint_parts3 \
      build/footprint/m4f-Os/bench/imucal_footprint_baseline [arm-none-eabi-]
"""
import re
import subprocess
import sys

# Matched against a function's own qualified name: no return type, parameters or template
# arguments ("imucal::GyroProblem::advance"; an anonymous namespace reads "(anon)"). First match
# wins.
PARTS = [
    ("Eigen's out-of-line code (small fixed-size expressions GCC did not inline)", r"^Eigen::"),
    ("field calibrator: decisions, the accelerometer's, gyro's and magnetometer's models, saves",
     r"^imucal::(FieldCalibrator|FieldSettings|AccelField|GyroField|GyroFieldSettings|BiasFilter|"
     r"MagField|mag_prior|save_field|resume_field)(?!\w)"),
    ("streaming calibrator: stream checks, initial rest, stillness, blocks, moves, poses",
     r"^imucal::(Calibrator|InitialRestWindow|PoseCollection|PoseStore|MoveStore|SampleBlock|"
     r"Segmenter|SubBlock|detail::RawSums|detail::FloatSums|SubBlockStats|StreamChecks|RestSummary|"
     r"DelayLine|GyroSegment|FullScale|RateWatch|ClockResetWatch|StillnessDetector|"
     r"TemperatureMean|SolveSequence|judge_quality|coverage_hint|set_coverage|split_rest_rotation|"
     r"compensated_add)(?!\w)"),
    ("accelerometer solver: pose checks, start, LM problem, covariance",
     r"^imucal::(AccelSolver|AccelCalibration|check_poses|fit_ellipsoid|accel_[a-z_]+|"
     r"\(anon\)::params_from_quadric)(?!\w)"),
    ("gyro solver: the chained residuals, input uncertainty",
     r"^imucal::(GyroProblem|GyroSolver|GyroInputUncertainty|GyroCalibration|rodrigues_coefficients|"
     r"gyro_[a-z_]+|skew|rotation_exp)(?!\w)"),
    ("normal equations and Levenberg-Marquardt",
     r"^imucal::(NormalEquations|LevenbergMarquardt|detail::(ldlt|ne)_[a-z_]+)(?!\w)"),
    ("magnetometer: collector, ellipsoid solve, alignment",
     r"^imucal::(Mag(Calibrator|Collector|Settings)|mag_(solve|align)|"
     r"\(anon\)::(AlignProblem|MagProblem|calibrated_coverage|settings_valid|"
     r"rotation_exp_and_left_jacobian|rotation_log))(?!\w)"),
    ("temperature: rest monitor, bias-against-temperature fit",
     r"^imucal::(TemperatureFit|RestMonitor|\(anon\)::finish_bias)(?!\w)"),
    ("record, its codec and bounds, the flash store",
     r"^imucal::(RecordStore|CalibrationRecord|encode_record|decode_record|make_record|"
     r"record_bound|crc32|[a-z_]+_bound|bounds|TemperatureBias|TemperatureModel|MagCalibration|"
     r"SimNorFlash|to_string|\(anon\))(?!\w)"),
    ("corrector", r"^imucal::Corrector(?!\w)"),
    ("elementary functions (log2, exp2, sin and cos)", r"^imucal::detail::"),
    ("the program's own calls (main, static construction)",
     r"^(main|_GLOBAL__sub_I_main|__static_initialization_and_destruction_0)$"),
]
RUNTIME = "C library and compiler runtime beyond the baseline's"


def own_name(demangled):
    """imucal::GyroProblem<float>::advance<true>(...) const [clone .isra.0] ->
    imucal::GyroProblem::advance (the return type, arguments and clones dropped)."""
    name = re.sub(r" \[clone [^]]*\]", "", demangled).replace("(anonymous namespace)", "(anon)")
    name = name.replace(") const::", ")::")  # a lambda in a const member function
    out, depth = [], 0
    for ch in name:  # template arguments out, at every depth
        if ch == "<" and not out[-8:] == list("operator"):
            depth += 1
        elif ch == ">" and depth:
            depth -= 1
        elif depth == 0:
            out.append(ch)
    name = "".join(out)
    # The parameter list: the last top-level "(...)" that is not "(anon)".
    depth, cut = 0, len(name)
    for i in range(len(name) - 1, -1, -1):
        if name[i] == ")":
            depth += 1
        elif name[i] == "(":
            depth -= 1
            if depth == 0 and not name.startswith("(anon)", i):
                cut = i
                break
    name = name[:cut].strip()
    depth = 0
    for i in range(len(name) - 1, -1, -1):  # the return type out: the last top-level space
        if name[i] in ")}":
            depth += 1
        elif name[i] in "({":
            depth -= 1
        elif name[i] == " " and depth == 0:
            return name[i + 1:]
    return name


def symbols(elf, nm):
    """{demangled name: size} of the program's functions, an alias (same address) once."""
    out = subprocess.run([nm, "-S", "-t", "d", "--defined-only", elf], capture_output=True,
                         text=True, check=True).stdout
    by_address = {}
    for line in out.splitlines():
        f = line.split(None, 3)
        if len(f) == 4 and f[2] in {"T", "t", "W", "w"}:
            by_address.setdefault(f[0], (f[3], int(f[1])))
    mangled = list(by_address.values())
    names = subprocess.run(["c++filt"], input="\n".join(n for n, _ in mangled),
                           capture_output=True, text=True, check=True).stdout.splitlines()
    sizes = {}
    for (_, size), name in zip(mangled, names):
        sizes[name] = sizes.get(name, 0) + size
    return sizes


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
    program, base = symbols(elf, nm), symbols(baseline, nm)
    totals = {}
    for name in set(program) | set(base):
        delta = program.get(name, 0) - base.get(name, 0)
        if delta == 0:
            continue
        own = own_name(name)
        label = next((lab for lab, rx in PARTS if re.search(rx, own)), None)
        if label is None:
            label = "other imucal code" if own.startswith("imucal::") else RUNTIME
        totals[label] = totals.get(label, 0) + delta
    rows = sorted(((v, k) for k, v in totals.items() if k != RUNTIME and v), reverse=True)
    rows.append((totals.get(RUNTIME, 0), RUNTIME))
    rest = share - sum(v for v, _ in rows)
    rows.append((rest, "constants, tables and alignment (text not in a function symbol)"))
    print(f"| part ({elf.split('/')[-1]}) | text (B) | share |")
    print("| --- | ---: | ---: |")
    for v, k in rows:
        print(f"| {k} | {v:,} | {100.0 * v / share:.0f} % |")
    print(f"| imucal's share | {share:,} | 100 % |")
    if rest < 0:
        sys.exit("footprint_breakdown: the function symbols add up to more than the share")


if __name__ == "__main__":
    main()
