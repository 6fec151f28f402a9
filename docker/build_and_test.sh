#!/bin/bash
# Builds the workspace image (docker/Dockerfile, on top of debian:bookworm from make_base.sh)
# and runs the test suite in it; exits with the tests' status.
#   HARVEST_IMAGE=name:tag          image to build (default harvest-ws:test)
#   HARVEST_DOCKER_CONTEXT=tree     build the working tree as it is (default)
#   HARVEST_DOCKER_CONTEXT=head     build the last commit only (git archive HEAD)
# Logs: test_results/docker-build.log and test_results/docker-test.log.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
IMAGE="${HARVEST_IMAGE:-harvest-ws:test}"
CONTEXT="${HARVEST_DOCKER_CONTEXT:-tree}"
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:$PATH"
SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
cd "$ROOT"
LOGDIR="$ROOT/test_results"
mkdir -p "$LOGDIR"
log() { echo "[docker-test] $*"; }

log "building $IMAGE from the $CONTEXT (log: test_results/docker-build.log)"
start=$(date +%s)
case "$CONTEXT" in
  tree) $SUDO docker build --force-rm --network host -f docker/Dockerfile -t "$IMAGE" . ;;
  head) git archive --format=tar HEAD \
          | $SUDO docker build --force-rm --network host -f docker/Dockerfile -t "$IMAGE" - ;;
  *) log "HARVEST_DOCKER_CONTEXT must be tree or head, not '$CONTEXT'"; exit 2 ;;
esac > "$LOGDIR/docker-build.log" 2>&1 || {
  tail -60 "$LOGDIR/docker-build.log"; log "image build FAILED"; exit 1; }
log "image built in $(( $(date +%s) - start )) s"
$SUDO docker images "$IMAGE"

NAME="harvest-test-$$"
# The container goes away on exit, also when this script is interrupted.
trap '$SUDO docker rm -f "$NAME" >/dev/null 2>&1 || true' EXIT INT TERM
log "running the tests in a container (log: test_results/docker-test.log)"
start=$(date +%s)
set +e
$SUDO docker run --rm --network host --name "$NAME" "$IMAGE" 2>&1 | tee "$LOGDIR/docker-test.log"
rc=${PIPESTATUS[0]}
set -e
log "tests took $(( $(date +%s) - start )) s; exit status $rc"
exit "$rc"
