"""What can be recorded from a built CPG: spikes per population, and traces of state variables
(with the unit they are stored in)."""

POPULATIONS = ("motor", "interneuron", "astrocyte")  # astrocyte "spikes": adenosine releases

TRACES = ("motor_Ca", "astrocyte_Ca", "astrocyte_IP3", "astrocyte_AG", "astrocyte_ADO")

# trace -> (group, variable, factor from Brian2's SI value to the stored unit, stored unit)
TRACE_SOURCES = {
    "motor_Ca": ("motor", "Ca", 1.0, "a.u."),
    # concentrations in uM (Brian2 keeps mol/m^3 = mM internally)
    "astrocyte_Ca": ("astrocyte", "Ca", 1e3, "uM"),
    "astrocyte_IP3": ("astrocyte", "IP3", 1e3, "uM"),
    "astrocyte_AG": ("astrocyte", "AG", 1.0, "a.u."),
    "astrocyte_ADO": ("astrocyte", "ADO", 1.0, "a.u."),
}
