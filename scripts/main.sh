#!/usr/bin/env bash
# Set up the environment and run the main job: the default modal analysis
# and the reference deployment (model.md §9), printed as tables.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup_env.sh" >/dev/null
source "$root/scripts/env.sh"
cd "$root"
sail-ros modes
sail-ros deploy --summary
