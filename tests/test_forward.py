"""codegen/forward.py: the tangent-linear program of a lowered kernel against closed-form Jacobians.

Small kernels as a user of the generator writes them (a KernelSpec with named intermediates and a
``Tangent`` request), lowered by ``codegen.emit.lower`` and printed to NumPy; their tangent output is
compared with SymPy's Jacobian of the eliminated expressions, evaluated at random points.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from codegen import emit
from codegen.ir import Argument, KernelSpec, Output, Tangent

X = Argument("x", 3, "coordinates")
P = Argument("p", 2, "parameters (not differentiated)")


def _numpy(kernel: emit.LoweredKernel):
    namespace = {"np": np}
    exec(emit.numpy_function(kernel), namespace)  # noqa: S102  the generator's own output
    return namespace[kernel.spec.name]


def _spec(seeds: dict, directions: int, partials=None, definitions=None) -> KernelSpec:
    x, p = X.symbols(), P.symbols()
    r = sp.Symbol("r", real=True)
    s = sp.Symbol("s", real=True)
    intermediates = [(r, sp.sqrt(x[0] ** 2 + x[1] ** 2 + p[0] ** 2)),
                     (s, sp.atan2(x[1], x[0]) * p[1] + sp.sin(r * x[2]))]
    force = [r * s + x[2] ** 3, s / r - p[0] * x[0], p[1] * r ** 2]
    return KernelSpec("toy_force", "a toy force", [X, P], [Output("force", (3,), force)],
                      intermediates=intermediates,
                      tangent=Tangent("force", "force_D_x", seeds, directions, "∂force/∂x",
                                      partials or {}, definitions or {}))


def _reference(spec: KernelSpec, seeds: dict, directions: int, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(∂force/∂x) · (the seeds' directions), from SymPy's Jacobian of the eliminated force."""
    (force,) = spec.eliminated_outputs()
    symbols = X.symbols() + P.symbols()
    values = dict(zip(symbols, [*x, *p]))
    jacobian = np.array([[float(sp.diff(f, xi).subs(values)) for xi in X.symbols()] for f in force])
    seed = np.zeros((3, directions))
    for name, column in seeds.items():
        k = int(name.split("_")[1])
        seed[k] = [float(sp.sympify(c).subs(values)) for c in column]
    return jacobian @ seed


def test_tangent_of_a_lowered_kernel_is_its_jacobian():
    """Unit seeds in the three coordinates: the tangent output is the Jacobian (round-off)."""
    seeds = {"x_0": [1, 0, 0], "x_1": [0, 1, 0], "x_2": [0, 0, 1]}
    spec = _spec(seeds, 3)
    kernel = emit.lower(spec)
    assert [o.name for o in kernel.spec.outputs] == ["force", "force_D_x"]
    function = _numpy(kernel)
    rng = np.random.default_rng(5)
    x, p = rng.normal(size=(4, 3)), rng.uniform(0.5, 2.0, size=(4, 2))
    force, tangent = function(x, p)
    assert tangent.shape == (4, 3, 3)
    for e in range(4):
        expected = _reference(spec, seeds, 3, x[e], p[e])
        np.testing.assert_allclose(tangent[e], expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())


def test_seeds_that_are_expressions_and_directions_that_do_not_move():
    """Seeds that are expressions of the inputs (a rotation-like direction x × e_z) and a direction no
    input moves in: that column is exactly zero, and nothing is emitted for it."""
    x = X.symbols()
    seeds = {"x_0": [-x[1], 0, 1], "x_1": [x[0], 0, 0]}  # x_2 does not move; direction 1 moves nothing
    spec = _spec(seeds, 3)
    kernel = emit.lower(spec)
    assert not any(symbol.name.endswith("_D1") for symbol, _ in kernel.temporaries)
    function = _numpy(kernel)
    rng = np.random.default_rng(6)
    xs, ps = rng.normal(size=(3, 3)), rng.uniform(0.5, 2.0, size=(3, 2))
    _, tangent = function(xs, ps)
    for e in range(3):
        expected = _reference(spec, seeds, 3, xs[e], ps[e])
        np.testing.assert_allclose(tangent[e], expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())
        assert np.all(tangent[e][:, 1] == 0.0)


def test_a_statement_differentiated_by_its_rule():
    """A statement whose definition is not the function to differentiate (here |x₀|, standing for the
    branch-free jet of θ/sin θ) is differentiated by the rule it is given, with the rule's definition
    added where the kernel lacks it; without a rule, the derivative is refused (not a closed form)."""
    x = X.symbols()
    a = sp.Symbol("a", real=True)
    spec = KernelSpec("toy_rule", "a toy with |x0|", [X], [Output("y", (1,), [a * x[1]])],
                      intermediates=[(a, sp.Abs(x[0]))],
                      tangent=Tangent("y", "y_D_x", {"x_0": [1, 0], "x_1": [0, 1]}, 2, "",
                                      {"a": {"x_0": sp.Symbol("a_slope", real=True)}},
                                      {"a_slope": sp.Integer(2) * x[0] / 2 / sp.Abs(x[0])}))
    function = _numpy(emit.lower(spec))
    xs = np.array([[0.7, -1.3, 0.0], [-2.0, 0.4, 0.0]])
    _, tangent = function(xs)
    np.testing.assert_allclose(tangent[:, 0, :], np.column_stack([np.sign(xs[:, 0]) * xs[:, 1], np.abs(xs[:, 0])]),
                               rtol=1e-15)
    bare = KernelSpec("toy_bare", "", [X], [Output("y", (1,), [a * x[1]])], intermediates=[(a, sp.Abs(x[0]))],
                      tangent=Tangent("y", "y_D_x", {"x_0": [1]}, 1))
    with pytest.raises(emit.EmitError, match="not a closed form"):
        emit.lower(bare)


def test_columns_combined_from_a_rigid_translation():
    """An output invariant under moving x₀ and x₁ together: seeding that rigid motion (direction 0)
    instead of x₀ alone, its tangent cancels line by line and nothing is emitted for it, and the
    column ∂/∂x₀ = (rigid) − ∂/∂x₁ (Tangent.columns) is still the Jacobian's."""
    x = X.symbols()
    c = sp.Symbol("c", real=True)
    seeds = {"x_0": [1, 0, 0], "x_1": [1, 1, 0], "x_2": [0, 0, 1]}
    spec = KernelSpec("toy_chord", "", [X], [Output("y", (2,), [sp.sin(c) * x[2], c ** 3 / (1 + x[2] ** 2)])],
                      intermediates=[(c, x[1] - x[0])],
                      tangent=Tangent("y", "y_D_x", seeds, 3, "", columns=[{0: 1, 1: -1}, {1: 1}, {2: 1}]))
    kernel = emit.lower(spec)
    assert not any(symbol.name.endswith("_D0") for symbol, _ in kernel.temporaries)
    xs = np.random.default_rng(7).normal(size=(3, 3))
    _, tangent = _numpy(kernel)(xs)
    (y,) = spec.eliminated_outputs()
    for e in range(3):
        values = dict(zip(x, xs[e]))
        expected = np.array([[float(sp.diff(f, xi).subs(values)) for xi in x] for f in y])
        np.testing.assert_allclose(tangent[e], expected, rtol=1e-13, atol=1e-14)
