"""Counter-based noise: every ``rand()`` and ``randn()`` of the network is a pure function of
(the trial's seed, the element's index within its trial and population (a synapse: within its
trial and object), the time step, the draw's position in the model's code).

Brian2's own ``rand()`` draws from one Mersenne Twister per process, for every neuron of every
trial at each step, so a trial's noise depended on the batch it ran in. Here each model's code
is rewritten when the network is built: the k-th ``rand()`` of a model (counted through its
equations, threshold, reset, ``on_pre``, ``on_step``, initial values and weight, in that order)
becomes a call of a :class:`brian2.Function` of that object and draw. Its value for element
``c`` of trial ``b`` (seed ``s = seed + b``) at step ``n`` is lane ``c mod 4`` of

    Philox4x64-10(counter = (n * W + c // 4 + 1, 0, 0, 0), key = (s, site))

with ``W = ceil(cells per trial / 4)`` and ``site`` a 64-bit number made from the population's
name and the draw's position (:func:`site_id`); the 64-bit word ``u`` becomes the double
``(u >> 11) * 2**-53`` in [0, 1). ``randn()`` is Box-Muller over two such uniforms (its
position and a second site). Philox4x64-10 is the counter-based generator of Salmon et al.
(2011), the one NumPy ships as ``numpy.random.Philox``.

Both Brian2 targets give the same uniform bits: numpy fills blocks of ``BLOCK_STEPS`` steps
per trial with NumPy's own Philox (C speed, one call per trial, site and block), Cython computes
the same words in C (``PHILOX_C``). ``randn()`` goes through ``log`` and ``cos``, whose
last bit may differ between NumPy's and the C library's implementations.

A stochastic threshold ``rand() < p`` is one call that decides it: C draws only where ``p``
leaves the outcome open, and for ``p`` written ``0.5*(1 + tanh(x))`` computes ``tanh`` only
where the draw lies within 1e-12 of the same sigmoid through ``exp``; the outcome is the
written comparison's, bit for bit (``_bernoulli_function``,
``_sigmoid_bernoulli_function``).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from brian2 import Function
from brian2.codegen.runtime.numpy_rt.numpy_rt import LazyArange

from ..models.names import DRAW_PREFIXES

#: Steps of draws NumPy generates per trial and site in one call (the cost of a call, a few
#: microseconds, is shared by this many steps; a block of 320 cells takes 160 KiB).
BLOCK_STEPS = 64
_TO_UNIT = 1.0 / 9007199254740992.0  # 2**-53
_MASK64 = (1 << 64) - 1
#: What the framework writes for the k-th rand() / randn() of an object's code (a model may
#: not give a parameter such a name: :data:`astrocpg.models.names.DRAW_PREFIXES`).
RAND_NAME, RANDN_NAME = (prefix + "{}" for prefix in DRAW_PREFIXES)
_CALL = re.compile(r"\b(randn|rand)\s*\(\s*\)")
#: A whole condition "rand() < p" whose p holds no draw, comparison or logical operator (so
#: that it is the comparison's whole right side): rewritten into one Bernoulli call
_BERNOULLI = re.compile(r"^\s*rand\s*\(\s*\)\s*<\s*((?:(?!\brandn?\b|\band\b|\bor\b|\bnot\b)"
                        r"[^<>=!\n:])+)$")
#: p of such a condition written as the sigmoid 0.5*(1 + tanh(x)) (the models' spike
#: probability): its Bernoulli call takes x, so that C needs no tanh where the outcome is certain
_SIGMOID = re.compile(r"^\s*0?\.5\s*\*\s*\(\s*1(?:\.0*)?\s*\+\s*tanh\s*\((.+)\)\s*\)\s*$")
#: |x| from which the C library's tanh(x) is exactly +-1.0 (glibc's and musl's tanh return
#: +-1.0 there by construction; mathematically 1 - |tanh(x)| < 2e-19, below half an ulp of 1)
TANH_SATURATED = 22.0
#: How far 1/(1 + exp(-2x)) may be from 0.5*(1 + tanh(x)) before the exact p is computed: both
#: are within a few ulps (< 1e-15) of the true sigmoid, so this margin is never crossed wrongly
SIGMOID_MARGIN = 1e-12
#: How the next networks draw: "streams" (the framework's, always outside measurements) or
#: "brian" (Brian2's own generator, what astrocpg drew from before the streams). Only
#: ``benchmarks/noise_cost.py`` changes it, to compare what the two cost within a step.
DRAWS = "streams"


def site_id(population: str, position: int, second: bool = False) -> int:
    """The 64-bit site of the ``position``-th draw (0-based) in the code of ``population``'s
    objects; ``second``: the second uniform of a ``randn()``. Made from the names alone, so
    adding a draw or a population elsewhere changes no other stream."""
    text = f"astrocpg-noise:{population}:{position}:{'b' if second else 'a'}"
    return int.from_bytes(hashlib.blake2b(text.encode(), digest_size=8).digest(), "little")


def philox4x64_10(counter: tuple[int, int, int, int], key: tuple[int, int]) -> list[int]:
    """Philox4x64 with 10 rounds, in plain Python integers: the definition the fast
    implementations are tested against (four 64-bit words out)."""
    M0, M1 = 0xD2E7470EE14C6C93, 0xCA5A826395121157
    W0, W1 = 0x9E3779B97F4A7C15, 0xBB67AE8584CAA73B
    c = [int(x) & _MASK64 for x in counter]
    k0, k1 = int(key[0]) & _MASK64, int(key[1]) & _MASK64
    for r in range(10):
        if r:
            k0, k1 = (k0 + W0) & _MASK64, (k1 + W1) & _MASK64
        p0, p1 = M0 * c[0], M1 * c[2]
        c = [(p1 >> 64) ^ c[1] ^ k0, p1 & _MASK64, (p0 >> 64) ^ c[3] ^ k1, p0 & _MASK64]
    return c


def uniform_reference(seed: int, site: int, cells_per_trial: int, cell: int, step: int) -> float:
    """One draw by the definition above (slow; for tests and the manual)."""
    width = (cells_per_trial + 3) // 4
    words = philox4x64_10((step * width + cell // 4 + 1, 0, 0, 0), (seed, site))
    return (words[cell % 4] >> 11) * _TO_UNIT


# ---- the C implementation (Cython target), included once per compiled module
PHILOX_C = r'''
cdef extern from *:
    """
    #include <stdint.h>
    static inline void astrocpg_philox4x64_10(uint64_t c0, uint64_t k0, uint64_t k1,
                                              uint64_t *out) {
        uint64_t c[4] = {c0, 0, 0, 0};
        for (int r = 0; r < 10; r++) {
            if (r) { k0 += 0x9E3779B97F4A7C15ULL; k1 += 0xBB67AE8584CAA73BULL; }
            unsigned __int128 p0 = (unsigned __int128)0xD2E7470EE14C6C93ULL * c[0];
            unsigned __int128 p1 = (unsigned __int128)0xCA5A826395121157ULL * c[2];
            uint64_t n0 = (uint64_t)(p1 >> 64) ^ c[1] ^ k0;
            uint64_t n2 = (uint64_t)(p0 >> 64) ^ c[3] ^ k1;
            c[0] = n0; c[1] = (uint64_t)p1; c[2] = n2; c[3] = (uint64_t)p0;
        }
        out[0] = c[0]; out[1] = c[1]; out[2] = c[2]; out[3] = c[3];
    }
    """
    void astrocpg_philox4x64_10(uint64_t c0, uint64_t k0, uint64_t k1, uint64_t *out) nogil
'''

_philox_dependency = Function(pyfunc=lambda: 0.0, arg_units=[], return_unit=1,
                              stateless=False)
_philox_dependency.implementations.add_implementation("cython", code=PHILOX_C,
                                                      name="astrocpg_philox4x64_10")
_philox_dependency.implementations.add_implementation("numpy", lambda: 0.0)


def _cython_uniform(name: str, site: int, width: int) -> str:
    """Cython code of one object's draw function: the word of element ``_idx`` at the step,
    with a one-block cache (four neighbouring cells share a Philox call)."""
    p = f"_ns_{name}_"
    return f'''
cdef uint64_t {name}_block = 0
cdef uint64_t {name}_key = 0
cdef uint64_t {name}_words[4]
cdef double {name}_word(int64_t step, size_t _idx):
    global {name}_block, {name}_key
    cdef uint64_t key = <uint64_t>_namespace{p}elements[2 * _idx]
    cdef int64_t cell = _namespace{p}elements[2 * _idx + 1]
    cdef uint64_t block = <uint64_t>((step + _namespace{p}offset[0]) * {width} + (cell >> 2) + 1)
    if block != {name}_block or key != {name}_key or block == 0:
        astrocpg_philox4x64_10(block, key, {site}ULL, {name}_words)
        {name}_block = block
        {name}_key = key
    return ({name}_words[cell & 3] >> 11) * {_TO_UNIT!r}
'''


@dataclass
class SiteStream:
    """One draw site of one Brian2 object: element ``e`` is cell ``cell[e]`` of the trial with
    seed ``seed[e]``. Called by Brian2's numpy code with the step and the elements drawn for."""

    name: str
    site: int
    seed: np.ndarray  # int64, per element: the seed of its trial
    cell: np.ndarray  # int64, per element: its index within its trial and population
    cells_per_trial: int
    offset: np.ndarray  # int64, one element: added to Brian2's step (replay)
    _start: int = -1
    _buffer: np.ndarray | None = None
    _flat: np.ndarray | None = None
    _identity: bool = False
    _trial_seeds: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __post_init__(self) -> None:
        self.width = (self.cells_per_trial + 3) // 4
        seeds, trial = np.unique(self.seed, return_inverse=True)
        self._trial_seeds = seeds.astype(np.int64)
        # element -> its position in the block (trials, BLOCK_STEPS, 4*width) at step 0
        self._flat = (trial.astype(np.int64) * BLOCK_STEPS * 4 * self.width
                      + self.cell).astype(np.intp)
        # every cell of every trial, in trial-major order: a step's draws are a block's row
        self._identity = (4 * self.width == self.cells_per_trial
                          and len(trial) == len(seeds) * self.cells_per_trial
                          and np.array_equal(trial.astype(np.int64) * self.cells_per_trial
                                             + self.cell, np.arange(len(trial))))
        self._bitgen = np.random.Philox(key=[0, 0])
        self._state = self._bitgen.state

    def _fill(self, step: int) -> None:
        """Draw steps ``step`` .. ``step + BLOCK_STEPS - 1`` of every trial: one call of NumPy's
        Philox per trial, doubles written in place ((word >> 11) * 2**-53, in C)."""
        row = 4 * self.width
        if self._buffer is None:
            self._buffer = np.empty((len(self._trial_seeds), BLOCK_STEPS, row))
            self._generator = np.random.Generator(self._bitgen)
        state = self._state
        counter, key = state["state"]["counter"], state["state"]["key"]
        for b, seed in enumerate(self._trial_seeds):
            counter[0] = np.uint64(step * self.width)  # the first word comes from counter + 1
            key[0], key[1] = np.uint64(int(seed) & _MASK64), np.uint64(self.site)
            state["buffer_pos"] = 4
            self._bitgen.state = state
            self._generator.random(BLOCK_STEPS * row, out=self._buffer[b].reshape(-1))
        self._start = step

    def uniform(self, step: Any, idx: Any) -> np.ndarray:
        """The draws of elements ``idx`` (Brian2's vectorisation index) at ``step``."""
        n = int(step) + int(self.offset[0])
        k = n - self._start
        if self._start < 0 or not 0 <= k < BLOCK_STEPS:
            self._fill(n)
            k = 0
        buffer = self._buffer
        if isinstance(idx, LazyArange):
            if self._identity and idx.start == 0 and idx.stop == len(self._flat):
                return buffer[:, k, :].reshape(-1)  # type: ignore[index]  # a copy
            idx = np.arange(idx.start, idx.stop)
        elif np.ndim(idx) == 0:  # Brian2's scalar code block
            idx = np.array([0]) if int(idx) == 1 else np.arange(int(idx))
        where = self._flat[np.asarray(idx, dtype=np.intp)]  # type: ignore[index]
        return buffer.reshape(-1)[where + k * 4 * self.width]  # type: ignore[union-attr]

    def namespace(self) -> dict[str, np.ndarray]:
        """The arrays the Cython code reads: (seed, cell) of each element, interleaved (one
        buffer to acquire per call of the code object), and the step offset."""
        p = f"_ns_{self.name}_"
        elements = np.ascontiguousarray(np.stack([self.seed, self.cell], axis=1).ravel(),
                                        dtype=np.int64)
        return {p + "elements": elements, p + "offset": self.offset}


