"""Inter-limb projection between thigh pools of different limbs, and its learning rule.

Every neuron of pool x reaches every neuron of pool y with one shared weight w[x, y] (the 8x8
table of the paper's Fig. 3a), so the projection acts pool to pool: pool y receives w[x, y] per
spike of pool x. Paper: "Inter-limb Connection", "Gait Learning Algorithm", "Astrocyte
Regulation", Table II.

Learning, once per step after the robot has moved (paper eqs. for Delta w):
  Delta w = Progress * (eta * r_eff * STDP  -  eta_ADO * [ADO_y]) * zeta(w)
with the STDP signal of the pool pair (``n``: spikes of a pool in this step, ``u``: its trace),
r_eff = r - c_average * (mean r over the last 0.1 s), and zeta(w) keeping w in [w_min, w_max].
``astrocyte_regulation`` = 0 removes the adenosine term (the paper's ablation). ``ADO`` is the
adenosine of the target pool's astrocyte. The paper's learning rates are per 1 ms step.

Delays: ``delay_X_Y`` is the delay from limb X's thigh pools to limb Y's, 0 or one step (1 ms).
The paper states none; 1 ms for every pair is the default. The authors' code adds the inter-limb
input inside its loop over the limbs FR, FL, RR, RL, so a lower-index limb reaches a higher-index
one in the same step (docs/model.md): ``models/variants/interlimb_authors_delays.toml`` sets those six
pairs to 0 ms. The limbs then integrate one after another within a step (see
``astrocpg.network.delays``).
"""

from brian2 import mV, ms, second

from .base import Interface, Parameter, ParameterTable, SynapseModel

MODEL = """
w : volt  # inter-limb weight w[x, y], learnt (ON_STEP)
dSTDP/dt = -STDP/tau_STDP + (n_post*u_pre - eta_negative_relative*n_pre*u_post)/dt : 1 (clock-driven)  # STDP signal of the pool pair
I_interlimb_post = w*n_pre/dt : volt/second (summed)  # input to the target pool, summed over source pools
zeta = (w_max - w)*(w - w_min)/(w_max - w_min)**2 : 1  # weight bound, 0 at w_min and w_max
r_eff = reward_post - c_average*reward_mean_post : 1  # reward minus c_average times its recent mean
ADO : 1 (linked)  # [ADO] of the target pool's astrocyte
astrocyte_index : integer (constant)  # index of the target pool's astrocyte
"""

ON_STEP = (
    "w = clip(w + learning_post*progress_post*(eta*r_eff*STDP"
    " - astrocyte_regulation*eta_ADO*ADO)*zeta, w_min, w_max)"
)

LIMBS = ("FR", "FL", "RR", "RL")
# The authors' loop over the limbs in this order: 0 ms to a later limb, 1 ms to an earlier one.
_AUTHORS = {(a, b): "0 ms" if LIMBS.index(a) < LIMBS.index(b) else "1 ms"
            for a in LIMBS for b in LIMBS if a != b}

PARAMETERS = ParameterTable("interlimb_synapse", [
    Parameter(name="w_min", value=-0.05*mV, symbol=r"w_{\mathrm{min}}",
              meaning="lower bound of an inter-limb weight"),
    Parameter(name="w_max", value=0.05*mV, symbol=r"w_{\mathrm{max}}",
              meaning="upper bound of an inter-limb weight"),
    Parameter(name="tau_STDP", value=2*second, symbol=r"\tau_{\mathrm{STDP}}",
              meaning="STDP signal decay time constant", positive=True),
    Parameter(name="eta_negative_relative", value=0.3,
              symbol=r"\eta_{\mathrm{negative\_relative}}",
              meaning="relative learning rate of the negative (pre-after-post) STDP term"),
    Parameter(name="eta", value=5e-10*mV, symbol=r"\eta",
              meaning="learning rate (weight change per step per unit of r_eff*STDP)"),
    Parameter(name="c_average", value=0.5, symbol=r"c_{\mathrm{average}}",
              meaning="weight of the 0.1 s mean reward subtracted from the reward"),
    Parameter(name="eta_ADO", value=1.8e-5*mV, symbol=r"\eta_{\mathrm{ADO}}",
              meaning="adenosine inhibition efficacy (weight change per step per unit [ADO])"),
    Parameter(name="astrocyte_regulation", value=1.0, symbol="-",
              meaning="1: adenosine depresses the weights into its pool; 0: the paper's ablation"),
] + [
    Parameter(name=f"delay_{source}_{target}", value=1*ms,
              symbol=rf"d_{{\mathrm{{{source}}}\to\mathrm{{{target}}}}}",
              meaning=f"delay from the {source} to the {target} thigh pools "
                      f"(0 or one step; authors' code: {_AUTHORS[source, target]})")
    for source in LIMBS for target in LIMBS if source != target
])

INTERFACE = Interface(variables=("w",),
                      parameters=("w_min", "w_max", "eta", "eta_ADO", "astrocyte_regulation"),
                      optional=tuple(f"delay_{source}_{target}" for source in LIMBS
                                     for target in LIMBS if source != target))
"""What the network reads or sets: the weight ``w`` (tables in and out); the bounds the
reports draw, the learning rates ``astrocpg power`` sets to zero, the ablation's switch; and,
optional, the ``delay_X_Y`` parameters (a pair without one: one step) that
:func:`astrocpg.network.delays.delay_steps` reads."""

INTERLIMB_SYNAPSE = SynapseModel(
    name="interlimb_synapse", model=MODEL, on_step=ON_STEP, parameters=PARAMETERS,
    method="input_then_decay", description=__doc__,
)
