"""models/units.py and models/expressions.py: values and model expressions are read without eval; every failure is one
InputError line naming the culprit."""

from __future__ import annotations

import builtins
import contextlib
import math
import os
import uuid
from unittest import mock

import brian2
import numpy as np
import pytest
from brian2 import Hz, mV, ms, second, umolar, volt
from brian2.units.allunits import joule, meter, newton, radian
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS, ExpressionModel
from astrocpg.models.expressions import FUNCTIONS, compile_expression
from astrocpg.models.units import example_value, finite_number, parse_value, unit_spelling

CULPRIT = "--set tau_motor"
SENTINEL = f"/tmp/astrocpg_pwned_{uuid.uuid4().hex}"
PAYLOADS = [
    f"open('{SENTINEL}','w')",
    f"__import__('os').system('touch {SENTINEL}')",
    f"[c for c in ().__class__.__base__.__subclasses__() if c.__name__ == 'Popen'][0]"
    f"(['touch', '{SENTINEL}'])",
    f"exec(\"open('{SENTINEL}','w')\")",
    f"eval(\"open('{SENTINEL}','w')\")",
]

HYPOTHESIS = settings(max_examples=100, deadline=None, database=None,
                      suppress_health_check=[HealthCheck.too_slow])


@contextlib.contextmanager
def no_eval():
    """eval and exec raise while the code under test runs."""
    def forbidden(*args, **kwargs):
        raise AssertionError("eval/exec called")

    with mock.patch.object(builtins, "eval", forbidden), \
            mock.patch.object(builtins, "exec", forbidden):
        yield


def dims(value):
    return brian2.get_dimensions(value)


def is_finite_value(value) -> bool:
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return math.isfinite(value)
    return isinstance(value, brian2.Quantity) and bool(np.isfinite(np.asarray(value)).all())


# ----------------------------------------------------------------------------- parse_value

@pytest.mark.parametrize("text, expected", [
    ("9*ms", 9 * ms),
    ("-70*mV", -70 * mV),
    ("40*newton*meter", 40 * newton * meter),
    ("40 newton*meter", 40 * joule),
    ("40 newton meter", 40 * joule),
    ("mV/second", mV / second),
    ("0.3*umolar", 0.3 * umolar),
    ("2*(3*ms)", 6 * ms),
    ("2 (3 ms)", 6 * ms),
    ("1e-3*second", 1 * ms),
    ("1E-3 second", 1 * ms),
    ("8 volt/second", 8 * volt / second),
    ("8000 mV/second", 8 * volt / second),
    ("  9 * ms  ", 9 * ms),
    ("(1*ms)**2", 1 * ms ** 2),
    ("ms**-1", 1 / ms),
    ("100*Hz", 100 * Hz),
    ("30*newton*meter/radian", 30 * joule),
    ("2*pi", 2 * math.pi),
    ("0.3", 0.3),
    ("-1.5e2", -150.0),
    ("+2", 2),
    ("2**10", 1024),
    ("1_000*ms", 1 * second),
    ("ms/ms", 1.0),
    ("007", 7),
])
def test_accepted_values(text, expected):
    with no_eval():
        value = parse_value(text, culprit=CULPRIT)
    assert dims(value) == dims(expected)
    assert float(np.asarray(value)) == pytest.approx(float(np.asarray(expected)), rel=1e-12)


def test_dimensionless_values_are_plain_numbers():
    assert parse_value("10", culprit=CULPRIT) == 10 and isinstance(
        parse_value("10", culprit=CULPRIT), int)
    assert isinstance(parse_value("ms/second", culprit=CULPRIT), float)


