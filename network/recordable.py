"""What can be recorded from a built CPG: spikes per population, and traces of state variables
(with the unit they are stored in). Both are read from the population table
(:mod:`astrocpg.network.populations`): the constants are the built-in rows; the functions follow
rows added with :func:`~astrocpg.network.populations.register` (use them where an added
population must be recordable)."""

from .populations import BUILT_IN, spike_populations, trace_sources

#: populations whose spikes are recordable (built-in rows; astrocyte "spikes": adenosine releases)
POPULATIONS: tuple[str, ...] = tuple(p.name for p in BUILT_IN if p.spikes)

#: trace -> (group, variable, factor from Brian2's SI value to the stored unit, stored unit)
TRACE_SOURCES: dict[str, tuple[str, str, float, str]] = {
    t: (p.name, s.variable, s.factor, s.unit) for p in BUILT_IN for t, s in p.traces.items()}

TRACES: tuple[str, ...] = tuple(TRACE_SOURCES)

__all__ = ["POPULATIONS", "TRACES", "TRACE_SOURCES", "spike_populations", "trace_sources"]
