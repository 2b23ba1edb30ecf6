"""One seed, one trajectory: the network's noise is counter-based (astrocpg.network.noise), so a
trial is the same whatever batch, study layout or Brian2 target it runs in, and a training's
session can be replayed alone."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.network import noise
from astrocpg.studies.commands.replay import replay_session as replay

CLI = [sys.executable, "-m", "astrocpg.studies.cli"]
MASK = (1 << 64) - 1


# ---- the generator
@pytest.mark.parametrize("counter, key, words", [
    # Random123's known-answer vectors of Philox4x64-10
    ((0, 0, 0, 0), (0, 0),
     "16554d9eca36314c db20fe9d672d0fdc d7e772cee186176b 7e68b68aec7ba23b"),
    ((MASK,) * 4, (MASK, MASK),
     "87b092c3013fe90b 438c3c67be8d0224 9cc7d7c69cd777b6 a09caebf594f0ba0"),
    ((0x243F6A8885A308D3, 0x13198A2E03707344, 0xA4093822299F31D0, 0x082EFA98EC4E6C89),
     (0x452821E638D01377, 0xBE5466CF34E90C6C),
     "a528f45403e61d95 38c72dbd566e9788 a5a1610e72fd18b5 57bd43b5e52b7fe6"),
])
def test_philox_reference_gives_the_published_vectors(counter, key, words) -> None:
    assert " ".join(f"{w:016x}" for w in noise.philox4x64_10(counter, key)) == words


def test_numpy_blocks_are_the_definition() -> None:
    """The numpy implementation (NumPy's Philox in blocks of steps) gives the defined draw of
    every element, across block boundaries and for any subset of elements."""
    per, seeds = 10, [7, 8, 2**40 + 3]
    seed, cell = noise.trial_major(np.arange(per * len(seeds)), per, seeds)
    site = noise.site_id("pop", 1)
    stream = noise.SiteStream(name="x", site=site, seed=seed, cell=cell, cells_per_trial=per,
                              offset=np.zeros(1, dtype=np.int64))
    for step in (0, 1, noise.BLOCK_STEPS - 1, noise.BLOCK_STEPS, 5 * noise.BLOCK_STEPS + 3):
        got = stream.uniform(step, np.arange(len(seed)))
        want = [noise.uniform_reference(int(s), site, per, int(c), step)
                for s, c in zip(seed, cell)]
        assert got.tolist() == want
    some = np.array([29, 3, 11])
    assert stream.uniform(7, some).tolist() == [
        noise.uniform_reference(int(seed[e]), site, per, int(cell[e]), 7) for e in some]
    stream.offset[0] = 100  # a replay's shift: Brian2's step 7 draws step 107
    assert stream.uniform(7, some).tolist() == [
        noise.uniform_reference(int(seed[e]), site, per, int(cell[e]), 107) for e in some]


@pytest.mark.slow
@pytest.mark.parametrize("order", ["in order", "scattered"])
def test_cython_draws_are_the_definition(order) -> None:
    """The Cython draw function gives the defined draw of every element at every step, whether
    the elements draw in cell order (a block's four cells one after the other) or scattered: a
    group of 2 trials x 37 cells (a partial last block), each element's cell taken in order or
    shuffled, over steps across several blocks of counters."""
    from brian2 import Network, NeuronGroup, ms, prefs

    per, seeds = 37, [5, 2**40 + 9]
    numbers = np.arange(per * len(seeds))
    if order == "scattered":
        numbers = np.random.default_rng(1).permutation(numbers)
    seed, cell = noise.trial_major(numbers, per, seeds)
    draws = noise.Rewriter("testpop")
    code = draws("x = rand()")
    functions = draws.bind(seed, cell, per, np.zeros(1, dtype=np.int64)).functions
    before = prefs.codegen.target
    prefs.codegen.target = "cython"
    try:
        group = NeuronGroup(len(numbers), "x : 1", namespace=dict(functions), dt=1 * ms)
        group.run_regularly(code, when="start")
        net = Network(group)
        site = noise.site_id("testpop", 0)
        for step in range(6):
            net.run(1 * ms, namespace={})
            want = [noise.uniform_reference(int(s), site, per, int(c), step)
                    for s, c in zip(seed, cell)]
            assert group.x[:].tolist() == want, step
    finally:
        prefs.codegen.target = before


def test_sites_depend_on_the_population_and_position_only() -> None:
    assert noise.site_id("motor", 0) == noise.site_id("motor", 0)
    ids = {noise.site_id(p, k, s) for p in ("motor", "interneuron") for k in range(3)
           for s in (False, True)}
    assert len(ids) == 12
    draws = noise.Rewriter("motor")
    code = draws("x = 2*rand() - 1 : 1 (constant over dt)\ny = randn( ) : 1")
    assert "rand()" not in code and "randn" not in code.replace("randn_stream_1", "")
    assert [(k, n) for k, n, _ in draws.sites] == [("rand", "rand_stream_0"),
                                                  ("randn", "randn_stream_1")]


def test_a_parameter_may_not_take_a_draws_name() -> None:
    from astrocpg.models.names import why_reserved
    assert "draws" in why_reserved("rand_stream_0")
    assert why_reserved("random_amplitude") is None


# ---- one seed, one trajectory
def _trial(result, b: int) -> dict[str, object]:
    """Trial ``b``'s spikes (indices within the trial), traces and robot arrays."""
    L, n = result.layout, result.n_trials
    per = {"motor": L.motor_per_trial, "interneuron": L.interneurons_per_trial,
           "astrocyte": L.thigh_pools_per_trial}
    out: dict[str, object] = {}
    for pop, (t, i) in result.spikes.items():
        keep = (i >= b * per[pop]) & (i < (b + 1) * per[pop])
        out[f"spikes {pop}"] = (t[keep].tolist(), (i[keep] - b * per[pop]).tolist())
    for name, (t, values) in result.traces.items():
        width = values.shape[1] // n
        out[f"trace {name}"] = np.asarray(values[:, b * width:(b + 1) * width]).tobytes()
    for name, values in (result.robot or {}).items():
        if isinstance(values, np.ndarray) and values.ndim >= 2 and values.shape[0] == n:
            out[f"robot {name}"] = np.asarray(values[b]).tobytes()
    return out


def _same_trial(alone, batch, b: int) -> None:
    a, c = _trial(alone, 0), _trial(batch, b)
    assert a.keys() == c.keys()
    differ = [k for k in a if a[k] != c[k]]
    assert not differ, f"trial {b} of the batch differs from its seed alone in {differ}"


@pytest.mark.parametrize("command", ["unit", "run"])
def test_seed_alone_equals_its_trial_in_a_batch(command: str) -> None:
    fn = getattr(ac, command)
    alone = fn(seconds=0.3, seed=3, progress=False)
    batch = fn(seconds=0.3, seed=1, trials=3, progress=False)
    _same_trial(alone, batch, 2)
    assert _trial(batch, 0) != _trial(batch, 1)  # the trials' noise differs


def test_limbs_in_stages_draw_like_one_group() -> None:
    """With 0 ms inter-limb delays the motor neurons are split into one group per stage of
    limbs; a neuron's draws are still those of its trial and cell."""
    preset = (Path(__file__).resolve().parents[1] / "models" / "variants"
              / "interlimb_authors_delays.toml").read_text()
    models = {"interlimb_synapse": preset}
    alone = ac.run(seconds=0.2, seed=3, models=models, progress=False)
    batch = ac.run(seconds=0.2, seed=1, trials=3, models=models, progress=False)
    _same_trial(alone, batch, 2)


def test_a_model_files_own_draws_are_per_trial_too() -> None:
    """rand() and randn() a user writes (equations, initial values) are mapped like the
    built-in ones."""
    from astrocpg.models import DEFAULT_MODELS
    text = DEFAULT_MODELS.motor_neuron.equations.replace(
        "noise = 2*rand() - 1 : 1 (constant over dt)",
        "noise = 0.5*randn() + 0.2*(2*rand() - 1) : 1 (constant over dt)")
    assert text != DEFAULT_MODELS.motor_neuron.equations
    alone = ac.unit(seconds=0.2, seed=5, equations={"motor_neuron": text}, progress=False)
    batch = ac.unit(seconds=0.2, seed=4, trials=2, equations={"motor_neuron": text},
                    progress=False)
    _same_trial(alone, batch, 1)


def _rows(path: Path) -> dict[tuple[str, str, str], dict[str, str]]:
    with path.open(newline="") as f:
        return {(r["condition"], r["seed"], r["session"]):
                {k: v for k, v in r.items() if k not in ("run_id", "trial")}
                for r in csv.DictReader(f)}


def test_a_studys_rows_do_not_depend_on_its_batch(tmp_path: Path) -> None:
    rows = {}
    for batch in (1, 4):
        study = tmp_path / f"b{batch}.toml"
        study.write_text(f"""
[study]
name = "b{batch}"
sessions = 2
seeds = {{ first = 1, count = 4 }}
batch = {batch}
[base]
L_max = "0.3*second"
L_non_alive = "0.1*second"
[conditions.astro]
astrocytes = true
""")
        subprocess.run([*CLI, "study", str(study), "--out", str(tmp_path / f"s{batch}"),
                        "--workers", "1", "--no-progress"], check=True,
                       stdout=subprocess.DEVNULL)
        rows[batch] = _rows(tmp_path / f"s{batch}" / "results.csv")
    assert len(rows[1]) == 8 and rows[1] == rows[4]
    # a seed's session replayed from either study's run
    for folder, trial in ((tmp_path / "s4" / "runs" / "astro__seeds1-4", 2),
                          (tmp_path / "s1" / "runs" / "astro__seed3", 0)):
        info = replay(folder, trial=trial, session=2, out=tmp_path / f"r{folder.name}",
                      progress=False).summary["replay"]
        assert info["same"] and info["seed"] == 3, info
        assert info["replayed_final_x_m"] == rows[1][("astro", "3", "2")]["final_x_m"]


# ---- replay
def test_a_replayed_session_ends_where_the_training_recorded(tmp_path: Path) -> None:
    training = tmp_path / "t"
    t = ac.train(out=training, sessions=4, trials=2, seed=5, progress=False,
                 overrides=["L_max=1*second", "L_non_alive=0.2*second"])
    assert np.nanmax(np.abs(t.weights[:, 1:])) > 0  # learning acted before the later sessions
    starts = np.load(training / "session_starts.npz")
    assert starts["step"].shape == (2, 4) and starts["step"][1, 0] == 0
    for trial, session in ((1, 4), (0, 3)):
        r = replay(training, trial=trial, session=session, out=tmp_path / f"r{trial}{session}",
                   progress=False)
        info = r.summary["replay"]
        assert info["same"], info
        assert info["recorded_final_x_m"] == info["replayed_final_x_m"]
    # the command line, and what it refuses
    done = subprocess.run([*CLI, "run", "--weights", str(training), "--trial", "1",
                           "--session", "2", "--out", str(tmp_path / "cli"), "--no-progress"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "the same" in done.stdout
    assert (tmp_path / "cli" / "recordings" / "trial00_session0001" / "robot.npz").is_file()
    with pytest.raises(InputError, match="sessions 1..4"):
        replay(training, trial=1, session=5, out=tmp_path / "x", progress=False)
    bad = subprocess.run([*CLI, "run", "--weights", str(training), "--session", "1",
                          "--seconds", "3", "--out", str(tmp_path / "y")],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "--seconds" in bad.stderr and not (tmp_path / "y").exists()


def test_session_starts_survive_the_checkpoint(tmp_path: Path) -> None:
    """What a resume reads back holds every session start the training wrote."""
    from astrocpg.studies.commands.train_state import _memory_from_state, read_checkpoint
    training = tmp_path / "t"
    ac.train(out=training, sessions=2, trials=2, seed=2, progress=False, workers=1,
             overrides=["L_max=0.5*second", "L_non_alive=0.2*second"])
    memory = _memory_from_state(read_checkpoint(training / "checkpoint.npz")["memory"], 2)
    files = np.load(training / "session_starts.npz")
    for b in range(2):
        assert [s.step for s in memory.starts[b]] == files["step"][b].tolist()
        for k, start in enumerate(memory.starts[b]):
            for key, values in start.state.items():
                assert np.array_equal(values, files[f"state.{key}"][b, k])


# ---- Cython
@pytest.mark.slow
def test_cython_seed_alone_equals_its_trial_and_agrees_with_numpy(tmp_path: Path,
                                                                  monkeypatch) -> None:
    """Cython: seed 3 alone is trial 2 of a batch of 3; numpy and Cython give the same spikes
    and joint angles within 1e-9 rad over 3 s."""
    from astrocpg.network import use_codegen
    monkeypatch.setenv("ASTROCPG_CODEGEN", "cython")  # the API's --codegen
    try:
        alone = ac.run(seconds=3, seed=3, progress=False, out=tmp_path / "alone")
        batch = ac.run(seconds=3, seed=1, trials=3, progress=False)
        unit_alone = ac.unit(seconds=1, seed=3, progress=False)
        unit_batch = ac.unit(seconds=1, seed=1, trials=3, progress=False)
    finally:
        monkeypatch.delenv("ASTROCPG_CODEGEN")
        use_codegen("numpy")
    assert ac.load(tmp_path / "alone").manifest["codegen"] == "cython"
    _same_trial(alone, batch, 2)
    _same_trial(unit_alone, unit_batch, 2)
    numpy_run = ac.run(seconds=3, seed=3, progress=False)
    for pop, (t, i) in numpy_run.spikes.items():
        assert np.array_equal(t, alone.spikes[pop][0]) and np.array_equal(i, alone.spikes[pop][1])
    dq = np.max(np.abs(numpy_run.robot["joint_angles"] - alone.robot["joint_angles"]))
    assert dq < 1e-9


# ---- a stochastic threshold drawn only where its probability is open
def test_a_threshold_rand_below_p_is_one_bernoulli_call_of_the_same_stream() -> None:
    draws = noise.Rewriter("motor")
    code = draws("rand() < p_spike*(1 + v/mV)")
    assert code == "rand_stream_0(t_in_timesteps, p_spike*(1 + v/mV))"
    assert [(k, n, p) for k, n, p in draws.sites] == [("bernoulli", "rand_stream_0", 0)]
    # p written as the sigmoid 0.5*(1 + tanh(x)): the call takes x
    draws = noise.Rewriter("motor")
    code = draws("rand() < 0.5*(1 + tanh((v - v_th)/S))")
    assert code == "rand_stream_0(t_in_timesteps, (v - v_th)/S)"
    assert [(k, n, p) for k, n, p in draws.sites] == [("sigmoid", "rand_stream_0", 0)]
    for text in ("rand() < 0.5 * (1.0 + tanh(x))", "rand()<.5*(1+tanh(a*(b+c)))"):
        assert noise.Rewriter("motor")(text).startswith("rand_stream_0(t_in_timesteps, "), text
    # a p that only looks like the sigmoid stays a plain Bernoulli call of p
    for p in ("0.5*(1 + tanh(a) * tanh(b))", "0.5*(1 + tanh(a)) * b", "0.4*(1 + tanh(a))",
              "0.5*(2 + tanh(a))", "0.5*(1 - tanh(a))"):
        other = noise.Rewriter("motor")
        assert other(f"rand() < {p}") == f"rand_stream_0(t_in_timesteps, {p})", p
        assert [k for k, _, _ in other.sites] == ["bernoulli"], p
    # anything else is left to the plain draw: a conjunction, a second draw, a reversed test
    for text in ("rand() < p and v > 0*mV", "rand() < rand()", "p > rand()",
                 "(rand() < p)"):
        other = noise.Rewriter("motor")
        other(text)
        assert all(k != "bernoulli" for k, _, _ in other.sites), text


@pytest.mark.parametrize("codegen", ["numpy", pytest.param("cython", marks=pytest.mark.slow)])
def test_the_bernoulli_threshold_spikes_exactly_as_the_comparison(codegen, monkeypatch) -> None:
    """The motor threshold as one Bernoulli call (C skips the draw where p is 0 or 1) against
    the same comparison written so that it stays a plain draw: the same site, the same
    stream, so the same spikes, step for step."""
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.models.files import model_to_toml
    from astrocpg.models.motor_neuron import THRESHOLD
    monkeypatch.setenv("ASTROCPG_CODEGEN", codegen)  # the unit's Brian2 target
    text = model_to_toml(DEFAULT_MODELS.motor_neuron)
    assert THRESHOLD.startswith("rand() <")
    plain = text.replace(THRESHOLD, f"({THRESHOLD})")
    assert plain != text
    runs = [ac.unit(seconds=0.5, seed=3, trials=2, progress=False, traces="none",
                    models=None if m is None else {"motor_neuron": m})
            for m in (None, plain)]
    a, b = (r.spikes["motor"] for r in runs)
    assert len(a[0]) > 100
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])



def test_the_c_librarys_tanh_is_one_from_22_on() -> None:
    """What the sigmoid threshold's C shortcut rests on (Python's math.tanh is the C
    library's): tanh is exactly +-1.0 for |x| >= 22, so p there is exactly 1 or 0."""
    import math
    for x in (22.0, 22.5, 30.0, 1e3, float("inf")):
        assert math.tanh(x) == 1.0 and math.tanh(-x) == -1.0
        assert 0.5 * (1.0 + math.tanh(x)) == 1.0 and 0.5 * (1.0 + math.tanh(-x)) == 0.0
    assert noise.TANH_SATURATED == 22.0


def _sigmoid_cases(seeds: list[int], per: int, site: int) -> np.ndarray:
    """x of each of ``len(seeds) * per`` cells: the edges of the shortcut (+-22, where the C
    library's tanh reaches +-1 exactly, and just inside), the saturated tails, NaN and the
    infinities, ordinary values, and cells whose p = 0.5*(1 + tanh(x)) is their own draw at
    step 0 to within rounding (the outcome decided by the exact p, not the margin)."""
    edges = [22.0, -22.0, np.nextafter(22.0, 0.0), np.nextafter(-22.0, 0.0), 19.5, -19.5,
             30.0, -30.0, 700.0, -700.0, np.nan, np.inf, -np.inf, 0.0, -0.0, 1e-300]
    rng = np.random.default_rng(7)
    # p near 0 and 1, where a shortcut taken too early would decide many cells wrongly
    x = np.concatenate([edges, rng.uniform(-4, 4, 40), rng.uniform(-25, 25, 40),
                        rng.uniform(1.2, 3, 50), rng.uniform(-3, -1.2, 50)])
    n = len(seeds) * per
    x = np.resize(x, n)
    for e in range(0, n, 3):  # every third cell: p on its own step-0 draw
        seed, cell = seeds[e // per], e % per
        u = noise.uniform_reference(seed, site, per, cell, 0)
        x[e] = np.arctanh(2.0 * u - 1.0)
    return x


@pytest.mark.parametrize("codegen", ["numpy", pytest.param("cython", marks=pytest.mark.slow)])
def test_the_sigmoid_threshold_decides_as_the_written_comparison(codegen) -> None:
    """``rand() < 0.5*(1 + tanh(x))`` taken as one call of x (C skips tanh where the outcome is
    certain) spikes, cell for cell and step for step, as the same comparison written so that it
    stays a plain draw of the same stream: at the shortcut's edges, on NaN and the infinities,
    and where p lies on the cell's draw."""
    from brian2 import Network, NeuronGroup, SpikeMonitor, ms, prefs

    per, seeds = 101, [3, 2**33 + 1]
    numbers = np.arange(per * len(seeds))
    seed, cell = noise.trial_major(numbers, per, seeds)
    x = _sigmoid_cases(seeds, per, noise.site_id("sigmoidpop", 0))
    written = "rand() < 0.5*(1 + tanh(x))"
    spikes = {}
    before = prefs.codegen.target
    prefs.codegen.target = codegen
    try:
        for label, text in (("sigmoid", written), ("plain", f"({written})")):
            draws = noise.Rewriter("sigmoidpop")
            code = draws(text)
            assert [k for k, _, _ in draws.sites] == [label if label == "sigmoid" else "rand"]
            functions = draws.bind(seed, cell, per, np.zeros(1, dtype=np.int64)).functions
            group = NeuronGroup(len(numbers), "x : 1 (constant)", threshold=code,
                                namespace=dict(functions), dt=1 * ms)
            group.x = x
            monitor = SpikeMonitor(group)
            Network(group, monitor).run(5 * ms, namespace={})
            spikes[label] = (np.asarray(monitor.t_[:]), np.asarray(monitor.i[:]))
    finally:
        prefs.codegen.target = before
    t, i = spikes["sigmoid"]
    assert 20 < len(i) < 5 * len(numbers)  # both outcomes occur
    np.testing.assert_array_equal(t, spikes["plain"][0])
    np.testing.assert_array_equal(i, spikes["plain"][1])
    # and as the definition: the cell's draw below the written p, with the target's tanh (the
    # C library's on Cython, as Python's math.tanh; numpy's own on numpy: their last bits differ)
    import math
    with np.errstate(invalid="ignore"):
        p = (0.5 * (1.0 + np.tanh(x)) if codegen == "numpy"
             else np.array([0.5 * (1.0 + math.tanh(v)) for v in x]))
    site = noise.site_id("sigmoidpop", 0)
    want = [(k, e) for k in range(5) for e in range(len(numbers))
            if noise.uniform_reference(int(seed[e]), site, per, int(cell[e]), k) < p[e]]
    got = sorted(zip(np.round(t * 1e3).astype(int).tolist(), i.tolist()))
    assert got == want
