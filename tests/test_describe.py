"""astrocpg describe: equations rendered by sympy with the paper's symbols, parameter tables."""

from __future__ import annotations

import re
from pathlib import Path

from astrocpg.models import DEFAULT_MODELS
from astrocpg.studies.cli import main
from astrocpg.studies.figures.describe import describe


def test_every_model_is_described_with_its_parameters() -> None:
    text = describe(fmt="markdown")
    for name, model in DEFAULT_MODELS.items():
        assert f"## {name}" in text
        for pname in model.parameters:
            assert f"| `{pname}` |" in text
    plain = describe()
    for name, model in DEFAULT_MODELS.items():
        assert f"\n{name}\n{'=' * len(name)}\n" in "\n" + plain
        for pname in model.parameters:
            assert re.search(rf"^  {re.escape(pname)}\s", plain, re.M), pname


def test_equations_use_the_papers_symbols() -> None:
    text = describe("astrocyte", "markdown")
    # dIP3/dt = (IP3* - IP3)/tau_IP3 + r_IP3 * AG, with the table's symbols
    assert r"\frac{dIP_{3}}{dt}" in text and r"\tau_{IP_3}" in text and "IP_3^*" in text
    latex = describe("motor_neuron", "latex")
    assert r"\begin{align*}" in latex and r"\tau_{\mathrm{motor}}" in latex
    assert "_placeholder" not in describe("motor_neuron", "markdown")


def test_describe_shows_an_edited_model(tmp_path: Path, capsys) -> None:
    from astrocpg.models.interneuron import EQUATIONS
    f = tmp_path / "in.txt"
    f.write_text(EQUATIONS.replace("dv/dt = ", "dv/dt = 0.5*"))
    assert main(["describe", "interneuron", "--equations", f"interneuron={f}"]) == 0
    assert "dv/dt = 0.5*" in capsys.readouterr().out
    assert main(["describe", "no_such_model"]) == 2
    assert main(["describe", "astrocyte", "--format", "html"]) == 2


