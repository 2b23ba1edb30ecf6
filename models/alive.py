"""Alive indicator of the robot (paper: "Training Session and Training Progress", Table II):
the torso counts as upright while the vertical component of its z axis is at least
``Thres_z_alive`` and its centre is at least ``Thres_height_alive`` above the ground.
``torso_z_up`` is that component (1 when standing level), ``torso_height`` the height of the
torso's centre (m, world z; the ground is the plane z = 0, a slope tilts gravity, not the
ground).

The paper's indicator reads the orientation alone; a robot lying flat on its belly keeps a
level torso, so with the orientation alone it counted as upright (a 1e6 kg payload pressed the
torso to the ground and the run said "upright 100%"). The height bound (SPEC) separates lying
(the torso's centre about 0.04-0.11 m up, legs folded or splayed) from standing and walking
(0.24 m and above in a run of the built-in CPG; 0.35 m at reset); a robot crouched under a
heavy load but still on its legs (about 0.17 m with 30 kg) counts as upright."""

from brian2 import meter

from .base import ExpressionModel, Parameter, ParameterTable

EXPRESSION = "(torso_z_up >= Thres_z_alive) * (torso_height >= Thres_height_alive)"

PARAMETERS = ParameterTable("alive", [
    Parameter(name="Thres_z_alive", value=0.5, symbol=r"\mathrm{Thres}_{z\_\mathrm{ALIVE}}",
              meaning="minimal vertical component of the torso's z axis to count as upright"),
    Parameter(name="Thres_height_alive", value=0.15*meter,
              symbol=r"\mathrm{Thres}_{h\_\mathrm{ALIVE}}",
              meaning="minimal height of the torso's centre above the ground to count as "
                      "upright (SPEC: lying on the ground is not upright)"),
])

ALIVE = ExpressionModel(name="alive", expression=EXPRESSION,
                        inputs=("torso_z_up", "torso_height"), parameters=PARAMETERS,
                        description=__doc__)
