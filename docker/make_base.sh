#!/bin/bash
# Makes sure a Docker engine answers and a `debian:bookworm` image exists, without Docker Hub:
#   1. installs docker.io and debootstrap with apt-get when they are missing;
#   2. starts dockerd in the background (log: $HARVEST_DOCKERD_LOG) when no engine answers,
#      and waits (bounded) until `docker info` answers;
#   3. when `debian:bookworm` is not in the local image store, builds it with
#      `debootstrap --variant=minbase` from the Debian mirror this host's apt already uses,
#      and loads it with `docker import`.
# Idempotent: a second run finds everything in place and only checks.
set -euo pipefail

BASE_IMAGE="${HARVEST_BASE_IMAGE:-debian:bookworm}"
SUITE=bookworm
DOCKERD_LOG="${HARVEST_DOCKERD_LOG:-/var/log/harvest-dockerd.log}"
DOCKERD_WAIT_S="${HARVEST_DOCKERD_WAIT_S:-60}"
# Debian's client first: it matches the daemon that docker.io installs.
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:$PATH"

SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
log() { echo "[docker-base] $*"; }

# 1. Tools.
need=()
command -v dockerd >/dev/null 2>&1 || need+=(docker.io)
command -v debootstrap >/dev/null 2>&1 || need+=(debootstrap)
if [ ${#need[@]} -gt 0 ]; then
  log "installing ${need[*]}"
  $SUDO apt-get update -q
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q -o DPkg::Lock::Timeout=300 \
    --no-install-recommends "${need[@]}"
fi

# 2. Engine.
engine_up() { $SUDO docker info >/dev/null 2>&1; }
if engine_up; then
  log "Docker engine: running"
else
  log "starting dockerd (log: $DOCKERD_LOG)"
  # setsid + nohup: the daemon outlives this script and make; it is meant to stay up.
  $SUDO sh -c "setsid nohup dockerd >>'$DOCKERD_LOG' 2>&1 </dev/null &"
  waited=0
  until engine_up; do
    if [ "$waited" -ge "$DOCKERD_WAIT_S" ]; then
      log "dockerd did not answer within ${DOCKERD_WAIT_S} s; last log lines:"
      $SUDO tail -30 "$DOCKERD_LOG" || true
      exit 1
    fi
    sleep 1; waited=$((waited + 1))
  done
  log "Docker engine: up after ${waited} s"
fi

# 3. Base image.
if $SUDO docker image inspect "$BASE_IMAGE" >/dev/null 2>&1; then
  log "$BASE_IMAGE: present"
  exit 0
fi

# The host's Debian mirrors, from one-line (.list) and deb822 (.sources) files:
# prints "SUITE URI" for every enabled deb entry.
host_apt_entries() {
  local f
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [ -f "$f" ] || continue
    awk '$1 == "deb" { i = 2; if ($2 ~ /^\[/) { while ($i !~ /\]$/) i++; i++ } print $(i+1), $i }' "$f"
  done
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    awk 'function flush() { if (types ~ /(^| )deb( |$)/ && enabled != "no") {
                              n = split(suites, s, " "); m = split(uris, u, " ");
                              for (a = 1; a <= n; a++) for (b = 1; b <= m; b++) print s[a], u[b] }
                            types = uris = suites = enabled = "" }
         /^[ \t]*$/ { flush(); next }
         /^#/ { next }
         { key = tolower($1); sub(/:$/, "", key); $1 = "" ; sub(/^ +/, "") }
         key == "types" { types = $0 } key == "uris" { uris = $0 }
         key == "suites" { suites = $0 } key == "enabled" { enabled = tolower($0) }
         END { flush() }' "$f"
  done
}
MIRROR="${HARVEST_DEBIAN_MIRROR:-$(host_apt_entries | awk -v s="$SUITE" '$1 == s { print $2; exit }')}"
SECURITY="$(host_apt_entries | awk -v s="$SUITE-security" '$1 == s { print $2; exit }')"
MIRROR="${MIRROR:-http://deb.debian.org/debian}"
SECURITY="${SECURITY:-http://deb.debian.org/debian-security}"
log "building $BASE_IMAGE with debootstrap from $MIRROR"

ROOTFS="$(mktemp -d /tmp/harvest-rootfs.XXXXXX)"
cleanup() { $SUDO rm -rf "$ROOTFS"; }
trap cleanup EXIT
start=$(date +%s)
$SUDO debootstrap --variant=minbase "$SUITE" "$ROOTFS" "$MIRROR" > "$ROOTFS.log" 2>&1 \
  || { tail -30 "$ROOTFS.log"; log "debootstrap FAILED (log: $ROOTFS.log)"; exit 1; }

# apt inside the image uses the same mirrors as this host (main, updates, security) and the
# host's mirror-related apt settings (e.g. a snapshot mirror needs Check-Valid-Until false).
$SUDO rm -f "$ROOTFS/etc/apt/sources.list"
$SUDO tee "$ROOTFS/etc/apt/sources.list.d/debian.sources" >/dev/null <<EOF
Types: deb
URIs: $MIRROR
Suites: $SUITE $SUITE-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: $SECURITY
Suites: $SUITE-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
apt-config dump 2>/dev/null \
  | grep -E '^Acquire::(Check-Valid-Until|Check-Date|https?::Proxy) ' \
  | $SUDO tee "$ROOTFS/etc/apt/apt.conf.d/90host-mirror" >/dev/null || true
# TLS inside the image trusts the same local CAs as this host (an HTTPS-intercepting egress
# proxy in front of PyPI, say): update-ca-certificates adds them when ca-certificates installs.
if compgen -G "/usr/local/share/ca-certificates/*.crt" >/dev/null; then
  $SUDO mkdir -p "$ROOTFS/usr/local/share/ca-certificates"
  $SUDO cp /usr/local/share/ca-certificates/*.crt "$ROOTFS/usr/local/share/ca-certificates/"
fi
# Image hygiene: no package cache kept, no translations, no recommends.
$SUDO tee "$ROOTFS/etc/apt/apt.conf.d/90image-slim" >/dev/null <<'EOF'
Dir::Cache::pkgcache "";
Dir::Cache::srcpkgcache "";
APT::Install-Recommends "false";
Acquire::Languages "none";
DPkg::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb || true"; };
EOF
$SUDO rm -rf "$ROOTFS"/var/cache/apt/archives/*.deb "$ROOTFS"/var/lib/apt/lists/* \
  "$ROOTFS"/var/log/* "$ROOTFS"/tmp/*
$SUDO tar -C "$ROOTFS" --numeric-owner -c . | $SUDO docker import \
  -c 'ENV LANG=C.UTF-8' -c 'CMD ["/bin/bash"]' - "$BASE_IMAGE" >/dev/null
rm -f "$ROOTFS.log"
log "$BASE_IMAGE: built in $(( $(date +%s) - start )) s"
$SUDO docker images "$BASE_IMAGE"
