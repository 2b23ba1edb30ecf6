"""Pacemaker stochastic leaky integrate-and-fire (PSLIF) motor neuron.

Paper: "Locomotion Unit" (membrane equation, Ca2+ dynamics, spike probability) and Table I.
The background drive grows with torso speed and carries uniform noise drawn per neuron per step.
Input (background, inter-limb, limit-position inhibition, synaptic) reaches only neurons that are
not refractory; the K+ current acts on every neuron (docs/model.md, "Discretisation").
"""

from brian2 import Hz, meter, ms, mV, second

from .base import Interface, NeuronModel, Parameter, ParameterTable, TraceSource

EQUATIONS = """
dv/dt = (v_motor_rest - v)/tau_motor + int(not_refractory)*I_input - C_K_chan*K_open : volt  # membrane potential
I_input = I_background*(1 + A_random*noise) + I_interlimb - C_limit_position*limit_inhibition : volt/second  # input, reaches only non-refractory neurons
I_background = I_background_0 + k_background_v*torso_speed : volt/second  # background stimulation, grows with torso speed
K_open = 1/(1 + exp(-S_K_chan*(Ca - Thres_Ca))) : 1  # open fraction of the Ca2+-activated K+ channel
dCa/dt = -Ca/tau_Ca : 1  # intracellular [Ca2+], +r_Ca per spike (reset)
noise = 2*rand() - 1 : 1 (constant over dt)  # uniform noise in [-1, 1], drawn per neuron per step
torso_speed : meter/second (linked)  # torso speed, from the neuron's pool
limit_inhibition : 1 (linked)  # 1 while the pool drives its joint into a limit, from the pool
I_interlimb : volt/second (linked)  # summed inter-limb input of the pool, from the pool
x_position : 1 (constant)  # position in the unit cube (intra-pool synapse strength)
y_position : 1 (constant)  # position in the unit cube
z_position : 1 (constant)  # position in the unit cube
"""

# p_spike = Sigmoid((v - v_th)/(S_spike/2)) of the paper, written as the identical
# 0.5*(1 + tanh((v - v_th)/S_spike)), which cannot overflow for strongly inhibited neurons.
THRESHOLD = "rand() < 0.5*(1 + tanh((v - v_motor_th)/S_motor_spike))"
RESET = "v = v_motor_rest; Ca += r_Ca"

# Refractory in the step of the spike and the next refractory_motor (authors' counter: set at the
# spike, checked before it counts down). With the 1 ms step the neuron can fire again after
# refractory + 1 ms; this reading reproduces docs/model.md's figures (period 0.52 s, 27/25 Hz), while
# Brian2's plain refractory=refractory_motor gives a 0.44 s period and 28.6 Hz.
REFRACTORY = "timestep(t - lastspike, dt) <= timestep(refractory_motor, dt)"

PARAMETERS = ParameterTable("motor_neuron", [
    Parameter(name="v_motor_rest", value=0*mV, symbol=r"v_{\mathrm{motor\_rest}}",
              meaning="resting and reset potential"),
    Parameter(name="v_motor_th", value=10*mV, symbol=r"v_{\mathrm{motor\_th}}",
              meaning="threshold potential (spike probability 1/2)"),
    Parameter(name="tau_motor", value=9*ms, symbol=r"\tau_{\mathrm{motor}}",
              meaning="membrane potential decay time constant", positive=True),
    Parameter(name="refractory_motor", value=5*ms, symbol=r"\mathrm{refractory}_{\mathrm{motor}}",
              meaning="refractory period", positive=True),
    Parameter(name="S_motor_spike", value=0.2*mV, symbol=r"S_{\mathrm{motor\_spike}}",
              meaning="transition width of the sigmoid spike probability", positive=True),
    Parameter(name="r_Ca", value=1.0, symbol=r"r_{\mathrm{Ca^{2+}}}",
              meaning="[Ca2+] increment per action potential"),
    Parameter(name="tau_Ca", value=250*ms, symbol=r"\tau_{\mathrm{Ca^{2+}}}",
              meaning="[Ca2+] decay time constant", positive=True),
    Parameter(name="Thres_Ca", value=10.0, symbol=r"\mathrm{Thres}_{\mathrm{Ca^{2+}}}",
              meaning="[Ca2+] at which the K+ channel is half open"),
    Parameter(name="S_K_chan", value=10.0, symbol=r"S_{\mathrm{K\_chan}}",
              meaning="sensitivity of the K+ channel to [Ca2+]"),
    Parameter(name="C_K_chan", value=8000*mV/second, symbol=r"C_{\mathrm{K\_chan}}",
              meaning="potential drop rate with the K+ channel fully open"),
    Parameter(name="C_limit_position", value=400*mV/second, symbol=r"C_{\mathrm{limit\_position}}",
              meaning="limit-position inhibition (potential drop rate)"),
    Parameter(name="I_background_0", value=1380*mV/second, symbol=r"I_{\mathrm{background},0}",
              meaning="background stimulation at zero torso speed"),
    Parameter(name="k_background_v", value=40*mV/meter, symbol=r"k_{\mathrm{background},v}",
              meaning="background stimulation increment per m/s of torso speed"),
    Parameter(name="A_random", value=0.5, symbol=r"\mathrm{A}_{\mathrm{random}}",
              meaning="amplitude of the uniform noise on the background stimulation"),
])

INTERFACE = Interface(variables=("x_position", "y_position", "z_position"), traces={
    "motor_Ca": TraceSource("Ca", 1.0, "a.u.",
                            "motor-neuron Ca2+ (dimensionless, drives the K+ adaptation current)")})
"""What the network sets (positions) or records (``Ca``); its linked variables must be pool
variables of the same name (checked when the network is built)."""

MOTOR_NEURON = NeuronModel(
    name="motor_neuron",
    equations=EQUATIONS,
    parameters=PARAMETERS,
    threshold=THRESHOLD,
    reset=RESET,
    refractory=REFRACTORY,
    method="input_then_decay",
    description=__doc__,
)

# Hz is re-exported for equations edited by users who write rates in Hz.
__all__ = ["MOTOR_NEURON", "EQUATIONS", "PARAMETERS", "Hz"]
