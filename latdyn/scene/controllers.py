"""A scene's controllers (SCENE.md ``controllers.NAME``): control laws in the loop.

A controller's ``output`` is an expression in ``t``, the names of the scene's probes (their
current values: its sensors), its ``states``, the scene's ``inputs`` and the controllers defined
before it in the file. ``states: {S: EXPR}`` are its internal states (dS/dt = EXPR for a
continuous controller; S ← S + EXPR/rate once per sample for a sampled one), starting at
``initial: {S: number}`` (default 0). ``rate: HZ`` makes it sampled (zero-order hold); ``limits:
[lo, hi]`` clips its output (not its states). A hinge torque or a load component names a
controller to be driven by its output (:class:`latdyn.scene.inputs.ControllerOutputs`).

This module reads and checks them (the namespace: probes, inputs and controllers share one, a
state is local; a word of the expression language is refused as a name; a controller may read
only those defined before it, so there is no cycle) and holds their SymPy expressions; the time
loop evaluates them (:mod:`latdyn.timeloop.sampling`).
"""
from __future__ import annotations

import re
from dataclasses import field
from typing import Any

from latdyn.errors import SceneError, show_value
from latdyn.records import record
from latdyn.scene.expressions import ACTIVE_PARAMETERS, parse_named_expression

__all__ = ["Controller", "CONTROLLER_KEYS", "controller_names", "read_controllers"]

CONTROLLER_KEYS = ("output", "states", "initial", "rate", "limits")
#: probes a continuous controller may not read (their value is not a function of the state it
#: could differentiate, or needs the whole model's sums): a sampled one may
_SAMPLED_ONLY = ("energy", "momentum")
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")


@record
class Controller:
    """One controller as the scene gives it, with its expressions read.

    ``reads``: the probes, inputs and earlier controllers its expressions name (file order of
    each kind: probes, then inputs, then controllers); ``symbols``: the SymPy symbols of ``t``,
    of ``reads`` and of its states, the arguments of ``output_expr`` and ``state_exprs``."""

    name: str
    output_text: Any
    states: tuple[str, ...] = ()
    state_texts: tuple = ()
    initial: dict[str, float] = field(default_factory=dict)
    rate: float | None = None
    limits: tuple[float, float] | None = None
    reads: tuple[str, ...] = ()
    symbols: tuple = ()
    output_expr: Any = None
    state_exprs: tuple = ()
    _functions: Any = field(default=None, repr=False, compare=False)
    _output_gradient: Any = field(default=None, repr=False, compare=False)

    @property
    def sampled(self) -> bool:
        return self.rate is not None

    @property
    def output_names_t(self) -> bool:
        """Whether the output's expression names t (its explicit ∂f/∂t enters where a row's or a step's time moves)."""
        return self.output_expr is not None and bool(self.symbols) and self.symbols[0] in getattr(
            self.output_expr, "free_symbols", ())

    @property
    def states_name_t(self) -> bool:
        """Whether a state's rate expression names t."""
        return bool(self.symbols) and any(self.symbols[0] in getattr(f, "free_symbols", ()) for f in self.state_exprs)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_functions"] = state["_output_gradient"] = None  # lambdified functions do not pickle: made again on use
        return state

    def functions(self):
        """(output, [dS/dt or the per-sample increment rate of each state]) as Python functions of
        ``(t, *reads values, *state values)`` (``math`` lambdas: one float each)."""
        if self._functions is None:
            import sympy as sp

            make = lambda e: sp.lambdify(self.symbols, e, modules=["math", "numpy"])  # noqa: E731
            self._functions = (make(self.output_expr), [make(e) for e in self.state_exprs])
        return self._functions

    def output_gradient(self, *arguments):
        """∂f/∂(reads, states) of the output f before saturation at ``arguments`` = (t, *reads values, *state
        values): one value per read (probes, inputs, earlier controllers: ∂f/∂y_j) and per state, in the order
        of ``symbols[1:]`` (float64 array). SymPy's derivatives of ``output_expr``, lambdified once and shared
        by every sensitivity that needs them (latdyn/analyses/sensitivities.py ControllerTerms,
        ControllerStates, SampledTerms; latdyn/analyses/controller_probe_sensitivities.py)."""
        import numpy as np

        if self._output_gradient is None:
            import sympy as sp

            self._output_gradient = sp.lambdify(self.symbols, [sp.diff(self.output_expr, x) for x in self.symbols[1:]],
                                                modules=["math", "numpy"])
        return np.array(self._output_gradient(*arguments), float).reshape(len(self.symbols) - 1)

    def clip(self, value: float) -> float:
        """The output after saturation (``limits``)."""
        if self.limits is None:
            return value
        return min(max(value, self.limits[0]), self.limits[1])


