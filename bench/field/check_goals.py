#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
# The field calibrator's goals on the field bench's JSON (field_bench --json, imucal and chre in one
# run): on every life, imucal's gyro bias error at most `ratio` of CHRE's at the median and at the
# 95th percentile, no false gyro update, and the sigma honest: on every life the RMS of error/sigma
# within --honesty, and over the lives (the RMS of the lives' figures, each life weighing the same)
# within --pooled. The accelerometer's and the magnetometer's figures over the lives are printed.
#   check_goals.py FILE [--ratio R] [--honesty LO HI] [--pooled LO HI]
# Prints one line per life and exits 1 (naming what failed) if any goal is missed.
import argparse
import json
import math
import sys

ap = argparse.ArgumentParser()
ap.add_argument("file")
ap.add_argument("--ratio", type=float, default=0.5)
ap.add_argument("--honesty", type=float, nargs=2, default=(0.7, 1.3))
ap.add_argument("--pooled", type=float, nargs=2, default=(0.8, 1.25))
a = ap.parse_args()


def over_the_lives(lives, sensor):
    """The RMS of the lives' sigma honesty for one sensor (lives where it published), and how many."""
    h = [e["imucal"][sensor]["sigma_honesty"] for e in (life["estimators"] for life in lives)
         if sensor in e["imucal"] and e["imucal"][sensor].get("sigma_honesty") is not None]
    return (math.sqrt(sum(x * x for x in h) / len(h)) if h else None), len(h)


failed = []
lives = json.load(open(a.file))
for life in lives:
    e = life["estimators"]
    mine, peer = e["imucal"]["gyro"], e["chre"]["gyro"]
    name = life["life"]
    if not mine["any"]:
        failed.append(f"{name}: imucal never published")
        continue
    med, p95 = mine["median"] / peer["median"], mine["p95"] / peer["p95"]
    print(f"{name}: imucal/chre median {med:.2f}, p95 {p95:.2f}; false updates {mine['false_updates']} "
          f"(chre {peer['false_updates']}); honesty {mine['sigma_honesty']:.2f}; first {mine['first_s']} s")
    if med > a.ratio:
        failed.append(f"{name}: median ratio {med:.2f} > {a.ratio}")
    if p95 > a.ratio:
        failed.append(f"{name}: p95 ratio {p95:.2f} > {a.ratio}")
    if mine["false_updates"] != 0:
        failed.append(f"{name}: {mine['false_updates']} false updates")
    h = mine["sigma_honesty"]
    if not a.honesty[0] <= h <= a.honesty[1]:
        failed.append(f"{name}: sigma honesty {h:.2f} outside {a.honesty[0]}..{a.honesty[1]}")
for sensor in ("gyro", "accel", "mag"):
    pooled, n = over_the_lives(lives, sensor)
    if pooled is None:
        continue
    print(f"{sensor} sigma honesty over the {n} lives it published on: {pooled:.2f}")
    if sensor == "gyro" and not a.pooled[0] <= pooled <= a.pooled[1]:
        failed.append(f"gyro sigma honesty over the lives {pooled:.2f} outside {a.pooled[0]}..{a.pooled[1]}")
if failed:
    print("field goals missed: " + "; ".join(failed))
    sys.exit(1)
print("field goals met")
