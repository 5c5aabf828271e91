"""A scene's laws in C: its functions of time and its hinge laws, for the compiled time step.

The element kernels are derived once and committed (``generated/``); the laws of a scene
(prescribed motion, loads, hinge torques, springs and dampers; SCENE.md "Expressions") are
known only when the scene is read. They go through the same pipeline on a smaller scale:
the SymPy expressions that :mod:`latdyn.scene.expressions` parsed and differentiated, CSE
(``sympy.cse``, one block per law: its value shares subexpressions with its derivatives),
the C99 printer of :mod:`codegen.emit` (no ``pow()`` for small integer and half-integer
powers), and the template ``codegen/templates/laws.c.j2`` with the file stamp. :mod:`latdyn.assembly.compiled_laws`
compiles the unit once per distinct source into the kernel cache and calls it from C, so
that no law is evaluated in Python inside the time loop.

The unit's two functions (the ABI :mod:`latdyn.assembly.compiled_laws` and ``latdyn/assembly/csrc/newton_step.c`` use):

``void latdyn_time_laws(double t, double *out)``
    every function of time at ``t``: ``out[3k], out[3k+1], out[3k+2]`` = f_k, df_k/dt, d²f_k/dt².
``void latdyn_hinge_laws(int64_t k, double theta, double theta_dot, double t, double *out)``
    hinge law k at (θ, θ̇, t): ``out[0..2]`` = f, ∂f/∂θ, ∂f/∂θ̇.
``void latdyn_controller_laws(int64_t k, double t, const double *s, double *out)``
    continuous controller k (SCENE.md ``controllers``) at t with the arguments ``s`` = the values of
    the m probes it reads, then of its p states: ``out[0]`` its output y (before saturation),
    ``out[1 + i]`` = ∂y/∂s_i (i < m + p), then for each state j at ``(1 + j)(1 + m + p)`` its rate
    f_j = dS_j/dt and ∂f_j/∂s_i, all exact ((1 + p)(1 + m + p) values; without states, y and ∂y/∂s).
``void latdyn_sampled_laws(int64_t k, double t, const double *s, double *out)``
    sampled controller k (SCENE.md ``controllers.NAME.rate``; :mod:`latdyn.timeloop.sampling`) at its
    sample instant t with the arguments ``s`` = the values of the m probes it reads, then of its p
    states: ``out[0]`` its output y (before saturation), ``out[1 + j]`` the rate EXPR_j of state j
    (the sample advances S_j by EXPR_j / rate); 1 + p values, no derivatives (a held output enters
    no matrix).
``void latdyn_bind_inputs(const double *inputs, const double *controllers)``
    the scene's inputs (SCENE.md ``inputs``; :mod:`latdyn.scene.inputs`) and its controllers'
    outputs: a law that names input i reads ``inputs[i]`` at each call, one that names controller k
    ``controllers[k]``, arrays the runtime owns (inputs set from outside, outputs held by the time
    loop). They are constant between settings: they add nothing to the time derivatives. A
    controller law that reads another controller's output takes it as an argument (``s``), not
    from ``controllers``: its caller passes the output at the state it evaluates.

Laws are plain data here (:class:`TimeLaw`, :class:`HingeLawC`), so that this module does
not import the runtime. A table in t is linear between its points and constant beyond them,
evaluated as ``numpy.interp`` does; its rate is the slope of the segment that starts at or
before t (0 beyond the ends), its acceleration 0 (:class:`latdyn.scene.expressions.TimeFunction`).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .emit import COMMAND, MARKER, CPrinter, EmitError, _comment_text, _environment, formulation_hash, tool_versions

#: The C names of the law variables (latdyn.scene.expressions: ``t``; hinge laws ``theta``, ``theta_dot``, ``t``).
VARIABLES = ("t", "theta", "theta_dot")


@dataclass(frozen=True)
class TimeLaw:
    """A scalar function of time: ``kind`` is ``"constant"`` (``value``), ``"table"``
    (``times``, ``values``) or ``"expression"`` (``variable`` and ``expressions`` = f, f′, f″)."""

    kind: str
    text: str
    value: float = 0.0
    times: tuple = ()
    values: tuple = ()
    variable: sp.Symbol | None = None
    expressions: tuple = ()


@dataclass(frozen=True)
class HingeLawC:
    """A hinge law: a function of time (``time``; its θ and θ̇ derivatives are 0) or an
    expression (``variables`` = (θ, θ̇, t), ``expressions`` = f, ∂f/∂θ, ∂f/∂θ̇)."""

    text: str
    time: TimeLaw | None = None
    variables: tuple = ()
    expressions: tuple = ()


@dataclass(frozen=True)
class ControllerLawC:
    """A continuous controller: ``variables`` = (t, s_0, s_1, …) its time and its arguments (the
    probes it reads, then its states), ``expressions`` = y, ∂y/∂s_0, ∂y/∂s_1, …, then each state's
    rate and its derivatives in the same order (the module docstring's layout)."""

    text: str
    variables: tuple = ()
    expressions: tuple = ()


@dataclass(frozen=True)
class SampledLawC:
    """A sampled controller: ``variables`` = (t, s_0, s_1, …) its sample instant and its arguments
    (the probes it reads, then its states), ``expressions`` = y, then each state's rate EXPR_j."""

    text: str
    variables: tuple = ()
    expressions: tuple = ()


class _LawPrinter(CPrinter):
    """The element printer, with ``Heaviside(x, h0)`` as a call of the unit's own helper."""

    def _print_Heaviside(self, expr):
        at_zero = expr.args[1] if len(expr.args) > 1 else sp.S.Half
        return f"latdyn_heaviside({self._print(expr.args[0])}, {self._print(sp.Float(at_zero, 17))})"


def _block(variables: dict, expressions, out: str, first: int, signals: dict | None = None) -> list[str]:
    """C statements of one law: CSE temporaries, then ``out[first + i] = ...``; a symbol named
    like a signal of ``signals`` (name -> the C text that reads it) reads it, unless it is one of
    the law's arguments ``variables`` (symbol -> its C name): an argument is read from its argument. A controller law that reads an
    earlier controller's output y_j takes it as its argument ``s[m]``, the value at the state its
    caller evaluates, not the scene's array, which holds y_j at the step's state (before, a
    variable named like a controller read that array: evaluated at a moved state, a chained law
    read a stale y_j)."""
    printer = _LawPrinter()
    signals = signals or {}
    renamed = [sp.sympify(e).xreplace(variables) for e in expressions]
    arguments = set(variables.values())
    named = {s: sp.Symbol(signals[s.name]) for e in renamed for s in e.free_symbols
             if s.name in signals and s not in arguments}
    renamed = [e.xreplace(named) for e in renamed]
    for e in renamed:
        strangers = e.free_symbols - set(variables.values()) - set(named.values())
        if strangers:
            raise EmitError(f"a law uses {', '.join(sorted(map(str, strangers)))}, not one of {', '.join(VARIABLES)}")
    temporaries, reduced = sp.cse(renamed, symbols=sp.numbered_symbols("w"), optimizations="basic")
    lines = []
    try:
        for symbol, value in temporaries:
            lines.append(f"const double {symbol} = {_one_line(printer.doprint(value))};")
        for i, e in enumerate(reduced):
            text = repr(float(e)) if not e.free_symbols else _one_line(printer.doprint(e))
            lines.append(f"{out}[{first + i}] = {text};")
    except (TypeError, ValueError) as error:  # a construct the C printer does not know
        raise EmitError(f"a law cannot be printed in C: {error}") from None
    return lines


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _c_names(symbols, signals: dict | None = None) -> dict:
    """The law's SymPy symbols mapped to plain symbols with the C names (assumptions dropped), but for
    those named like a signal of ``signals``: a law of θ, θ̇, t reads those from the runtime's arrays."""
    return {s: sp.Symbol(s.name) for s in symbols if s.name not in (signals or {})}


def _time_block(law: TimeLaw, out: str, first: int, inputs: dict | None = None) -> dict:
    if law.kind == "constant":
        lines = [f"{out}[{first}] = {float(law.value)!r};", f"{out}[{first + 1}] = 0.0;", f"{out}[{first + 2}] = 0.0;"]
    elif law.kind == "table":
        n = len(law.times)
        times = ", ".join(repr(float(x)) for x in law.times)
        values = ", ".join(repr(float(x)) for x in law.values)
        lines = [f"static const double times[{n}] = {{{times}}};",
                 f"static const double values[{n}] = {{{values}}};",
                 f"latdyn_table(t, {n}, times, values, {out} + {first});",
                 f"{out}[{first + 2}] = 0.0;"]
    elif law.kind == "expression":
        lines = _block(_c_names([law.variable], inputs), law.expressions, out, first, inputs)
    else:
        raise EmitError(f"unknown kind of law {law.kind!r}")
    return {"text": _comment_text(law.text), "lines": lines}


def _hinge_block(law: HingeLawC, inputs: dict | None = None) -> dict:
    if law.time is not None:
        block = _time_block(law.time, "out", 0, inputs)
        # f(t) only: its θ and θ̇ derivatives are zero (out[1] held df/dt: overwritten)
        block["lines"] = [line for line in block["lines"] if not line.startswith(("out[1]", "out[2]"))]
        block["lines"] += ["out[1] = 0.0;", "out[2] = 0.0;"]
        block["text"] = _comment_text(law.text)
        return block
    return {"text": _comment_text(law.text),
            "lines": _block(_c_names(law.variables, inputs), law.expressions, "out", 0, inputs)}


def _controller_block(law: ControllerLawC | SampledLawC, inputs: dict) -> dict:
    """A controller law of its arguments ``s`` (module docstring). An argument that is an earlier controller's output
    is read from ``s`` into a local named as the array's entry ``latdyn_controllers[k]`` was printed, with ``_`` for
    the brackets (``latdyn_controllers_k_``, which sorts among the law's symbols as that name did): SymPy orders a
    sum's terms by their symbols' names, so the printed arithmetic is the one the array's read printed, and where the
    argument is that entry's value (the time step's, csrc/evaluate.c ``controller_outputs``) the bits are too."""
    t, *sensors = law.variables
    variables, aliases = {t: sp.Symbol("t")}, []
    for m, v in enumerate(sensors):
        entry = inputs.get(v.name, "")
        if entry.startswith("latdyn_controllers["):
            local = entry.replace("[", "_").replace("]", "_")
            aliases.append(f"const double {local} = s[{m}];")
            variables[v] = sp.Symbol(local)
        else:
            variables[v] = sp.Symbol(f"s[{m}]")
    return {"text": _comment_text(law.text), "lines": aliases + _block(variables, law.expressions, "out", 0, inputs)}


def laws_source(time_laws: list[TimeLaw], hinge_laws: list[HingeLawC], inputs: tuple = (),
                controllers: tuple = (), controller_laws: tuple = (), sampled_laws: tuple = ()) -> str:
    """The C unit of a scene's laws (see the module docstring); ``inputs``, ``controllers``: the
    names of the scene's inputs and controllers in order. :class:`EmitError` when a law cannot be
    printed in C (the caller then evaluates the laws in Python)."""
    inputs = {**{name: f"latdyn_inputs[{i}]" for i, name in enumerate(inputs)},
              **{name: f"latdyn_controllers[{k}]" for k, name in enumerate(controllers)}}
    template = _environment().get_template("laws.c.j2")
    return template.render(
        marker=MARKER, command=COMMAND, versions=tool_versions(), hash=formulation_hash(), variant=None,
        time_laws=[_time_block(law, "out", 3 * k, inputs) for k, law in enumerate(time_laws)],
        hinge_laws=[_hinge_block(law, inputs) for law in hinge_laws],
        controller_laws=[_controller_block(law, inputs) for law in controller_laws],
        sampled_laws=[_controller_block(law, inputs) for law in sampled_laws],
    )
