"""The controllers' last central differences in the parameters' part of an event's impulse weight derivative, exact
(latdyn/analyses/parameter_stiffness.py ``sampled_held_along``, ``held_angles_along``, ``controller_parameter_along``'s
joint forces; docs/parameters.md "The impulse weight's derivative"):

* a sampled controller's held output δy is a constant of the step, so its hinge row −a δy does not move along w and a
  load component a δy turns with its node and frame (``point_load_stiffness_D_q`` at a δy);
* an angle friction holds is no free coordinate: its K column times δθ moves along w as ∂(K e_j)/∂q w (the generated
  ``beam_stiffness_D_q`` at the held slot times w, the couplings' row of the held angle from the controllers' second
  derivatives), with W's K (the elements' gravity tangent is not in it: the difference of the static K's columns it
  replaces held it, 8.6e-6 of the block off);
* a controller reading a free joint's torque whose law a parameter moves: ∂F/∂p = −∂f/∂p moves along the joint's angle
  by the generated ``hinge_force`` stiffness with the derivative law in its slot.

Before, ``TransientSensitivities._terms_beside_stiffness_along`` took a central difference of those terms along w (two
configuration moves an event; the adjoint's sampled block two). Each test counts the moves (0 now, 2 before) and holds
the block against Richardson-extrapolated differences of the same block below the difference's error; the whole runs
against Richardson differences of whole runs, through the API and ``latdyn run``."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from tests.test_controller_stop_sensitivities import CHAINED
from tests.test_sensitivities_controller_states import PD_STOP
from tests.test_sensitivities_friction import STUCK_3D

#: the digital PD's hub on a skew axis (1, −2, 3), its tip off the axes, bouncing twice off its stop (e = 0.5), a
#: force and a moment in the tip's axes 0.3 pd, 0.2 pd, 0.05 pd besides its torque
SAMPLED_STOP = (PD_STOP.replace("axis: [0, 0, 1]", "axis: [1, -2, 3]")
                .replace("tip: {at: [0.5, 0, 0],", "tip: {at: [0.4, 0.2, 0.2],")
                .replace("\nsolve:", '\nloads:\n  - {at: tip, force: [0, "0.3*pd", "0.2*pd"], moment: ["0.05*pd", 0, 0], '
                         'frame: tip}\nsolve:'))
#: the wheel through its rigid stop, its arm on a root hinge (0, 1, 1) with a spring ks (1 + 3 θ²), pd reading that
#: hinge's torque tq (a free joint's force whose law ks moves)
FORCE_STOP = (CHAINED.replace("parameters: {Kt: 2.0,", "parameters: {ks: 40.0, Kt: 2.0,")
              .replace("elements: 2,\n", 'elements: 2,\n        start: {hinge: {axis: [0, 1, 1], '
                       'stiffness: "ks*(1 + 3*theta**2)", damping: 0.5}},\n', 1)
              .replace('pd: {output: "Kp*(lead - angle)', 'pd: {output: "Kp*(lead - angle) + 0.4*tq + 0.2*tq*angle')
              .replace('push: {output: "Kl*(0.7 - tip_x) + 0.2*pd"}', 'push: {output: "Kl*(0.7 - tip_x) + 0.2"}')
              .replace("sensitivities: [Kp, Kt]", "sensitivities: [ks, Kp]")
              .replace("    angle: {", "    tq: {hinge: arm.start, quantity: torque}\n    angle: {", 1))
#: the same with push reading pd (the chain through the joint's force; its block alone: the loop of steps took a
#: chained reader of a joint-force reader 0.10 off while a chain started only at controllers with partials:
#: tests/test_sensitivities_in_loop_controller_chains.py)
FORCE_CHAINED = FORCE_STOP.replace('"Kl*(0.7 - tip_x) + 0.2"}', '"Kl*(0.7 - tip_x) + 0.2*pd"}')
#: the 3D panel stuck by friction at the flexible arm's tip, its arm on a root hinge (0, 1, 1) with a spring k turned
#: by a PD of the root's and the panel's angles (its coupling on the held angle's column), latching at θ = 0.05
#: (0.115 s) before the panel sticks at 0.26 s; or never latching, the panel stuck at 0.37 s beside the free PD
PD_STUCK = (STUCK_3D.replace("parameters: {Fc: 0.2,", "parameters: {k: 2.0, Kp: 0.5, Fc: 0.2,")
            .replace("elements: 2,\n", 'elements: 2,\n        start: {hinge: {axis: [0, 1, 1], stiffness: "k", '
                     'torque: "ctl", lock_at: 0.05}},\n')
            .replace("solve:", 'controllers:\n  ctl: {output: "-Kp*th0 - 0.3*th0**2 + 0.3*angle*(1 + th0)"}\nsolve:')
            .replace("sensitivities: [Fc, EI]", "sensitivities: [k, Kp, Fc]")
            .replace("    angle: {", "    th0: {hinge: arm.start, quantity: angle}\n    angle: {"))
PD_STUCK_FREE = PD_STUCK.replace("lock_at: 0.05", "lock_at: -0.05")
assert "frame: tip" in SAMPLED_STOP and "ks*(1 + 3*theta**2)" in FORCE_STOP and "0.2*pd" in FORCE_CHAINED
assert 'torque: "ctl"' in PD_STUCK and "lock_at: -0.05" in PD_STUCK_FREE


def _held_columns(owner, state) -> np.ndarray:
    """Σ_j K[:, θ_j] δθ_j on the free coordinates with W's K (the evaluation with the inertia forces: its tangent
    without the elements' gravity tangent, as the impulse weighs), the reference's block of the held angles."""
    model, native = owner.model, owner.assembler.native(True)
    native.evaluate(state, True, 1.0, True, False)
    b, control = native.buffers, owner.assembler.control
    out = np.zeros((model.n_total + 1, owner.held.shape[1]))
    for j in np.flatnonzero(np.any(owner.held, axis=1)):
        d = model.hinge_dofs[j]
        column = np.zeros(model.n_total + 1)
        elements, slot = np.nonzero(model.element_dofs == d)
        np.add.at(column, model.element_dofs[elements], b["tangent"][elements, :, slot])
        coupled = control.coupling_cols == d
        np.add.at(column, control.coupling_rows[coupled], b["coupling_stiffness"][coupled])
        out += np.outer(column, owner.held[j])
    return owner._on_free_coordinates(state, out)


def _block(owner, moved) -> np.ndarray:
    """The terms ``_terms_beside_stiffness_along`` differentiates, at ``moved``: the controllers' (their outputs at
    the moved state) and the held angles' columns of W's K."""
    total = np.zeros((owner.model.n_total + 1, len(owner.names)))
    with owner._controller_outputs_at(moved):
        owner.controllers.add(moved, total)
    out = owner._on_free_coordinates(moved, total)
    if owner.held is not None and np.any(owner.held):
        out = out + _held_columns(owner, moved)
    return out


def _richardson(function, assembler, state, w: np.ndarray, length: float, relative: float = 1e-3) -> np.ndarray:
    """Richardson-extrapolated central differences of ``function`` along w (steps ``relative`` ℓ/|w|_∞ and half)."""
    def central(eta):
        return (function(assembler.advance(state, eta * w)) - function(assembler.advance(state, -eta * w))) / (2 * eta)

    eta = relative * length / float(np.max(np.abs(w)))
    return (4 * central(eta / 2) - central(eta)) / 3


def _counted(owner_assembler, call):
    """(``call()``, the configuration moves it took)."""
    moves, advance = [], owner_assembler.advance

    def counted(at, increment):
        moves.append(1)
        return advance(at, increment)

    owner_assembler.advance = counted
    try:
        return call(), len(moves)
    finally:
        del owner_assembler.advance


def _events_block(monkeypatch, text: str, tol: float = 1e-12) -> tuple:
    """``text`` through the API (Newton's tolerance ``tol``): (the result, [(the block, its moves, the Richardson
    reference of the block) at each event's weighing, taken there: a latch renumbers after it])."""
    seen, original = [], TransientSensitivities._terms_beside_stiffness_along

    def spy(self, state, w):
        block, moves = _counted(self.assembler, lambda: original(self, state, w))
        reference = _richardson(lambda moved: _block(self, moved), self.assembler, state, w, self.length or 1.0)
        seen.append((block, moves, reference))
        return block

    monkeypatch.setattr(TransientSensitivities, "_terms_beside_stiffness_along", spy)
    data = yaml.safe_load(text)
    data["solve"]["tol"] = tol
    result = latdyn.run(latdyn.load_scene(data))
    monkeypatch.undo()
    return result, seen


