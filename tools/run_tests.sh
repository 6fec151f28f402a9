#!/bin/bash
# Runs every check and test of the workspace and prints one pass/fail summary:
#   catkin_lint, the Python 3.8 compatibility gate (vermin), the rostests (`catkin_make
#   run_tests_<package>`), and pytest (pure logic) beside the whole-mission rostests.
# Expects tools/setup.sh to have run (make test does that).
set -o pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
export PATH="$VENV/bin:/usr/bin:/bin:$PATH"
cd "$ROOT"
# shellcheck disable=SC1091
source devel/setup.bash
RESULTS="$ROOT/test_results"
rm -rf "$RESULTS" build/test_results
mkdir -p "$RESULTS"
FAILED_STEPS=()

echo "=== catkin_lint"
if catkin_lint -W2 --strict --quiet src; then echo "catkin_lint: clean"; else FAILED_STEPS+=(catkin_lint); fi

echo "=== Python 3.8 compatibility gate (vermin)"
# every .py file (git's list; in a Docker image without .git, find's) and every python script
mapfile -t PYFILES < <({ git ls-files '*.py' 2>/dev/null | grep . || find src tools -name '*.py' -not -path '*/__pycache__/*'; } ; grep -rlE '^#!.*python' --include='*' src/*/scripts src/*/nodes src/*/test tools 2>/dev/null | sort -u)
if vermin -q --no-tips --violations --eval-annotations --target=3.8- "${PYFILES[@]}" >"$RESULTS/vermin.txt" 2>&1; then
  echo "vermin: all ${#PYFILES[@]} files run on Python 3.8"
else
  cat "$RESULTS/vermin.txt"; FAILED_STEPS+=(vermin)
fi

if [ "${HARVEST_ONLY_LINT:-0}" = "1" ]; then
  [ ${#FAILED_STEPS[@]} -eq 0 ] && exit 0 || { echo "FAILED: ${FAILED_STEPS[*]}"; exit 1; }
fi

# The whole-mission rostests (harvest_bringup) are made to be as correct on a busy machine as on a
# quiet one, so pytest runs beside them instead of before everything (a minute saved); every
# other rostest runs first, alone.
TARGETS="$(make -C build help 2>/dev/null | sed -n 's/^\.\.\. \(run_tests_[a-z0-9_]*\)$/\1/p')"
ROSTEST_PKGS=()
for xml in src/*/package.xml; do
  pkg="$(basename "$(dirname "$xml")")"
  if [ "$pkg" != harvest_bringup ] && grep -qx "run_tests_$pkg" <<<"$TARGETS"; then
    ROSTEST_PKGS+=("run_tests_$pkg")
  fi
done

echo "=== rostest (nodes talking to each other): ${ROSTEST_PKGS[*]#run_tests_}"
if ! catkin_make -C "$ROOT" "${ROSTEST_PKGS[@]}" -j1 > "$RESULTS/rostest.log" 2>&1; then
  tail -80 "$RESULTS/rostest.log"; FAILED_STEPS+=(rostest-build)
fi

echo "=== pytest (pure logic, no ROS master), beside the whole-mission rostests (harvest_bringup)"
python -m pytest -q -p no:cacheprovider --junitxml="$RESULTS/pytest.xml" \
  $(ls -d src/*/test 2>/dev/null) --ignore-glob='*/rostest/*' -o junit_family=xunit1 \
  > "$RESULTS/pytest.log" 2>&1 &
PYTEST_PID=$!
if ! catkin_make -C "$ROOT" run_tests_harvest_bringup -j1 >> "$RESULTS/rostest.log" 2>&1; then
  tail -80 "$RESULTS/rostest.log"; FAILED_STEPS+=(rostest-build)
fi
wait $PYTEST_PID
rc=$?
tail -3 "$RESULTS/pytest.log"
if [ $rc -ne 0 ] && [ $rc -ne 5 ]; then cat "$RESULTS/pytest.log"; FAILED_STEPS+=(pytest); fi
cp -r build/test_results "$RESULTS/catkin" 2>/dev/null || true

echo "=== summary"
python tools/test_summary.py "$RESULTS" || FAILED_STEPS+=(tests)
if [ ${#FAILED_STEPS[@]} -ne 0 ]; then
  echo "make test: FAILED (${FAILED_STEPS[*]})"; exit 1
fi
echo "make test: OK"
