#!/bin/bash
# `make load-check`: every mission scenario with two CPU hogs beside it (see tools/load_check.py).
set -eo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="$ROOT/.venv/bin:/usr/bin:/bin:$PATH"
cd "$ROOT"
# shellcheck disable=SC1091
source devel/setup.bash
exec python tools/load_check.py "$@"
