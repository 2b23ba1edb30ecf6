"""The world the robot walks in: ground, gravity, load and disturbances (beyond the paper: its
"future work" on terrain, and robustness tests). The defaults are the paper's world, a flat
plane with the A1's own ground friction, no load and no disturbance; with them the robot's
trajectory is exactly the one without this table.

slope tilts gravity in the robot's x-z plane instead of tilting the ground, so that the torso's
height, the reward's forward velocity and the alive test all stay in the frame of the slope.
The heightfield is Gaussian-filtered white noise of RMS ``terrain_height`` and correlation length
``terrain_length``, drawn from ``terrain_seed`` (the same field for every trial and session). The
push acts on the torso, sideways (+y, to the robot's left), once per session (in ``run``: once,
from the run's start), from ``push_time`` for ``push_duration``. ``torque_noise`` multiplies
every motor's torque by (1 + torque_noise * N(0, 1)), drawn per motor and step from the run's
seed.
"""

from brian2 import kilogram, meter, second
from brian2.units.allunits import newton
from brian2.units.allunits import radian

from .base import Interface, Parameter, ParameterTable, WorldModel

PARAMETERS = ParameterTable("world", [
    Parameter(name="slope", value=0.0*radian, symbol=r"\alpha",
              meaning="ground slope, positive uphill along +x (the robot's forward direction)"),
    Parameter(name="terrain_height", value=0.0*meter, symbol=r"\sigma_h",
              meaning="RMS height of a rough-terrain heightfield (0: the flat plane)"),
    Parameter(name="terrain_length", value=0.5*meter, symbol=r"\ell_h",
              meaning="correlation length of the heightfield's bumps", positive=True),
    Parameter(name="terrain_seed", value=0, symbol="-",
              meaning="seed of the heightfield (an integer; the same field for every trial)"),
    Parameter(name="friction", value=0.6, symbol=r"\mu",
              meaning="sliding friction coefficient of the ground (default: the A1 model's 0.6)",
              positive=True),
    Parameter(name="payload", value=0.0*kilogram, symbol=r"m_{\mathrm{payload}}",
              meaning="mass added to the torso at its centre of mass"),
    Parameter(name="push_force", value=0.0*newton, symbol=r"F_{\mathrm{push}}",
              meaning="lateral force on the torso during a push (+y, to the robot's left)"),
    Parameter(name="push_time", value=5.0*second, symbol=r"t_{\mathrm{push}}",
              meaning="start of the push, from the start of each session"),
    Parameter(name="push_duration", value=0.1*second, symbol=r"T_{\mathrm{push}}",
              meaning="duration of the push", positive=True),
    Parameter(name="torque_noise", value=0.0, symbol=r"\sigma_\tau",
              meaning="relative Gaussian noise on every motor torque, drawn per step"),
])

INTERFACE = Interface(parameters=tuple(PARAMETERS))
"""Every world parameter is read by the coupling (``astrocpg.coupling.world``)."""

WORLD = WorldModel(name="world", parameters=PARAMETERS, description=__doc__)

# The generated heightfield's extent and grid (m): long enough for a 10 s session at twice the
# paper's speed, flat within TERRAIN_FLAT_RADIUS of the start (the robot starts on level ground).
TERRAIN_X = (-5.0, 35.0)
TERRAIN_Y = (-5.0, 5.0)
TERRAIN_RESOLUTION = 0.05
TERRAIN_THICKNESS = 0.1
TERRAIN_FLAT_RADIUS = 0.5