def _uniform_function(name: str, streams: list[SiteStream]) -> Function:
    s = streams[0]
    f = Function(pyfunc=lambda step: 0.0, arg_units=[1], return_unit=1,
                 arg_types=["integer"], return_type="float", stateless=False,
                 auto_vectorise=True)
    f.implementations.add_implementation("numpy", s.uniform, name=name)
    code = _cython_uniform(name, s.site, s.width) + f'''
cdef double {name}(int64_t step, size_t _idx):
    return {name}_word(step, _idx)
'''
    f.implementations.add_implementation("cython", code=code, name=name,
                                         namespace=s.namespace(),
                                         dependencies={"_astrocpg_philox": _philox_dependency})
    return f


def _bernoulli_function(name: str, streams: list[SiteStream]) -> Function:
    """``rand() < p`` as one call: the same uniform, but C draws it only where ``p`` leaves the
    comparison open (a uniform in [0, 1) is below any p >= 1 and below no p <= 0, NaN
    included), so the result is that of the comparison, bit for bit, at a fraction of the
    draws (a threshold far from its transition). Numpy draws for every element as before."""
    s = streams[0]

    def numpy_bernoulli(step: Any, p: Any, idx: Any) -> np.ndarray:
        return s.uniform(step, idx) < p

    return _decision_function(name, s, numpy_bernoulli, f'''
cdef bint {name}(int64_t step, double p, size_t _idx):
    if p >= 1.0:
        return True
    if not p > 0.0:
        return False
    return {name}_word(step, _idx) < p
''')


