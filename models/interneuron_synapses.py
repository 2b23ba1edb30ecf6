"""The two projections of a V1/V2b or IIN interneuron: every spike of its source pool excites it,
and each of its spikes inhibits every neuron of its target pool. Paper: "Locomotion Unit" and
Table I; the table of which interneuron links which pools is docs/model.md.
"""

from brian2 import mV

from .base import Parameter, ParameterTable, SynapseModel

POOL_TO_INTERNEURON = SynapseModel(
    name="pool_to_interneuron",
    model="",
    on_pre="v_post += w_motor_to_interneuron*int(not_refractory_post)",
    parameters=ParameterTable("pool_to_interneuron", [
        Parameter(name="w_motor_to_interneuron", value=2*mV,
                  symbol=r"w_{\mathrm{motor}\rightarrow\mathrm{V1/V2b}}",
                  meaning="synapse strength from a motor neuron to its interneuron"),
    ]),
    description="Excitation of an interneuron by each spike of its source pool.",
)

INTERNEURON_TO_POOL = SynapseModel(
    name="interneuron_to_pool",
    model="",
    on_pre="v_post += w_interneuron_to_motor*int(not_refractory_post)",
    parameters=ParameterTable("interneuron_to_pool", [
        Parameter(name="w_interneuron_to_motor", value=-50*mV,
                  symbol=r"w_{\mathrm{V1/V2b}\rightarrow\mathrm{motor}}",
                  meaning="synapse strength from an interneuron to each neuron of its target pool"),
    ]),
    description="Inhibition of every neuron of the target pool by each interneuron spike.",
)
