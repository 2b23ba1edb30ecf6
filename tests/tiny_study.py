"""The smallest study the tests run: one condition (with astrocytes), one seed, one run, short
sessions (0.2 s, a fall ends one after 0.1 s)."""


def tiny_study(name: str = "tiny", sessions: int = 2) -> str:
    """The study file's text."""
    return f"""
[study]
name = "{name}"
sessions = {sessions}
seeds = {{ first = 1, count = 1 }}
batch = 1
[base]
L_max = "0.2*second"
L_non_alive = "0.1*second"
[conditions.astro]
astrocytes = true
"""
