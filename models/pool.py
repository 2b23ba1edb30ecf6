"""A motor-neuron pool as a whole: its spike count in the current step and the inputs that reach
all of its neurons alike (torso speed for the background drive, limit-position inhibition, the
summed inter-limb input). The motor neurons read these through linked variables.

``u`` is the pool's spike trace of the reward-modulated STDP (paper: "Gait Learning Algorithm").
``reward``, ``reward_mean`` (its mean over the last 0.1 s of the session), ``progress`` and
``learning`` (1 once the session has passed t_learning_start) are the trial's learning signals,
set by the session loop and read by the inter-limb synapses.

``limit_margin`` is the distance from a thigh joint limit within which the pool that drives the
joint toward that limit is inhibited (paper: 0.05 rad; the
authors' code in effect used 0: docs/model.md).
"""

from brian2 import second
from brian2.units.allunits import radian

from .base import Interface, NeuronModel, Parameter, ParameterTable, SynapseModel

EQUATIONS = """
n : 1  # spike count of the pool in this step (pool_activity)
du/dt = -u/tau_trace + n/dt : 1  # spike trace of the pool (STDP)
torso_speed : meter/second  # torso speed (set by the session loop)
limit_inhibition : 1  # 1 while the pool drives its joint into a limit (set by the session loop)
I_interlimb : volt/second  # summed inter-limb input (interlimb_synapse)
reward : 1  # reward r of the trial (set by the session loop)
reward_mean : 1  # mean of r over the last reward_window of the session
progress : 1  # training Progress of the trial
learning : 1  # 1 once the session has passed t_learning_start, else 0
"""

PARAMETERS = ParameterTable("pool", [
    Parameter(name="pool_size", value=20, symbol=r"\mathbf{Size}_{\mathrm{pool}}",
              meaning="number of motor neurons in a pool", positive=True),
    Parameter(name="tau_trace", value=0.01*second, symbol=r"\tau_{\mathrm{trace}}",
              meaning="pool spike trace decay time constant (STDP)", positive=True),
    Parameter(name="limit_margin", value=0.05*radian, symbol=r"\mathrm{margin}",
              meaning="inhibition region next to a thigh joint limit (paper 0.05 rad)"),
])

INTERFACE = Interface(
    variables=("n", "torso_speed", "limit_inhibition", "I_interlimb", "reward", "reward_mean",
               "progress", "learning"),
    parameters=("pool_size", "limit_margin"))
"""What the network, the robot bridge and the learning rule read or set on a pool (and the
pool's size and the joint-limit margin, which the network and the bridge read)."""

POOL = NeuronModel(name="pool", equations=EQUATIONS, parameters=PARAMETERS,
                   method="input_then_decay", description=__doc__)

# Every motor neuron reports its spike of this step to its pool.
POOL_ACTIVITY = SynapseModel(
    name="pool_activity",
    model="n_post = int(lastspike_pre == t) : 1 (summed)  # 1 if the neuron spiked in this step",
    parameters=ParameterTable("pool_activity", []),
    description="Spike count of a pool in the current step (sum over its motor neurons).",
)