@pytest.mark.parametrize("text, says", [
    ("__import__('os').system('x')", "not accepted"),
    ("__import__", "'_'"),
    ("().__class__.__bases__[0].__subclasses__()", "attribute"),
    ("[x for x in ()]", "brackets"),
    ("lambda: 1", "lambdas"),
    ("ms.__class__", "attribute"),
    ("open('f')", "not accepted"),
    ("open (ms)", "unknown unit name 'open'"),
    ("ms(1)", "calls"),
    ("(2)(3)", "calls"),
    ("()", "tuples"),
    ("nan", "finite"),
    ("inf", "finite"),
    ("-inf*ms", "finite"),
    ("1e309", "finite"),
    ("1e308*10", "finite"),
    ("1e308*second*10", "finite"),
    ("1e300*ms*1e300", "finite"),
    ("((9**9)**10)**10", "overflow"),
    ("10**10**10", "exponent"),
    ("2**ms", "exponent"),
    ("1*ms + 1*mV", "cannot add"),
    ("1/0", "division by zero"),
    ("ms/(0*second)", "division by zero"),
    ("0**-1", "division by zero"),
    ("(-8)**(1/3)", "negative"),
    ("'9'", "quotes"),
    ("f'{1}'", "quotes"),
    ("(a:=1)", "':'"),
    ("(" * 1000 + "1" + ")" * 1000, "longer than 200"),
    ("(" * 30 + "1" + ")" * 30, "parentheses nested deeper"),
    ("1" * 10_000, "longer than 200"),
    ("ms if 1 else mV", "keyword 'if'"),
    ("not 1", "keyword 'not'"),
    ("1 < 2", "comparisons"),
    ("1 == 1", "'='"),
    ("1 and 2", "keyword 'and'"),
    ("1, 2", "commas"),
    ("{1}", "braces"),
    ("J", "unknown unit name 'J' (did you mean joule?)"),
    ("40*J", "did you mean joule?"),
    ("8 V/s", "did you mean volt?"),
    ("9ms", "space between a number and a unit"),
    ("1j", "unknown unit name 'j'"),
    ("0x10", "unknown unit name 'x10'"),
    ("1 000", "two numbers"),
    ("2//3", "cannot read"),
    ("2 * * 3", "cannot read"),
    ("(1*ms", "unbalanced"),
    ("1*ms)", "unbalanced"),
    ("", "empty"),
    ("   ", "empty"),
    ("9*\u00b5s", "micro"),
    ("9*ms\n+1*ms", "line breaks"),
    ("9\x00", "NUL"),
    ("\uff19*ms", "character"),  # a full-width digit: ASCII only
])
def test_refused_values(text, says):
    with no_eval(), pytest.raises(InputError) as info:
        parse_value(text, culprit=CULPRIT)
    line = str(info.value)
    assert line.startswith(CULPRIT + ": ")
    assert "\n" not in line and len(line) <= 600
    assert says in line
    assert info.value.exit_code == 2


def test_refused_non_text():
    with pytest.raises(InputError, match=CULPRIT):
        parse_value(9, culprit=CULPRIT)  # type: ignore[arg-type]


# a grammar of fragments for adversarial text
_FRAGMENTS = st.sampled_from([
    "ms", "mV", "second", "newton", "meter", "umolar", "joule", "Hz", "pi", "volt", "J", "V",
    "0", "1", "9", "-70", "0.3", "1e-3", "1e309", "1e308", "10", "007", ".5", "1_0", "1j",
    "+", "-", "*", "/", "**", "//", "%", "@", "(", ")", "((", "))", " ", "  ", "\t",
    "__class__", "__import__", "__builtins__", "__subclasses__", "__globals__", "_",
    ".", ",", ":", ":=", "=", "==", "<", "[", "]", "[0]", "{", "}", "'", '"', "f'", "\\",
    "lambda", "if", "else", "not", "and", "or", "for", "in", "is", "import", "yield", "await",
    "open", "eval", "exec", "os", "system", "nan", "inf", "\n", "\x00", "\u00b5",
    *PAYLOADS,
])
_ADVERSARIAL = st.lists(_FRAGMENTS, max_size=12).map("".join)
# values that should mostly be accepted, to exercise the arithmetic
_ARITHMETIC = st.recursive(
    st.one_of(st.sampled_from(["ms", "mV", "second", "newton", "meter", "umolar", "pi"]),
              st.floats(allow_nan=False, allow_infinity=False).map(repr),
              st.integers(-10**20, 10**20).map(str)),
    lambda inner: st.one_of(
        st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**", " "]), inner).map(
            lambda t: f"({t[0]}){t[1]}({t[2]})" if t[1] != " " else f"{t[0]} {t[2]}"),
        inner.map(lambda t: f"-({t})")),
    max_leaves=8,
)


def _check_parse(text: str) -> None:
    with no_eval():
        try:
            value = parse_value(text, culprit=CULPRIT)
        except InputError as e:
            assert str(e).startswith(CULPRIT + ": ") and "\n" not in str(e)
        else:
            assert is_finite_value(value), (text, value)
    assert not os.path.exists(SENTINEL)


@HYPOTHESIS
@given(st.text(max_size=300))
def test_any_text_gives_a_finite_value_or_input_error(text):
    _check_parse(text)


@HYPOTHESIS
@given(_ADVERSARIAL)
def test_adversarial_text_gives_a_finite_value_or_input_error(text):
    _check_parse(text)


@HYPOTHESIS
@given(_ARITHMETIC)
def test_arithmetic_gives_a_finite_value_or_input_error(text):
    _check_parse(text)


@pytest.mark.parametrize("payload", PAYLOADS)
def test_payloads_are_refused_and_run_nothing(payload):
    with no_eval(), pytest.raises(InputError):
        parse_value(payload, culprit=CULPRIT)
    assert not os.path.exists(SENTINEL)


# ----------------------------------------------------------------------------- unit_spelling

