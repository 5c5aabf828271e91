"""Time functions of scene files: values, derivatives, tables, safety (latdyn.scene.expressions)."""
from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from latdyn.errors import SceneError
from latdyn.scene.expressions import ALLOWED_NAMES, TimeFunction, parse_time_function

SPINUP = "Piecewise((6/15*(t**2/2 + (15/(2*pi))**2*(cos(2*pi*t/15) - 1)), t < 15), (6*(t - 7.5), True))"


def test_spinup_law_values_and_derivatives():
    f = TimeFunction(SPINUP)
    assert f.value(0.0) == pytest.approx(0.0, abs=1e-14)
    assert f.value(7.5) == pytest.approx(6.6905467, abs=1e-7)
    assert f.rate(7.5) == pytest.approx(3.0, rel=1e-12)
    assert f.value(15.0) == pytest.approx(45.0, rel=1e-12)
    assert f.rate(15.0) == pytest.approx(6.0, rel=1e-12)
    for t in (15.5, 17.0, 20.0):
        assert f.rate(t) == pytest.approx(6.0, rel=1e-12)
        assert f.accel(t) == pytest.approx(0.0, abs=1e-12)
    # the spin-up law: accel = 0.4 (1 - cos(2 pi t / 15)) before 15 s
    assert f.accel(7.5) == pytest.approx(0.8, rel=1e-12)
    assert f.rate(0.0) == pytest.approx(0.0, abs=1e-14)
    assert not f.is_constant
    assert f.source == SPINUP
    assert f.kind == "expression"


def test_derivatives_match_finite_differences():
    f = TimeFunction("exp(-t/3)*sin(2*t) + sqrt(1 + t**2) + atan2(t, 2) + tanh(t)")
    t = np.linspace(0.1, 5.0, 17)
    h = 1e-5
    assert np.allclose(f.rate(t), (f.value(t + h) - f.value(t - h)) / (2 * h), rtol=1e-7, atol=1e-8)
    assert np.allclose(f.accel(t), (f.rate(t + h) - f.rate(t - h)) / (2 * h), rtol=1e-6, atol=1e-7)


def test_vectorised_evaluation_keeps_shape_and_types():
    f = TimeFunction(SPINUP)
    t = np.array([[0.0, 7.5], [15.0, 20.0]])
    v = f.value(t)
    assert v.shape == (2, 2) and v.dtype == np.float64
    assert v[1, 1] == pytest.approx(6 * 12.5)
    assert isinstance(f.value(1.0), float)
    c = TimeFunction(2.5)
    assert c.value(np.zeros(4)).shape == (4,)
    assert np.all(c.rate(np.zeros(4)) == 0.0) and c.is_constant
    assert TimeFunction("3*pi").is_constant
    assert TimeFunction("3*pi").value(np.arange(3.0)) == pytest.approx(np.full(3, 3 * math.pi))


def test_piecewise_heaviside_abs_sign_min_max_vectorised():
    t = np.array([0.0, 0.5, 1.0, 2.0])
    assert np.array_equal(TimeFunction("Heaviside(t - 1)").value(t), [0.0, 0.0, 0.5, 1.0])
    assert np.array_equal(TimeFunction("Heaviside(t - 1, 1)").value(t), [0.0, 0.0, 1.0, 1.0])
    assert np.array_equal(TimeFunction("Heaviside(t - 1)").rate(t), np.zeros(4))  # DiracDelta dropped
    assert np.array_equal(TimeFunction("abs(t - 1)").value(t), [1.0, 0.5, 0.0, 1.0])
    assert np.array_equal(TimeFunction("abs(t - 1)").rate(t), [-1.0, -1.0, 0.0, 1.0])
    assert np.array_equal(TimeFunction("sign(t - 1)").value(t), [-1.0, -1.0, 0.0, 1.0])
    assert np.array_equal(TimeFunction("Min(t, 1) + Max(t, 1)").value(t), [1.0, 1.5, 2.0, 3.0])
    pw = TimeFunction("Piecewise((t**2, t < 1), (2*t - 1, True))")
    assert np.allclose(pw.value(t), [0.0, 0.25, 1.0, 3.0])
    assert np.allclose(pw.rate(t), [0.0, 1.0, 2.0, 2.0])
    assert np.allclose(pw.accel(t), [2.0, 2.0, 0.0, 0.0])
    eq = TimeFunction("Piecewise((1, t == 1), (0, t != 1))")
    assert np.array_equal(eq.value(t), [0.0, 0.0, 1.0, 0.0])
    chained = TimeFunction("Piecewise((1, 0.25 < t <= 1), (0, True))")
    assert np.array_equal(chained.value(t), [0.0, 1.0, 1.0, 0.0])


