"""A controller reading a force whose own law a parameter moves, in the parameters' part of an event's impulse weight
derivative, exact (latdyn/analyses/parameter_stiffness.py ``_moved_forces_along``; docs/parameters.md "The impulse
weight's derivative"):

* a cable's tension N = EA (ℓ − L0)/L0 + c ℓ̇ whose EA, damping or rest length a parameter moves: its move along w
  the generated ``cable_tension_D_q_D_section``'s ∂²N/∂σ∂q w, σ = (L0, EA, c), times the parameter's δσ (from ctrlexact
  to shearsec by hand from facts of the law: N linear in (EA, c), ∂²N/∂L0∂q = −(1/L0) ∂N_el/∂q);
* an element's section force whose section values a parameter moves, shear-rigid or shear-flexible (whose axial force
  reads EIz and 1/GAy through μ_z = 1/(1 + 12 EIz/(GAy L²)), nonlinearly): ∂S/∂p = (∂S/∂σ) δσ moves along w as
  (∂((∂S/∂q) w)/∂σ) δσ, the generated ``beam_section_forces_D_q_D_section`` (codegen/derivation.py; a shear-rigid
  element's S at the section [L0, δσ] times w from ctrlexact to shearsec, a shear-flexible one's difference before).

Before, ``TransientSensitivities._terms_beside_stiffness_along`` took a central difference of the controllers' whole
terms of ∂r/∂p along w (two configuration moves an event). Each test counts the moves (0 now) and holds the block
against Richardson-extrapolated differences of the same block (tests/test_weight_derivative_controllers_held.py's
helpers); the whole runs against Richardson differences of whole runs, the adjoint against the forward method."""
from __future__ import annotations

import numpy as np
import pytest

from latdyn.analyses.transient_sensitivities import TransientSensitivities
from tests.test_controller_stop_sensitivities import CHAINED
from tests.test_weight_derivative_controllers_held import _assert_exact, _counted, _events_block
from tests.test_weight_derivative_force_sensors import TENSION

#: the controlled boom's PD reading the stay's tension (nonlinear in it) through the arm's latch, the stay's EA and
#: its damping cs the parameters
TENSION_EA = (TENSION.replace("damping: 0.4}", 'damping: "cs"}', 1)
              .replace("Kp: 0.4, Kd: 0.05}", "Kp: 0.4, Kd: 0.05, cs: 0.4}", 1)
              .replace("sensitivities: [Kp, k]", "sensitivities: [EA, cs, Kp]"))
#: the same with the stay's rest length Ls the parameter
TENSION_L = (TENSION_EA.replace("rest_length: 0.9,", 'rest_length: "Ls",', 1)
             .replace("cs: 0.4}", "cs: 0.4, Ls: 0.9}", 1)
             .replace("sensitivities: [EA, cs, Kp]", "sensitivities: [Ls, Kp]"))
#: the wheel of tests/test_controller_stop_sensitivities.py through its rigid stop (e = 0.8, hit twice), its arm's
#: EIz the parameter EI, pd reading the arm's root element's bending moment M_z (linearly and times the angle)
SECTION_EIZ = (CHAINED.replace("parameters: {Kt: 2.0,", "parameters: {EI: 300.0, Kt: 2.0,")
               .replace("EIz: 1.0e4,", 'EIz: "EI",')
               .replace('pd: {output: "Kp*(lead - angle)', 'pd: {output: "Kp*(lead - angle) + 0.01*mz + 0.02*mz*angle')
               .replace("sensitivities: [Kp, Kt]", "sensitivities: [EI, Kp]")
               .replace("    angle: {", '    mz: {element: "arm.element[0]", quantity: moment_z}\n    angle: {', 1))
assert '"cs"' in TENSION_EA and "[EA, cs, Kp]" in TENSION_EA and '"Ls"' in TENSION_L and "[Ls, Kp]" in TENSION_L
assert 'EIz: "EI"' in SECTION_EIZ and "0.02*mz*angle" in SECTION_EIZ and "moment_z" in SECTION_EIZ
#: the same wheel with a shear-flexible arm (Φ_z = 12 EIz/(GAy L²) = 1.44 on its two elements of 0.5 at GAy = GA), pd
#: reading the root element's axial force too, which reads EIz and GAy through μ_z (nonlinearly); EI, GA, Kp the
#: parameters; EA 1e4 (1e6 left the axial force's Richardson reference 3e-5 off by its own round-off: 2.8e-6 at a
#: step 10x larger, 3e-4 at 10x smaller, the same on the base)
SHEAR_EIZ = (SECTION_EIZ.replace("parameters: {EI: 300.0,", "parameters: {EI: 300.0, GA: 10000.0,")
             .replace("rhoIz: 0.01}}", 'rhoIz: 0.01, GAy: "GA", GAz: 5.0e5}}').replace("EA: 1.0e6,", "EA: 1.0e4,")
             .replace("+ 0.02*mz*angle", "+ 0.02*mz*angle + 0.002*nx*angle")
             .replace("sensitivities: [EI, Kp]", "sensitivities: [EI, GA, Kp]")
             .replace("    mz: {", '    nx: {element: "arm.element[0]", quantity: axial_force}\n    mz: {', 1))
