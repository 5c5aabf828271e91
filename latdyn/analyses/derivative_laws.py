"""The parameters' derivative laws of the state, compiled: a hinge law's derivative by a parameter that names θ, θ̇
or an input (the torque k (θ₀ − θ) − c θ̇ by k: θ₀ − θ), and the stiffness law of a hinge whose rest angle is a
parameter where that law names them, compiled as the forward step compiles the scene's hinge laws
(:func:`latdyn.assembly.compiled_laws.compile_laws`: the C unit of :mod:`codegen.laws`, from SymPy's expression, in
the kernel cache). Their value f(θ, θ̇, t) is then one C function, ``latdyn_hinge_laws(k, θ, θ̇, t, out)``, that the
per-step Python path (:meth:`latdyn.analyses.sensitivities.ParameterDerivatives._hinge_force`, through ctypes) and
the loop of steps in C (csrc/sensitivity_loop.c, at the hinge's θ, θ̇ in C) both call: the same bits on both paths
(issue 34; latdyn/analyses/sensitivities_in_loop.py). Laws of t alone keep their Python value (the loop tabulates
them per grid point). A law that does not print in C, or no compiler: :func:`DerivativeLaws.of` is None and the
Python path evaluates the law with NumPy, as before; such a run takes every step from Python.

A law naming an input reads it from the array the scene's inputs hold (:attr:`latdyn.scene.inputs.Signals.values`),
bound before each use (:meth:`DerivativeLaws.bind`: a library is shared by every run with the same laws in a
process), so that a value set between runs is the one read.
"""
from __future__ import annotations

import ctypes

import numpy as np

__all__ = ["ControllerPartials", "DerivativeLaws", "chained_outputs", "of_the_state"]

_LAW = ctypes.CFUNCTYPE(None, ctypes.c_int64, ctypes.c_double, ctypes.c_double, ctypes.c_double,
                        ctypes.POINTER(ctypes.c_double))


def of_the_state(law) -> bool:
    """Whether a law's value depends on the state or the inputs (θ, θ̇ or an input), not on t alone."""
    return bool({"theta", "theta_dot"} & set(law.depends_on)) or bool(law.input_names)


class DerivativeLaws:
    """The compiled derivative laws of the state of one run's parameters (module docstring), numbered in the order
    of :attr:`laws`."""

    def __init__(self, scene, laws: list, compiled):
        self.scene, self.laws, self.compiled = scene, laws, compiled
        self._index = {id(law): i for i, law in enumerate(laws)}
        self.address = compiled.hinge_laws
        self._function = _LAW(self.address)
        self._out = (ctypes.c_double * 3)()
        self._signals = _Signals(scene)

    @classmethod
    def of(cls, owner) -> "DerivativeLaws | None":
        """The compiled derivative laws of the state of ``owner`` (a ParameterDerivatives) with C kernels: its hinge
        uses' derivative laws of the state and, for a rest angle, the hinge's stiffness law of the state; None where
        there is none, no C kernels, or they do not compile (the Python path's NumPy values, module docstring)."""
        if getattr(owner.kernels, "backend", None) != "c":
            return None
        laws, seen = [], set()

        def add(law):
            if of_the_state(law) and id(law) not in seen:
                seen.add(id(law))
                laws.append(law)

        hinges = owner.model.hinges
        for j, which, by_column in owner._hinge_uses():   # noqa: SLF001
            for law in by_column.values():
                add(law)
            if which == "rest_angle":
                add(hinges[j].stiffness)
        if not laws:
            return None
        return cls.of_laws(owner.scene, laws)

    @classmethod
    def of_laws(cls, scene, laws: list) -> "DerivativeLaws | None":
        """``laws`` (hinge laws of the state of ``scene``) compiled, numbered in their order; None where they do not
        compile or there is no compiler."""
        from latdyn.assembly.compiled_laws import LawsUnavailable, compile_laws

        outputs = getattr(scene, "controller_outputs", None)
        signals = (tuple(scene.inputs.names) if scene.inputs is not None else (),
                   tuple(outputs.names) if outputs is not None else ())
        try:
            compiled = compile_laws([], laws, signals)
        except LawsUnavailable:
            return None
        return cls(scene, laws, compiled)

    def index(self, law) -> int:
        """The law's number among :attr:`laws`, −1 where it is not one (a law of t alone)."""
        return self._index.get(id(law), -1)

    def bind(self) -> None:
        """Point the library at the scene's inputs and controllers' outputs (module docstring)."""
        self._signals.bind(self.compiled)

    def value(self, law, theta: float, rate: float, t: float) -> float:
        """f(θ, θ̇, t) of ``law``: the compiled law's where it is one of :attr:`laws`, else the law's own value."""
        i = self._index.get(id(law), -1)
        if i < 0:
            return law.value(theta, rate, t)
        self.bind()
        self._function(i, float(theta), float(rate), float(t), self._out)
        return float(self._out[0])

    def values(self, law, theta: float, rate: float, t: float) -> tuple:
        """(f, ∂f/∂θ, ∂f/∂θ̇) of ``law`` at (θ, θ̇, t): the compiled law's where it is one of :attr:`laws`, else the
        law's own (the work accounts' laws of the state: latdyn/analyses/energy_sensitivities.py ``account_laws``)."""
        i = self._index.get(id(law), -1)
        if i < 0:
            return law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)
        self.bind()
        self._function(i, float(theta), float(rate), float(t), self._out)
        return float(self._out[0]), float(self._out[1]), float(self._out[2])


