#!/usr/bin/env bash
# Set up the environment and run the whole test suite (lint included).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup_env.sh" >/dev/null
source "$root/scripts/env.sh"
cd "$root"
exec python -m pytest "$@"
