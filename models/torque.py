"""Motor torque trace of a joint (thigh or calf): every extensor spike adds +I_joint, every
flexor spike -I_joint, and the trace decays with tau_h. Paper: "Locomotion Unit", torque
equation, and Table I. ``n_extensor``/``n_flexor`` are the pools' spike counts in this step.
"""

from brian2 import meter, second
from brian2.units.allunits import newton

from .base import Interface, NeuronModel, Parameter, ParameterTable

EQUATIONS = """
dh/dt = -h/tau_h + I_joint*(n_extensor - n_flexor)/dt : newton*meter  # motor torque of the joint
I_joint : newton*meter (constant)  # torque per spike: I_thigh or I_calf
n_extensor : 1 (linked)  # spikes of the extensor pool in this step
n_flexor : 1 (linked)  # spikes of the flexor pool in this step
"""

PARAMETERS = ParameterTable("torque", [
    Parameter(name="tau_h", value=0.1*second, symbol=r"\tau_h",
              meaning="motor torque trace decay time constant", positive=True),
    Parameter(name="I_thigh", value=0.7*newton*meter, symbol=r"I_{\mathrm{thigh}}",
              meaning="torque increment per spike, thigh joint"),
    Parameter(name="I_calf", value=1.1*newton*meter, symbol=r"I_{\mathrm{calf}}",
              meaning="torque increment per spike, calf joint"),
])

INTERFACE = Interface(variables=("h", "I_joint", "n_extensor", "n_flexor"),
                      parameters=("I_thigh", "I_calf"))
"""What the network sets (``I_joint``, the linked spike counts) or reads (``h``, the torque;
``I_thigh``/``I_calf``, the torque per spike it gives each joint's ``I_joint``)."""

TORQUE = NeuronModel(
    name="torque",
    equations=EQUATIONS,
    parameters=PARAMETERS,
    method="input_then_decay",
    description=__doc__,
)