class _Signals:
    """The arrays of a scene's inputs and controllers' outputs that its compiled laws read (module docstring)."""

    def __init__(self, scene):
        inputs, outputs = scene.inputs, getattr(scene, "controller_outputs", None)
        self.inputs = inputs.values if inputs is not None and len(inputs) else np.zeros(1)
        self.outputs = outputs.values if outputs is not None and len(outputs) else np.zeros(1)
        self.any = bool(inputs is not None and len(inputs)) or bool(outputs is not None and len(outputs))

    def bind(self, compiled) -> None:
        if self.any:
            compiled.bind_inputs(self.inputs, self.outputs)


_CONTROLLER_LAW = ctypes.CFUNCTYPE(None, ctypes.c_int64, ctypes.c_double, ctypes.POINTER(ctypes.c_double),
                                   ctypes.POINTER(ctypes.c_double))


def chained_outputs(terms) -> list:
    """The continuous controllers without states whose outputs (and their derivatives by what they read) a chain
    through a parameter needs, in file order (ControllerTerms.add: dy_k/dp = ∂f_k/∂p + Σ_j ∂f_k/∂y_j dy_j/dp): those
    that read an earlier controller or are read by one, among the controllers a parameter's slope reaches (those with
    partials, those reading a force whose own laws a parameter moves, and every reader of one, transitively) and the
    controllers they read (transitively)."""
    continuous = [c for c in terms.continuous if not c.states]
    names = {c.name for c in terms.continuous}
    reads = {c.name: [r for r in c.reads if r in names] for c in continuous}
    #: a parameter's slope starts at a controller with partials ∂f/∂p, or at one reading a force whose own laws a
    #: parameter moves (its ∂f/∂s ∂F/∂p, ControllerTerms.sensed_force_slopes), partials or none
    reached = set(terms.partials) | {name for name, forces in terms.forces_read.items() if forces}
    for c in continuous:   # file order: a controller reads only earlier ones
        if any(r in reached for r in reads[c.name]):
            reached.add(c.name)
    needed = set(reached)
    for c in reversed(continuous):
        if c.name in needed:
            needed.update(reads[c.name])
    read = {r for c in continuous if c.name in needed for r in reads[c.name]}
    return [c.name for c in continuous if c.name in needed and (reads[c.name] or c.name in read)]


