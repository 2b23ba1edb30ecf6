"""Li-Rinzel astrocyte with 2-AG input and adenosine release (one per thigh motor-neuron pool).

Paper: "Astrocyte Regulation" and Table II; the Li-Rinzel equations and constants are not in the
paper: docs/model.md, "Li-Rinzel astrocyte" (time in s, concentrations in uM). 2-AG is
released by the astrocyte's own pool
(``n_pool`` spikes in a step add ``r_AG`` each). Adenosine is released (``+r_ADO``) when
[Ca2+] exceeds its threshold and the release refractory period has passed, then decays.
"""

from brian2 import second, umolar

from .base import Interface, NeuronModel, Parameter, ParameterTable, TraceSource

EQUATIONS = """
dCa/dt = J_chan + J_leak - J_pump : mmolar  # cytosolic [Ca2+]
J_chan = r_C*(m_inf*n_inf*h)**3*(C0 - (1 + c1)*Ca) : mmolar/second  # Ca2+ release from the ER through IP3 receptors
J_leak = r_L*(C0 - (1 + c1)*Ca) : mmolar/second  # Ca2+ leak from the ER
J_pump = v_ER*Ca**2/(k_ER**2 + Ca**2) : mmolar/second  # Ca2+ uptake into the ER by SERCA pumps
m_inf = IP3/(IP3 + d1) : 1  # IP3 activation of the IP3 receptor (steady state)
n_inf = Ca/(Ca + d5) : 1  # Ca2+ activation of the IP3 receptor (steady state)
dh/dt = (h_inf - h)/tau_h : 1  # fraction of IP3 receptors not inactivated by Ca2+
h_inf = Q2/(Q2 + Ca) : 1  # steady state of h
tau_h = 1/(a2*(Q2 + Ca)) : second  # time constant of h
Q2 = d2*(IP3 + d1)/(IP3 + d3) : mmolar  # apparent dissociation constant of Ca2+ inactivation
dIP3/dt = (IP3_star - IP3)/tau_IP3 + r_IP3*AG : mmolar  # [IP3], produced by 2-AG
dAG/dt = -AG/tau_AG + r_AG*n_pool/dt : 1  # [2-AG], released by the pool's spikes
dADO/dt = -ADO/tau_ADO : 1  # [ADO], +r_ADO per release (reset)
n_pool : 1 (linked)  # spikes of the astrocyte's pool in this step, from the pool
"""

# Adenosine release: the "spike" of an astrocyte.
THRESHOLD = "Ca > Thres_Ca_ADO"
RESET = "ADO += r_ADO"

INITIAL_STATE = {"Ca": 0.071006*umolar, "h": 0.7791, "IP3": 0.16*umolar, "AG": 0.0, "ADO": 0.0}

PARAMETERS = ParameterTable("astrocyte", [
    Parameter(name="IP3_star", value=0.16*umolar, symbol=r"IP_3^*",
              meaning="resting IP3 concentration (docs/model.md)"),
    Parameter(name="tau_IP3", value=7*second, symbol=r"\tau_{IP_3}",
              meaning="IP3 decay time constant (docs/model.md)", positive=True),
    Parameter(name="r_IP3", value=0.5*umolar/second, symbol=r"r_{IP_3}",
              meaning="IP3 production per unit of 2-AG (docs/model.md)"),
    Parameter(name="r_C", value=6/second, symbol=r"r_C",
              meaning="maximal IP3R channel flux rate (docs/model.md)"),
    Parameter(name="r_L", value=0.11/second, symbol=r"r_L", meaning="ER leak rate (docs/model.md)"),
    Parameter(name="C0", value=2*umolar, symbol=r"C_0",
              meaning="total cell free Ca2+ per cytosolic volume (docs/model.md)"),
    Parameter(name="c1", value=0.185, symbol=r"c_1",
              meaning="ER to cytosol volume ratio (docs/model.md)"),
    Parameter(name="v_ER", value=0.8*umolar/second, symbol=r"v_{ER}",
              meaning="maximal SERCA pump rate (docs/model.md)"),
    Parameter(name="k_ER", value=0.1*umolar, symbol=r"k_{ER}",
              meaning="SERCA pump half-activation (docs/model.md)", positive=True),
    Parameter(name="a2", value=0.2/(umolar*second), symbol=r"a_2",
              meaning="IP3R Ca2+ inactivation binding rate (docs/model.md)", positive=True),
    Parameter(name="d1", value=0.13*umolar, symbol=r"d_1",
              meaning="IP3 dissociation constant (docs/model.md)", positive=True),
    Parameter(name="d2", value=1.049*umolar, symbol=r"d_2",
              meaning="Ca2+ inactivation dissociation constant (docs/model.md)", positive=True),
    Parameter(name="d3", value=0.9434*umolar, symbol=r"d_3",
              meaning="IP3 dissociation constant (docs/model.md)", positive=True),
    Parameter(name="d5", value=0.08234*umolar, symbol=r"d_5",
              meaning="Ca2+ activation dissociation constant (docs/model.md)", positive=True),
    Parameter(name="r_AG", value=1e-3, symbol=r"r_{\mathrm{AG}}",
              meaning="2-AG released per motor-neuron spike of the pool"),
    Parameter(name="tau_AG", value=1*second, symbol=r"\tau_{\mathrm{AG}}",
              meaning="[2-AG] decay time constant", positive=True),
    Parameter(name="Thres_Ca_ADO", value=0.3*umolar, symbol=r"\mathrm{Thres\_Ca}_{\mathrm{ADO}}",
              meaning="[Ca2+] threshold for adenosine release"),
    Parameter(name="r_ADO", value=0.01, symbol=r"r_{\mathrm{ADO}}",
              meaning="adenosine released per release event"),
    Parameter(name="tau_ADO", value=1*second, symbol=r"\tau_{\mathrm{ADO}}",
              meaning="[ADO] decay time constant (the paper's table calls it tau_AG: a typo)",
              positive=True),
    Parameter(name="refractory_ADO", value=0.3*second, symbol=r"\mathrm{refractory}_{\mathrm{ADO}}",
              meaning="adenosine release refractory period", positive=True),
])

# concentrations are stored in uM (Brian2 keeps mol/m^3 = mM)
INTERFACE = Interface(variables=("n_pool", "ADO"), traces={
    "astrocyte_Ca": TraceSource("Ca", 1e3, "uM", "astrocyte cytosolic Ca2+ (Li-Rinzel)"),
    "astrocyte_IP3": TraceSource("IP3", 1e3, "uM", "astrocyte IP3"),
    "astrocyte_AG": TraceSource("AG", 1.0, "a.u.",
                                "2-AG (endocannabinoid) at the astrocyte (dimensionless)"),
    "astrocyte_ADO": TraceSource("ADO", 1.0, "a.u.",
                                 "adenosine released by the astrocyte (dimensionless)"),
})
"""What the network reads or sets: ``n_pool`` (linked to the pool's spike count), ``ADO``
(linked into the inter-limb synapse); and what it records: ``Ca``, ``IP3``, ``AG``, ``ADO``."""

ASTROCYTE = NeuronModel(
    name="astrocyte",
    equations=EQUATIONS,
    parameters=PARAMETERS,
    threshold=THRESHOLD,
    reset=RESET,
    refractory="refractory_ADO",
    method="euler",
    initial_values=INITIAL_STATE,
    description=__doc__,
)
