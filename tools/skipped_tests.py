#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Lists every GoogleTest case that skipped (GTEST_SKIP) in the last ctest run of each build
folder given, with its reason and the builds it skipped in, and the ctest tests reported
"Skipped" (every case they ran skipped). With --data-present, a case that skipped because a
recording was not found is an error: the real recordings are beside the clone.

  tools/skipped_tests.py [--data-present] BUILD_DIR...
"""
import argparse
import collections
import pathlib
import re
import sys

RUN = re.compile(r"^\[ RUN      \] (\S+)")
SKIPPED_AT = re.compile(r"^\S.*:\d+: Skipped$")
SKIPPED = re.compile(r"^\[  SKIPPED \] (\S+) \(")
CTEST_SKIPPED = re.compile(r'^\d+/\d+ Test: (\S+)$')


def skips_in(log_text):
    """(case, reason) of every skipped case in a ctest LastTest.log."""
    current, reason, in_reason = None, [], False
    for line in log_text.splitlines():
        m = RUN.match(line)
        if m:
            current, reason, in_reason = m.group(1), [], False
            continue
        if SKIPPED_AT.match(line):
            in_reason = True
            continue
        m = SKIPPED.match(line)
        if m and m.group(1) == current:
            yield current, " ".join(r for r in reason if r) or "(no reason given)"
            current, reason, in_reason = None, [], False
            continue
        if in_reason:
            reason.append(line.strip())


def skipped_ctest_tests(log_text):
    """Names of the ctest tests whose status was "Skipped"."""
    names, name = [], None
    for line in log_text.splitlines():
        m = CTEST_SKIPPED.match(line)
        if m:
            name = m.group(1)
        elif line.startswith("Skip regular expression found in output"):
            names.append(name)
    return names


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-present", action="store_true",
                        help="a case skipped for a missing recording is an error")
    parser.add_argument("builds", nargs="+", type=pathlib.Path)
    args = parser.parse_args()
    where = collections.defaultdict(list)  # (case, reason) -> builds
    ctest_skipped = collections.defaultdict(list)  # ctest test -> builds
    for build in args.builds:
        log = build / "Testing" / "Temporary" / "LastTest.log"
        if not log.is_file():
            continue
        text = log.read_text(errors="replace")
        for case_reason in dict.fromkeys(skips_in(text)):
            where[case_reason].append(build.name)
        for test in skipped_ctest_tests(text):
            ctest_skipped[test].append(build.name)
    print(f"skipped gtest cases: {len(where)} (in {sum(map(len, where.values()))} runs)")
    for (case, reason), builds in sorted(where.items()):
        print(f"  {case} [{' '.join(builds)}]: {reason}")
    print(f"ctest tests reported Skipped: {len(ctest_skipped)}")
    for test, builds in sorted(ctest_skipped.items()):
        print(f"  {test} [{' '.join(builds)}]")
    missing = [c for (c, r) in where if "recording not found" in r]
    if args.data_present and missing:
        print("the recordings are beside the clone, yet these skipped for a missing recording: "
              + " ".join(sorted(set(missing))))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
