#!/usr/bin/env bash
# scripts/check-format fails naming the file that is not formatted as
# .clang-format says, and passes the one that is: two files, one of them
# with the 4-space indent, the space before `(` and the line over 120 columns
# the style refuses.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/good.cpp" <<'CPP'
#include "z.hpp"
#include "a.hpp"

namespace cansim {

int twice(int x) { return 2 * x; }

}  // namespace cansim
CPP
cat > "$tmp/bad.cpp" <<'CPP'
namespace cansim {

int twice (int x) {
    return 2 * x;
}

int sum(int aaaaaaaaaaaaaaaaaaaa, int bbbbbbbbbbbbbbbbbbbbbbbbb, int cccccccccccccccccccccccc, int dddddddddddddddddddd) { return 0; }

}  // namespace cansim
CPP
"$root/scripts/check-format" "$tmp/good.cpp" >/dev/null ||
  { echo "FAIL: check-format refused a formatted file (includes out of order must stay)" >&2; exit 1; }
status=0
"$root/scripts/check-format" "$tmp/good.cpp" "$tmp/bad.cpp" >"$tmp/out" 2>&1 || status=$?
[ "$status" -eq 1 ] || { echo "FAIL: exit $status, not 1, for an unformatted file:" >&2; cat "$tmp/out" >&2; exit 1; }
grep -qx "$tmp/bad.cpp" "$tmp/out" || { echo "FAIL: bad.cpp not named:" >&2; cat "$tmp/out" >&2; exit 1; }
if grep -q "good.cpp" "$tmp/out"; then echo "FAIL: good.cpp named:" >&2; cat "$tmp/out" >&2; exit 1; fi
grep -q '^check-format: 1 of 2 file(s) are not formatted' "$tmp/out" ||
  { echo "FAIL: no summary:" >&2; cat "$tmp/out" >&2; exit 1; }
status=0
"$root/scripts/check-format" --bogus >/dev/null 2>&1 || status=$?
[ "$status" -eq 2 ] || { echo "FAIL: a bad option exits $status, not 2" >&2; exit 1; }
echo "check-format: the unformatted file named, the formatted one passed"
