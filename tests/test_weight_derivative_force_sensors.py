"""The force sensors' second derivatives in an event's impulse weight derivative H = ∂(W w)/∂q, generated
(latdyn/analyses/weight_derivative.py ``_sensor_kinematics``, docs/parameters.md "The impulse weight's derivative"):
a continuous controller reading a cable's tension (the generated ``cable_tension_D_q_D_q``, codegen/joints.py) or an
element's section force (``beam_section_forces_D_q_D_q``, codegen/derivation.py: the forward-mode program of the
lowered product (∂S/∂q) a) takes no central difference any more. The kernels against central differences of their
gradients on SO(3); on the genuinely 3D latching boom of tests/test_weight_derivative_rest.py the sensors' second
derivatives against central differences of their gradients, H's blocks against Richardson-extrapolated differences
of their K w, and through the latch the sensitivities against Richardson differences of whole runs, through the API
and ``latdyn run``, the loop of steps on and off giving the same bits."""
from __future__ import annotations

import numpy as np
import pytest

import element_states as es
from latdyn.analyses.weight_derivative import exact_couplings, rest_support
from latdyn.model.kernels import load_kernels
from tests.test_weight_derivative_couplings import (CHAIN, _assert_blocks_are_richardsons,
                                                    latdyn_run_through_the_latch_agrees)
from tests.test_weight_derivative_couplings import \
    test_a_sensors_second_derivative_is_the_central_difference_of_its_gradient as _sensor_check
from tests.test_weight_derivative_couplings import \
    test_through_the_latch_the_sensitivities_agree_and_the_loop_keeps_the_bits as _through_the_latch
from tests.test_weight_derivative_rest import CONTROLLED_BOOM, _boom_state, _moved_cable, _row

H = 1e-6

#: the controlled boom's PD reading the stay's tension (its damper's c ℓ̇ included), nonlinear in it
TENSION = CONTROLLED_BOOM.replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                                  '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) + 0.3*pull*angle '
                                  '+ 0.2*pull**2"}', 1)
#: the controlled boom's PD reading the arm's tip element's bending moment M_y and its torque, nonlinear in them
SECTION = (CONTROLLED_BOOM.replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                                   '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) + 0.02*tip_m*angle '
                                   '+ 0.001*tip_m**2 + 0.01*tip_t"}', 1)
           .replace("    angle: {", '    tip_m: {element: "arm.element[1]", quantity: moment_y}\n'
                    '    tip_t: {element: "arm.element[1]", quantity: torque}\n    angle: {', 1))
#: the chain's spar on a hinge of its own driven by a controller of the stay's tension and the spar's own bending
#: moment (that hinge stays free through the arm's latch, so its coupling reaches the sensitivities)
SPAR = (CHAIN.replace("start: {hinge: {axis: [0, 1, 1], stiffness: 3.0}}}",
                      'start: {hinge: {axis: [0, 1, 1], stiffness: 3.0, torque: "sc"}}}', 1)
        .replace("\nsolve:", '\n  sc: {output: "-Ks*sin(spar_angle - 0.1)*(1 + 0.2*pull) + 0.3*pull*spar_angle '
                              '+ 0.05*spar_m*(1 + spar_angle)"}\nsolve:', 1)
        .replace("Kp: 0.4, Kd: 0.05}", "Kp: 0.4, Kd: 0.05, Ks: 0.8}", 1)
        .replace("    angle: {", '    spar_m: {element: "spar.element[0]", quantity: moment_z}\n    angle: {', 1))


def _stretched_damped_cable(rng) -> tuple:
    """A cable element's kernel inputs at random: its end nodes' positions (about 2 apart along x) and turns, random
    rates, and its block [L0, L0_dot, EA, c] = [1.5, 0.1, 300, 2.5] (stretched: taut)."""
    geometry = np.concatenate([rng.normal(size=3), rng.normal(size=3) + [2.0, 0, 0], 0.2 * rng.normal(size=6)])
    return geometry, rng.normal(size=12), np.array([1.5, 0.1, 300.0, 2.5])