def test_describe_a_parameter_by_its_name(capsys) -> None:
    """``astrocpg describe tau_motor``: the model that declares it, its value with units and
    every statement that uses it; a misspelt name: one line with the closest name."""
    assert main(["describe", "tau_motor", "--format", "markdown"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("## tau_motor: a parameter of motor_neuron")
    assert "| 9. ms |" in text and r"\tau_{\mathrm{motor}}" in text
    assert "- motor_neuron (equation):" in text and "/tau_motor" in text
    assert "## motor_neuron" not in text  # the parameter, not the whole model
    # the API, with an override: the value described is the one given
    import astrocpg
    assert "| 12. ms |" in astrocpg.describe("tau_motor", "markdown",
                                             overrides=["tau_motor=12*ms"])
    latex = describe("tau_motor", "latex")
    assert r"\subsection*{tau\_motor: a parameter of motor\_neuron}" in latex
    assert r"\begin{align*}" in latex
    assert main(["describe", "tau_motr"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "did you mean tau_motor?" in err, err


def test_plain_text_by_default_reads_in_a_terminal(capsys) -> None:
    """``astrocpg describe`` prints plain text: no LaTeX, no Markdown table; each statement as
    the model file states it, with its unit; the parameters with their units and symbols in
    Unicode."""
    assert main(["describe", "astrocyte"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("astrocyte\n=========\n")
    assert "\\frac" not in text and "$" not in text and "|---|" not in text
    assert "  dCa/dt = J_chan + J_leak - J_pump  [mM]  # cytosolic [Ca2+]" in text
    assert "  reset: ADO += r_ADO" in text
    assert re.search(r"^  tau_ADO\s+τ_ADO\s+1\. s\s+\[ADO\] decay", text, re.M)


def test_the_learning_rule_reads_with_its_signs() -> None:
    """``describe eta_ADO``: the rule with its terms and signs in the order written, in every
    format; a parameter with no symbol (``astrocyte_regulation``: "-") is named, not shown as
    a minus sign."""
    text = describe("eta_ADO")
    rule = ("w ← clip(w + learning_post*progress_post*(eta*r_eff*STDP - "
            "astrocyte_regulation*eta_ADO*ADO)*zeta, w_min, w_max)")
    assert f"interlimb_synapse (on_step): {rule}" in text
    assert "\\" not in text and "$" not in text
    latex = describe("eta_ADO", "latex")
    assert (r"\eta \cdot r_{eff} \cdot STDP - astrocyte_{regulation} \cdot "
            r"\eta_{\mathrm{ADO}} \cdot ADO") in latex
    assert r"\cdot - \cdot" not in latex and r"- ADO" not in latex
    md = describe("eta_ADO", "markdown")
    assert r"\cdot - \cdot" not in md
    # an unevaluated unary minus: -x, not (-1)*x
    astro = describe("astrocyte", "latex")
    assert r"\frac{dADO}{dt} = \frac{-ADO}{\tau_{\mathrm{ADO}}}" in astro
    assert r"\left(-1\right)" not in astro


def _statement_order(text: str, names: list[str]) -> list[int]:
    return [text.index(n) for n in names]


def test_equations_in_the_model_files_order() -> None:
    """The statements come in the order of the model's equation string (its file), not
    Brian2's or sympy's (differential equations first, subexpressions sorted); every format."""
    from brian2 import Equations

    from astrocpg.models.astrocyte import EQUATIONS
    declared = list(Equations(EQUATIONS).keys())
    assert declared != [eq.varname for eq in Equations(EQUATIONS).ordered]  # a real test
    plain = describe("astrocyte")
    starts = [f"  d{v}/dt =" if v in ("Ca", "h", "IP3", "AG", "ADO") else f"  {v} "
              for v in declared]
    where = _statement_order(plain, starts)
    assert where == sorted(where), declared
    md = describe("astrocyte", "markdown")
    codes = [f"`d{v}/dt =" if v in ("Ca", "h", "IP3", "AG", "ADO") else f"`{v} " for v in declared]
    where = _statement_order(md, codes)
    assert where == sorted(where)


def test_latex_still_works(capsys) -> None:
    assert main(["describe", "interlimb_synapse", "--format", "latex"]) == 0
    text = capsys.readouterr().out
    assert text.startswith(r"\subsection*{interlimb\_synapse}")
    assert r"\begin{align*}" in text and r"\end{tabular}" in text
    assert r"\texttt{astrocyte\_regulation} & -- & 1.0" in text
    assert main(["describe", "astrocyte", "--format", "txt"]) == 2
    assert "did you mean text?" in capsys.readouterr().err


def test_the_model_file_example_prints_its_new_parameter(tmp_path: Path) -> None:
    """docs/examples/model_file.md through the API (no subprocess): the dumped astrocyte with a
    new parameter; ``describe`` of that parameter prints its row and the equation using it."""
    import astrocpg as ac

    page = (Path(__file__).resolve().parents[1] / "docs/examples/model_file.md").read_text()
    assert "subprocess" not in page and "ac.dump_model(" in page
    text = ac.dump_model("astrocyte")
    edited = text.replace("dAG/dt = -AG/tau_AG + r_AG*n_pool/dt : 1",
                          "dAG/dt = -AG/tau_AG + r_AG*n_pool/dt + 1/tau_extra : 1")
    edited = edited.replace("[parameters]\n", '[parameters]\ntau_extra = { value = "2*second", '
                            'symbol = "\\\\tau_{extra}", meaning = "a constant 2-AG source", '
                            'positive = true }\n', 1)
    out = ac.describe("tau_extra", models={"astrocyte": edited})
    assert re.search(r"^tau_extra\s+τ_extra\s+2\. s\s+a constant 2-AG source$", out, re.M), out
    assert "astrocyte (equation): dAG/dt = -AG/tau_AG + r_AG*n_pool/dt + 1/tau_extra" in out


def test_the_frames_example_reads_a_real_video() -> None:
    """docs/examples/frames.md reads the frames of a video astrocpg wrote, not one it drew."""
    page = (Path(__file__).resolve().parents[1] / "docs/examples/frames.md").read_text()
    assert "ac.video(" in page and "ac.run(" in page and "get_writer" not in page
