#!/usr/bin/env bash
# Creates .venv and installs sfv with its test and mocap extras. Uses the local CPU torch
# wheel when the machine has one (plain `pip install torch` would pull GBs of CUDA).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
. .venv/bin/activate
python -m pip install -q --upgrade pip
if ! python -c "import torch" >/dev/null 2>&1; then
  wheel=$(ls /opt/wheels/torch-*+cpu-*.whl 2>/dev/null | head -1 || true)
  if [ -n "$wheel" ]; then
    pip install -q "$wheel"
  else
    pip install -q torch --index-url https://download.pytorch.org/whl/cpu
  fi
fi
pip install -q -e ".[mocap,dev]"