def _assert_exact(seen: list, tolerance: float) -> list:
    """No move, and each nonzero block within ``tolerance`` of its reference's largest; the scales."""
    scales = []
    for block, moves, reference in seen:
        assert moves == 0
        scale = float(np.abs(reference).max())
        scales.append(scale)
        assert np.abs(block - reference).max() <= tolerance * scale + 1e-300, (np.abs(block - reference).max(), scale)
    assert max(scales) > 0
    return scales


@pytest.mark.parametrize("text, events, tolerance", [(SAMPLED_STOP, ["stop", "stop"], 1.5e-12),
                                                     (FORCE_STOP, ["stop", "stop"], 1e-12),
                                                     (FORCE_CHAINED, ["stop"], 1e-12)],
                         ids=["sampled-hub-stops", "joint-force-reader-stops", "joint-force-reader-chained"])
def test_the_controllers_blocks_are_exact_and_take_no_difference(monkeypatch, text, events, tolerance):
    """The sampled PD's held outputs through its two stops: measured 1.9e-13 – 5.1e-13 of the block (the difference
    4.2e-12 – 1.4e-11); pd reading the root hinge's torque whose spring ks moves, at the wheel's stop: 4.8e-14 – 1.4e-13
    (4.9e-12, 3.5e-12), push reading pd beside it the same. No configuration move (two an event before). Fails
    before (the moves, and the difference's error above each bound)."""
    result, seen = _events_block(monkeypatch, text)
    assert [e["kind"] for e in result.summary["events"]] == events
    _assert_exact(seen, tolerance)


