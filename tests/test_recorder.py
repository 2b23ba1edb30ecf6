"""Recorded training sessions hold exactly the spikes Brian2 saw in them, traces at the chosen
stride, and only the chosen sessions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from brian2 import SpikeMonitor, StateMonitor

from astrocpg.coupling.recorder import RecordPlan
from astrocpg.models.compose import model_set as models_from
from astrocpg.studies.commands.train import Trainer, TrainSettings


def test_recorded_sessions_match_brian2_monitors(tmp_path: Path) -> None:
    settings = TrainSettings(n_sessions=5, seed=3, n_trials=2, astrocytes=True,
                             overrides=["L_max=0.3*second"])
    plan = RecordPlan(every=2, spikes=("motor", "astrocyte", "interneuron"),
                      traces=("astrocyte_Ca", "motor_Ca"), stride=3)
    trainer = Trainer(models_from(settings.overrides, {}), settings, tmp_path, progress=False,
                      record=plan)
    cpg = trainer.cpg
    motor = SpikeMonitor(cpg.motor, name="check_motor")
    inter = SpikeMonitor(cpg.interneuron, name="check_interneuron")
    ca = StateMonitor(cpg.astrocyte, "Ca", record=True, name="check_ca")
    cpg.net.add(motor, inter, ca)
    trainer.run()

    names = sorted(p.name for p in (tmp_path / "recordings").iterdir())
    assert names == [f"trial{b:02d}_session{k:04d}" for b in (0, 1) for k in (1, 3, 5)]
    rows = trainer.training.memory.rows
    L = cpg.layout
    for b in (0, 1):
        lengths = [r["length_s"] for r in rows if r["trial"] == b]
        starts = np.concatenate([[0.0], np.cumsum(lengths)])
        for k in (1, 3, 5):
            folder = tmp_path / "recordings" / f"trial{b:02d}_session{k:04d}"
            t0, t1 = starts[k - 1], starts[k]
            with np.load(folder / "spikes.npz") as z:
                for mon, pop, n in ((motor, "motor", L.motor_per_trial),
                                    (inter, "interneuron", L.interneurons_per_trial)):
                    t, i = np.asarray(mon.t_[:]), np.asarray(mon.i[:])
                    sel = (i // n == b) & (t >= t0 - 1e-9) & (t < t1 - 1e-9)
                    want = sorted(zip(np.round((t[sel] - t0) * 1e3).astype(int), i[sel] % n))
                    got = sorted(zip(np.round(z[f"{pop}_times"] * 1e3).astype(int),
                                     z[f"{pop}_indices"]))
                    assert got == want and len(got) > 0
            with np.load(folder / "traces.npz") as z:
                n_steps = int(round(lengths[k - 1] * 1e3))
                assert z["astrocyte_Ca"].shape == ((n_steps + 2) // 3, 8)
                assert z["motor_Ca"].shape[1] == L.motor_per_trial
                # sample j is taken at session step 3j: the monitor's value at that time
                # sample j: the state at the end of session step 3j = the monitor's value at
                # the start of the next step (but the session's last step: then comes a reset)
                steps = np.round((t0 + z["astrocyte_Ca_t"]) * 1e3).astype(int)
                keep = steps < int(round(t1 * 1e3))
                np.testing.assert_allclose(z["astrocyte_Ca"][keep],
                                           ca.Ca_[b * 8:(b + 1) * 8, steps[keep]].T * 1e3,
                                           rtol=1e-6)
            with np.load(folder / "robot.npz") as z:
                assert z["joint_angles"].shape == (1, (n_steps + 2) // 3, 4, 3)
