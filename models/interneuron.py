"""Stochastic leaky integrate-and-fire (SLIF) interneuron: V1/V2b and IIN share it.

Paper: "Locomotion Unit" and Table I (V1/V2b); the IINs "share the same model hyperparameters
with the V1/V2b interneurons". No background drive: they fire only when their pool bursts.
"""

from brian2 import ms, mV

from .base import NeuronModel, Parameter, ParameterTable

EQUATIONS = """
dv/dt = (v_interneuron_rest - v)/tau_interneuron : volt  # membrane potential
"""

# p_spike = Sigmoid((v - v_th)/(S_spike/2)) of the paper, written as the identical
# 0.5*(1 + tanh((v - v_th)/S_spike)), which cannot overflow for strongly inhibited neurons.
THRESHOLD = "rand() < 0.5*(1 + tanh((v - v_interneuron_th)/S_interneuron_spike))"
RESET = "v = v_interneuron_rest"

# Refractory in the step of the spike and the next refractory_interneuron steps (the authors'
# counter: set at the spike, checked before it counts down), read as the motor neuron's is
# (models/motor_neuron.py). With Table I's 3 ms and the 1 ms step an interneuron can fire again
# 4 ms after a spike (at most 250 Hz), where Brian2's plain refractory=refractory_interneuron
# would allow 3 ms (333 Hz). One rule for both neuron kinds; docs/model.md's figures (among them
# the six interneurons of a unit, 160 Hz together) were measured with it.
REFRACTORY = "timestep(t - lastspike, dt) <= timestep(refractory_interneuron, dt)"

PARAMETERS = ParameterTable("interneuron", [
    Parameter(name="v_interneuron_rest", value=0*mV, symbol=r"v_{\mathrm{V1/V2b\_rest}}",
              meaning="resting and reset potential"),
    Parameter(name="v_interneuron_th", value=10*mV, symbol=r"v_{\mathrm{V1/V2b\_th}}",
              meaning="threshold potential (spike probability 1/2)"),
    Parameter(name="tau_interneuron", value=9*ms, symbol=r"\tau_{\mathrm{V1/V2b}}",
              meaning="membrane potential decay time constant", positive=True),
    Parameter(name="refractory_interneuron", value=3*ms,
              symbol=r"\mathrm{refractory}_{\mathrm{V1/V2b}}", meaning="refractory period",
              positive=True),
    Parameter(name="S_interneuron_spike", value=0.2*mV, symbol=r"S_{\mathrm{V1/V2b\_spike}}",
              meaning="transition width of the sigmoid spike probability", positive=True),
])

INTERNEURON = NeuronModel(
    name="interneuron",
    equations=EQUATIONS,
    parameters=PARAMETERS,
    threshold=THRESHOLD,
    reset=RESET,
    refractory=REFRACTORY,
    method="input_then_decay",
    description=__doc__,
)
