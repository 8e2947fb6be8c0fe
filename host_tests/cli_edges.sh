#!/bin/sh
# SPDX-License-Identifier: MIT
# The command's edges that need a process of its own: a stdout that cannot be written, and
# inputs that never end or are far larger than what they can be.
#   cli_edges.sh IMUCAL RECORDING.csv
# - calibrate, noise and record with stdout on a full device: exit 2 and the reason on stderr.
# - calibrate and noise of /dev/zero (endless NUL bytes) and of an endless line without a line
#   end: exit 2 within seconds, with the reason.
# - record of /dev/zero, of a 2 GB file and of a record followed by 600 bytes: refused at once
#   (a record has at most 512 bytes): exit 1 with the reason, in bounded memory.
tool="$1"
recording="$2"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
failed=0
fail() { echo "FAILED: $*"; failed=1; }
# expect NAME STATUS WORDS COMMAND...: the command's exit status and a phrase of its stderr.
expect() {
  name="$1"; status="$2"; words="$3"; shift 3
  timeout 20 "$@" >"$dir/out" 2>"$dir/err"
  got=$?
  echo "$name: exit $got: $(head -c 300 "$dir/err" | tr '\n' ' ')"
  [ "$got" -eq "$status" ] || fail "$name: exit $got, expected $status"
  grep -q -- "$words" "$dir/err" || fail "$name: stderr does not say '$words'"
}

# A still recording for noise, a record for record.
awk 'BEGIN { srand(7); print "t,ax,ay,az,gx,gy,gz";
             for (i = 0; i < 3000; i++) printf "%.2f,%.5f,%.5f,%.5f,%.6f,%.6f,%.6f\n", i / 100,
               rand() / 100, rand() / 100, 9.81 + rand() / 100, rand() / 1000, rand() / 1000,
               rand() / 1000 }' >"$dir/still.csv"
"$tool" calibrate "$recording" --quiet --record "$dir/rec.bin" >/dev/null 2>&1 ||
  fail "the recording does not calibrate"

if [ -w /dev/full ]; then
  expect "calibrate > /dev/full" 2 "stdout" sh -c "\"$tool\" calibrate \"$recording\" --quiet >/dev/full"
  expect "noise > /dev/full" 2 "stdout" sh -c "\"$tool\" noise \"$dir/still.csv\" >/dev/full"
  expect "record > /dev/full" 2 "stdout" sh -c "\"$tool\" record \"$dir/rec.bin\" >/dev/full"
fi

expect "calibrate /dev/zero" 2 "NUL" "$tool" calibrate /dev/zero --quiet
expect "noise /dev/zero" 2 "NUL" "$tool" noise /dev/zero --rate 100
expect "calibrate of an endless line" 2 "longer than" \
  sh -c "yes 1 | tr -d '\n' | \"$tool\" calibrate - --quiet"
expect "noise of an endless line" 2 "longer than" \
  sh -c "yes 1 | tr -d '\n' | \"$tool\" noise - --rate 100"

expect "record /dev/zero" 1 "more than 512 bytes" "$tool" record /dev/zero
{ cat "$dir/rec.bin"; head -c 600 /dev/zero; } >"$dir/rec_long.bin"
expect "record and 600 bytes more" 1 "more than 512 bytes" "$tool" record "$dir/rec_long.bin"
truncate -s 2G "$dir/big.bin"
expect "record of 2 GB" 1 "more than 512 bytes" sh -c "ulimit -v 200000; \"$tool\" record \"$dir/big.bin\""

# One absurd accelerometer value (1e12) in the initial rest: refused as a glitch, the calibration
# as without it.
awk -F, 'NR == 306 { $2 = "1e12" } { print }' OFS=, "$recording" >"$dir/glitch.csv"
"$tool" calibrate "$dir/glitch.csv" >"$dir/glitch.out" 2>&1
got=$?
echo "a glitch in the initial rest: exit $got: $(grep -E 'poses,|stream faults' "$dir/glitch.out" | tr '\n' ' ')"
[ "$got" -eq 0 ] || fail "a glitch in the initial rest: exit $got, expected 0"
grep -q "25 poses" "$dir/glitch.out" || fail "a glitch in the initial rest: not 25 poses"
grep -q "glitches (refused) 1" "$dir/glitch.out" || fail "a glitch in the initial rest: not counted"

[ "$failed" -eq 0 ] && echo "every edge handled"
exit "$failed"