class ControllerPartials:
    """The continuous controllers' outputs' derivatives by the parameters, ∂f/∂p (t, s, S) of
    :class:`latdyn.analyses.sensitivities.ControllerTerms`, compiled as the step's controller laws are (each one a
    controller law of the same arguments: ``latdyn_controller_laws(k, t, s, out)``, its ``out[0]``): the one C function
    the per-step Python path (:meth:`ControllerTerms.add`, through ctypes) and the loop of steps in C call. Numbered in
    the order of ``ControllerTerms.partials`` (controller, then column); after them, of each such controller with limits,
    its output f itself (:attr:`outputs`), whose value decides whether it is clipped (ControllerTerms.add) on both
    paths, then of each controller of a chain (:func:`chained_outputs`) the output f, whose value a later controller
    reads and whose derivatives by what it reads (the law's ``out[1:]``: :meth:`gradient`) carry the earlier
    controllers' slopes, then of each controller that reads a force whose own laws a parameter moves the output f, whose
    derivative by that force carries the force's ∂F/∂p (ControllerTerms.sensed_force_slopes); last, the states' rates' partials ∂(dS/dt)/∂p (``ControllerTerms.rate_partials``, which
    ControllerStates reads through :meth:`value`)."""

    def __init__(self, uses: list, compiled, width: int, scene, outputs: dict, rate_uses: list = ()):
        self.uses = uses   # (controller name, column, the partial's lambda) in their law's order
        #: controller name -> the number of its output's law (controllers with limits and partials)
        self.outputs = outputs
        #: the states' rates' partials: (controller name, column, state, the partial's lambda), numbered after the rest
        self.rate_uses = list(rate_uses)
        first = len(uses) + len(outputs)
        self._index = {**{id(partial): i for i, (_, _, partial) in enumerate(uses)},
                       **{id(partial): first + i for i, (_, _, _, partial) in enumerate(self.rate_uses)}}
        self.address = compiled.controller_laws
        self.compiled = compiled
        self._function = _CONTROLLER_LAW(self.address)
        self._arguments = (ctypes.c_double * max(width, 1))()
        self._out = (ctypes.c_double * (1 + max(width, 1)))()
        self._signals = _Signals(scene)

    @classmethod
    def of(cls, terms, expressions: dict, rate_expressions: dict | None = None) -> "ControllerPartials | None":
        """The compiled partials of ``terms`` (a ControllerTerms; ``expressions``: controller name -> {column: the
        partial's SymPy expression}; ``rate_expressions``: controller name -> {column: {state: its rate's partial}},
        of ``terms.rate_partials``, None: none); None without C kernels, without partials, or where they do not
        compile."""
        from types import SimpleNamespace

        from latdyn.assembly.compiled_laws import LawsUnavailable, compile_laws

        owner = terms.owner
        rate_expressions = rate_expressions or {}
        #: controllers with states and limits: their outputs compiled, which decide the clip on both paths
        stated = [c.name for c in terms.continuous if c.states and c.limits is not None]
        #: controllers reading a force whose own laws a parameter moves: their outputs' derivatives ∂f/∂s carry its
        #: ∂F/∂p (ControllerTerms.sensed_force_slopes) on both paths
        readers = [c.name for c in terms.continuous if not c.states and terms.forces_read.get(c.name)]
        if getattr(owner.kernels, "backend", None) != "c" or not (terms.partials or rate_expressions or stated
                                                                   or readers):
            return None
        by_name = {c.name: c for c in terms.continuous}
        uses, laws = [], []
        for name, by_column in terms.partials.items():
            c = by_name.get(name)
            if c is None:   # a sampled controller's (SampledTerms): its lambdas
                continue
            for column, partial in by_column.items():
                uses.append((name, column, partial))
                law = SimpleNamespace(name=f"{name}.d{column}", symbols=c.symbols, output_expr=expressions[name][column],
                                      states=tuple(c.states), state_exprs=(), output_text=f"d/dp[{column}]")
                laws.append((law, tuple(c.reads)))
        outputs = {}
        limited = [name for name in dict.fromkeys(name for name, _, _ in uses) if by_name[name].limits is not None]
        limited += [name for name in stated if name not in limited]
        chained = [name for name in chained_outputs(terms) if name not in limited]
        for name in limited + chained + [name for name in readers if name not in limited and name not in chained]:
            c = by_name[name]   # the outputs of those with limits, then of the chains' (after the partials)
            outputs[name] = len(laws)
            laws.append((SimpleNamespace(name=f"{name}.y", symbols=c.symbols, output_expr=c.output_expr,
                                         states=tuple(c.states), state_exprs=(), output_text=c.output_text),
                         tuple(c.reads)))
        rate_uses = []
        for name, by_column in rate_expressions.items():   # the states' rates' ∂f/∂p, each a law of (t, reads, states)
            c = by_name.get(name)
            if c is None:   # a sampled controller's (SampledTerms): its lambdas
                continue
            for column, by_state in by_column.items():
                for state, expr in by_state.items():
                    rate_uses.append((name, column, state, terms.rate_partials[name][column][state]))
                    laws.append((SimpleNamespace(name=f"{name}.{state}.d{column}", symbols=c.symbols, output_expr=expr,
                                                 states=tuple(c.states), state_exprs=(),
                                                 output_text=f"d(d{state}/dt)/dp[{column}]"), tuple(c.reads)))
        if not laws:
            return None
        scene = owner.scene
        held = getattr(scene, "controller_outputs", None)
        signals = (tuple(scene.inputs.names) if scene.inputs is not None else (),
                   tuple(held.names) if held is not None else ())
        try:
            compiled = compile_laws([], [], signals, laws)
        except LawsUnavailable:
            return None
        width = max([1] + [len(c.reads) + len(c.states) for c in terms.continuous])
        return cls(uses, compiled, width, scene, outputs, rate_uses)

    def bind(self) -> None:
        """Point the library at the scene's inputs and controllers' outputs (module docstring)."""
        self._signals.bind(self.compiled)

    def index(self, partial) -> int:
        """The partial's number (a lambda of ``ControllerTerms.partials``), −1 where it is not one."""
        return self._index.get(id(partial), -1)

    def output(self, c, arguments: list) -> float:
        """f(t, s, S) of controller ``c`` before its limits: the compiled law's where it is one of :attr:`outputs`,
        else its lambda's (as ControllerTerms.add reads it)."""
        i = self.outputs.get(c.name, -1)
        return self._call(i, arguments) if i >= 0 else float(c.functions()[0](*arguments))

    def _call(self, i: int, arguments: list) -> float:
        for j, a in enumerate(arguments[1:]):
            self._arguments[j] = float(a)
        self.bind()
        self._function(i, float(arguments[0]), self._arguments, self._out)
        return float(self._out[0])

    def gradient(self, c, arguments: list) -> np.ndarray:
        """∂f/∂(reads, states) of controller ``c``'s output before its limits at ``arguments``: the compiled output
        law's derivatives (its ``out[1:]``, as the step's controller laws give them) where it is one of
        :attr:`outputs`, else :meth:`Controller.output_gradient` (SymPy's, lambdified)."""
        i = self.outputs.get(c.name, -1)
        if i < 0:
            return c.output_gradient(*arguments)
        self._call(i, arguments)
        return np.array(self._out[1:len(arguments)], float)

    def value(self, partial, arguments: list) -> float:
        """∂f/∂p at ``arguments`` (t, the sensors, the states): the compiled law's, or the lambda's where it is not one."""
        i = self._index.get(id(partial), -1)
        if i < 0:
            return float(partial(*arguments))
        return self._call(i, arguments)
