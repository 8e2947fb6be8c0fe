#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Fails if a tracked source or build file lacks the line "SPDX-License-Identifier: MIT" among its
# first lines (after a shebang or an opening comment). Files: .hpp .cpp .c .h .cmake .sh .py .pyi
# and CMakeLists.txt.
#   tools/check_spdx.sh [LINES]   LINES: how many first lines to look in (default 5)
set -euo pipefail
cd "$(dirname "$0")/.."
lines=${1:-5}
missing=()
checked=0
while IFS= read -r -d '' f; do
  checked=$((checked + 1))
  head -n "$lines" "$f" | grep -q 'SPDX-License-Identifier: MIT' || missing+=("$f")
done < <(git ls-files -z -- '*.hpp' '*.cpp' '*.c' '*.h' '*.cmake' '*.sh' '*.py' '*.pyi' \
  'CMakeLists.txt' '*/CMakeLists.txt')
if [ ${#missing[@]} -gt 0 ]; then
  printf '%s\n' "${missing[@]}"
  echo "SPDX: ${#missing[@]} of $checked files lack 'SPDX-License-Identifier: MIT' in their first $lines lines"
  exit 1
fi
echo "SPDX: all $checked files carry 'SPDX-License-Identifier: MIT'"
