"""A MUJOCO_GL naming an OpenGL backend the machine lacks is the environment's fault (exit 1,
one line naming the variable and what to install), never an internal error."""

from __future__ import annotations

import ctypes.util
import os
import subprocess
import sys

import pytest


@pytest.mark.skipif(ctypes.util.find_library("OSMesa") is not None,
                    reason="OSMesa is installed here: MUJOCO_GL=osmesa works")
def test_a_missing_gl_backend_is_named_in_one_line(tmp_path):
    env = dict(os.environ, MUJOCO_GL="osmesa")
    env.pop("PYOPENGL_PLATFORM", None)
    done = subprocess.run([sys.executable, "-m", "astrocpg", "run", "--seconds", "0.01",
                           "--out", str(tmp_path / "r")], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    lines = [x for x in done.stderr.splitlines() if x.strip()]
    assert done.returncode == 1, done.stderr
    assert len(lines) == 1 and "internal error" not in lines[0], done.stderr
    assert "MUJOCO_GL=osmesa" in lines[0] and "libosmesa6" in lines[0], lines[0]
    assert not (tmp_path / "r").exists()
