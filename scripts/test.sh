#!/usr/bin/env bash
# The test command (README): unit and integration tests with real Ray, gRPC and Redis.
# The OpenGL backend is not forced here: the renderer picks the one the machine has
# (services/render/gl.py), and an explicit MUJOCO_GL in the environment still wins.
set -uo pipefail
cd "$(dirname "$0")/.."
.venv/bin/python -m pytest -q -p no:cacheprovider "$@"
rc=$?
# pytest's 5 means "no tests collected": a selection that matched nothing is not a failure.
[ "$rc" -eq 5 ] && exit 0
exit "$rc"
