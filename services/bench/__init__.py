"""Throughput benchmarks (`sfv bench`): how close stepping gets to MuJoCo's own speed, how far
ahead of pybullet's DeepMimic env, and what training, learning and the video front end deliver.

    report = run_benchmarks(BenchConfig.quick_defaults(suites=("env",)))
    print(markdown_table(report))
"""
from services.bench.config import SUITES, BenchConfig
from services.bench.report import markdown_table, write_json_atomic
from services.bench.runner import parse_suites, run_benchmarks

__all__ = ["SUITES", "BenchConfig", "markdown_table", "parse_suites", "run_benchmarks", "write_json_atomic"]