def _fail(file, key, expected, got=None):
    raise SceneError(file, key, expected if got is None else f"{expected}, got {show_value(got)}")


def controller_names(value, file: str, reserved: tuple, taken: dict[str, str]) -> tuple[str, ...]:
    """The names of ``controllers`` (checked: an identifier, no word of the expression language,
    not an input's name; ``taken``: name -> what already holds it)."""
    if value is None:
        return ()
    if not isinstance(value, dict):
        _fail(file, "controllers", "expected a mapping of controller names to controllers "
                                   "{NAME: {output: EXPR, ...}}", value)
    for name in value:
        key = f"controllers.{name}"
        if not isinstance(name, str) or not _IDENTIFIER.fullmatch(name):
            _fail(file, key if isinstance(name, str) else "controllers",
                  "expected a controller name that an expression can use: a letter or _ followed by "
                  "letters, digits or _", name)
        if name in reserved:
            _fail(file, key, "a word of the expression language cannot name a controller; expected a name "
                             f"other than {', '.join(reserved)}", name)
        if name in taken:
            _fail(file, key, f"{name!r} already names {taken[name]}; probes, inputs and controllers share "
                             "one namespace: expected another name", name)
    return tuple(value)


def _number(value, file, key, *, positive=False) -> float:
    """A number of ``rate``, ``limits`` or ``initial``: as every number of a scene, a constant expression (of
    ``parameters``, recorded as their use at ``key``) or a plain number."""
    import math

    from latdyn.scene.expressions import parse_time_function

    if isinstance(value, str):
        function = parse_time_function(value, file, key)
        if not function.is_constant:
            _fail(file, key, "expected a constant (a number or an expression without t)", value)
        value = function.value(0.0)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(file, key, "expected a number", value)
    try:
        x = float(value)
    except OverflowError:
        _fail(file, key, "expected a finite number", value)
    if not math.isfinite(x) or (positive and not x > 0):
        _fail(file, key, "expected a positive number" if positive else "expected a finite number", value)
    return x


def _later_or_self(text, name: str, order: tuple, file, key, probe_controllers: dict) -> None:
    """Refuse a controller named in ``text`` that is ``name`` itself or defined after it (directly,
    or through a probe that records it), before the expression is read."""
    if not isinstance(text, str):
        return
    words = set(_IDENTIFIER.findall(text))
    here = order.index(name)
    for word in words:
        target = word if word in order else probe_controllers.get(word)
        if target is None:
            continue
        via = "" if target == word else f" (through the probe {word!r}, which records it)"
        if target == name:
            _fail(file, key, f"controller {name!r} reads its own output{via}: a cycle; expected an expression "
                             "in its sensors, states, inputs and the controllers defined before it", word)
        if order.index(target) > here:
            _fail(file, key, f"controller {target!r} is defined later in the file{via}; a controller reads only "
                             "those defined before it (which also rules out cycles): expected it earlier", word)


