#!/usr/bin/env bash
# Set up the environment and run the whole test suite (lint included).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup_env.sh" >/dev/null
# Foxglove's JavaScript readers for test/system/test_conformance.py, exactly as the lockfile
# pins them, installed again only when it changed; without node and npm that test
# fails and says so.
js="$root/test/js"
lock="$(sha256sum "$js/package-lock.json" | cut -d' ' -f1)"
if ! command -v npm >/dev/null; then
  echo "npm not found: test/system/test_conformance.py needs Node.js 20 and npm" >&2
elif [ "$(cat "$js/node_modules/.installed" 2>/dev/null)" != "$lock" ]; then
  (cd "$js" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error >&2)
  echo "$lock" > "$js/node_modules/.installed"
fi
source "$root/scripts/env.sh"
cd "$root"
# three tests at a time on 2 cores: much of a multi-process test is waiting (DDS discovery,
# real-time runs, timers), which a third worker fills (test/conftest.py: which tests share
# a worker, `timing` tests apart from the other multi-process ones)
exec python -m pytest -n 3 --dist loadgroup "$@"
