#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
r"""Where a benchmark's instructions go, by source line: runs an instruction-count program under
QEMU with the counting plugin in profile mode (bench/qemu_plugin), then sums the instructions
of the functions whose names match FUNCTIONS by the project's source line they come from (code
inlined from Eigen or the C++ library counts at the project line that called it; a function
compiled outside the project, such as a soft-float routine, counts under its own name), divided by
the number of regions profiled: the first REGIONS regions if given, else all. A second table
charges the routines outside the project (soft float on a core without an FPU) to the project
lines that call them. Markdown out.

  bench/insn_profile.py PRESET ELF FUNCTIONS [REGIONS] [LINES]
  bench/insn_profile.py m4f build/insn/m4f/bench/bench_stream_insn . 51175

bench_stream_insn's first 51175 regions are the add() calls, one per sample of the Xsens
recording: with '.' as FUNCTIONS, where add()'s instructions go, averaged over every sample
(initial rest, rests and moves together). The programs are built with -g1 (bench/insn_cores.sh
builds them in build/insn/CORE). Built with -DIMUCAL_BENCH_RAW_FIRST, bench_stream_insn's first
51175 regions are add_raw()'s instead, and with -DIMUCAL_BENCH_PROFILE_STILL as well its regions
are only those of the frames that come while the calibrator is still after the initial rest
(REGIONS 0: all of them), the per-frame cost at rest; built with -DIMUCAL_BENCH_PROFILE_FIELD, bench_field_insn's
regions are the field calibrator's add_raw() calls alone (REGIONS 0: all of them), and with
-DIMUCAL_BENCH_PROFILE_STILL as well only those of still frames while no model solves (a rest
judged in one of them still counts). For example:

  cmake -S . -B build/prof/m0plus -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g -DIMUCAL_BENCH_PROFILE_FIELD" \
    -DCMAKE_TOOLCHAIN_FILE=$PWD/toolchains/cortex-m0plus.cmake -DIMUCAL_BUILD_TESTS=OFF \
    -DIMUCAL_BUILD_BENCH=ON -DIMUCAL_BUILD_INSN_BENCH=ON
  cmake --build build/prof/m0plus --target bench_field_insn
  bench/insn_profile.py m0plus build/prof/m0plus/bench/bench_field_insn . 0
"""
import os
import re
import subprocess
import sys
import tempfile

MACHINES = {"m4f": "mps2-an386", "m7": "mps2-an500", "m33": "mps2-an505", "m3": "mps2-an385",
            "m0plus": "mps2-an385", "rv32": "riscv32:virt"}


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    preset, elf, pattern = sys.argv[1:4]
    first = int(sys.argv[4]) if len(sys.argv) > 4 else 0
    top = int(sys.argv[5]) if len(sys.argv) > 5 else 25
    here = os.path.dirname(os.path.abspath(__file__))
    prefix = "riscv64-unknown-elf-" if preset == "rv32" else "arm-none-eabi-"
    with tempfile.TemporaryDirectory() as tmp:
        profile = os.path.join(tmp, "profile.txt")
        run = subprocess.run([os.path.join(here, "qemu_plugin", "qemu_insn_count.sh"),
                              MACHINES[preset], elf], capture_output=True, text=True,
                             env=dict(os.environ, IMUCAL_INSN_PROFILE=profile,
                                      IMUCAL_INSN_PROFILE_REGIONS=str(first)))
        if run.returncode != 0 or not os.path.exists(profile):
            sys.exit(f"insn_profile: the program failed (exit {run.returncode})\n{run.stderr}")
        counts, regions = {}, 0
        for line in open(profile):
            a, b = line.split()
            if a == "regions":
                regions = int(b)
            else:
                counts[int(a, 16)] = int(b)
    if regions == 0:
        sys.exit("insn_profile: no region was counted")
    # The profile must hold exactly the regions' own counts (the plugin's insn_count lines).
    region_counts = [int(t.split()[1]) for t in run.stdout.splitlines()
                     if t.startswith("insn_count ")][:regions]
    if sum(counts.values()) != sum(region_counts):
        sys.exit(f"insn_profile: the profile holds {sum(counts.values())} instructions, the "
                 f"regions {sum(region_counts)}")
    # The matching functions' instruction addresses, from the symbol table.
    syms = subprocess.run([prefix + "nm", "-S", "-C", "--defined-only", elf], capture_output=True,
                          text=True, check=True).stdout
    ranges, functions = [], []
    for text in syms.splitlines():
        f = text.split(None, 3)
        if len(f) == 4 and f[2] in {"T", "t", "W", "w"}:
            start = int(f[0], 16) & ~1
            functions.append((start, start + int(f[1], 16), f[3]))
            if re.search(pattern, f[3]):
                ranges.append((start, start + int(f[1], 16)))
    counted = sorted(a for a in counts if any(lo <= a < hi for lo, hi in ranges))

    def function_of(a):  # code outside the project's sources: the C runtime, soft float
        return next((name for lo, hi, name in functions if lo <= a < hi), "?")

    if not counted:
        sys.exit(f"insn_profile: no instruction of a function matching '{pattern}' ran")
    # Each address's inlining chain, innermost first; the first frame in the project's sources.
    root = os.path.dirname(os.path.realpath(here))
    lines = subprocess.run([prefix + "addr2line", "-i", "-a", "-e", elf] +
                           [hex(a) for a in counted], capture_output=True, text=True,
                           check=True).stdout.splitlines()
    where_of, address, chosen = {}, None, None
    for text in lines + ["0x"]:
        if text.startswith("0x"):
            if address is not None:
                where_of[address] = chosen or f"({function_of(address)})"
            address, chosen = (int(text, 16) if text != "0x" else None), None
            continue
        path, _, line = text.partition(" ")[0].rpartition(":")
        path = os.path.realpath(path) if path.startswith("/") else path
        if chosen is None and path.startswith(root + "/") and line.isdigit() and int(line) > 0:
            chosen = f"{os.path.relpath(path, root)}:{line}"
    if not any(not w.startswith("(") for w in where_of.values()):
        sys.exit("insn_profile: no instruction maps to a line of the project's sources (an ELF "
                 "built without -g1?)")
    by_line = {}
    for a in counted:
        by_line[where_of[a]] = by_line.get(where_of[a], 0) + counts[a]
    total = sum(by_line.values())
    print(f"functions matching '{pattern}': {total / regions:.1f} instructions per region "
          f"({regions} regions)\n")
    print("| instructions per region | source line | code |")
    print("| ---: | --- | --- |")
    for where, n in sorted(by_line.items(), key=lambda kv: -kv[1])[:top]:
        code = ""
        if not where.startswith("("):
            path, line = where.rsplit(":", 1)
            try:
                code = open(os.path.join(root, path)).read().splitlines()[int(line) - 1].strip()
            except (OSError, IndexError, ValueError):
                pass
        code = code[:80].replace("|", "\\|")
        where = (where if len(where) <= 100 else where[:99] + "…").replace("|", "\\|")
        print(f"| {n / regions:.1f} | {where} | `{code}` |")
    print_runtime_callers(prefix, elf, counts, regions, functions, root, top)