def test_the_generated_tension_second_derivative_is_the_central_difference_of_its_gradient():
    """``cable_tension_D_q_D_q`` of a damped, stretched element at random rates: its gradient is ``cable_tension``'s
    ∂N/∂q to round-off (1e-15; their CSE differs), and its derivative by the 12 end coordinates the central difference of that gradient along
    the configuration's update (measured ≤ 4.0e-10 relative)."""
    kernels = load_kernels("auto", "default")
    rng = np.random.default_rng(36)
    for _ in range(3):
        geometry, velocity, section = _stretched_damped_cable(rng)

        def gradient(g):
            return np.asarray(kernels.cable_tension(_row(g), _row(velocity), _row(section))[1]).reshape(12)

        first, second = (np.asarray(x)[0] for x in kernels.cable_tension_D_q_D_q(
            _row(geometry), _row(velocity), _row(section)))
        np.testing.assert_allclose(first, gradient(geometry), rtol=0, atol=1e-15 * np.abs(first).max())
        second = second.reshape(12, 12)
        for k in range(12):
            step = np.zeros(12)
            step[k] = H
            numeric = (gradient(_moved_cable(geometry, step)) - gradient(_moved_cable(geometry, -step))) / (2 * H)
            assert np.abs(second[:, k] - numeric).max() <= 1e-8 * np.abs(second).max()


@pytest.mark.parametrize("regime", list(es.REGIMES))
def test_the_generated_section_force_second_derivative_is_the_central_difference_of_its_gradient(regime):
    """3D ``default``: ``beam_section_forces_D_q_D_q``'s (∂S/∂q) a is ``beam_section_forces_D_q``'s ∂S/∂q times a,
    and its derivative by the 14 coordinates on SO(3) at fixed a the central difference of that product (measured
    ≤ 3.5e-10 relative over the regimes)."""
    kernels = load_kernels("auto", "default")
    rng = np.random.default_rng(37)
    state = es.random_state(rng, deformation=es.REGIMES[regime])
    a, section = rng.normal(size=14), state.section[None]

    def product(s):
        return np.asarray(kernels.beam_section_forces_D_q(s.geometry(), section)[1])[0].reshape(4, 14) @ a

    along, tangent = (np.asarray(x)[0] for x in kernels.beam_section_forces_D_q_D_q(state.geometry(), a[None],
                                                                                     section))
    np.testing.assert_allclose(along, product(state), rtol=0, atol=1e-12 * np.abs(along).max())
    tangent = tangent.reshape(4, 14)
    for k in range(14):
        step = np.zeros(14)
        step[k] = H
        numeric = (product(state.moved(step)) - product(state.moved(-step))) / (2 * H)
        assert np.abs(tangent[:, k] - numeric).max() <= 1e-8 * np.abs(tangent).max()


@pytest.mark.parametrize("variant", ["default", "cr4402_xy"])
def test_the_generated_section_force_derivative_by_the_section_values_is_the_central_difference_of_its_product(
        variant):
    """``beam_section_forces_D_q_D_section`` (codegen/derivation.py: the forward-mode program of the lowered product
    seeded with the section values): its (∂S/∂q) a is ``beam_section_forces_D_q``'s ∂S/∂q times a, and its derivative
    by each of the nine section values (EA … 1/GAz) at fixed a and configuration the central difference of that
    product (h = 1e-4 of the value: at 1e-6 the differences' round-off is 2.2e-7 of it, at
    1e-5 1.3e-8), on shear-flexible sections, where the axial force reads EIz, EIy and the
    compliances through μ (nonlinearly): 3D ``default`` at a random state of each regime, the planar ``cr4402_xy``
    (measured ≤ 1.1e-9 and 2.4e-9 relative to the derivative's largest)."""
    from test_planar import planar_state

    kernels = load_kernels("auto", variant)
    rng = np.random.default_rng(38)
    states = ([es.random_state(rng, deformation=regime) for regime in es.REGIMES.values()] if variant == "default"
              else [planar_state(rng, 2, deformation=0.3)])
    worst = 0.0
    for state in states:
        geometry, section, a = state.geometry(), state.section, rng.normal(size=14)
        assert section[-2:].all(), section   # shear-flexible: μ < 1 in both planes

        def product(block):
            return np.asarray(kernels.beam_section_forces_D_q(geometry, block[None])[1])[0].reshape(4, 14) @ a

        along, by_section = (np.asarray(x)[0] for x in kernels.beam_section_forces_D_q_D_section(
            geometry, a[None], section[None]))
        np.testing.assert_allclose(along, product(section), rtol=0, atol=1e-12 * np.abs(along).max())
        by_section = by_section.reshape(4, 9)
        numeric = np.empty((4, 9))
        for d in range(9):
            h = 1e-4 * section[d + 1]
            up, down = section.copy(), section.copy()
            up[d + 1] += h
            down[d + 1] -= h
            numeric[:, d] = (product(up) - product(down)) / (2 * h)
        # each column relative to the derivative's largest: a value the section forces do not read (ρA …) gives 0
        scale = np.abs(numeric).max()
        assert np.abs(numeric[:, 4:7]).max() == 0.0 and np.all(by_section[:, 4:7] == 0.0)
        if variant == "default":   # the axial force reads EIy, EIz, 1/GAy, 1/GAz through μ
            assert np.abs(numeric[0, [1, 2, 7, 8]]).min() > 0.0
        worst = max(worst, np.abs(by_section - numeric).max() / scale)
    assert worst <= 1e-8, worst