def read_controllers(value, file: str, order: tuple, probes: list, inputs: tuple,
                     reserved: tuple) -> dict[str, Controller]:
    """Every controller of ``controllers`` (names ``order``, checked by :func:`controller_names`)
    read and checked against the scene's ``probes`` (loader Probes) and ``inputs`` (names);
    ``reserved``: the words of the expression language."""
    if not order:
        return {}
    kinds = {p.name: p.kind for p in probes}
    probe_controllers = {p.name: p.controller for p in probes if p.kind == "controller"}
    out: dict[str, Controller] = {}
    for name in order:
        key = f"controllers.{name}"
        spec = value[name]
        if not isinstance(spec, dict):
            _fail(file, key, "expected a controller: a mapping with output and optionally states, initial, "
                             "rate, limits", spec)
        for k in spec:
            if k not in CONTROLLER_KEYS:
                _fail(file, f"{key}.{k}", f"unknown key; allowed keys here: {', '.join(CONTROLLER_KEYS)}")
        if "output" not in spec:
            _fail(file, f"{key}.output", "missing required key 'output'")
        rate = _number(spec["rate"], file, f"{key}.rate", positive=True) if spec.get("rate") is not None else None
        limits = None
        if spec.get("limits") is not None:
            lim = spec["limits"]
            if not isinstance(lim, (list, tuple)) or len(lim) != 2:
                _fail(file, f"{key}.limits", "expected saturation limits [lo, hi] of the output", lim)
            lo, hi = (_number(x, file, f"{key}.limits[{i}]") for i, x in enumerate(lim))
            if not lo < hi:
                _fail(file, f"{key}.limits", "expected lo < hi", lim)
            limits = (lo, hi)
        states_spec = spec.get("states") or {}
        if not isinstance(states_spec, dict):
            _fail(file, f"{key}.states", "expected a mapping of state names to their rates {S: EXPR}", states_spec)
        global_names = set(kinds) | set(inputs) | set(order)
        parameter_names = set(ACTIVE_PARAMETERS.get().values) if ACTIVE_PARAMETERS.get() is not None else set()
        for s in states_spec:
            skey = f"{key}.states.{s}"
            if not isinstance(s, str) or not _IDENTIFIER.fullmatch(s):
                _fail(file, skey if isinstance(s, str) else f"{key}.states",
                      "expected a state name that an expression can use: a letter or _ followed by letters, "
                      "digits or _", s)
            if s in reserved:
                _fail(file, skey, "a word of the expression language cannot name a state; expected another name", s)
            if s in global_names:
                _fail(file, skey, f"{s!r} already names a probe, an input or a controller; expected a state name "
                                  "of its own", s)
            if s in parameter_names:   # its name replaced by the value in every text: the state never read
                _fail(file, skey, f"{s!r} already names a parameter (parameters.{s}), whose value replaces the name "
                                  "in every expression, so the state would never be read; expected a state name "
                                  "of its own", s)
        states = tuple(states_spec)
        initial_spec = spec.get("initial") or {}
        if not isinstance(initial_spec, dict):
            _fail(file, f"{key}.initial", "expected a mapping of state names to numbers {S: number}", initial_spec)
        initial = {s: 0.0 for s in states}
        for s, v in initial_spec.items():
            if s not in states:
                _fail(file, f"{key}.initial.{s}", f"expected one of the controller's states "
                                                  f"({', '.join(states) if states else 'it has none'})", s)
            initial[s] = _number(v, file, f"{key}.initial.{s}")
        earlier = order[:order.index(name)]
        names = tuple(kinds) + tuple(inputs) + earlier
        what = ("the names of probes (" + (", ".join(kinds) or "none") + "), inputs ("
                + (", ".join(inputs) or "none") + "), controllers defined before it ("
                + (", ".join(earlier) or "none") + ") and its states (" + (", ".join(states) or "none") + ")")
        texts = [(f"{key}.output", spec["output"])] + [(f"{key}.states.{s}", states_spec[s]) for s in states]
        exprs = []
        for k, text in texts:
            _later_or_self(text, name, order, file, k, probe_controllers)
            symbols, expr = parse_named_expression(text, names + states, file, k, what)
            exprs.append((k, expr))
        used = set().union(*(e.free_symbols for _, e in exprs))
        used_names = {s.name for s in used}
        reads = tuple(n for n in names if n in used_names)
        if rate is None:
            for n in reads:
                if kinds.get(n) in _SAMPLED_ONLY:
                    k = next(k for k, e in exprs if n in {s.name for s in e.free_symbols})
                    _fail(file, k, f"a continuous controller cannot read the {kinds[n]} probe {n!r} (not a function "
                                   "of the coordinates it can differentiate); expected a sampled controller "
                                   f"(rate: HZ) to read it", n)
        import sympy as sp

        symbols = (sp.Symbol("t", real=True), *[sp.Symbol(n, real=True) for n in reads + states])
        out[name] = Controller(name=name, output_text=spec["output"], states=states,
                               state_texts=tuple(states_spec[s] for s in states), initial=initial, rate=rate,
                               limits=limits, reads=reads, symbols=symbols, output_expr=exprs[0][1],
                               state_exprs=tuple(e for _, e in exprs[1:]))
    return out
