#!/bin/sh
# SPDX-License-Identifier: MIT
# imucal out of memory: exit 2 with the reason on stderr, never an abort. An endless stream on
# stdin under a 160 MB address-space limit (not run under AddressSanitizer, which reserves more).
#   cli_out_of_memory.sh IMUCAL
tool="$1"
err=$(mktemp)
ulimit -v 160000
awk 'BEGIN { print "t,ax,ay,az,gx,gy,gz"; for (i = 0; i < 20000000; i++) printf "%.2f,0,0,9.81,0,0,0\n", i / 100 }' |
  "$tool" calibrate --quiet - >/dev/null 2>"$err"
status=$?
cat "$err"
said=$(grep -c "out of memory" "$err")
rm -f "$err"
[ "$status" -eq 2 ] || { echo "exit status $status, expected 2"; exit 1; }
[ "$said" -ge 1 ] || { echo "no reason given"; exit 1; }
echo "exit 2 with the reason"
