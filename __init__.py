"""astrocpg: an astrocyte-regulated spiking central pattern generator, declared as Brian2
equation strings, driving a simulated Unitree A1 quadruped in MuJoCo.

Sub-packages:
  models    the biophysics: one model per module, its equation string and parameter table
  network   builds populations and synapses (for ``n_trials`` independent copies)
  coupling  the A1 robot model and the 1 ms Brian2 <-> MuJoCo bridge
  studies   runs, outputs, figures and the ``astrocpg`` command line
"""

__version__ = "0.1.0"