def _decision_function(name: str, s: SiteStream, numpy_code: Any, cython_code: str) -> Function:
    """A draw's Bernoulli decision as a Brian2 function of (the step, one float): ``numpy_code``
    on numpy, ``cython_code`` (which calls the site's ``{name}_word``) on Cython."""
    f = Function(pyfunc=lambda step, value: False, arg_units=[1, 1], return_unit=bool,
                 arg_types=["integer", "float"], return_type="boolean", stateless=False,
                 auto_vectorise=True)
    f.implementations.add_implementation("numpy", numpy_code, name=name)
    f.implementations.add_implementation("cython", code=_cython_uniform(name, s.site, s.width)
                                         + cython_code, name=name, namespace=s.namespace(),
                                         dependencies={"_astrocpg_philox": _philox_dependency})
    return f


def _balanced(text: str) -> bool:
    """Whether ``text``'s parentheses pair up within it (so that ``tanh(text)`` is one call)."""
    depth = 0
    for ch in text:
        depth += (ch == "(") - (ch == ")")
        if depth < 0:
            return False
    return depth == 0


def sigmoid_argument(p: str) -> str | None:
    """``x`` where ``p`` is written ``0.5*(1 + tanh(x))``, else None."""
    m = _SIGMOID.match(p)
    return m.group(1).strip() if m and _balanced(m.group(1)) else None