assert 'GAy: "GA"' in SHEAR_EIZ and "0.002*nx*angle" in SHEAR_EIZ and "axial_force" in SHEAR_EIZ
assert "[EI, GA, Kp]" in SHEAR_EIZ


@pytest.mark.parametrize("text, events, bound", [(TENSION_EA, ["latch"], 5e-11), (TENSION_L, ["latch"], 5e-11),
                                                 (SECTION_EIZ, ["stop", "stop"], 5e-11),
                                                 (SHEAR_EIZ, ["stop", "stop"], 2e-10)],
                         ids=["tension-EA-latch", "tension-rest-length-latch", "section-EIz-stops",
                              "shear-flexible-section-stops"])
def test_the_sensed_forces_blocks_are_exact_and_take_no_difference(monkeypatch, text, events, bound):
    """Each column of the block against Richardson differences of itself, relative to that column's largest: the PD
    of the stay's tension at the arm's latch by EA, cs and Kp measured 2.4e-12, 2.2e-13 and 3.8e-14 (the central
    difference 1.1e-10, 7.4e-11 and 6.0e-11), by the stay's rest length Ls 6.5e-13 (the difference 2.7e-11); pd of
    the root element's M_z at the wheel's stops and restarts (four weighings) by EI 4.2e-14 – 1.8e-11 and Kp
    4.9e-14 – 1.4e-13 (the difference 5.7e-12 – 3.3e-10 and 2.8e-12 – 4.9e-12). No configuration move (two a
    weighing before). The shear-flexible wheel (pd reading the root element's M_z and axial force), by EI, GA, Kp at
    its stops and restarts (four weighings): 1.1e-13 – 2.4e-11, 9.4e-12 – 6.1e-11, 4.8e-14 – 1.4e-13, where the
    difference was 1.4e-11 – 1.0e-9, 7.0e-10 – 8.3e-8, 2.8e-12 – 6.2e-12 (GA's column is 1e-11 – 1e-8 of the
    others': its reference's own round-off, hence 2e-10 there). Fails before on the moves (and the tension's and the
    section's columns above 5e-11, the shear-flexible EI's and GA's above 2e-10)."""
    result, seen = _events_block(monkeypatch, text)
    assert [e["kind"] for e in result.summary["events"]] == events
    _assert_exact(seen, 1e-11)
    for block, _, reference in seen:
        scale = np.abs(reference).max(axis=0)
        assert np.all(scale > 0)
        error = np.abs(block - reference).max(axis=0)
        assert np.all(error <= bound * scale), error / scale


@pytest.mark.parametrize("text, name", [(TENSION_EA, "EA"), (TENSION_L, "Ls"), (SECTION_EIZ, "EI"),
                                        (SHEAR_EIZ, "EI")],
                         ids=["tension-EA-latch", "tension-rest-length-latch", "section-EIz-stops",
                              "shear-flexible-EI-stops"])
def test_through_the_events_the_sensitivities_agree_with_richardson(monkeypatch, text, name):
    """Whole runs by the sensed force's own parameter against Richardson differences of whole runs
    (tests/test_sensitivities_events.py ``_agree``, every probe and the event times), taken with no configuration move
    at the events (two each before: fails before on the moves): measured EA 2.0e-7 and Ls 5.2e-8 through the latch,
    EI 7.5e-8 through the stops, the shear-flexible wheel's EI 5.9e-7 (its GA, 1.4e-6 off on the base and the branch
    alike, is its reference's round-off: 2.6e-7 at a step 10x larger; its block is checked above), the same digits
    as with the difference (the whole runs' agreement is the reference's: the difference's error, 1e-10 of the
    block, is below it)."""
    import test_sensitivities_events as events

    counts, original = [], TransientSensitivities._terms_beside_stiffness_along

    def spy(self, state, w):
        block, moves = _counted(self.assembler, lambda: original(self, state, w))
        counts.append(moves)
        return block

    monkeypatch.setattr(TransientSensitivities, "_terms_beside_stiffness_along", spy)
    result = events._run(text, name)
    monkeypatch.undo()
    assert counts and not any(counts)
    assert events._agree(result, text, name, tolerance=1e-6, event_tolerance=1e-6) <= 1e-6


@pytest.mark.parametrize("text", [SECTION_EIZ, SHEAR_EIZ], ids=["section-EIz-stops", "shear-flexible-section-stops"])
def test_the_adjoint_gives_the_forward_methods(text):
    """The adjoint's sensitivities through the wheel's stops, pd reading M_z by EI: the forward method's (measured
    3.0e-12; the tension's PD through its latch 1.9e-11); the shear-flexible wheel's, pd reading M_z and N by EI, GA,
    Kp, 1.8e-11 (9.6e-12 before). A guard: the adjoint takes the same (∂W/∂p) w, and before it matched the forward method's to the
    same digits (below)."""
    from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both

    forward, adjoint = _both(text)
    assert _adjoint_error(forward, adjoint) <= 1e-10
