#!/usr/bin/env bash
# Build the documentation site offline into docs/_build/html (git-ignored), warnings as
# errors: the guide, the physics reference, the interface pages, the API reference from
# the docstrings, and the examples, run now to draw the guide's figures. Extra arguments
# go to sphinx-build (e.g. -E to rebuild every page).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup_env.sh" >/dev/null
source "$root/scripts/env.sh"
cd "$root"
exec python -m sphinx -W --keep-going -b html -q -c docs . docs/_build/html "$@"