def _sigmoid_bernoulli_function(name: str, streams: list[SiteStream]) -> Function:
    """``rand() < 0.5*(1 + tanh(x))`` as one call of ``x``: the same uniform and the same
    outcome, bit for bit, as the comparison (numpy computes it as written). C decides without
    ``tanh``, the costliest part of a stochastic threshold, wherever the outcome is certain:

    * ``|x| >= 22``: the C library's tanh is exactly +-1.0, so p is 1 or 0 and no draw is made
      (as :func:`_bernoulli_function` skips it); NaN gives no spike, as ``p > 0`` fails for it;
    * otherwise the uniform ``u`` is drawn and compared with ``q = 1/(1 + exp(-2x))``, the same
      sigmoid through ``exp`` (a few times cheaper than ``tanh``): ``u < q - margin`` is a spike,
      ``u >= q + margin`` none, and only between (a chance of about 2e-12 a draw) is p computed
      as written, ``0.5*(1 + tanh(x))``, and compared.

    The margin (:data:`SIGMOID_MARGIN`, 1e-12) is a thousand times the largest possible
    difference between q and the written p (each within a few ulps of the true sigmoid)."""
    s = streams[0]

    def numpy_bernoulli(step: Any, x: Any, idx: Any) -> np.ndarray:
        return s.uniform(step, idx) < 0.5 * (1.0 + np.tanh(x))

    return _decision_function(name, s, numpy_bernoulli, f'''
cdef bint {name}(int64_t step, double x, size_t _idx):
    cdef double u, q
    if x >= {TANH_SATURATED!r}:
        return True
    if not x > -{TANH_SATURATED!r}:
        return False
    u = {name}_word(step, _idx)
    q = 1.0 / (1.0 + exp(-2.0 * x))
    if u < q - {SIGMOID_MARGIN!r}:
        return True
    if u >= q + {SIGMOID_MARGIN!r}:
        return False
    return u < 0.5 * (1.0 + tanh(x))
''')


