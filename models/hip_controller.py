"""PI controller that holds each hip joint at a lateral position (paper supplementary).
``error`` is the hip angle minus its target (+hip_target for left legs, -hip_target for right
legs: outward); ``error_integral`` its time integral since the start of the session.
"""

from brian2 import meter, second
from brian2.units.allunits import radian
from brian2.units.allunits import newton

from .base import ExpressionModel, Interface, Parameter, ParameterTable

EXPRESSION = "-K_P*error - K_I*error_integral"

PARAMETERS = ParameterTable("hip_controller", [
    Parameter(name="K_P", value=30*newton*meter/radian, symbol=r"K_{\mathrm{P}}",
              meaning="proportional gain"),
    Parameter(name="K_I", value=10*newton*meter/(radian*second), symbol=r"K_{\mathrm{I}}",
              meaning="integral gain"),
    Parameter(name="hip_target", value=0.1*radian, symbol=r"\mathrm{pos}^*_{\mathrm{hip}}",
              meaning="lateral (outward) target angle of the hips"),
])

HIP_CONTROLLER = ExpressionModel(
    name="hip_controller", expression=EXPRESSION, inputs=("error", "error_integral"),
    parameters=PARAMETERS, description=__doc__,
)

INTERFACE = Interface(inputs=("error", "error_integral"), parameters=("hip_target",))
"""What the bridge gives (the hip's error and its integral) and reads (the hips' target)."""
