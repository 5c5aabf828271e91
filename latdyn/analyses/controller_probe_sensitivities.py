"""Exact sensitivities of controller probes (SCENE.md ``controllers``: probe ``{controller: NAME}``
records the output after saturation, ``{controller: NAME, state: S}`` a state; "Parameters and
sensitivities": the derivative of each recorded probe; docs/parameters.md, "Controllers").

Transient runs, forward method, from what the step already carries for the residual
(latdyn/analyses/sensitivities.py):

- a continuous controller's state S: its carried δS (:class:`ControllerStates`, ``controller_dS``);
- a continuous controller's output y = clip(f(t, s, S; p)) at the row's state:

      δy = Σ_s ∂f/∂s δs + Σ_j ∂f/∂y_j δy_j + Σ_S ∂f/∂S δS + ∂f/∂p      (t fixed: no event moves it),

  δs the sensors' derivatives (the probes' own, along the carried δq, δv), δy_j those of earlier
  controllers it reads (the same, in file order), inputs held (no parameter moves them), the output,
  its partial derivatives and ∂f/∂p (:class:`ControllerTerms`' ``partials``) the step's compiled laws'
  (derivative_laws.ControllerPartials; ∂f/∂S the compiled controller law's, ControllerStates.output_by_states,
  as :meth:`ControllerTerms.add` reads them), SymPy's lambdified where they did not compile. While the output is clipped — at a limit too: the one-sided value of the clipped side,
  as the step's own ∂r/∂p takes it (:meth:`ControllerTerms.add`), so the probe's derivative is the
  derivative of the trajectory computed — δy = 0;
- a sampled controller's output and state: the held δy_k and δS_{k+1} of the last sample
  (:class:`SampledTerms`, ``sampled_dy``, ``sampled_dS``), the values the probe records.

Refused (:func:`refusal`, exit 2 naming ``solve.sensitivities``): controller probes of static paths.
The discrete adjoint is seeded by a controller's output and states, continuous or sampled
(latdyn/analyses/adjoint_controller_states.py ``probe_forms``), beside events too: at a row whose time moves with p an
output naming t seeds t̄ there with its ∂f/∂t (latdyn/analyses/adjoint_time.py ``row_coefficients``).
"""
from __future__ import annotations

import numpy as np

__all__ = ["is_controller_probe", "describe", "refusal", "names_t", "controller_arguments", "output_and_gradient",
           "probe_derivatives"]


def is_controller_probe(probe) -> bool:
    """Whether ``probe`` records a controller's output or state."""
    return probe.kind == "controller"


def describe(probe) -> str:
    """``controller NAME output`` or ``controller NAME state S``, as refusals name the probe."""
    return f"controller {probe.controller} " + ("output" if probe.state is None else f"state {probe.state}")


def refusal(scene, probe) -> str | None:
    """Why the derivative of the controller probe ``probe`` is not computed for ``scene``, or None."""
    if scene.solve.analysis != "transient":
        return (f"probe {probe.name!r} ({describe(probe)}) is differentiated in transient runs only, not in a "
                f"{scene.solve.analysis} analysis")
    return None


def names_t(scene, c) -> bool:
    """Whether the continuous controller ``c``'s output names t, or that of a continuous controller it reads (the
    chain :func:`_continuous_output` adds ∂f/∂t δt along at a row whose time moves; the adjoint seeds it on t̄ there,
    AdjointSensitivities.reverse)."""
    return c.output_names_t or any(names_t(scene, scene.controllers[r]) for r in c.reads
                                   if r in scene.controllers and not scene.controllers[r].sampled)


def _time_partial(owner, c):
    """∂f/∂t of controller ``c``'s output as a function of (t, reads, S), cached on ``owner``: a row whose time
    moves with p (δt after an event, adaptive steps) moves the output by ∂f/∂t δt."""
    import sympy as sp

    cache = owner.__dict__.setdefault("_controller_time_partials", {})
    if c.name not in cache:
        derivative = sp.lambdify(c.symbols, sp.diff(c.output_expr, c.symbols[0]), modules=["math", "numpy"])
        cache[c.name] = lambda *arguments: float(derivative(*arguments))
    return cache[c.name]