def _parameters():
    return [(f"{model_name}.{p.name}", p) for model_name, model in DEFAULT_MODELS.items()
            for p in model.parameters.values()]


@pytest.mark.parametrize("name, parameter", _parameters(), ids=[n for n, _ in _parameters()])
def test_unit_spelling_round_trips_for_every_parameter(name, parameter):
    d = dims(parameter.value)
    for source in (parameter.value, d):
        spelling = unit_spelling(source)
        assert dims(parse_value(spelling, culprit=name)) == d, spelling
    example = example_value(parameter.value)
    value = parse_value(example, culprit=name)
    assert dims(value) == d
    assert float(np.asarray(value)) == pytest.approx(float(np.asarray(parameter.value)),
                                                     rel=1e-9, abs=1e-300)


@pytest.mark.parametrize("value, spelling", [
    (30 * joule, "joule"), (9 * ms, "ms"), (-70 * mV, "mV"), (8 * volt / second, "volt/second"),
    (2 * umolar, "umolar"), (100 * Hz, "Hz"), (1.0, "1"), (0.5 * radian, "1"),
    (brian2.get_dimensions(second / meter), "second/meter"),
])
def test_unit_spelling_examples(value, spelling):
    assert unit_spelling(value) == spelling


def test_example_value():
    assert example_value(30 * newton * meter) == "30*joule"
    assert example_value(0.5) == "0.5"
    assert example_value(8000 * mV / second) == "8*volt/second"


# ----------------------------------------------------------------------------- finite_number

@pytest.mark.parametrize("text, kwargs, expected", [
    ("2.5", {}, 2.5), (" 1e-3 ", {}, 1e-3), ("-4", {}, -4.0), ("8", {"kind": int}, 8),
    ("0", {"minimum": 0}, 0.0), ("1", {"strictly_positive": True}, 1.0), (3, {"kind": int}, 3),
    (0.25, {}, 0.25),
])
def test_finite_number_accepts(text, kwargs, expected):
    value = finite_number(text, culprit="--seconds", **kwargs)
    assert value == expected and type(value) is type(expected)


@pytest.mark.parametrize("text, kwargs, says", [
    ("nan", {}, "finite"), ("inf", {}, "finite"), ("-inf", {}, "finite"),
    ("1e309", {}, "finite"), ("abc", {}, "expected"), ("", {}, "expected"),
    ("1_0", {}, "expected"), ("\uff19", {}, "expected"), ("8.5", {"kind": int}, "integer"),
    ("1e3", {"kind": int}, "integer"), ("-1", {"minimum": 0}, "at least 0"),
    ("0", {"strictly_positive": True}, "greater than 0"), (float("nan"), {}, "finite"),
    (True, {}, "bool"), (2.5, {"kind": int}, "integer"), ("9" * 200, {}, "expected"),
])
def test_finite_number_refuses(text, kwargs, says):
    with pytest.raises(InputError) as info:
        finite_number(text, culprit="--seconds", **kwargs)
    assert str(info.value).startswith("--seconds: ") and says in str(info.value)


@settings(max_examples=60, deadline=None, database=None)
@given(st.one_of(st.text(max_size=40), st.floats(), st.integers()))
def test_finite_number_gives_a_finite_number_or_input_error(text):
    for kind in (float, int):
        try:
            value = finite_number(text, culprit="--trials", kind=kind, minimum=1)
        except InputError as e:
            assert str(e).startswith("--trials: ")
        else:
            assert math.isfinite(value) and value >= 1 and type(value) is kind


# ----------------------------------------------------------------------------- compile_expression

def _expression_models():
    return [(name, m) for name, m in DEFAULT_MODELS.items() if isinstance(m, ExpressionModel)]


def _constants(model):
    return {n: float(np.asarray(p.value)) for n, p in model.parameters.items()}


def _reference(model):
    """The eval-based ExpressionModel.compile this module replaces (trusted model text)."""
    code = compile(model.expression, f"<{model.name}>", "eval")
    env = {"abs": np.abs, "exp": np.exp, "sqrt": np.sqrt, "clip": np.clip, **_constants(model)}
    return lambda **inputs: builtins.eval(code, env, inputs)  # noqa: S307


@pytest.mark.parametrize("name, model", _expression_models(),
                         ids=[n for n, _ in _expression_models()])
def test_compile_expression_matches_the_eval_version(name, model):
    with no_eval():
        fn = compile_expression(model.expression, owner=name, inputs=model.inputs,
                                constants=_constants(model))
    reference = _reference(model)
    rng = np.random.default_rng(7)
    for scale in (1e-12, 0.1, 1.0, 10.0, 1e3):
        for size in (1, 13):
            inputs = {k: rng.normal(scale=scale, size=size) for k in model.inputs}
            with np.errstate(all="ignore"):
                expected = reference(**inputs)
                with no_eval():
                    got = fn(**inputs)
            np.testing.assert_array_equal(got, expected)
    scalars = {k: 0.75 for k in model.inputs}  # training passes plain floats
    with np.errstate(all="ignore"):
        assert fn(**scalars) == reference(**scalars)


