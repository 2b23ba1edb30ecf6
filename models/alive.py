"""Alive indicator of the robot (paper: "Training Session and Training Progress", Table II):
the torso counts as upright while the vertical component of its z axis is at least
``Thres_z_alive``. ``torso_z_up`` is that component (1 when standing level).

The paper's indicator reads the orientation alone, so a robot pressed flat onto its belly with
a level torso still counts as alive. A model file may also read ``torso_height``, the height
of the torso's centre above the ground plane (m); ``models/variants/alive_height.toml`` is the
paper's indicator with a height bound added."""

from .base import ExpressionModel, Interface, Parameter, ParameterTable

EXPRESSION = "torso_z_up >= Thres_z_alive"

PARAMETERS = ParameterTable("alive", [
    Parameter(name="Thres_z_alive", value=0.5, symbol=r"\mathrm{Thres}_{z\_\mathrm{ALIVE}}",
              meaning="minimal vertical component of the torso's z axis to count as upright"),
])

SENSES: tuple[str, ...] = ("torso_z_up", "torso_height")
"""What the robot offers an alive model: ``torso_z_up`` (1) and ``torso_height`` (m). A model
file may read any of them; the built-in indicator reads the first."""

INTERFACE = Interface(inputs=SENSES)
"""The senses the robot gives an alive model (it reads no alive parameter by name)."""

ALIVE = ExpressionModel(name="alive", expression=EXPRESSION, inputs=("torso_z_up",),
                        parameters=PARAMETERS, description=__doc__)