def test_the_generated_tension_derivative_by_its_values_is_the_central_difference_of_its_gradient():
    """``cable_tension_D_q_D_section`` (codegen/joints.py) of a damped, stretched element at random rates: its gradient
    is ``cable_tension``'s ∂N/∂q, and its derivative by the rest length share L0, EA and c the central difference of
    that gradient in each (h = 1e-6 of the value; measured ≤ 4.6e-9 relative)."""
    kernels = load_kernels("auto", "default")
    rng = np.random.default_rng(39)
    worst = 0.0
    for _ in range(3):
        geometry, velocity, section = _stretched_damped_cable(rng)

        def gradient(block):
            return np.asarray(kernels.cable_tension(_row(geometry), _row(velocity), _row(block))[1]).reshape(12)

        first, by_section = (np.asarray(x)[0] for x in kernels.cable_tension_D_q_D_section(
            _row(geometry), _row(velocity), _row(section)))
        np.testing.assert_allclose(first, gradient(section), rtol=0, atol=1e-15 * np.abs(first).max())
        by_section = by_section.reshape(12, 3)
        for column, slot in enumerate((0, 2, 3)):   # L0, EA, c of the block [L0, L0_dot, EA, c]
            h = 1e-6 * section[slot]
            up, down = section.copy(), section.copy()
            up[slot] += h
            down[slot] -= h
            numeric = (gradient(up) - gradient(down)) / (2 * h)
            worst = max(worst, np.abs(by_section[:, column] - numeric).max() / np.abs(numeric).max())
    assert worst <= 1e-8, worst


@pytest.mark.parametrize("text, kinds", [(TENSION, [11]), (SECTION, [12, 12])], ids=["tension", "section_force"])
def test_a_force_sensors_second_derivative_is_the_central_difference_of_its_gradient(text, kinds):
    """The stay's tension (kind 11) and the arm's tip element's bending moment and torque (12) at a moved state:
    their gradient is the one csrc/evaluate.c computes (``sensor_jacobian``'s columns of K, to the bit), and its
    derivative along each of their coordinates (the configuration's update: turns on SO(3)) the central difference
    of that gradient (measured 1.1e-10 for the tension, 6.1e-10 and 2.2e-10 for the moment and the torque; the
    check of tests/test_weight_derivative_couplings.py)."""
    _sensor_check(text, kinds)


@pytest.mark.parametrize("text", [TENSION, SECTION, SPAR], ids=["tension", "section_force", "spar"])
def test_a_controller_reading_a_tension_or_a_section_force_is_generated(text):
    """The PD of the stay's tension, the PD of the tip element's bending moment and torque, and the spar's hinge
    driven by a controller of both: no coordinate left to difference (af426b0 differenced 7, 13 and 13) and H's
    blocks (hinges', loads', cables', couplings') agree with Richardson differences of their K w (measured ≤ 7.9e-13,
    1.3e-10, 4.6e-12 over three directions; the difference 2.0e-11, 5.1e-9, 1.5e-9)."""
    prepared, _, _ = _boom_state(text)
    assert exact_couplings(prepared.assembler).all() and len(rest_support(prepared.assembler)) == 0
    _assert_blocks_are_richardsons(text, 1e-9)


def test_through_the_latch_the_section_force_pds_sensitivities_agree_and_the_loop_keeps_the_bits():
    """Through the arm's latch, no difference left in H: the PD of the tip element's moment and torque. The
    sensitivities by Kp agree with Richardson differences of whole runs (measured 2.3e-6 on the torque's probe, as
    with the difference: the reference's own error) and the loop of steps on and off give the same bits, with steps
    in the loop (the check of tests/test_weight_derivative_couplings.py)."""
    _through_the_latch(SECTION, "Kp", 5e-6)


def test_latdyn_run_of_the_tension_pd_agrees_with_richardson_and_the_loop_off_writes_the_same(tmp_path):
    """``latdyn run`` of the PD of the stay's tension through its latch: no difference left in H, the event
    sensitivities by Kp in summary.json the API's, agreeing with Richardson differences of whole runs, and the loop
    of steps off writes the same files byte for byte."""
    latdyn_run_through_the_latch_agrees(tmp_path, TENSION.replace("sensitivities: [Kp, k]", "sensitivities: [Kp]"),
                                        "Kp", 1e-6)
