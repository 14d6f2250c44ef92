#!/usr/bin/env bash
# Regenerates proto/asi_pb2.py and proto/asi_pb2_grpc.py from proto/asi.proto.
# Run from anywhere: `bash proto/generate.sh` (uses the project venv when present).
# protoc runs with the repository root as include path, so the generated grpc
# module already imports `from proto import asi_pb2`; the sed below only
# guarantees that form if a future grpc_tools emits a bare `import asi_pb2`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
python="${PYTHON:-$root/.venv/bin/python}"
[ -x "$python" ] || python=python3
cd "$root"
"$python" -m grpc_tools.protoc -I . --python_out=. --pyi_out=. --grpc_python_out=. proto/asi.proto
sed -i -E 's/^import asi_pb2 as /from proto import asi_pb2 as /' proto/asi_pb2_grpc.py
echo "generated proto/asi_pb2.py proto/asi_pb2.pyi proto/asi_pb2_grpc.py"
