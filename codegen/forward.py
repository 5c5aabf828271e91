"""Forward-mode differentiation of a lowered kernel: its tangent-linear program.

A kernel after CSE (:func:`codegen.emit.lower`) is a straight-line program

    t_i = f_i(a, b, …)        (temporaries, each a short expression of inputs and earlier t's)
    y_r = g_r(a, b, …)        (the outputs' entries)

Its derivative in ``D`` directions is the program that carries, next to every t_i, its tangent
ṫ_i[d] = Σ_a (∂f_i/∂a) ȧ[d] (d = 0 … D − 1): classical forward-mode automatic differentiation by
source transformation.  Each ∂f_i/∂a is the SymPy derivative of one short CSE line, so the cost of
generating the tangent is linear in the length of the program, and the result is exact (no step).
The seeds ȧ of the inputs are given (:class:`codegen.ir.Tangent`: for the element, the first
variation of the geometry block under the configuration update); an input without a seed, and
every temporary that depends on none, has an identically zero tangent and emits nothing
(sparsity: an end's quantities have no tangent in the other end's directions).  A partial used by
more than one direction is a temporary of its own; what no output needs is dropped.

The output's columns may be combinations of the directions seeded (``Tangent.columns``): the
element's force is invariant under a rigid translation, so seeding that translation instead of
one end's gives three directions whose tangents cancel line by line and are pruned, and
∂/∂d₁ = (rigid) − ∂/∂d₂ costs a sign.

A statement whose definition is not the function to differentiate (the branch-free jet of θ/sin θ,
whose |x − x_s| has no derivative at the switch) carries its partials as a rule
(``Tangent.partials``), with the definitions they use (``Tangent.definitions``).
"""
from __future__ import annotations

import dataclasses

from .ir import Output, Tangent

class TangentError(ValueError):
    """A tangent that cannot be emitted (a derivative that is not a closed form, a bad request)."""


def _cheap(expr) -> bool:
    """A number, a symbol or a negated symbol: used in place, never a temporary of its own."""
    if expr.is_Number or expr.is_Symbol:
        return True
    return expr.is_Mul and len(expr.args) == 2 and expr.args[0].is_Number and expr.args[1].is_Symbol