def controller_arguments(terms, c, state, earlier) -> list:
    """(t, the reads, the states) of controller ``c`` at ``state``: the sensors' and inputs' values
    (``ControllerTerms.signal_values``), an earlier controller's output ``earlier(name)``, the accepted states."""
    values = terms.signal_values(state)
    reads = [values[r] if r in values else earlier(r) for r in c.reads]
    return [state.t, *reads, *terms.state_values(c)]


def output_and_gradient(terms, c, arguments: list) -> tuple:
    """(f, ∂f/∂(reads, S) or None while clipped) of the continuous controller ``c``'s output before its limits at
    ``arguments`` (t, the reads, the states): the step's compiled laws where they compiled (ControllerTerms.add reads
    the same), ∂f/∂(reads, S) the step's compiled controller law's (ControllerStates.output_gradient), else the
    compiled output law's (SymPy's lambdified gradient where it did not compile)."""
    compiled = terms.compiled
    raw = float(c.functions()[0](*arguments)) if compiled is None else compiled.output(c, arguments)
    if not (c.limits is None or c.limits[0] < raw < c.limits[1]):
        return raw, None
    gradient = terms.states.output_gradient(c, arguments) if c.states and terms.states is not None else None
    if gradient is None:
        gradient = c.output_gradient(*arguments) if compiled is None else compiled.gradient(c, arguments)
    return raw, gradient


def _continuous_output(owner, name: str, state, carried: dict, sensed, done: dict) -> np.ndarray:
    """δy (k,) of the continuous controller ``name`` at ``state`` (module docstring), ``done`` the
    earlier controllers' (value, δy) by name."""
    if name in done:
        return done[name][1]
    terms = owner.controllers
    scene = owner.scene
    c = scene.controllers[name]
    def earlier(r):
        _continuous_output(owner, r, state, carried, sensed, done)
        return done[r][0]

    arguments = controller_arguments(terms, c, state, earlier)
    compiled = terms.compiled
    raw, gradient = output_and_gradient(terms, c, arguments)
    slope = np.zeros(terms.k)
    if gradient is not None:
        probes = {p.name: p for p in scene.output.probes}
        for i, r in enumerate(c.reads):
            if r in probes:
                slope += gradient[i] * sensed(probes[r])
            elif r in scene.controllers:
                slope += gradient[i] * done[r][1]
            # an input: held, no parameter moves it
        if c.states:   # ∂y/∂S δS: the step's compiled controller law's ∂y/∂S (ControllerStates.output_by_states)
            first = terms.states.first[c.name]
            by_states = terms.states.output_by_states(c, arguments)
            if by_states is None:
                by_states = gradient[len(c.reads):]
            for l, row in enumerate(carried["controller_dS"][first:first + len(c.states)]):
                slope += by_states[l] * row   # in the states' order, as ControllerTerms.add sums them
        for column, partial in terms.partials.get(c.name, {}).items():
            slope[column] += float(partial(*arguments)) if compiled is None else compiled.value(partial, arguments)
        moved = np.asarray(carried.get("dt", 0.0))
        if np.any(moved) and c.output_names_t:   # the row's time moved (events, adaptive)
            slope += _time_partial(owner, c)(*arguments) * moved
    done[name] = (c.clip(raw), slope)
    return slope


def probe_derivatives(owner, probe, state, dx, dpi, dtheta, rates) -> list:
    """The derivatives of the controller probe ``probe`` at ``state`` by every parameter, from what the
    transient step carried (``owner.carried_accounts``, set by ``record``) and the sensors' derivatives
    along (δx, δπ, δθ) and the rates' (module docstring)."""
    carried, terms = owner.carried_accounts, owner.controllers
    c = owner.scene.controllers[probe.controller]
    if c.sampled:
        sampled = terms.sampled
        i = sampled.index[c.name]
        if probe.state is None:
            return [float(v) for v in carried["sampled_dy"][i]]
        row = sampled.first[c.name] + c.states.index(probe.state)
        return [float(v) for v in carried["sampled_dS"][row]]
    if probe.state is not None:
        row = terms.states.first[c.name] + c.states.index(probe.state)
        return [float(v) for v in carried["controller_dS"][row]]

    def sensed(sensor):
        return np.array(owner._probe_derivatives(sensor, state, dx, dpi, dtheta, rates), float)

    return [float(v) for v in _continuous_output(owner, c.name, state, carried, sensed, {})]
