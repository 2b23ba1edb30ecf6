"""Analysis of recorded activity: bursts, rhythm, phases, gait labels, weight structure.
Pure numpy: arrays in, numbers out; nothing here runs a simulation or writes a file."""
