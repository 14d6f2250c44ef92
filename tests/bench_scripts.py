"""The benchmark scripts (bench/scripts/) as fresh modules, for the tests that exercise their functions."""
from __future__ import annotations

import importlib.util
from pathlib import Path

BENCH_DIR = Path(__file__).resolve().parents[1] / "bench" / "scripts"


def load_bench_script(name: str):
    """bench/scripts/<name>.py imported under the module name `bench_<name>`."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCH_DIR / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
