#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Checks field_bench --trace against the tables of the same run: for every estimator and
parameter, as many update lines marked FALSE as the JSON counts false updates, at most as many
update lines as updates (an update line is a second in which one or more were published), and
imucal's own decisions traced (its events) when it ran.

  field_bench --life L ... --estimators imucal,chre --trace --json run.json > trace.txt
  bench/field/check_trace.py trace.txt run.json
"""
import collections
import json
import sys


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    lines = [t.split() for t in open(sys.argv[1]) if t.startswith("trace ")]
    updates, false, events = collections.Counter(), collections.Counter(), collections.Counter()
    for f in lines:
        if len(f) > 3 and f[3] == "update":
            updates[(f[1], f[2])] += 1
            false[(f[1], f[2])] += f[-1] == "FALSE"
        else:
            events[f[1]] += 1
    problems = []
    for life in json.load(open(sys.argv[2])):
        for name, params in life["estimators"].items():
            for param, s in params.items():
                key = (name, param)
                if false[key] != s["false_updates"]:
                    problems.append(f"{name} {param}: {false[key]} lines FALSE, the table "
                                    f"{s['false_updates']}")
                if updates[key] > s["updates"] or (s["updates"] > 0) != (updates[key] > 0):
                    problems.append(f"{name} {param}: {updates[key]} update lines, the table "
                                    f"{s['updates']} updates")
            if name == "imucal" and events["imucal"] == 0:
                problems.append("imucal ran but traced no decision")
    if problems:
        sys.exit("field trace: " + "; ".join(problems))
    print(f"field trace checked: {sum(updates.values())} update lines, {sum(false.values())} "
          f"false, {sum(events.values())} decisions")


if __name__ == "__main__":
    main()
