#!/bin/bash
# Runs a workspace Python tool (`make demo`, `make load-check`) with the ROS interpreter's venv
# and the built workspace: tools/ws_run.sh tools/SCRIPT.py [ARGS...]
set -eo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="$ROOT/.venv/bin:/usr/bin:/bin:$PATH"
cd "$ROOT"
ARGS=("$@")
set --                # setup.bash reads the positional parameters: give it none
# shellcheck disable=SC1091
source devel/setup.bash
exec python "${ARGS[@]}"
