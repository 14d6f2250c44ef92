#!/usr/bin/env bash
# Everything a fresh machine needs: the system packages (redis-server for the Redis-backed ASI
# store and its tests, libosmesa6 for headless rendering, ffmpeg for videos), then .venv with
# sfv and its test and mocap extras. Missing packages are installed with apt-get when run as
# root; otherwise it prints the one command to run and stops. Uses the local CPU torch wheel
# when the machine has one (plain `pip install torch` would pull GBs of CUDA).
set -euo pipefail
cd "$(dirname "$0")/.."

SYSTEM_PACKAGES="redis-server libosmesa6 ffmpeg"
APT_LOG=${SFV_APT_LOG:-${TMPDIR:-/tmp}/sfv-setup-apt.log}

have_package() {
  if command -v dpkg-query >/dev/null 2>&1; then
    dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"
    return
  fi
  case "$1" in  # no dpkg: look for what the package provides
    libosmesa6) ldconfig -p 2>/dev/null | grep -q libOSMesa ;;
    *) command -v "$1" >/dev/null 2>&1 ;;
  esac
}

missing=""
for package in $SYSTEM_PACKAGES; do
  have_package "$package" || missing="$missing $package"
done
missing=${missing# }
if [ -n "$missing" ]; then
  if ! command -v apt-get >/dev/null 2>&1; then
    echo "setup.sh: missing system packages: $missing (install them with your package manager, then run setup.sh again)" >&2
    exit 1
  fi
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup.sh: missing system packages; run: sudo apt-get install -y $missing" >&2
    exit 1
  fi
  echo "setup.sh: installing $missing (apt-get; log: $APT_LOG)"
  if ! (export DEBIAN_FRONTEND=noninteractive
        apt-get update -q && apt-get install -y -q --no-install-recommends $missing) >"$APT_LOG" 2>&1; then
    tail -n 20 "$APT_LOG" >&2
    echo "setup.sh: apt-get install $missing failed (log: $APT_LOG)" >&2
    exit 1
  fi
fi

PIP_LOG=${SFV_PIP_LOG:-${TMPDIR:-/tmp}/sfv-setup-pip.log}
: >"$PIP_LOG"
quietly() {  # run a step with its output in $PIP_LOG; on failure show the tail and stop
  if ! "$@" >>"$PIP_LOG" 2>&1; then
    tail -n 20 "$PIP_LOG" >&2
    echo "setup.sh: '$*' failed (log: $PIP_LOG)" >&2
    exit 1
  fi
}

PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || quietly "$PY" -m venv .venv
. .venv/bin/activate
quietly python -m pip install -q --upgrade pip
if ! python -c "import torch" >/dev/null 2>&1; then
  wheel=$(ls /opt/wheels/torch-*+cpu-*.whl 2>/dev/null | head -1 || true)
  if [ -n "$wheel" ]; then
    quietly pip install -q "$wheel"
  else
    quietly pip install -q torch --index-url https://download.pytorch.org/whl/cpu
  fi
fi
quietly pip install -q -e ".[mocap,dev]"
