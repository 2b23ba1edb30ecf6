"""Inter-limb projection between thigh pools of different limbs. Every neuron of pool x reaches
every neuron of pool y with one shared weight w[x, y] (the 8x8 table of the paper's Fig. 3a), so
the projection acts pool to pool: pool y receives w[x, y] per spike of pool x.
Paper: "Inter-limb Connection" and Table II (weight range). The learning rule is separate.
"""

from brian2 import mV

from .base import Parameter, ParameterTable, SynapseModel

MODEL = """
w : volt
I_interlimb_post = w*n_pre/dt : volt/second (summed)
"""

PARAMETERS = ParameterTable("interlimb_synapse", [
    Parameter(name="w_min", value=-0.05*mV, symbol=r"w_{\mathrm{min}}",
              meaning="lower bound of an inter-limb weight"),
    Parameter(name="w_max", value=0.05*mV, symbol=r"w_{\mathrm{max}}",
              meaning="upper bound of an inter-limb weight"),
])

INTERLIMB_SYNAPSE = SynapseModel(
    name="interlimb_synapse", model=MODEL, parameters=PARAMETERS, description=__doc__,
)