def print_runtime_callers(prefix, elf, counts, regions, functions, root, top):
    """The instructions of routines outside the project's sources (soft float, the C runtime)
    charged to the project line that calls them: each call site's count (its call instruction's)
    times the routine's own instructions per call. A routine's calls into others count at the
    routine's name."""
    dis = subprocess.run([prefix + "objdump", "-d", "--no-show-raw-insn", elf], capture_output=True,
                         text=True, check=True).stdout
    call = re.compile(r"^\s*([0-9a-f]+):\s+(?:bl|blx|jal|call)\s+(?:ra,)?\s*[0-9a-f]+ <([^>+]+)>")
    sites = [(int(m.group(1), 16), m.group(2)) for m in map(call.match, dis.splitlines()) if m]
    sites = [(a, name) for a, name in sites if a in counts]
    span = {name: (lo, hi) for lo, hi, name in functions}
    own = {}
    for lo, hi, name in functions:
        n = sum(c for a, c in counts.items() if lo <= a < hi)
        if n:
            own[name] = n
    calls = {}
    for a, name in sites:
        calls[name] = calls.get(name, 0) + counts[a]
    # Routines outside the project: no instruction of theirs maps to a project line.
    names = sorted(own)
    firsts = subprocess.run([prefix + "addr2line", "-e", elf] + [hex(span[n][0]) for n in names],
                            capture_output=True, text=True, check=True).stdout.splitlines()
    outside = {n for n, text in zip(names, firsts) if not text.startswith(root + "/")}
    charged = [(a, name) for a, name in sites if name in outside and calls.get(name)]
    if not charged:
        return
    where = subprocess.run([prefix + "addr2line", "-i", "-a", "-e", elf] +
                           [hex(a) for a, _ in charged], capture_output=True, text=True,
                           check=True).stdout.splitlines()
    line_of, address = {}, None
    for text in where + ["0x"]:
        if text.startswith("0x"):
            address = int(text, 16) if text != "0x" else None
            continue
        path, _, line = text.partition(" ")[0].rpartition(":")
        path = os.path.realpath(path) if path.startswith("/") else path
        if address not in line_of and path.startswith(root + "/") and line.isdigit():
            line_of[address] = f"{os.path.relpath(path, root)}:{line}"
    by_line = {}
    for a, name in charged:
        key = line_of.get(a) or f"({next((f for lo, hi, f in functions if lo <= a < hi), '?')})"
        by_line[key] = by_line.get(key, 0) + counts[a] * own[name] / calls[name]
    print(f"\nruntime routines (soft float, the C runtime) charged to the lines that call them: "
          f"{sum(by_line.values()) / regions:.1f} instructions per region\n")
    print("| instructions per region | calling line |")
    print("| ---: | --- |")
    for key, n in sorted(by_line.items(), key=lambda kv: -kv[1])[:top]:
        print(f"| {n / regions:.1f} | {key} |")


if __name__ == "__main__":
    main()
