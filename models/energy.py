"""Power estimates of the controller (paper: "Power Consumption Benefits"; docs/model.md).

SNN: one accumulate (ADD) per synaptic event. ``ops_*`` are the synaptic events caused by one
spike of each population (counted on the built network), ``f_*`` the total firing frequencies
of the populations (Hz, all neurons together); ``f_limit`` is the rate of limit-position
inhibition events, each reaching one pool. RL: one multiply and one add per weight of the
policy network of Fu et al. 2021 (42 inputs, two hidden layers of 128, 12 outputs) at its
control frequency. Energies per operation: 45 nm CMOS (Han et al. 2015).
"""

from brian2 import Hz
from brian2.units.allunits import joule

from .base import ExpressionModel, Interface, Parameter, ParameterTable

pJ = 1e-12 * joule

SNN_EXPRESSION = (
    "epsilon_ADD*(ops_inhibitory*f_inhibitory + ops_calf*f_calf + ops_thigh*f_thigh"
    " + ops_limit*f_limit)"
)

SNN_POWER = ExpressionModel(
    name="snn_power", expression=SNN_EXPRESSION,
    inputs=("ops_inhibitory", "ops_calf", "ops_thigh", "ops_limit",
            "f_inhibitory", "f_calf", "f_thigh", "f_limit"),
    parameters=ParameterTable("snn_power", [
        Parameter(name="epsilon_ADD", value=0.9*pJ, symbol=r"\epsilon_{\mathrm{ADD}}",
                  meaning="energy of one addition, 45 nm CMOS (paper)", positive=True),
    ]),
    description=__doc__,
)

RL_EXPRESSION = (
    "f_control*(d_state*d_hidden + d_hidden*d_hidden + d_hidden*d_action)"
    "*(epsilon_MULT + epsilon_ADD)"
)

RL_POWER = ExpressionModel(
    name="rl_power", expression=RL_EXPRESSION, inputs=("epsilon_ADD",),
    parameters=ParameterTable("rl_power", [
        Parameter(name="f_control", value=100*Hz, symbol=r"f_{\mathrm{control}}",
                  meaning="control frequency of the RL policy (paper, Fu et al. 2021)",
                  positive=True),
        Parameter(name="d_state", value=42, symbol=r"d_{\mathrm{state}}",
                  meaning="input dimension of the policy network (paper)", positive=True),
        Parameter(name="d_hidden", value=128, symbol=r"d_{\mathrm{hidden}}",
                  meaning="neurons per hidden layer (paper)", positive=True),
        Parameter(name="d_action", value=12, symbol=r"d_{\mathrm{action}}",
                  meaning="output dimension: the 12 joint targets (paper)", positive=True),
        Parameter(name="epsilon_MULT", value=3.7*pJ, symbol=r"\epsilon_{\mathrm{MULT}}",
                  meaning="energy of one multiplication, 45 nm CMOS (paper)", positive=True),
    ]),
    description="RL policy power: one MULT and one ADD per weight per inference, "
                "epsilon_ADD from snn_power.",
)

SNN_POWER_INTERFACE = Interface(inputs=SNN_POWER.inputs, parameters=("epsilon_ADD",))
"""What ``astrocpg power`` gives (events and rates) and reads (``epsilon_ADD``, which it gives
the RL policy's model)."""

RL_POWER_INTERFACE = Interface(inputs=RL_POWER.inputs)
"""What ``astrocpg power`` gives the RL policy's model."""
