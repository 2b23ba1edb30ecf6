"""Alive indicator of the robot (paper: "Training Session and Training Progress", Table II):
the torso counts as upright while the vertical component of its z axis is at least
``Thres_z_alive``. ``torso_z_up`` is that component (1 when standing level)."""

from .base import ExpressionModel, Parameter, ParameterTable

EXPRESSION = "torso_z_up >= Thres_z_alive"

PARAMETERS = ParameterTable("alive", [
    Parameter(name="Thres_z_alive", value=0.5, symbol=r"\mathrm{Thres}_{z\_\mathrm{ALIVE}}",
              meaning="minimal vertical component of the torso's z axis to count as upright"),
])

ALIVE = ExpressionModel(name="alive", expression=EXPRESSION, inputs=("torso_z_up",),
                        parameters=PARAMETERS, description=__doc__)
