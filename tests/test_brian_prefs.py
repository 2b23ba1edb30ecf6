"""The framework's Brian2 settings are its own: importing astrocpg, building a CPG and
``ac.run`` leave the user's ``brian2.prefs``, warning filters and Brian2 log filters as they
were, and a user's own Brian2 model gives the same result before and after
(network/brian_prefs.py, applied by RUN_LOCK). Each check runs in a fresh process, with Brian2
imported by the user first (a notebook), as without astrocpg."""

from __future__ import annotations

import json
import os
import subprocess
import sys

USER_MODEL = r'''
import json, warnings, brian2

def snapshot():
    return {"prefs": {k: repr(v) for k, v in brian2.prefs.items()},
            "warnings": repr(warnings.filters),
            "log_filters": [type(f).__name__
                            for f in brian2.BrianLogger.console_handler.filters]}

def user_model():
    """A user's own model: its objects use the user's target; its voltages after 5 ms."""
    brian2.start_scope()
    brian2.seed(11)
    g = brian2.NeuronGroup(3, "dv/dt = (1 - v) / (10*ms) + 0.1*xi/sqrt(ms) : 1", method="euler")
    m = brian2.StateMonitor(g, "v", record=True)
    brian2.run(5 * brian2.ms)
    return {"target": type(g.state_updater.codeobj).__name__, "v": m.v[:].tolist()}

brian2.prefs.codegen.target = "numpy"  # the user's choices, unlike the framework's
brian2.prefs.codegen.loop_invariant_optimisations = False
brian2.prefs.logging.delete_log_on_exit = False
before, model_before = snapshot(), user_model()
'''

WITH_ASTROCPG = USER_MODEL + r'''
import astrocpg.network
after_import = snapshot()
from astrocpg.network import build_cpg
cpg = build_cpg(seed=2)
after_build = snapshot()
import astrocpg as ac
ac.run(seconds=0.01)
after_run = snapshot()
model_after = user_model()
print(json.dumps({"before": before, "after_import": after_import, "after_build": after_build,
                  "after_run": after_run, "model_before": model_before,
                  "model_after": model_after}))
'''


def _python(code: str) -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg", "MUJOCO_GL": "egl"}
    env.pop("ASTROCPG_CODEGEN", None)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_astrocpg_leaves_the_users_brian2_as_it_was():
    got = _python(WITH_ASTROCPG)
    for moment in ("after_import", "after_build", "after_run"):
        diff = {k: (v, got[moment]["prefs"].get(k)) for k, v in got["before"]["prefs"].items()
                if got[moment]["prefs"].get(k) != v}
        assert not diff, f"{moment}: brian2.prefs changed (before, after): {diff}"
        assert set(got[moment]["prefs"]) == set(got["before"]["prefs"]), moment
        assert got[moment]["warnings"] == got["before"]["warnings"], moment
    # the one filter astrocpg leaves on Brian2's console handler drops only the warning about
    # its own unused objects (brian_prefs._FrameworkObjectsOnly), added at its first run
    assert got["after_import"]["log_filters"] == got["before"]["log_filters"]
    assert got["model_after"] == got["model_before"]
    assert got["model_before"]["target"] == "NumpyCodeObject"


def test_the_users_unused_objects_still_warn_and_the_frameworks_do_not():
    code = USER_MODEL + r'''
import gc, logging, io
import astrocpg as ac
ac.run(seconds=0.01)
stream = io.StringIO()
brian2.BrianLogger.console_handler.setStream(stream)
brian2.NeuronGroup(1, "v : 1", name="users_unused")
gc.collect()
print(json.dumps({"log": stream.getvalue()}))
'''
    got = _python(code)
    assert "users_unused" in got["log"], got


def test_inside_the_framework_its_settings_apply_and_are_undone():
    code = USER_MODEL + r'''
from astrocpg.network import RUN_LOCK
brian2.prefs.codegen.target = "auto"
with RUN_LOCK:
    inside = {"target": brian2.prefs.codegen.target,
              "opt": brian2.prefs.codegen.loop_invariant_optimisations}
    with RUN_LOCK:  # reentrant: the inner release keeps the framework's settings
        pass
    still = brian2.prefs.codegen.target
print(json.dumps({"inside": inside, "still": still, "after": brian2.prefs.codegen.target,
                  "opt_after": brian2.prefs.codegen.loop_invariant_optimisations}))
'''
    got = _python(code)
    assert got["inside"] == {"target": "numpy", "opt": True}
    assert got["still"] == "numpy"
    assert got["after"] == "auto" and got["opt_after"] is False
