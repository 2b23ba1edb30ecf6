"""Excitatory synapses among the 20 motor neurons of a pool (all pairs, no self-synapse), with a
weight that decays with the distance between the neurons' positions in the unit cube.
Paper: "Locomotion Unit", intra-pool weight equation, and Table I.
"""

from brian2 import mV

from .base import Parameter, ParameterTable, SynapseModel

MODEL = "w : volt (constant)  # synapse strength, from the neurons' distance (WEIGHT)"
ON_PRE = "v_post += w*int(not_refractory_post)"
WEIGHT = (
    "w_0dist*exp(-c_dist*sqrt((x_position_pre - x_position_post)**2"
    " + (y_position_pre - y_position_post)**2 + (z_position_pre - z_position_post)**2))"
)

PARAMETERS = ParameterTable("intra_pool_synapse", [
    Parameter(name="w_0dist", value=4*mV, symbol=r"w_{0\mathrm{dist}}",
              meaning="intra-pool synapse strength at zero distance"),
    Parameter(name="c_dist", value=0.3, symbol=r"c_{\mathrm{dist}}",
              meaning="spatial decay coefficient of the synapse strength (per unit distance)"),
])

INTRA_POOL_SYNAPSE = SynapseModel(
    name="intra_pool_synapse", model=MODEL, on_pre=ON_PRE, weight=WEIGHT,
    parameters=PARAMETERS, description=__doc__,
)
