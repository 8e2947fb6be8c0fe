#!/bin/sh
# The command's edges that need a process of its own.
#   cli_edges.sh IMUCAL RECORDING.csv
# - calibrate, noise and record with stdout on a full device: exit 2 and the reason on stderr.
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

[ "$failed" -eq 0 ] && echo "every edge handled"
exit "$failed"
