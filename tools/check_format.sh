#!/usr/bin/env bash
# The C, C++ lines a change touches follow .clang-format: clang-format-diff over the diff from BASE (default: the last
# commit's parent, so CI on a clean clone checks the newest commit; uncommitted changes are included). Lines the change
# does not touch are left as they are. Exit 1 with the diff that would fix them.
# Usage: tools/check_format.sh [BASE]
set -euo pipefail
cd "$(dirname "$0")/.."
base="${1:-HEAD~1}"
if ! git rev-parse -q --verify "$base^{commit}" >/dev/null; then
  echo "check_format: no commit $base here (a shallow clone?): nothing to compare with, nothing checked"
  exit 0
fi
formatter=$(command -v clang-format-diff || command -v clang-format-diff-14 || true)
[[ -n $formatter ]] || { echo "check_format: clang-format-diff is not installed (Debian clang-format)"; exit 1; }
fixes=$(git diff -U0 --no-color "$base" -- '*.cpp' '*.hpp' '*.c' '*.h' | "$formatter" -p1)
if [[ -n $fixes ]]; then
  echo "$fixes"
  echo "FAIL: the lines above, changed since $base, do not follow .clang-format (clang-format-diff -p1 -i fixes them)"
  exit 1
fi
echo "the changed lines since $base follow .clang-format"
