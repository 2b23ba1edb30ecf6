"""Training sessions (paper: "Training Session and Training Progress", Table II): a session ends
at L_max or when the robot has been non-upright for L_non_alive (steps need not be consecutive).
Before each session, from the mean length of the last ``session_memory`` sessions (sessions not
yet run count as 0):
  Progress = Sigmoid(-(mean_length/L_max - 0.9)/0.02)
  t_learning_start = Clip(mean_length - 1 s, 0, 2 s)
"""

from brian2 import second

from .base import ExpressionModel, Interface, Parameter, ParameterTable

PROGRESS = ExpressionModel(
    name="progress",
    expression="1/(1 + exp((mean_length/L_max - progress_centre)/progress_width))",
    inputs=("mean_length",),
    parameters=ParameterTable("progress", [
        Parameter(name="L_max", value=10*second, symbol=r"L_{\mathrm{max}}",
                  meaning="maximum session length", positive=True),
        Parameter(name="L_non_alive", value=0.5*second,
                  symbol=r"L_{\mathrm{non\_alive\_threshold}}",
                  meaning="non-upright time that ends a session", positive=True),
        Parameter(name="session_memory", value=10, symbol="10",
                  meaning="number of previous sessions whose mean length sets Progress",
                  positive=True),
        Parameter(name="progress_centre", value=0.9, symbol="0.9",
                  meaning="relative mean session length at which Progress = 1/2"),
        Parameter(name="progress_width", value=0.02, symbol="0.02",
                  meaning="width of the Progress sigmoid", positive=True),
    ]),
    description="Training progress: learning slows as sessions approach L_max.",
)

LEARNING_START = ExpressionModel(
    name="learning_start",
    expression="clip(mean_length - learning_start_offset, 0, learning_start_max)",
    inputs=("mean_length",),
    parameters=ParameterTable("learning_start", [
        Parameter(name="learning_start_offset", value=1*second, symbol="1 s",
                  meaning="t_learning_start = mean length minus this"),
        Parameter(name="learning_start_max", value=2*second, symbol="2 s",
                  meaning="latest start of learning within a session"),
    ]),
    description="Start of the learning period within a session.",
)

PROGRESS_INTERFACE = Interface(inputs=("mean_length",),
                               parameters=("L_max", "L_non_alive", "session_memory"))
"""What the session loop gives (the mean session length) and reads (the session bounds and
how many sessions it remembers)."""

LEARNING_START_INTERFACE = Interface(inputs=("mean_length",))
"""What the session loop gives a learning-start model."""
