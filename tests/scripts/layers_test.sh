#!/usr/bin/env bash
# scripts/layers --check refuses what the layering forbids: a copy of src/
# passes, then fails naming each file once a vendor header includes the
# registry and core includes a personality.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cp -r "$root/src" "$tmp/src"
"$root/scripts/layers" --check --src "$tmp/src" >/dev/null

echo '#include "personalities/registry.hpp"' >> "$tmp/src/personalities/smc.hpp"
echo '#include "personalities/cia404.hpp"' >> "$tmp/src/core/od.hpp"
if "$root/scripts/layers" --check --src "$tmp/src" >/dev/null 2>"$tmp/err"; then
  echo "FAIL: --check accepted a vendor header including the registry" >&2
  exit 1
fi
grep -q '^layers: personalities/smc.hpp: a vendor part must not include personalities/registry.hpp' "$tmp/err" ||
  { echo "FAIL: smc.hpp not named:" >&2; cat "$tmp/err" >&2; exit 1; }
grep -q '^layers: core/od.hpp: core must not include personalities/cia404.hpp' "$tmp/err" ||
  { echo "FAIL: core/od.hpp not named:" >&2; cat "$tmp/err" >&2; exit 1; }
echo "layers --check: both violations named"