@pytest.mark.parametrize("text", [PD_STUCK, PD_STUCK_FREE], ids=["beside-a-latch", "beside-a-free-pd"])
def test_the_held_angles_columns_are_exact_and_take_no_difference(monkeypatch, text):
    """The panel stuck at the arm's tip beside the root's PD (latched before, or free: the PD's coupling on the held
    angle's column): the held angle's block is ∂(K e_j)/∂q w δθ_j with W's K, measured 1.3e-13 of the block (1.1e-4
    relative to the held part of 1.3e4 at the stick); the difference of the static K's columns was 6.2e-6 – 1.1e-5 off
    (the elements' gravity tangent's move, which W does not hold). Fails before."""
    result, seen = _events_block(monkeypatch, text)
    assert result.summary["events"] == [] or [e["kind"] for e in result.summary["events"]] == ["latch"]
    scales = _assert_exact(seen, 1e-12)
    assert max(scales) > 1e3   # the stick's weighing holds the held angle's columns


def test_the_adjoints_sampled_block_is_exact_and_the_adjoint_gives_the_forward_methods(monkeypatch):
    """The adjoint's ∂(A_y δy)/∂q w of the sampled PD's held outputs (latdyn/analyses/adjoint_controller_states.py
    ``SamplesTransposed.held_stiffness_along``): no move (two before), Richardson differences of A_y along w to 1e-12
    of its largest; the adjoint's sensitivities the forward method's (measured 7.8e-11; 8.0e-11 before). Fails before."""
    from latdyn.analyses.adjoint_controller_states import SamplesTransposed
    from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both

    seen, original = [], SamplesTransposed.held_stiffness_along

    def spy(self, state, w):
        block, moves = _counted(self.owner.assembler, lambda: original(self, state, w))
        if np.any(w):
            seen.append((block, moves, _richardson(self.held_map, self.owner.assembler, state, w,
                                                   self.owner.length or 1.0)))
        return block

    monkeypatch.setattr(SamplesTransposed, "held_stiffness_along", spy)
    forward, adjoint = _both(SAMPLED_STOP)
    assert seen
    _assert_exact(seen, 1e-12)
    assert _adjoint_error(forward, adjoint) <= 1e-10


@pytest.mark.parametrize("text, name, tolerance", [(SAMPLED_STOP, "Kp", 1e-6), (FORCE_STOP, "ks", 1e-7)],
                         ids=["sampled-hub-stops-Kp", "joint-force-reader-stops-ks"])
def test_through_the_events_the_sensitivities_agree_with_richardson_and_the_cli_writes_the_apis(tmp_path, monkeypatch,
                                                                                               text, name, tolerance):
    """Whole runs against Richardson differences of whole runs (tests/test_sensitivities_events.py ``_agree``):
    measured Kp 1.2e-7 on the sampled hub (the same before: the difference's error was below the runs'), ks 8.6e-9 on
    the joint-force reader (the same before); taken with no configuration move at the events (two each before: fails
    before); ``latdyn run`` writes the API's probe sensitivities to the bit (the scene written with its keys in the
    user's order: sorted, as yaml.safe_dump writes by default, its parameters, probes and sections came in another
    order, a scene of other round-off: 2.2e-12 and 6.5e-12 off on the joint-force reader, which this allowed 1e-10)."""
    import test_sensitivities_events as events
    from tests.cli_runs import latdyn_run

    counts, original = [], TransientSensitivities._terms_beside_stiffness_along

    def spy(self, state, w):
        block, moves = _counted(self.assembler, lambda: original(self, state, w))
        counts.append(moves)
        return block

    monkeypatch.setattr(TransientSensitivities, "_terms_beside_stiffness_along", spy)
    result = events._run(text, name)
    monkeypatch.undo()
    assert counts and not any(counts)
    assert events._agree(result, text, name, tolerance=tolerance, event_tolerance=1.0) <= tolerance
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = [name]
    run, out = latdyn_run(tmp_path, yaml.safe_dump(data, sort_keys=False))
    assert run.returncode == 0, run.stderr
    written, api = json.loads((out / "summary.json").read_text())["probe_sensitivities"], result.summary[
        "probe_sensitivities"]
    assert written == api
