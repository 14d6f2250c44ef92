"""GL only where it renders: the backend is chosen by what the machine has, commands that do not
render never load a GL library, a render without one is one line naming the package."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

from learner.errors import SfvError
from services.render import gl
from tests.conftest import REPO


def finder(*present: str):
    return lambda name: f"lib{name}.so" if name in present else None


def test_an_explicit_backend_wins_when_its_library_is_there():
    assert gl.choose_backend({"MUJOCO_GL": "osmesa"}, finder("EGL", "OSMesa"), gpu=True) == "osmesa"
    assert gl.choose_backend({"MUJOCO_GL": "egl"}, finder("EGL", "OSMesa"), gpu=False) == "egl"


def test_the_backend_follows_the_machine():
    assert gl.choose_backend({}, finder("EGL", "OSMesa"), gpu=True) == "egl"
    assert gl.choose_backend({}, finder("EGL", "OSMesa"), gpu=False) == "osmesa"
    assert gl.choose_backend({}, finder("OSMesa"), gpu=True) == "osmesa"
    assert gl.choose_backend({}, finder("EGL"), gpu=False) == "egl"


def test_no_gl_library_is_one_line_naming_the_package():
    with pytest.raises(SfvError) as missing:
        gl.choose_backend({}, finder(), gpu=False)
    assert "\n" not in str(missing.value) and "apt-get install libosmesa6" in str(missing.value)
    with pytest.raises(SfvError) as explicit:
        gl.choose_backend({"MUJOCO_GL": "egl"}, finder("OSMesa"), gpu=False)
    assert "MUJOCO_GL=egl" in str(explicit.value) and "apt-get install libegl1" in str(explicit.value)


def test_an_unusable_explicit_backend_is_disabled_for_import_and_named_at_render():
    environ = {"MUJOCO_GL": "osmesa"}
    gl.defuse_unusable_backend(environ, finder("EGL"))
    assert environ["MUJOCO_GL"] == "disabled"
    with pytest.raises(SfvError, match="apt-get install libosmesa6"):
        gl.choose_backend(environ, finder("EGL"), gpu=False)
    kept = {"MUJOCO_GL": "osmesa"}
    gl.defuse_unusable_backend(kept, finder("OSMesa"))
    assert kept == {"MUJOCO_GL": "osmesa"}


def _sfv(args, env, cwd):
    return subprocess.run([sys.executable, "-m", "services.cli", *args], capture_output=True, text=True, timeout=600,
                          env=env, cwd=cwd)


def test_sfv_render_without_gl_is_one_line_naming_the_package(tmp_path):
    env = {**os.environ, "MUJOCO_GL": "disabled", gl.REQUESTED_ENV: "osmesa"}  # what a machine without libOSMesa gets
    done = _sfv(["render", str(tmp_path / "run"), "--out", str(tmp_path / "walk.mp4")], env, REPO)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().count("\n") == 0
    assert done.stderr.startswith("sfv: render: MUJOCO_GL=osmesa") and "apt-get install libosmesa6" in done.stderr


NO_GL_SCRIPT = r"""
import json, sys
from services.cli import main
run, onnx = sys.argv[1], sys.argv[2]
codes = [
    main(["train", "--motion", "deepmimic:walk", "--runner", "in_process", "--workers", "1", "--envs-per-worker", "2",
          "--samples", "64", "--batch-size", "64", "--eval-every", "0", "--quiet", "--out", run]),
    main(["eval", run, "--episodes", "1"]),
    main(["export", run, "--onnx", onnx]),
]
maps = open("/proc/self/maps").read()
gl_libraries = sorted({line.split("/")[-1] for line in maps.splitlines() if any(n in line for n in ("libGL", "libEGL", "libOSMesa"))})
print(json.dumps({"codes": codes, "gl_libraries": gl_libraries,
                  "gl_modules": sorted(m for m in sys.modules if m.split(".")[0] == "OpenGL" or m in ("mujoco.osmesa", "mujoco.egl"))}))
"""


@pytest.mark.integration
def test_train_eval_export_load_no_gl_library(tmp_path):
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    done = subprocess.run([sys.executable, "-c", NO_GL_SCRIPT, str(tmp_path / "run"), str(tmp_path / "policy.onnx")],
                          capture_output=True, text=True, timeout=900, env=env, cwd=REPO)
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report == {"codes": [0, 0, 0], "gl_libraries": [], "gl_modules": []}
    assert (tmp_path / "policy.onnx").stat().st_size > 0


def test_the_pose_models_sigmoid_does_not_overflow():
    from services.pose.landmarks import _sigmoid

    logits = np.array([-1e5, -1000.0, -5.0, 0.0, 5.0, 1000.0, 1e5], np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        probabilities = _sigmoid(logits)
    assert probabilities.dtype == np.float32
    np.testing.assert_allclose(probabilities[2:5], 1.0 / (1.0 + np.exp(-logits[2:5].astype(np.float64))), rtol=1e-6)
    assert probabilities[0] == 0.0 and probabilities[-1] == 1.0
