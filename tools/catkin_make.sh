#!/bin/bash
# catkin_make of this workspace with its one set of arguments (tools/setup.sh builds with it,
# tools/run_tests.sh builds the test binaries with it): catkin_make runs CMake again whenever
# its arguments differ from the previous call's, about 10 s, so both must pass the same ones.
# Messages are generated for Python and C++ only: the installed message generators of other
# languages (Lisp; on Ubuntu also EusLisp and Node.js) are turned off through ROS_LANG_DISABLE,
# a fifth less build time on the 2-core machine (naming one that is not installed makes CMake
# warn, hence the check). Extra arguments (targets, -j) go to catkin_make.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DISABLE=""
for g in genlisp geneus gennodejs; do
  if rospack find "$g" >/dev/null 2>&1; then DISABLE="${DISABLE:+$DISABLE:}$g"; fi
done
export ROS_LANG_DISABLE="$DISABLE"
catkin_make -C "$ROOT" -DPYTHON_EXECUTABLE="$ROOT/.venv/bin/python" \
  -DCMAKE_BUILD_TYPE=Release "$@"
# The test targets run their commands through build/catkin_generated/env_cached.sh, a snapshot
# of what sourcing devel/setup.sh changes, taken when CMake configured. On a fresh clone that is
# before the build made devel/lib/python3/dist-packages, so the snapshot set PYTHONPATH to ''
# and every test missed the workspace's Python packages (once CMake no longer ran a second time
# with the other arguments of an older run_tests.sh). Taken again now that the devel space is
# there, by the script CMake generated for it.
CACHED_SETUP="$ROOT/build/catkin_generated/generate_cached_setup.py"
if [ -f "$CACHED_SETUP" ]; then
  "$ROOT/.venv/bin/python" "$CACHED_SETUP"
fi
