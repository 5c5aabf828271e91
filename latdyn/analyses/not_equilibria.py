"""What a static, steady or buckling state says where it is not the equilibrium of the structure the scene
describes: a state past a joint's rigid stop or ``lock_at`` (stops and latches are events of the time loop,
which a static analysis does not apply: :func:`stops_passed`), and a state where a continuous controller's
state is not at rest (static and steady analyses hold the states at their values: :func:`states_not_at_rest`).
Each gives warnings, said by the caller (``latdyn.solve``: stderr and summary.json ``warnings``)."""
from __future__ import annotations


def stops_passed(model, state, sensitivities: bool = False, load_factor: float | None = None) -> list[str]:
    """What a static state that lies past a joint's rigid stop (``limits`` of a hinge or a guide without
    ``contact``) or its ``lock_at`` says: rigid stops and latches are events of the time loop, which a
    static analysis does not apply (docs/static_paths.md), so such a state is not the equilibrium the
    structure reaches; one warning for each joint. A compliant stop's force is part of the static
    residual: past it is its equilibrium. With ``sensitivities`` the warning says that the path's
    sensitivities are those of this path too (docs/parameters.md, "Sensitivities"). With
    ``load_factor`` the state is one of a buckling analysis' path, at that factor: its buckling factor
    is then that of the structure without the stop or latch."""
    if load_factor is None:
        where = "the static state puts"
        stop_means = ("a static analysis does not apply stops (they are events of the time loop), so this is "
                      "not the equilibrium the stop allows")
        latch_means = ("a static analysis does not latch (latches are events of the time loop), so this is not "
                       "the equilibrium the latch allows")
    else:
        where = f"buckling: the static path at load factor {load_factor:.6g} puts"
        stop_means = ("a buckling analysis does not apply stops (they are events of the time loop), so its "
                      "buckling factor is that of the structure without the stop, not of the structure held by it")
        latch_means = ("a buckling analysis does not latch (latches are events of the time loop), so its buckling "
                       "factor is that of the structure without the latch, not of the structure latched")
    found = []
    for k, joint in enumerate(model.hinges):
        value = float(state.theta[k])
        what = f"guide {joint.name} at s = {value:.6g}" if joint.kind == "guide" else \
            f"hinge {joint.name} at {value:.6g} rad"
        if joint.limits is not None and getattr(joint, "contact", None) is None:
            lo, hi = joint.limits
            margin = 1e-9 * max(1.0, abs(lo), abs(hi))
            if value < lo - margin or value > hi + margin:
                found.append(f"{where} {what}, past its limits [{lo:g}, {hi:g}]: {stop_means}")
        if joint.lock_at is not None and joint.lock_at != 0.0 and (value - joint.lock_at) * joint.lock_at > 0.0:
            found.append(f"{where} {what}, past its lock_at {joint.lock_at:g}: {latch_means}")
    if sensitivities:
        found = [f"{warning}; its sensitivities (solve.sensitivities) are those of this path, without the stop or "
                 "latch, as its rows are" for warning in found]
    return found


def controller_values(assembler, state, probes) -> dict:
    """The values a controller's expressions read at ``state``: inputs, controllers' outputs, probes."""
    scene = assembler.model.scene
    return {**scene.inputs.current(), **scene.controller_outputs.current(),
            **dict(zip(probes.names, probes.values(state.copy())))}


#: a state's rate below this share of what its sensors' and states' round-off moves it by is zero
STATE_RATE_NOISE = 1e-7


def states_not_at_rest(assembler, state, where: str) -> list[str]:
    """What a static or steady state says where a continuous controller's state is not at rest in it:
    such analyses hold the states at their values (docs/control.md), so where dS/dt = f(s, S) ≠ 0
    there (integral action with its error not zero, a filter not settled on its input) the state is
    no equilibrium of the closed loop, and a transient run leaves it. One warning per state whose rate
    exceeds what round-off of its sensors and states gives (``STATE_RATE_NOISE`` of each read value,
    at least of 1, times |∂f/∂value|)."""
    import sympy as sp

    from latdyn.results.probes import ProbeSet

    scene = assembler.model.scene
    continuous = [c for c in scene.controllers.values() if not c.sampled and c.states]
    if not continuous:
        return []
    values = controller_values(assembler, state, ProbeSet(assembler, assembler.initial_state()))
    found = []
    for c in continuous:
        at = {x: float(state.t) if x.name == "t" else
              (scene.controller_states[f"{c.name}.{x.name}"] if x.name in c.states else values[x.name])
              for x in c.symbols}
        for s, f in zip(c.states, c.state_exprs):
            rate = float(sp.sympify(f).evalf(subs=at))
            noise = sum(abs(float(sp.diff(f, x).evalf(subs=at))) * max(abs(v), 1.0)
                        for x, v in at.items() if x.name != "t") * STATE_RATE_NOISE
            if abs(rate) > noise:
                found.append(f"{where}: the state {c.name}.{s} of controller {c.name} is not at rest there "
                             f"(d{s}/dt = {rate:.6g}; {s} = {scene.controller_states[f'{c.name}.{s}']:.6g} held): a "
                             "static or steady analysis holds a controller's states at their values "
                             "(docs/control.md), so this is no equilibrium of the closed loop and a transient run "
                             "leaves it (integral action there has not removed its error)")
    return found
