#!/usr/bin/env bash
# Set up the environment and run the main job: the simulator and the recorder
# as separate processes, the reference deployment (model.md §9) driven through
# /sail/deploy_cmd, and a summary of the MCAP log read back.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup_env.sh" >/dev/null
source "$root/scripts/env.sh"
cd "$root"
exec sail-ros demo "$@"
