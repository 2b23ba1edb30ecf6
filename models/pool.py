"""A motor-neuron pool as a whole: its spike count in the current step and the inputs that reach
all of its neurons alike (torso speed for the background drive, limit-position inhibition, the
summed inter-limb input). The motor neurons read these through linked variables.

``limit_margin`` is the distance from a thigh joint limit within which the pool that drives the
joint toward that limit is inhibited (paper: 0.05 rad; SPEC: the authors' code in effect used 0).
"""

from brian2.units.allunits import radian

from .base import NeuronModel, Parameter, ParameterTable, SynapseModel

EQUATIONS = """
n : 1
torso_speed : meter/second
limit_inhibition : 1
I_interlimb : volt/second
"""

PARAMETERS = ParameterTable("pool", [
    Parameter(name="pool_size", value=20, symbol=r"\mathbf{Size}_{\mathrm{pool}}",
              meaning="number of motor neurons in a pool", positive=True),
    Parameter(name="limit_margin", value=0.05*radian, symbol=r"\mathrm{margin}",
              meaning="inhibition region next to a thigh joint limit (paper 0.05 rad; SPEC)"),
])

POOL = NeuronModel(name="pool", equations=EQUATIONS, parameters=PARAMETERS, description=__doc__)

# Every motor neuron reports its spike of this step to its pool.
POOL_ACTIVITY = SynapseModel(
    name="pool_activity",
    model="n_post = int(lastspike_pre == t) : 1 (summed)",
    parameters=ParameterTable("pool_activity", []),
    description="Spike count of a pool in the current step (sum over its motor neurons).",
)