def tangent_linear(temporaries: list, outputs: list[list], spec) -> tuple[list, list[list], object, int]:
    """The tangent-linear program of a lowered kernel (module docstring).

    ``temporaries`` and ``outputs`` are :class:`codegen.emit.LoweredKernel`'s (SymPy); ``spec.tangent``
    (a :class:`codegen.ir.Tangent`) names the output to differentiate, the seeds and the directions.
    The derivatives are taken in SymEngine (each line crosses once, codegen/emit.py's converters).
    Returns (temporaries, outputs, spec, op count) of the kernel with the tangent appended as the
    output ``spec.tangent.name`` of shape (size of the differentiated output, directions), row-major:
    entry [r, d] = ∂y_r/∂q_d; the operations are counted by SymEngine (``symengine.count_ops``).
    """
    import symengine as se

    from .emit import _evaluation_order, to_symengine

    request: Tangent = spec.tangent
    D = request.directions
    names = [out.name for out in spec.outputs]
    if request.of not in names:
        raise TangentError(f"kernel {spec.name!r}: no output {request.of!r} to differentiate")
    cache: dict = {}
    values = to_symengine([value for _, value in temporaries], cache)
    program = [(se.Symbol(symbol.name), value) for (symbol, _), value in zip(temporaries, values)]
    defined = {symbol.name for symbol, _ in temporaries}
    zero = se.Integer(0)
    statements: list = []
    dot: dict = {}

    def define(name: str, value):
        if _cheap(value):
            return value
        symbol = se.Symbol(name)
        statements.append((symbol, value))
        return symbol

    for name, column in request.seeds.items():
        if len(column) != D:
            raise TangentError(f"kernel {spec.name!r}: seed of {name} has {len(column)} directions, not {D}")
        column = to_symengine(column, cache)
        if any(c != zero for c in column):
            dot[se.Symbol(name)] = [define(f"{name}_D{d}", c) for d, c in enumerate(column)]

    def rule_partials(symbol) -> dict | None:
        rule = request.partials.get(symbol.name)
        if rule is None:
            return None
        partials = {}
        for argument, partial in rule.items():
            (partial,) = to_symengine([partial], cache)
            for needed in sorted(partial.free_symbols, key=str):
                if needed.name not in defined and needed.name in request.definitions:
                    (definition,) = to_symengine([request.definitions[needed.name]], cache)
                    statements.append((needed, definition))
                    defined.add(needed.name)
            partials[se.Symbol(argument)] = partial
        return partials

    def total(label: str, value, partials: dict | None) -> list:
        """Σ_a (∂value/∂a) ȧ[d] for every direction d (0 where no argument moves in d)."""
        if partials is None:
            moving = sorted((a for a in value.free_symbols if a in dot), key=str)
            partials = {a: se.diff(value, a) for a in moving}
        terms: list[list] = [[] for _ in range(D)]
        for a, partial in partials.items():
            if a not in dot or partial == zero:
                continue
            directions = [d for d in range(D) if dot[a][d] != zero]
            if not directions:
                continue
            if len(directions) > 1:
                partial = define(f"{label}_by_{a.name}", partial)
            for d in directions:
                terms[d].append(partial * dot[a][d])
        return [se.Add(*row) if row else zero for row in terms]

    for symbol, value in program:
        statements.append((symbol, value))
        rows = total(symbol.name, value, rule_partials(symbol))
        if any(r != zero for r in rows):
            dot[symbol] = [define(f"{symbol.name}_D{d}", r) for d, r in enumerate(rows)]

    flat_outputs = to_symengine([e for row in outputs for e in row], cache)
    start = sum(out.size for out in spec.outputs[:names.index(request.of)])
    differentiated = flat_outputs[start:start + spec.outputs[names.index(request.of)].size]
    tangent = []
    for r, expr in enumerate(differentiated):
        rows = total(f"{request.of}_{r}", expr, None)
        if request.columns is not None:  # the output's columns as combinations of the directions seeded
            rows = [se.Add(*[se.sympify(c) * rows[d] for d, c in column.items()]) for column in request.columns]
        tangent.extend(rows)
    ordered = _evaluation_order(statements, flat_outputs + tangent)
    for symbol, value in ordered:
        if value.atoms(se.Derivative, se.Subs):
            raise TangentError(f"kernel {spec.name!r}: the derivative {symbol.name} is not a closed form "
                               f"({value}); give the statement a rule (Tangent.partials)")
    # counted in SymEngine (SymPy's count_ops takes minutes on a 3D tangent): a subtraction counts as two
    op_count = sum(se.count_ops(value) for _, value in ordered) + sum(se.count_ops(e) for e in flat_outputs + tangent)
    back = {se.Symbol(symbol.name): symbol for symbol, _ in temporaries}
    back.update({original: copy for original, copy in zip(values, (value for _, value in temporaries))})
    ordered = [(_to_sympy(symbol, back), _to_sympy(value, back)) for symbol, value in ordered]
    tangent = [_to_sympy(expr, back) for expr in tangent]
    shape = (len(differentiated), D if request.columns is None else len(request.columns))
    extended = dataclasses.replace(spec, outputs=[*spec.outputs, Output(request.name, shape, tangent, request.doc)])
    return ordered, [*outputs, tangent], extended, int(op_count)


def _refuse(node):
    raise TangentError(f"cannot convert {node} ({type(node).__name__}) of a tangent program to SymPy")


def _to_sympy(expr, cache: dict):
    """A SymEngine expression of the tangent program in SymPy, built unevaluated (memoised in ``cache``):
    codegen/emit.py's ``to_sympy`` with ``evaluate=False``, a node it cannot convert refused."""
    from .emit import to_sympy

    return to_sympy(expr, cache, evaluate=False, refuse=_refuse)