def test_table_interpolation_slopes_and_ends():
    f = TimeFunction({"table": [[0, 0], [1, 2], [3, 2], [4, -2]]})
    t = np.array([-1.0, 0.0, 0.5, 1.0, 2.0, 3.5, 4.0, 9.0])
    assert np.allclose(f.value(t), [0, 0, 1, 2, 2, 0, -2, -2])
    assert np.allclose(f.rate(t), [0, 2, 2, 0, 0, -4, 0, 0])
    assert np.all(f.accel(t) == 0.0)
    assert f.value(0.25) == pytest.approx(0.5)
    assert f.kind == "table" and not f.is_constant
    single = TimeFunction({"table": [[1.0, 3.0]]})
    assert single.value(0.0) == 3.0 and single.rate(5.0) == 0.0 and single.is_constant


@pytest.mark.parametrize("rows", [
    [],
    [[0, 1], [0, 2]],
    [[1, 1], [0, 2]],
    [[0, 1, 2]],
    [[0, "1"]],
    [[0, True]],
    [[0, float("nan")]],
    "x",
])
def test_table_validation(rows):
    with pytest.raises(SceneError) as err:
        parse_time_function({"table": rows}, "f.yaml", "loads[0].force[0]")
    assert "loads[0].force[0]" in str(err.value) and str(err.value).startswith("f.yaml: ")


def test_pickle_rebuilds_lazily():
    for source in (SPINUP, 4.0, {"table": [[0, 0], [2, 4]]}):
        f = TimeFunction(source)
        g = pickle.loads(pickle.dumps(f))
        assert g == f and g.source == f.source
        t = np.linspace(0, 20, 11)
        assert np.array_equal(g.value(t), f.value(t))
        assert np.array_equal(g.rate(t), f.rate(t))
        assert np.array_equal(g.accel(t), f.accel(t))


@pytest.mark.parametrize("text", [
    "__import__('os')",
    "__import__('os').system('true')",
    "t.real",
    "[1]",
    "(1)[0]",
    "lambda: 1",
    "lambda t: t",
    "foo",
    "x + t",
    "Symbol('a')",
    "sympify('t')",
    "eval('1')",
    "'t'",
    "1_000",
    "0x10",
    "2j",
    "t if t else 1",
    "t and 1",
    "not t",
    "t % 2",
    "t // 2",
    "t @ t",
    "a = 1",
    "t; 1",
    "{1: 2}",
    "t # comment",
    "Eq(t, 1)",
    "9**9**9",
    "(10**100)**100",
    "t**9**9",
    "",
    "sin(",
    "sin(1, 2)",
    "t < 1",
    "sqrt(-1)",
    "log(t)",
    "1/0",
    "_",
])
def test_refused_text(text):
    with pytest.raises(SceneError) as err:
        parse_time_function(text, "scene.yaml", "bodies.hub.motion.rotation.angle")
    msg = str(err.value)
    assert msg.startswith("scene.yaml: bodies.hub.motion.rotation.angle: ")
    assert "expected" in msg


def test_refusal_names_what_is_allowed():
    with pytest.raises(SceneError) as err:
        parse_time_function("t.real", "s.yaml", "loads[0].force[2]")
    assert err.value.file == "s.yaml" and err.value.key == "loads[0].force[2]"
    for name in ("sin", "Piecewise", "Heaviside"):
        assert name in err.value.expected


@pytest.mark.parametrize("value", [True, None, float("inf"), float("nan"), [1, 2], {"tabel": []}])
def test_refused_values(value):
    with pytest.raises(SceneError):
        parse_time_function(value, "s.yaml", "k")


def test_every_allowed_name_parses():
    uses = {
        "t": "t", "pi": "pi", "e": "e", "sin": "sin(t)", "cos": "cos(t)", "tan": "tan(t)",
        "exp": "exp(t)", "log": "log(1 + t)", "sqrt": "sqrt(1 + t)", "abs": "abs(t)",
        "sign": "sign(t)", "Min": "Min(t, 1)", "Max": "Max(t, 1)",
        "Piecewise": "Piecewise((t, t < 1), (1, True))", "Heaviside": "Heaviside(t)",
        "True": "Piecewise((1, True))", "False": "Piecewise((1, False), (2, True))",
        "asin": "asin(t/10)", "acos": "acos(t/10)", "atan": "atan(t)", "atan2": "atan2(t, 1)",
        "sinh": "sinh(t)", "cosh": "cosh(t)", "tanh": "tanh(t)",
    }
    assert set(uses) == set(ALLOWED_NAMES)
    for text in uses.values():
        f = TimeFunction(text)
        assert np.all(np.isfinite(f.value(np.linspace(0, 2, 5)))), text


def test_numbers_and_strings_agree():
    assert TimeFunction(3).value(1.0) == 3.0
    assert TimeFunction("2.8e7").value(0.0) == 2.8e7
    assert TimeFunction("  1 +\n  2*t ").value(1.0) == 3.0
    assert TimeFunction("6/15").value(0.0) == pytest.approx(0.4)
