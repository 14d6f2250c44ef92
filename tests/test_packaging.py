"""What `pip install` ships: the library packages, never the study scripts in bench/ or the tests."""
from __future__ import annotations

import tomllib

from setuptools import find_packages

from tests.conftest import REPO


def installed_packages() -> list[str]:
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    include = pyproject["tool"]["setuptools"]["packages"]["find"]["include"]
    return find_packages(where=str(REPO), include=include)


def test_the_package_ships_the_library_and_not_bench_or_tests():
    packages = installed_packages()
    assert {"actors", "learner", "services", "proto", "services.specs", "services.bench"} <= set(packages)
    assert not [p for p in packages if p.split(".")[0] in ("bench", "tests")], packages
