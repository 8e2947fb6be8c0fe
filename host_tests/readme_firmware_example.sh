#!/bin/sh
# SPDX-License-Identifier: MIT
# The README's firmware example is the example firmware's own code: every line of its C++ block
# (under "## In a firmware") is a line of examples/firmware/main.cpp, leading blanks aside; lines
# that are only a comment are the README's own headings.
#   readme_firmware_example.sh SOURCE_DIR
src="$1"
block=$(awk '/^## In a firmware/ { in_section = 1; next }
             /^## / { in_section = 0 }
             in_section && /^```cpp/ { in_code = 1; next }
             in_code && /^```/ { exit }
             in_code { print }' "$src/README.md")
if [ -z "$block" ]; then
  echo "no C++ block under '## In a firmware' in README.md"
  exit 1
fi
missing=0
lines=0
printf '%s\n' "$block" | sed 's/^ *//' | grep -v -e '^$' -e '^//' > "${TMPDIR:-/tmp}/readme_block.$$"
sed 's/^ *//' "$src/examples/firmware/main.cpp" > "${TMPDIR:-/tmp}/main_lines.$$"
while IFS= read -r line; do
  lines=$((lines + 1))
  if ! grep -qxF -- "$line" "${TMPDIR:-/tmp}/main_lines.$$"; then
    echo "not in examples/firmware/main.cpp: $line"
    missing=$((missing + 1))
  fi
done < "${TMPDIR:-/tmp}/readme_block.$$"
rm -f "${TMPDIR:-/tmp}/readme_block.$$" "${TMPDIR:-/tmp}/main_lines.$$"
[ "$missing" -eq 0 ] || exit 1
echo "the README's firmware example: $lines lines, all in examples/firmware/main.cpp"
