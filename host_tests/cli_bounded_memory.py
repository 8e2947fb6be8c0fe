#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The command's memory does not grow with its input.

  cli_bounded_memory.py IMUCAL RECORDING.csv [GIGABYTES]

- A file of GIGABYTES (default 2) made of the recording's readings over and over (no t column,
  --rate): calibrated with the default --memory, its peak RSS stays under FILE_BOUND_MB (it is
  read again instead of kept) and every sample is counted.
- An endless stdin of the same readings, with --memory 16: stopped after a few seconds, in which
  it has read far more than 16 MB of samples; its peak RSS stays under 16 MB + STREAM_OVER_MB.
- `imucal noise` on the same endless stdin: its peak RSS stays under NOISE_BOUND_MB.
The bounds are those docs/commands.md states.
"""
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time

FILE_BOUND_MB = 40
STREAM_MEMORY_MB = 16
STREAM_OVER_MB = 40
NOISE_BOUND_MB = 40


def readings(recording):
    """The recording's settings comment and its ax..gz columns as lines, without t."""
    settings, header, rows = [], None, []
    with open(recording) as f:
        for line in f:
            if line.startswith("# imucal:"):
                settings.append(line)
            elif line.startswith("#") or not line.strip():
                continue
            elif header is None:
                header = line.strip().split(",")
            else:
                v = line.strip().split(",")
                rows.append(",".join(v[header.index(c)] for c in ("ax", "ay", "az", "gx", "gy", "gz")))
    return settings, ("\n".join(rows) + "\n").encode(), len(rows)


def vm_hwm_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def main():
    tool, recording = sys.argv[1], sys.argv[2]
    gigabytes = float(sys.argv[3]) if len(sys.argv) > 3 else 2.0
    settings, block, rows = readings(recording)
    head = "".join(settings).encode() + b"ax,ay,az,gx,gy,gz\n"
    failed = []

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "long.csv")
        repeats = int(gigabytes * 1e9 / len(block)) + 1
        with open(path, "wb") as f:
            f.write(head)
            for _ in range(repeats):
                f.write(block)
        size = os.path.getsize(path)
        out = os.path.join(tmp, "long.json")
        start = time.monotonic()
        status = subprocess.run([tool, "calibrate", path, "--rate", "100", "--quiet", "--json", out],
                                stdout=subprocess.DEVNULL).returncode
        seconds = time.monotonic() - start
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
        print(f"file: {size / 1e9:.2f} GB, {repeats * rows} samples: exit {status}, "
              f"peak RSS {peak:.1f} MB (bound {FILE_BOUND_MB}), {seconds:.1f} s")
        if status not in (0, 1):
            failed.append(f"the file's run exited {status}")
        else:
            j = json.load(open(out))
            if j["input"]["samples"] != repeats * rows:
                failed.append(f"{j['input']['samples']} samples counted, {repeats * rows} in the file")
            if j["input"]["reads"] < 2:
                failed.append("the file was not read again")
        if not peak < FILE_BOUND_MB:
            failed.append(f"peak RSS {peak:.1f} MB on the file")

    def endless(args, bound):
        """The command on an endless stdin for 6 s: its peak RSS, or a failure."""
        proc = subprocess.Popen([tool] + args, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        written = [0]

        def feed():
            try:
                proc.stdin.write(head)
                while True:
                    proc.stdin.write(block)
                    written[0] += len(block)
            except (BrokenPipeError, ValueError, OSError):
                pass

        threading.Thread(target=feed, daemon=True).start()
        time.sleep(6)
        alive = proc.poll() is None
        peak = vm_hwm_mb(proc.pid) if alive else float("nan")
        proc.kill()
        proc.wait()
        samples = written[0] / len(block) * rows
        print(f"{args[0]} on stdin: {written[0] / 1e6:.0f} MB written ({samples:.0f} samples, "
              f"{samples * 64 / 1e6:.0f} MB as kept) in 6 s: peak RSS {peak:.1f} MB (bound {bound})")
        if not alive:
            failed.append(f"{args[0]}: the run ended before it was stopped")
        if not samples * 64 > 4 * STREAM_MEMORY_MB * 1e6:
            failed.append(f"{args[0]}: too little was read to reach --memory")
        if not peak < bound:
            failed.append(f"{args[0]}: peak RSS {peak:.1f} MB on the stream")

    endless(["calibrate", "-", "--rate", "100", "--quiet", "--memory", str(STREAM_MEMORY_MB)],
            STREAM_MEMORY_MB + STREAM_OVER_MB)
    endless(["noise", "-", "--rate", "100"], NOISE_BOUND_MB)

    for f in failed:
        print("FAILED:", f)
    if not failed:
        print("memory bounded")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