def box_muller(u1: np.ndarray, u2: np.ndarray) -> np.ndarray:
    """Standard normals from two uniforms in [0, 1) (the C code of ``randn()`` is the same)."""
    return np.sqrt(-2.0 * np.log1p(-u1)) * np.cos(2.0 * np.pi * u2)


def _normal_function(name: str, streams: list[SiteStream]) -> Function:
    a, b = streams

    def normal(step: Any, idx: Any) -> np.ndarray:
        u1, u2 = a.uniform(step, idx), b.uniform(step, idx)
        return box_muller(u1, u2)

    f = Function(pyfunc=lambda step: 0.0, arg_units=[1], return_unit=1,
                 arg_types=["integer"], return_type="float", stateless=False,
                 auto_vectorise=True)
    f.implementations.add_implementation("numpy", normal, name=name)
    code = (_cython_uniform(name + "_a", a.site, a.width)
            + _cython_uniform(name + "_b", b.site, b.width) + f'''
cdef double {name}(int64_t step, size_t _idx):
    cdef double u1 = {name}_a_word(step, _idx)
    cdef double u2 = {name}_b_word(step, _idx)
    return sqrt(-2.0 * log1p(-u1)) * cos(2.0 * M_PI * u2)
''')
    f.implementations.add_implementation("cython", code=code, name=name,
                                         namespace=a.namespace() | b.namespace(),
                                         dependencies={"_astrocpg_philox": _philox_dependency})
    return f


@dataclass
class ObjectDraws:
    """The draw functions of one Brian2 object, by the name its rewritten code calls."""

    functions: dict[str, Function] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return bool(self.functions)


