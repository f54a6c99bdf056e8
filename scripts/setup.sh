#!/usr/bin/env bash
# Installs what stereocache needs on Debian 12 (bookworm), idempotently, and says
# what it installs: Vulkan loader + tools, lavapipe from Mesa >= 24.1 (bookworm's
# own Mesa 22.3 has no ray queries, so mesa-vulkan-drivers comes from the
# backports suite), glslc, and the Khronos validation layer.
#
# The backports source is derived from the machine's existing Debian apt source
# (same mirror URI), never from a hard-coded host.
set -euo pipefail

log() { echo "[setup] $*"; }
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
packages=(libvulkan1 libvulkan-dev vulkan-tools glslc vulkan-validationlayers mesa-vulkan-drivers)
# `setup.sh --test` also installs what only the test suite needs: Debian's
# chromium, to load the HTML report in a real headless browser.
# and python3-venv, for the MaterialX Python package whose documents the
# material-graph tests read.
if [ "${1:-}" = "--test" ]; then packages+=(chromium python3 python3-venv); fi

have_all() {
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || return 1
  done
  # lavapipe must be new enough for ray queries (Mesa >= 24.1).
  local v
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || echo 0)
  dpkg --compare-versions "$v" ge 24.1 || return 1
  command -v glslc >/dev/null || return 1
}

if have_all; then
  log "all system packages present: ${packages[*]} (mesa-vulkan-drivers $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers))"
else
  backports_list=/etc/apt/sources.list.d/stereocache-backports.sources
  if [ "$codename" = "bookworm" ] && ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
    # Take the URI of the existing main Debian source (deb822 or one-line format).
    uri=""
    for f in /etc/apt/sources.list.d/*.sources; do
      [ -f "$f" ] || continue
      uri=$(awk '/^URIs:/{u=$2} /^Suites:/{ if ($0 ~ /(^| )bookworm( |$)/ && u!="") {print u; exit} }' "$f")
      [ -n "$uri" ] && break
    done
    if [ -z "$uri" ] && [ -f /etc/apt/sources.list ]; then
      uri=$(awk '$1=="deb" && $0 !~ /security/ { for (i=2;i<=NF;i++) if ($i ~ /^[a-z]+:\/\//) { print $i; exit } }' /etc/apt/sources.list)
    fi
    if [ -z "$uri" ]; then
      echo "[setup] error: found no Debian apt source to derive the bookworm-backports suite from" >&2
      exit 1
    fi
    log "adding bookworm-backports from the existing Debian source ($backports_list)"
    $SUDO tee "$backports_list" >/dev/null <<SRC
Types: deb
URIs: $uri
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
  fi
  log "apt-get update"
  $SUDO apt-get update -qq
  to_install=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || to_install+=("$p")
  done
  export DEBIAN_FRONTEND=noninteractive
  if [ "$codename" = "bookworm" ]; then
    log "installing Mesa (lavapipe) from bookworm-backports: mesa-vulkan-drivers"
    $SUDO apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers >/dev/null
  fi
  rest=()
  for p in "${to_install[@]}"; do [ "$p" = mesa-vulkan-drivers ] || rest+=("$p"); done
  if [ ${#rest[@]} -gt 0 ]; then
    log "installing: ${rest[*]}"
    $SUDO apt-get install -y -qq "${rest[@]}" >/dev/null
  fi
  have_all || { echo "[setup] error: packages still missing or Mesa older than 24.1 after install" >&2; exit 1; }
  log "installed; mesa-vulkan-drivers $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)"
fi

# The Python packages the tests use, in one virtual environment in the
# checkout, .tools/venv (Debian's python3 refuses system-wide pip installs,
# PEP 668), whose interpreter the tests ask first:
#   MaterialX 1.39: its libraries/ are the import test corpus and the
#     reference node signatures of tests/material_graphs.rs;
#   Mitsuba 3.9 and numpy: the independent renderer the reference path tracer
#     is checked against (tests/independent_reference.rs,
#     scripts/mitsuba_reference.py).
if [ "${1:-}" = "--test" ]; then
  root=$(cd "$(dirname "$0")/.." && pwd)
  venv="$root/.tools/venv"
  py="$venv/bin/python3"
  missing=()
  { [ -x "$py" ] && "$py" -c "import MaterialX" 2>/dev/null; } || missing+=("MaterialX>=1.39,<1.40")
  { [ -x "$py" ] && "$py" -c "import mitsuba, numpy" 2>/dev/null; } || missing+=("mitsuba>=3.9,<3.10" numpy)
  if [ ${#missing[@]} -eq 0 ]; then
    log "Python test packages present in .tools/venv (MaterialX, Mitsuba 3, numpy)"
  else
    log "installing into .tools/venv for the tests: ${missing[*]}"
    [ -x "$py" ] || python3 -m venv "$venv" \
      || { echo "[setup] error: python3 -m venv failed (python3-venv missing?)" >&2; exit 1; }
    "$py" -m pip install --quiet "${missing[@]}" \
      || { echo "[setup] error: pip could not install ${missing[*]} into .tools/venv" >&2; exit 1; }
  fi
fi

if ! command -v cargo >/dev/null; then
  echo "[setup] error: cargo not found; install a Rust toolchain (rustup) first" >&2
  exit 1
fi
