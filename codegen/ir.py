"""The intermediate representation handed from derivation to emission.

A :class:`KernelSpec` is a batch kernel: every input is a flat block of
``width`` float64 scalars per element, every output a block of ``prod(shape)``
scalars per element written row-major.  The same spec is printed to NumPy
(vectorised over the leading element axis) and to C99 (a loop over elements),
so both backends share one argument convention, documented in
``docs/kernels.md`` and in :data:`ARGUMENTS`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from math import prod

import sympy as sp


@dataclass(frozen=True)
class Argument:
    """One input block: ``width`` scalars per element, named ``name``."""

    name: str
    width: int
    doc: str

    def symbols(self) -> list[sp.Symbol]:
        """The scalar symbols of this block, ``name_0 … name_{width-1}``."""
        return [sp.Symbol(f"{self.name}_{k}") for k in range(self.width)]


@dataclass
class Output:
    """One output block with its row-major expressions."""

    name: str
    shape: tuple[int, ...]
    expressions: list[sp.Expr]
    doc: str = ""

    def __post_init__(self) -> None:
        if len(self.expressions) != prod(self.shape):
            raise ValueError(
                f"output {self.name!r}: {len(self.expressions)} expressions for shape {self.shape}"
            )

    @property
    def size(self) -> int:
        return prod(self.shape)


@dataclass(frozen=True)
class Tangent:
    """The derivative of one output, emitted as the tangent-linear program of the lowered kernel
    (:mod:`codegen.forward`): a new output ``name`` of shape (size of ``of``, ``directions``),
    entry [r, d] = ∂of_r/∂q_d.

    ``seeds``: input scalar name (``geometry_7``) → its derivative in each direction (expressions of
    the inputs); an input not named does not move.  ``partials``: statement name → {argument name:
    ∂statement/∂argument}, for a statement whose definition is not the function to differentiate
    (the jet of θ/sin θ); ``definitions``: name → expression of what those partials use, added where
    the kernel does not compute it.  ``columns``: the output's columns as combinations of the seeded
    directions (default: direction d is column d).
    """

    of: str
    name: str
    seeds: dict
    directions: int
    doc: str = ""
    partials: dict = field(default_factory=dict)
    definitions: dict = field(default_factory=dict)
    #: the output's columns as combinations of the seeded directions ({direction: coefficient} each);
    #: None: column d is direction d
    columns: list | None = None


@dataclass
class KernelSpec:
    """A batched kernel ``name(inputs…) -> outputs…``."""

    name: str
    doc: str
    inputs: list[Argument]
    outputs: list[Output]
    variant: str = "default"
    equations: str = ""
    # Named intermediate results, evaluated in order before the outputs; later
    # intermediates and the outputs may refer to earlier ones by their symbol.
    intermediates: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)  # the CR-4402 equations this kernel implements, for the file header
    extra: dict = field(default_factory=dict)
    #: an output differentiated by forward mode after CSE (codegen/forward.py); its output is added by emit.lower
    tangent: Tangent | None = None

    def eliminated_outputs(self) -> list[list[sp.Expr]]:
        """The outputs with every intermediate substituted (for direct evaluation in tests)."""
        values: dict = {}
        for symbol, expr in self.intermediates:
            values[symbol] = expr.xreplace(values)
        return [[e.xreplace(values) for e in out.expressions] for out in self.outputs]

    def check_free_symbols(self) -> None:
        """Refuse a kernel whose expressions use a symbol that is not an input."""
        allowed = {s for a in self.inputs for s in a.symbols()}
        for symbol, expr in self.intermediates:
            stray = set(expr.free_symbols) - allowed
            if stray:
                names = ", ".join(sorted(str(s) for s in stray))
                raise ValueError(
                    f"kernel {self.name!r}, intermediate {symbol}: symbol(s) {names} are not inputs "
                    "or earlier intermediates"
                )
            allowed.add(symbol)
        for out in self.outputs:
            for k, expr in enumerate(out.expressions):
                stray = set(expr.free_symbols) - allowed
                if stray:
                    names = ", ".join(sorted(str(s) for s in stray))
                    raise ValueError(
                        f"kernel {self.name!r}, output {out.name}[{k}]: symbol(s) {names} "
                        f"are not inputs (inputs: {', '.join(a.name for a in self.inputs)})"
                    )