def test_compiled_function_has_no_builtins_and_keyword_only_inputs():
    fn = compile_expression("k*x + clip(y, 0, 1)", owner="m", inputs=("x", "y"),
                            constants={"k": 2.0})
    assert fn.__globals__["__builtins__"] == {}
    assert set(fn.__globals__) == {"__builtins__", *FUNCTIONS}
    assert fn(x=1.0, y=3.0) == 3.0
    with pytest.raises(TypeError):
        fn(1.0, 3.0)


@pytest.mark.parametrize("expression, says", [
    ("foo*x", "unknown name 'foo'"),
    ("x.__class__", "attribute"),
    ("__import__('os')", "calls to '__import__'"),
    ("open('f')", "calls to 'open'"),
    ("np.exp(x)", "calls are accepted only"),
    ("exp", "must be called"),
    ("exp(x, x)", "takes 1 argument"),
    ("clip(x, 0)", "takes 3 arguments"),
    ("abs(x=1)", "positional"),
    ("abs(*x)", "positional"),
    ("x[0]", "subscripts"),
    ("[x]", "lists"),
    ("lambda: x", "lambdas"),
    ("x if k else 1", "conditional"),
    ("0 < x < 1", "chained"),
    ("x and k", "'and'/'or'"),
    ("not x", "'not'"),
    ("x is k", "comparison"),
    ("x // 2", "'//'"),
    ("'x'", "str literals"),
    ("1e309*x", "not finite"),
    ("(x := 1)", "':='"),
    ("[c for c in x]", "comprehensions"),
    ("x +", "syntax error"),
    ("2**10**10", "exponent of '**'"),
    ("(9**9)**10", "base of '**'"),
    ("x" + "+x" * 1500, "longer than"),
    ("abs(" * 150 + "x" + ")" * 150, "nested"),
])
def test_compile_expression_refuses(expression, says):
    with no_eval(), pytest.raises(InputError) as info:
        compile_expression(expression, owner="reward", inputs=("x", "y"), constants={"k": 1.0})
    line = str(info.value)
    assert line.startswith("reward: ") and "\n" not in line and says in line


@pytest.mark.parametrize("inputs, constants, says", [
    (("exp",), {}, "names a function"), (("x", "x"), {}, "twice"), (("x-y",), {}, "cannot name"),
    (("x",), {"k": float("nan")}, "not finite"), (("x",), {"k": "a"}, "not a number"),
])
def test_compile_expression_refuses_bad_names_and_constants(inputs, constants, says):
    with pytest.raises(InputError, match=says):
        compile_expression("x", owner="m", inputs=inputs, constants=constants)


_EXPRESSION_FRAGMENTS = st.sampled_from([
    "x", "y", "k", "abs", "exp", "sqrt", "clip", "where", "minimum", "tanh", "log",
    "0", "1", "2", "0.5", "1e309", "10", "-", "+", "*", "/", "**", "//", "%", "(", ")", ",",
    " ", "<", ">=", "==", "!=", " and ", " or ", " not ", " if ", " else ", " lambda ",
    ".", "[", "]", "'", "__class__", "__import__", "__builtins__", "open", "eval", "exec",
    ":=", "=", "{", "}", *PAYLOADS,
])


@HYPOTHESIS
@given(st.lists(_EXPRESSION_FRAGMENTS, max_size=14).map("".join))
def test_random_expressions_compile_safely_or_give_input_error(expression):
    with no_eval():
        try:
            fn = compile_expression(expression, owner="m", inputs=("x", "y"),
                                    constants={"k": 0.5})
        except InputError as e:
            assert str(e).startswith("m: ") and "\n" not in str(e)
        else:
            assert callable(fn)
            with np.errstate(all="ignore"):
                try:
                    fn(x=np.array([0.5, -2.0]), y=np.array([3.0, 0.0]))
                except (TypeError, ValueError, ZeroDivisionError, OverflowError):
                    pass  # numpy refusing an operation (e.g. '-' of booleans) at run time
    assert not os.path.exists(SENTINEL)


def test_a_combined_unit_is_spelled_the_same_whatever_the_process_created_before():
    """Brian2 keeps every combined unit a process creates; dividing mV by ms made the spelling
    of volt/second read ``mV/ms`` in a clean checkout's test run. It must not depend on that."""
    from brian2 import ms as _ms, mV as _mV

    _ = _mV / _ms  # registers mV/ms for the dimensions of volt/second
    assert unit_spelling(8 * volt / second) == "volt/second"
    assert example_value(8000 * _mV / second) == "8*volt/second"
