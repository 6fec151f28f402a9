#!/bin/bash
# The main job: runs the simulated continuous harvest headless and prints the mission summary.
set -eo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="$ROOT/.venv/bin:/usr/bin:/bin:$PATH"
cd "$ROOT"
# shellcheck disable=SC1091
source devel/setup.bash
exec python tools/run_demo.py "$@"
