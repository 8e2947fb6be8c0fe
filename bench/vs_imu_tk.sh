#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# imucal against imu_tk (the paper's own toolkit) on the Xsens recording, side by side in one
# paired run: each round runs both programs back to back (the order alternating), and the figure
# is the median of the per-round ratios of wall time, with both programs' peak RSS.
#   bench/vs_imu_tk.sh [ROUNDS]     (after `cmake --build --preset host`; default 21 rounds)
# imu_tk is built Release from ../shared/peers/imu_tk (copied into build/, never linked into
# imucal) with Debian's Ceres; the packages it needs are installed when missing.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds="${1:-21}"
peer_src="${IMUCAL_PEER_DIR:-../shared/peers/imu_tk}"
data="${IMUCAL_XSENS_DIR:-../shared/data/xsens}"
tool="${IMUCAL_TOOL:-build/host/tools/imucal}"
if [ ! -f "$data/xsens_acc.mat" ] || [ ! -f "$peer_src/CMakeLists.txt" ]; then
  echo "vs_imu_tk: the xsens recording or imu_tk's source is missing: skipped"
  exit 0
fi
[ -x "$tool" ] || { echo "vs_imu_tk: build the host preset first ($tool)"; exit 1; }

tools/setup_debian.sh libceres-dev libgoogle-glog-dev libgflags-dev libboost-dev libeigen3-dev time

# imu_tk writes its programs into its source tree: build a copy.
peer=build/peer/imu_tk
if [ ! -x "$peer/bin/xsens_calib" ]; then
  rm -rf "$peer"
  mkdir -p build/peer
  cp -r "$peer_src" "$peer"
  chmod -R u+w "$peer"
  cmake -S "$peer" -B "$peer/build" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$peer/build" -j2 --target xsens_calib >/dev/null
fi

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
python3 - "$rounds" "$out" "$peer/bin/xsens_calib" "$tool" "$data" <<'EOF'
import os, statistics, subprocess, sys, time
rounds, out, peer, tool, data = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]
acc, gyro = os.path.join(data, "xsens_acc.mat"), os.path.join(data, "xsens_gyro.mat")
# The same calibration each way: imu_tk's Xsens settings (as in its own test program), and the
# README's imucal command with the same units and gravity.
commands = {
    "imu_tk": [peer, acc, gyro, "0", os.path.join(out, "peer")],
    "imucal": [tool, "calibrate", acc, gyro, "--accel-unit", "counts", "--accel-lsb-per-g", "4070",
               "--accel-zero", "32768", "--gyro-unit", "counts", "--gyro-lsb-per-dps", "83.2522",
               "--gravity", "9.81744", "--quiet", "--json", os.path.join(out, "xsens.json")],
}

def run(cmd):
    start = time.perf_counter()
    status = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    wall = time.perf_counter() - start
    if status != 0:
        sys.exit(f"vs_imu_tk: {cmd[0]} failed (status {status})")
    return wall

def peak_rss(cmd):  # MiB, by GNU time (a forked Python's own pages would count in wait4's)
    r = subprocess.run(["/usr/bin/time", "-f", "%M"] + cmd, stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True)
    return int(r.stderr.strip().splitlines()[-1]) / 1024.0

rss = {name: peak_rss(cmd) for name, cmd in commands.items()}  # also warms the page cache
ratios, walls = [], {k: [] for k in commands}
for i in range(rounds):
    order = list(commands) if i % 2 == 0 else list(reversed(commands))
    got = {}
    for name in order:
        got[name] = run(commands[name])
        walls[name].append(got[name])
    ratios.append(got["imu_tk"] / got["imucal"])
med = statistics.median
q = statistics.quantiles(ratios, n=4)
for name in commands:
    print(f"{name}: wall median {med(walls[name]) * 1e3:.1f} ms, peak RSS {rss[name]:.1f} MiB")
print(f"paired ratio imu_tk / imucal (wall, {rounds} rounds): median {med(ratios):.1f}x "
      f"(quartiles {q[0]:.1f}x .. {q[2]:.1f}x)")
EOF
