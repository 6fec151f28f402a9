#!/bin/bash
# Runs every check and test of the workspace and prints one pass/fail summary:
#   catkin_lint, the Python 3.8 compatibility gate (vermin), and every catkin test target
#   (`catkin_make run_tests_<package>`: rostests, launch checks, gtests, pytest), pytest beside
#   the whole-mission rostests. Logs in test_results/, JUnit results in build/test_results/.
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

echo "=== every Python file compiles (a syntax error in a script no test imports stays hidden otherwise)"
if python - "${PYFILES[@]}" >"$RESULTS/compile.txt" 2>&1 <<'PYEOF'
import sys
bad = 0
for name in sys.argv[1:]:
    try:
        with open(name, 'rb') as f:
            compile(f.read(), name, 'exec')
    except (SyntaxError, ValueError) as exc:
        bad += 1
        print('%s: %s' % (name, exc))
print('%d of %d files do not compile' % (bad, len(sys.argv) - 1) if bad else
      'all %d files compile' % (len(sys.argv) - 1))
sys.exit(1 if bad else 0)
PYEOF
then cat "$RESULTS/compile.txt"; else cat "$RESULTS/compile.txt"; FAILED_STEPS+=(compile); fi

if [ "${HARVEST_ONLY_LINT:-0}" = "1" ]; then
  [ ${#FAILED_STEPS[@]} -eq 0 ] && exit 0 || { echo "FAILED: ${FAILED_STEPS[*]}"; exit 1; }
fi

# Every test is a catkin test target: the rostests, the launch file checks, the gtests and pytest
# (harvest_add_pytests of harvest_test_utils: run_tests_<package>_pytest), so `catkin_make
# run_tests` alone runs them all and every result lands in one tree, build/test_results/<package>/
# (JUnit XML), which the summary reads. Here the same targets run in two steps to save wall time:
# every rostest and check of the other packages first, two packages at a time; then the whole-mission rostests of
# harvest_bringup (made to be as correct on a busy machine as on a quiet one) beside every
# package's pytest target (pure logic, no master, no fixed ports), a second make process.
# A test skipped for something tools/setup.sh installs fails here (harvest_test_utils.strict_deps).
export HARVEST_STRICT_DEPS=1
# The rostests' simulated controllers and farm server listen on fixed ports of their .test files
# (15000-15099, 18431) plus HARVEST_TEST_PORT_OFFSET, a multiple of 100 picked here with every one
# of those ports free, so two suites (two clones, or CI beside a developer) run side by side.
if [ -z "${HARVEST_TEST_PORT_OFFSET:-}" ]; then
  HARVEST_TEST_PORT_OFFSET="$(python -c 'from harvest_test_utils.net import free_port_offset; print(free_port_offset())')" || exit 1
fi
export HARVEST_TEST_PORT_OFFSET
if [ -n "${HARVEST_TEST_SCHEDULE:-}" ]; then
  echo "scenario mission rostests: task planner schedule $HARVEST_TEST_SCHEDULE (HARVEST_TEST_SCHEDULE)"
fi
echo "test ports: offset $HARVEST_TEST_PORT_OFFSET (controllers 15000-15099, farm server 18431, plus the offset)"
TARGETS="$(make -C build help 2>/dev/null | sed -n 's/^\.\.\. \(run_tests_[a-z0-9_-]*\)$/\1/p')"
ROSTEST_TARGETS=()    # run_tests_<package>_<type> of the other packages, <type> != pytest
MISSION_TARGETS=()    # the same of harvest_bringup
PYTEST_TARGETS=()     # run_tests_<package>_pytest of every package
for xml in src/*/package.xml; do
  pkg="$(basename "$(dirname "$xml")")"
  while read -r target; do
    [ -n "$target" ] || continue
    if [ "$target" = "run_tests_${pkg}_pytest" ]; then PYTEST_TARGETS+=("$target")
    elif [ "$pkg" = harvest_bringup ]; then MISSION_TARGETS+=("$target")
    else ROSTEST_TARGETS+=("$target"); fi
  done < <(grep -x "run_tests_${pkg}_[a-z-]*" <<<"$TARGETS")      # <type>: rostest, gtest...
done

# the longest pytest targets first (harvest_sim about 55 s, network_pkg and control_pkg about
# 20 s each in a loaded run), so that the lane ends with short ones
LONG_PYTESTS=(run_tests_harvest_sim_pytest run_tests_network_pkg_pytest run_tests_control_pkg_pytest)
ORDERED=()
for target in "${LONG_PYTESTS[@]}"; do
  for t in "${PYTEST_TARGETS[@]}"; do [ "$t" = "$target" ] && ORDERED+=("$t"); done
done
for t in "${PYTEST_TARGETS[@]}"; do
  case " ${LONG_PYTESTS[*]} " in *" $t "*) ;; *) ORDERED+=("$t");; esac
done
PYTEST_TARGETS=("${ORDERED[@]}")

echo "=== whole-mission rostests (${MISSION_TARGETS[*]#run_tests_}), beside: the other packages' rostests, then every package's pytest"
# Two lanes, plain make in the build directory catkin_make configured (tools/setup.sh); two
# catkin_make at once race on build/catkin_make.cache and both run cmake in the same directory.
# Lane 1: the whole-mission rostests of harvest_bringup, one at a time (made to be as correct on a
# busy machine as on a quiet one; two at a time each took 1.7x as long), from the start: they are
# the longest chain. Lane 2: the other packages' rostests (every rostest has its own master on a
# free port, each test file that runs a simulated controller its own Modbus port, the Xvfb tests
# a free display). Lane 3, also from the start: every package's pytest target (pure logic, no
# master), one make process per target (make_each), the longest first; the rostests mostly
# wait on mock servers and timers, so the pytests fill the CPU they leave. CMake's top-level
# Makefile is .NOTPARALLEL: one make given several goals runs them one after another whatever
# its -j, so the rostests' -j3 below runs them one at a time (parallel rostests not tried).
# every run_tests target depends on `tests` (the gtest binaries): built once here, before the lanes,
# so the two makes never compile the same file at once. Through tools/catkin_make.sh (setup.sh's
# arguments: catkin_make only checks the build system, CMake does not run again and rewrite the
# devel space's Python packages while the other lanes' tests import them)
if ! tools/catkin_make.sh tests -j2 > "$RESULTS/tests-build.log" 2>&1; then
  tail -80 "$RESULTS/tests-build.log"; FAILED_STEPS+=(tests-build)
fi
# make_each JOBS LOG TARGET...: one make process per target, JOBS at a time, each into its own
# log; LOG gets them in the order given; fails when one of them failed
make_each() {
  local jobs=$1 log=$2 dir="$RESULTS/make_each"
  shift 2
  rm -rf "$dir"; mkdir -p "$dir"
  printf '%s\n' "$@" | xargs -P "$jobs" -I{} sh -c \
    'make -C "$0/build" "$1" > "$2/$1.log" 2>&1 || echo "$1" >> "$2/failed"' "$ROOT" {} "$dir"
  for target in "$@"; do cat "$dir/$target.log"; done > "$log"
  [ ! -s "$dir/failed" ]
}
make -C "$ROOT/build" "${MISSION_TARGETS[@]}" -j1 > "$RESULTS/mission.log" 2>&1 &
MISSION_PID=$!
echo "=== pytest (pure logic, no ROS master), from the start, one target at a time: ${PYTEST_TARGETS[*]#run_tests_}"
make_each 1 "$RESULTS/pytest.log" "${PYTEST_TARGETS[@]}" &
PYTEST_PID=$!
if ! make -C "$ROOT/build" "${ROSTEST_TARGETS[@]}" -j3 > "$RESULTS/rostest.log" 2>&1; then
  tail -80 "$RESULTS/rostest.log"; FAILED_STEPS+=(rostest-build)
fi
if ! wait $PYTEST_PID; then
  tail -80 "$RESULTS/pytest.log"; FAILED_STEPS+=(pytest-build)
fi
if ! wait $MISSION_PID; then
  tail -80 "$RESULTS/mission.log"; FAILED_STEPS+=(mission-build)
fi
# one line per package, "pytest <package>: N passed in S s" (failures: the summary, pytest.log),
# from each package's JUnit file: the log's order of make's command lines and pytest's output
# is not the same everywhere (in the Docker image every line carried the previous package's name)
PYTEST_PKGS=()
for target in "${PYTEST_TARGETS[@]}"; do
  pkg=${target#run_tests_}; PYTEST_PKGS+=("${pkg%_pytest}")
done
python tools/test_summary.py --pytest-lines build/test_results "${PYTEST_PKGS[@]}"

echo "=== summary (build/test_results)"
python tools/test_summary.py build/test_results || FAILED_STEPS+=(tests)
if [ ${#FAILED_STEPS[@]} -ne 0 ]; then
  echo "make test: FAILED (${FAILED_STEPS[*]})"; exit 1
fi
echo "make test: OK"
