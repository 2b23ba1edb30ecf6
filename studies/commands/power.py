"""``astrocpg power DIR``: the paper's power comparison for a trained controller.

The trained inter-limb table of one trial runs, with learning off, for 10 sessions of at most
L_max (the training's own session rules: a session also ends when the robot has been down for
L_non_alive, then the network and robot are reset, astrocytes and weights kept). Per session,
the total firing frequency of each population is its spike count over the session length; the
estimate uses their mean over sessions (paper: "Power Consumption Benefits").

Synaptic events per spike are counted on the built network: a thigh or calf motor neuron's
outgoing synapses (its pool, its interneurons, and for thigh pools the inter-limb synapses of its
pool times the target pool's size); an interneuron's synapses onto motor neurons; a
limit-position inhibition event reaches every neuron of one pool. The bookkeeping synapse that
counts a pool's spikes for the torque is not a synaptic operation and is left out.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...coupling.assembly import build_closed_loop
from ...coupling.bridge import ORDER_MEASURE
from ...coupling.training import Training
from ...errors import InputError, setting
from ...network import exclusive
from ..outputs.folder import verify
from ..outputs.weights import load_weights
from ..runtime.progress import Bar as tqdm  # warnings wait until the bar closes
from ..runtime.resources import check_memory, estimate_bytes
from ...models import ModelSet
from ...models.compose import model_set
from ..settings.power import PowerSettings
from ..settings.checks import number
from ..settings.populations import population_models, population_table

# The paper's figures, shown next to ours (not used in any computation).
PAPER = {
    "ops_per_spike": {"inhibitory": 20, "calf": 20, "thigh": 81, "limit": 20},
    "total_rate_Hz": {"inhibitory": 669.0, "calf": 4340.0, "thigh": 4520.0, "limit": 2220.0},
    "snn_W": 4.60e-7, "rl_W": 1.07e-5, "ratio": 23.3,
}


def synaptic_events_per_spike(cpg) -> dict[str, float]:
    """Mean number of synaptic events one spike causes, per population, from the built
    network's synapses."""
    L = cpg.layout
    n_motor = L.n_trials * L.motor_per_trial
    fanout = np.zeros(n_motor)
    # every synapse object's source element, as the files' motor-neuron (or pool) number
    motor_number = [p.numbers() for p in cpg.parts("motor")]
    for name in ("intra_pool", "pool_to_interneuron"):
        for s, numbers in zip(cpg.synapse_kinds[name], motor_number):
            fanout += np.bincount(numbers[np.asarray(s.i[:])], minlength=n_motor)
    if "interlimb" in cpg.synapse_kinds:
        n_pools = L.n_trials * L.pools_per_trial
        pool_number = cpg.parts("pool")[0].numbers()
        per_pool = sum(np.bincount(pool_number[np.asarray(s.i[:])], minlength=n_pools)
                       for s in cpg.synapse_kinds["interlimb"]) * L.pool_size
        fanout += np.repeat(per_pool, L.pool_size)  # pool of each motor neuron, files' order
    kind = (np.arange(n_motor) % L.motor_per_trial) // L.pool_size % 4  # POOLS order
    n_in = L.n_trials * L.interneurons_per_trial
    in_fanout = sum(np.bincount(np.asarray(s.i[:]), minlength=n_in)
                    for s in cpg.synapse_kinds["interneuron_to_pool"])
    return {"inhibitory": float(in_fanout.mean()), "calf": float(fanout[kind >= 2].mean()),
            "thigh": float(fanout[kind < 2].mean()), "limit": float(L.pool_size)}


@exclusive  # one Brian2 build-and-run at a time per process (network/runlock.py)
def measure(folder: Path, *, trial: int = 0, sessions: int = 10,
            progress: bool = True, overrides: list[str] | tuple[str, ...] = ()
            ) -> dict[str, Any]:
    """Run trial ``trial``'s trained table of the training in ``folder`` for ``sessions``
    sessions with learning off; return rates, events per spike and the power estimates.
    ``overrides``: ``NAME=VALUE`` settings over the training's models (e.g.
    ``limit_margin=0*radian``), to measure what one parameter does to the rates."""
    trial = number(trial, setting("trial"), integer=True, minimum=0)
    sessions = number(sessions, setting("sessions"), integer=True, minimum=1)
    check_memory(estimate_bytes(trials=1, seconds=0.0, spikes=False, sessions=sessions),
                 culprit=setting("sessions", sessions))
    manifest = verify(folder, culprit="power", strict=False)  # files as its manifest lists
    weights = load_weights(str(folder), trial, culprit="power")  # (8, 8) volt
    settings, models = _trained(folder, manifest, overrides)
    seed = int(manifest.get("seed", settings.get("seed", 1))) + trial
    # the network the table trained on: with the populations its training added
    loop = build_closed_loop(models, n_trials=1, seed=seed, weights=weights,
                             populations=population_table(settings.get("populations")))
    cpg, bridge = loop.cpg, loop.bridge
    L_max = models.value("L_max")
    bar = tqdm(total=sessions, unit="session", desc="power", disable=not progress)
    limit = cpg.array("pool", "limit_inhibition")
    counted = {"limit": 0.0}
    per_session: list[dict[str, float]] = []

    def on_session(training: Training, b: int) -> None:
        row = training.memory.rows[-1]
        length = row["length_s"]
        per_session.append({
            "length_s": length,
            "inhibitory": row["spikes_interneuron"] / length,
            "calf": row["spikes_calf_motor"] / length,
            "thigh": row["spikes_thigh_motor"] / length,
            "limit": counted["limit"] / length,
            "forward_speed_m_per_s": row["mean_forward_speed_m_per_s"],
        })
        counted["limit"] = 0.0
        bar.update(1)

    # the session loop hooks itself into the bridge ("training", ORDER_TRAINING)
    Training(cpg, bridge, models, n_sessions=sessions, on_session=on_session)

    def count_limit() -> None:
        # limit-position inhibition events of this step (pools inhibited), before the session
        # loop possibly closes the session
        counted["limit"] += float(limit.sum())

    bridge.add_hook("after_physics", "limit_count", count_limit, order=ORDER_MEASURE)
    try:
        loop.run(sessions * L_max + 1.0)
    finally:
        bar.close()
    if len(per_session) < sessions:  # Brian2 stopped the run cleanly on Ctrl-C / SIGTERM
        raise KeyboardInterrupt
    return {"trial": trial, "seed": seed, "overrides": list(overrides),
            "sessions": per_session, **_estimates(models, cpg, per_session), "paper": PAPER}