class Rewriter:
    """Numbers one object's ``rand()``/``randn()`` calls in code order and rewrites each into a
    call of its own function; :meth:`bind` then makes the functions once the object's
    elements (and so their trials and cells) are known."""

    def __init__(self, population: str) -> None:
        self.population = population
        self.sites: list[tuple[str, str, int]] = []  # (kind, function name, position)

    def __call__(self, code: Any) -> Any:
        """``code`` with its draws rewritten (non-strings and strings without draws as given)."""
        if not isinstance(code, str) or "rand" not in code or DRAWS == "brian":
            return code
        whole = _BERNOULLI.match(code)
        if whole:  # "rand() < p" (a stochastic threshold): one call that may skip the draw
            position = len(self.sites)
            name = RAND_NAME.format(position)
            p = whole.group(1).strip()
            x = sigmoid_argument(p)
            if x is not None:  # p = 0.5*(1 + tanh(x)): the call takes x (C may skip tanh)
                self.sites.append(("sigmoid", name, position))
                return f"{name}(t_in_timesteps, {x})"
            self.sites.append(("bernoulli", name, position))
            return f"{name}(t_in_timesteps, {p})"

        def one(match: re.Match) -> str:
            kind = match.group(1)
            position = len(self.sites)
            name = (RANDN_NAME if kind == "randn" else RAND_NAME).format(position)
            self.sites.append((kind, name, position))
            return f"{name}(t_in_timesteps)"

        return _CALL.sub(one, code)

    def bind(self, seed: np.ndarray, cell: np.ndarray, cells_per_trial: int,
             offset: np.ndarray) -> ObjectDraws:
        """The functions of the rewritten calls, for elements of seeds ``seed`` and cells
        ``cell`` (both per element, in the object's order)."""
        out = ObjectDraws()
        seed = np.ascontiguousarray(seed, dtype=np.int64)
        cell = np.ascontiguousarray(cell, dtype=np.int64)
        for kind, name, position in self.sites:
            def stream(second: bool) -> SiteStream:
                return SiteStream(name=name + ("_b" if second else "_a" if kind == "randn" else ""),
                                  site=site_id(self.population, position, second),
                                  seed=seed, cell=cell, cells_per_trial=cells_per_trial,
                                  offset=offset)
            if kind == "rand":
                out.functions[name] = _uniform_function(name, [stream(False)])
            elif kind == "bernoulli":
                out.functions[name] = _bernoulli_function(name, [stream(False)])
            elif kind == "sigmoid":
                out.functions[name] = _sigmoid_bernoulli_function(name, [stream(False)])
            else:
                out.functions[name] = _normal_function(name, [stream(False), stream(True)])
        return out


class TrialNormals:
    """Standard normal draws outside Brian2's code, one stream per trial and element, drawn
    like a ``randn()`` of population ``population`` (e.g. the coupling's torque noise):
    ``draw(step)`` gives the (trials, cells_per_trial) draws of ``step``."""

    def __init__(self, population: str, seeds: list[int], cells_per_trial: int,
                 offset: np.ndarray) -> None:
        n = len(seeds) * cells_per_trial
        seed, cell = trial_major(np.arange(n), cells_per_trial, seeds)
        self._a, self._b = (SiteStream(name=population, site=site_id(population, 0, second),
                                       seed=seed, cell=cell, cells_per_trial=cells_per_trial,
                                       offset=offset) for second in (False, True))
        self._all = np.arange(n)
        self.shape = (len(seeds), cells_per_trial)

    def draw(self, step: int) -> np.ndarray:
        u1, u2 = self._a.uniform(step, self._all), self._b.uniform(step, self._all)
        return box_muller(u1, u2).reshape(self.shape)


def trial_major(numbers: np.ndarray, cells_per_trial: int,
                seeds: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(seed, cell) of each element of an object whose element ``e`` is the trial-major
    number ``numbers[e]`` of its population (``cells_per_trial`` per trial)."""
    numbers = np.asarray(numbers, dtype=np.int64)
    return np.asarray(seeds, dtype=np.int64)[numbers // cells_per_trial], numbers % cells_per_trial


__all__ = ["site_id", "philox4x64_10", "uniform_reference", "Rewriter", "ObjectDraws",
           "SiteStream", "TrialNormals", "BLOCK_STEPS", "trial_major"]
