"""Reward of the gait search (paper: "Gait Learning Algorithm", Table II). The angular-rate
coefficients are negative, so the angular rates are penalties
(docs/model.md settles the double minus).
``vel_x``: torso velocity along world x; ``omega_*``: gyro rates in the torso frame.
"""

from brian2 import meter, second
from brian2.units.allunits import radian

from .base import ExpressionModel, Interface, Parameter, ParameterTable

EXPRESSION = (
    "alpha_vel_x*vel_x + alpha_omega_roll*abs(omega_roll)"
    " + alpha_omega_pitch*abs(omega_pitch) + alpha_omega_yaw*abs(omega_yaw)"
)

PARAMETERS = ParameterTable("reward", [
    Parameter(name="alpha_vel_x", value=1*second/meter, symbol=r"\alpha_{\mathrm{vel}_x}",
              meaning="reward per m/s of forward speed"),
    Parameter(name="alpha_omega_roll", value=-0.1*second/radian,
              symbol=r"\alpha_{\omega_{\mathrm{roll}}}", meaning="roll-rate coefficient"),
    Parameter(name="alpha_omega_pitch", value=-0.1*second/radian,
              symbol=r"\alpha_{\omega_{\mathrm{pitch}}}", meaning="pitch-rate coefficient"),
    Parameter(name="alpha_omega_yaw", value=-0.1*second/radian,
              symbol=r"\alpha_{\omega_{\mathrm{yaw}}}", meaning="yaw-rate coefficient"),
    Parameter(name="reward_window", value=0.1*second, symbol=r"0.1\,\mathrm{s}",
              meaning="length of the sliding mean of r subtracted in r_eff (within the session)",
              positive=True),
])

REWARD = ExpressionModel(
    name="reward", expression=EXPRESSION,
    inputs=("vel_x", "omega_roll", "omega_pitch", "omega_yaw"),
    parameters=PARAMETERS, description=__doc__,
)

INTERFACE = Interface(inputs=("vel_x", "omega_roll", "omega_pitch", "omega_yaw"),
                      parameters=("reward_window",))
"""What the bridge gives (the torso's velocities) and the session loop reads (the window of the
reward's sliding mean)."""