def _trained(folder: Path, manifest: dict[str, Any], overrides: Sequence[str]
             ) -> tuple[dict[str, Any], ModelSet]:
    """A training's settings (from its ``manifest``) and the model set it trained with,
    ``overrides`` over it, learning off: a measurement, not a training."""
    settings = manifest.get("settings")
    if manifest.get("astrocpg_command") not in ("train", "study-run") \
            or not isinstance(settings, dict):
        raise InputError("not a training run (astrocpg train, or a study's run)",
                         culprit=f"power {folder}")
    models = model_set([*settings.get("overrides", []), *overrides],
                       settings.get("equations", {}), models=settings.get("models"),
                       added=population_models(settings.get("populations")))
    # weights fixed: a measurement, not training (zero in each rate's own unit)
    models = models.with_zeros("eta", "eta_ADO")
    if not settings.get("astrocytes", True):
        models = models.with_values({"astrocyte_regulation": 0.0})
    return settings, models


def _estimates(models: ModelSet, cpg: Any, per_session: list[dict[str, float]]
               ) -> dict[str, Any]:
    """The populations' mean rates over the sessions, the synaptic events per spike counted
    on the network, and the power estimates of the paper's equations from them."""
    rates = {k: float(np.mean([s[k] for s in per_session]))
             for k in ("inhibitory", "calf", "thigh", "limit")}
    ops = synaptic_events_per_spike(cpg)
    snn = float(models.snn_power.compile()(
        **{f"ops_{k}": v for k, v in ops.items()}, **{f"f_{k}": v for k, v in rates.items()}))
    rl = float(models.rl_power.compile()(epsilon_ADD=models.value("epsilon_ADD")))
    # for comparison only: our rates with the paper's count of events per spike
    snn_paper_ops = float(models.snn_power.compile()(
        **{f"ops_{k}": v for k, v in PAPER["ops_per_spike"].items()},
        **{f"f_{k}": v for k, v in rates.items()}))
    return {"total_rate_Hz": rates, "ops_per_spike": ops, "snn_W": snn, "rl_W": rl,
            "ratio": rl / snn, "snn_W_with_paper_ops": snn_paper_ops}


def format_power(res: dict[str, Any]) -> str:
    p = res["paper"]
    names = {"inhibitory": "inhibitory interneurons", "calf": "calf motor neurons",
             "thigh": "thigh motor neurons", "limit": "limit-position inhibition"}
    lengths = [s["length_s"] for s in res["sessions"]]
    over = res.get("overrides") or []
    lines = [f"{len(lengths)} sessions with the trained table of trial {res['trial']} "
             f"(seed {res['seed']}{', overrides ' + ' '.join(over) if over else ''}), lengths "
             f"{min(lengths):.2f}–{max(lengths):.2f} s",
             f"{'population':28s} {'events/spike':>12s} {'(paper)':>8s} {'total rate (Hz)':>16s}"
             f" {'(paper)':>9s}"]
    for k, label in names.items():
        lines.append(f"{label:28s} {res['ops_per_spike'][k]:12.1f} {p['ops_per_spike'][k]:8d} "
                     f"{res['total_rate_Hz'][k]:16.4g} {p['total_rate_Hz'][k]:9.4g}")
    lines += [f"SNN CPG power   {res['snn_W']:.3g} W   (paper {p['snn_W']:.3g} W)",
              f"RL policy power {res['rl_W']:.3g} W   (paper {p['rl_W']:.3g} W)",
              f"ratio RL / SNN  {res['ratio']:.1f}x    (paper {p['ratio']:.1f}x)",
              f"with the paper's events per spike and these rates: SNN "
              f"{res['snn_W_with_paper_ops']:.3g} W, ratio "
              f"{res['rl_W'] / res['snn_W_with_paper_ops']:.1f}x"]
    return "\n".join(lines)


def power(value: PowerSettings, *, progress: bool = True) -> tuple[Path, dict[str, Any]]:
    """:func:`measure` with the settings ``value``, then ``power_trial<K>.json`` in its folder
    (with the settings, package versions and the process's command line, as manifests record
    them, whichever door called; with ``overrides``, ``power_trial<K>_<name>=<value>....json``,
    one file per setting); returns its path and the figures."""
    import sys

    from ..outputs.folder import refuse_in_use
    from ..outputs.writing import package_versions, save_json

    folder = Path(value.folder)
    tag = "".join("_" + re.sub(r"[^A-Za-z0-9_.=+-]+", "", o) for o in value.overrides)
    path = folder / f"power_trial{value.trial}{tag}.json"
    refuse_in_use(path, culprit=str(folder))  # a training or study run that is running
    res = measure(folder, trial=value.trial, sessions=value.sessions, progress=progress,
                  overrides=value.overrides)
    refuse_in_use(path, culprit=str(folder))
    save_json(path, res | {"settings": value.record(), "package_versions": package_versions(),
                           "argv": sys.argv})
    return path, res
