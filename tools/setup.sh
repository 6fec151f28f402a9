#!/bin/bash
# Installs what is missing (Debian packages, the Python virtual environment) and builds the
# catkin workspace. Idempotent: a second run skips the installs that are already done.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
ROS_PY=/usr/bin/python3
cd "$ROOT"

SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi

# 1. Debian packages: install only those missing.
mapfile -t PKGS < <(grep -v '^#' tools/apt-packages.txt | sed '/^\s*$/d')
MISSING=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    MISSING+=("$p")
  fi
done
if [ ${#MISSING[@]} -gt 0 ]; then
  echo "[setup] installing ${#MISSING[@]} Debian packages: ${MISSING[*]}"
  $SUDO apt-get update -q
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${MISSING[@]}"
else
  echo "[setup] Debian packages: all present"
fi

# 2. Virtual environment from the ROS interpreter, with the system site packages (rospy & co).
if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c 'import rospy' 2>/dev/null; then
  echo "[setup] creating $VENV from $ROS_PY"
  rm -rf "$VENV"
  "$ROS_PY" -m venv --system-site-packages "$VENV"
fi
REQ_STAMP="$VENV/.requirements.sha256"
if [ ! -f "$REQ_STAMP" ] || ! sha256sum -c --status "$REQ_STAMP" 2>/dev/null; then
  echo "[setup] installing pinned PyPI packages"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check -r requirements.txt
  sha256sum requirements.txt > "$REQ_STAMP"
else
  echo "[setup] PyPI packages: up to date"
fi

# 3. Build the workspace with the venv's interpreter (tools/catkin_make.sh: its arguments, and
#    messages for Python and C++ only).
if [ "${HARVEST_SKIP_BUILD:-0}" != "1" ]; then
  echo "[setup] building the workspace"
  tools/catkin_make.sh -j2 > "$ROOT/build.log" 2>&1 || { tail -60 "$ROOT/build.log"; echo "[setup] build FAILED (see build.log)"; exit 1; }
  echo "[setup] build ok"
fi
