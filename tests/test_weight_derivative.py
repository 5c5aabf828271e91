"""The impulse weight's derivative along the configuration, H = ∂(W w)/∂q (latdyn/analyses/weight_derivative.py):
the generated ``beam_stiffness_D_q`` against central differences of (∂F_i/∂q) v on SO(3) at random large-rotation
states with offsets, hinges and shear (3D, every regime of the log map; planar along the in-plane coordinates), and
the assembled H of whole models — a planar arm with a joint body under gravity, a follower load (generated:
tests/test_weight_derivative_rest.py) and a hinge law nonlinear in θ (generated: tests/test_weight_derivative_laws.py),
and the genuinely 3D wheel of the event tests — against
Richardson-extrapolated central differences of the evaluation's W w = (M + s K) w along random directions. The runs through latches and
stops that use it: tests/test_sensitivities_events.py, tests/test_adjoint_events.py."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import element_states as es
import latdyn
from latdyn.analyses.weight_derivative import configuration_tangent_of_weight, rest_support
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from latdyn.model.kernels import generated_info, load_kernels
from test_planar import in_plane_coordinates, planar_state, planar_velocity
from tests.test_sensitivities_events import LATCH_3D

H = 1e-6


def _needs(variant: str) -> None:
    """Skip where ``variant`` was generated before ``beam_stiffness_D_q`` (python -m codegen regenerates it)."""
    if "beam_stiffness_D_q" not in generated_info(variant):
        pytest.skip(f"generated variant {variant!r} predates beam_stiffness_D_q (python -m codegen --variant {variant})")


def _check_kernel(kernels, state, v, coordinates) -> float:
    """The largest error of ``beam_stiffness_D_q`` (its product against ∂F_i/∂q v, its derivative against central
    differences along ``coordinates``), relative to the largest entry."""
    geometry, section = state.geometry(), state.section[None]
    along, tangent = (np.asarray(x)[0] for x in kernels.beam_stiffness_D_q(geometry, v[None], section))
    tangent = tangent.reshape(14, 14)
    product = np.asarray(kernels.beam_internal_force_D_q(geometry, section)[1])[0].reshape(14, 14) @ v
    np.testing.assert_allclose(along, product, rtol=0, atol=1e-12 * np.abs(product).max())

    def stiffness_along(dq):
        moved = state.moved(dq)
        return np.asarray(kernels.beam_internal_force_D_q(moved.geometry(), section)[1])[0].reshape(14, 14) @ v

    worst = 0.0
    for k in coordinates:
        step = np.zeros(14)
        step[k] = H
        numeric = (stiffness_along(step) - stiffness_along(-step)) / (2 * H)
        worst = max(worst, float(np.abs(tangent[:, k] - numeric).max() / np.abs(tangent).max()))
    return worst


@pytest.mark.parametrize("regime", list(es.REGIMES))
def test_the_generated_stiffness_derivative_is_the_central_difference_of_k_v_in_3d(regime):
    """3D ``default``: ∂((∂F_i/∂q) v)/∂q on SO(3) at fixed v, all 14 directions (measured ≤ 1.1e-9)."""
    _needs("default")
    kernels = load_kernels("auto", "default")
    rng = np.random.default_rng(34)
    for _ in range(2):
        state = es.random_state(rng, deformation=es.REGIMES[regime])
        assert _check_kernel(kernels, state, rng.normal(size=14), range(14)) < 1e-6


def test_the_generated_stiffness_derivative_is_the_central_difference_of_k_v_in_the_plane():
    """Planar ``default_xy``: along the in-plane coordinates, with an in-plane v (measured ≤ 3.3e-10)."""
    _needs("default_xy")
    kernels = load_kernels("auto", "default_xy")
    rng = np.random.default_rng(35)
    keep = in_plane_coordinates(2)
    for _ in range(3):
        state = planar_state(rng, 2, deformation=0.5)
        assert _check_kernel(kernels, state, planar_velocity(rng, 2), keep) < 1e-6


#: a planar arm on a hinge with a law nonlinear in θ and a compliant damper, a joint body with its centre of mass
#: off its node under gravity, and a load turning with the body (a follower): every block of H generated
ARM_PLANAR = """
title: planar arm, a nonlinear hinge spring, an offset body under gravity and a follower load
gravity: [0, -9.81, 0]
sections:
  s: {EA: 1.0e4, EIy: 20.0, EIz: 20.0, GJ: 10.0, rhoA: 0.5, rhoIy: 0.0005, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0, 0], mass: 0.3, com: [0.05, 0.02, 0], inertia: [0.01, 0.01, 0.01]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "2*(1 + theta**2)", damping: 0.05, rest_angle: 2.0}}
loads:
  - {at: tip, force: [0, 3.0, 0], frame: tip}
solve: {analysis: transient, dt: 0.01, t_end: 0.1}
"""


def _moved_state(prepared, rng):
    """The scene's start moved along a random direction (a deformed, turned configuration), with random rates
    and accelerations on the free coordinates."""
    assembler, state = prepared.assembler, prepared.state
    n = prepared.model.n_dofs
    state = assembler.advance(state, 0.2 * rng.normal(size=n))
    unpack_free(prepared.model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(prepared.model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    return state


def _check_model(text: str, seed: int) -> float:
    """The largest error of H δq (W = M + 1e-4 K and W = K) against Richardson-extrapolated central differences of
    the evaluation's W w along δq, over random w and δq, relative to the largest |H δq|."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler = prepared.assembler
    rng = np.random.default_rng(seed)
    state = _moved_state(prepared, rng)
    n = prepared.model.n_dofs
    worst = 0.0
    for mass, scale in ((True, 1e-4), (False, 1.0)):   # M + dt²K at dt = 0.01, and K alone
        w, dq = rng.normal(size=n), rng.normal(size=n)
        exact = configuration_tangent_of_weight(assembler, state, w, scale, mass, 1e-5) @ dq

        def product(eta):
            ev = assembler.evaluate(assembler.advance(state, eta * dq), matrices=True)
            return np.asarray(ev.combined(1.0 if mass else 0.0, 0.0, scale) @ w)

        eta = 1e-4   # Richardson-extrapolated central differences: truncation O(η⁴), round-off 1e-16/η
        central = [(product(h) - product(-h)) / (2 * h) for h in (eta, eta / 2)]
        numeric = (4 * central[1] - central[0]) / 3
        worst = max(worst, float(np.abs(exact - numeric).max() / np.abs(numeric).max()))
    return worst


def test_h_of_a_planar_model_with_every_block_is_the_central_difference_of_w_w():
    """The planar arm: elements, the body's mass and weight, the hinge's nonlinear law and the follower load's blocks
    generated, no difference left (measured 1.3e-12, as with the hinge and the load differenced; 2.0e-5 without the
    hinge's and the load's parts: they are in W w)."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(ARM_PLANAR)))
    support = rest_support(prepared.assembler)
    model = prepared.model
    assert len(support) == 0 < model.n_dofs   # the hinge's and the follower load's parts are generated
    assert _check_model(ARM_PLANAR, 7) < 1e-8


#: the wheel of the event tests, heavy on a soft arm, under a skew gravity: the wheel's weight (its centre of mass
#: off the hinge) a good part of K
WHEEL_UNDER_GRAVITY = (LATCH_3D.replace("sections:", "gravity: [1.0, -2.0, -9.81]\nsections:", 1)
                       .replace("m: 1.0, EI: 1.0e4", "m: 50.0, EI: 10.0").replace("EA: 1.0e6", "EA: 1.0e3"))


@pytest.mark.parametrize("text", [LATCH_3D, WHEEL_UNDER_GRAVITY], ids=["without_gravity", "under_gravity"])
def test_h_of_the_3d_wheel_is_the_central_difference_of_w_w(text):
    """The 3D wheel on its hinge (tests/test_sensitivities_events.py LATCH_3D), out of the coordinate planes: the
    two elements and the wheel's mass — under gravity, heavy on a soft arm, its weight's stiffness too — generated,
    the hinge's linear spring generated too (hinge_stiffness_by_angle; measured 1.5e-10 with it differenced; under gravity 1.4e-10, 5.1e-5
    without the weight's ``joint_body_gravity_stiffness_D_q``)."""
    _needs("default")
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assert prepared.assembler.has_gravity == (text is WHEEL_UNDER_GRAVITY)
    assert list(rest_support(prepared.assembler)) == []   # the hinge's part generated too: no difference left
    assert _check_model(text, 8) < 1e-8


def test_the_generated_weight_stiffness_of_a_joint_body_is_the_central_difference_of_g_w():
    """``joint_body_gravity_stiffness_D_q``: G(T) w_π (G the body's gravity stiffness, ``joint_body``'s
    ``body_gravity_stiffness``) and its derivative by the node's π against central differences on SO(3) at random
    frames, centres of mass and gravity (measured 2.4e-10)."""
    from latdyn.model.kernels import load_kernels as load

    kernels = load("auto", "default")
    rng = np.random.default_rng(36)
    worst = 0.0
    for _ in range(3):
        frame = es.expm_so3(rng.normal(size=3) * 2.0)
        body = np.concatenate([[1.3], rng.normal(size=3) * 0.2, np.diag(rng.uniform(0.5, 1.0, 3)).ravel()])[None]
        gravity, w = rng.normal(size=(1, 3)) * 9.81, rng.normal(size=(1, 6))

        def along(T):
            blocks = np.asarray(kernels.joint_body(T.reshape(1, 9), np.zeros((1, 9)), body, gravity)[3])[0]
            return blocks.reshape(6, 6) @ w[0]

        product, tangent = (np.asarray(x)[0] for x in kernels.joint_body_gravity_stiffness_D_q(
            frame.reshape(1, 9), w, body, gravity))
        np.testing.assert_allclose(product, along(frame), rtol=0, atol=1e-12 * np.abs(product).max())
        tangent = tangent.reshape(6, 6)
        assert not np.any(tangent[:, :3])   # a translation moves no weight's stiffness
        for k in range(3):
            turn = np.zeros(3)
            turn[k] = H
            numeric = (along(es.expm_so3(turn) @ frame) - along(es.expm_so3(-turn) @ frame)) / (2 * H)
            worst = max(worst, float(np.abs(tangent[:, 3 + k] - numeric).max() / np.abs(tangent).max()))
    assert worst < 1e-7, worst


def _check_stiffness_derivative(text: str, seed: int) -> tuple:
    """(which parameters' (∂K/∂p) w is generated alone, the largest error of ``_stiffness_derivative`` over every
    parameter against Richardson-extrapolated central differences in the parameter of the evaluation's K w at a
    fixed state, K the impulse's: ``assembler.evaluate(state, matrices=True)``'s, each column relative to its
    largest entry, the largest of all where the column is 0)."""
    from latdyn.analyses.transient_sensitivities import TransientSensitivities

    data = yaml.safe_load(text)
    prepared = prepare(latdyn.load_scene(data))
    owner = TransientSensitivities(prepared)
    rng = np.random.default_rng(seed)
    state = _moved_state(prepared, rng)
    w = rng.normal(size=prepared.model.n_dofs)
    computed = owner._stiffness_derivative(state, w)

    def product(name, value):
        moved = yaml.safe_load(text)
        moved["parameters"][name] = value
        evaluation = prepare(latdyn.load_scene(moved)).assembler.evaluate(state, matrices=True)
        return np.asarray(evaluation.combined(0.0, 0.0, 1.0) @ w)

    numeric = np.zeros_like(computed)
    for c, name in enumerate(owner.names):
        p0 = float(data["parameters"][name])
        central = [(product(name, p0 + h) - product(name, p0 - h)) / (2 * h) for h in (1e-3 * p0, 5e-4 * p0)]
        numeric[:, c] = (4 * central[1] - central[0]) / 3
    exact = owner.by_sections_only()
    scales = np.abs(numeric).max(axis=0)
    scales[scales == 0.0] = np.abs(numeric).max()   # a column K does not depend on (a damping): against the largest
    return ([name for name, e in zip(owner.names, exact) if e],
            float(np.max(np.abs(computed - numeric).max(axis=0) / scales)))


#: the latching arm (tests/test_sensitivities_events.py) under gravity, off its plane's axes, ρ also the load
#: ``0*rho``'s: ρ then takes the difference of ∂r/∂p (not by section values alone), whose static residual holds the
#: elements' gravity load −λ ∂Q/∂p, which the evaluation's K (the impulse's) leaves out
LATCH_PLANAR_GRAVITY = """
title: planar hinged arm under gravity, swung open by its spring, latching
parameters: {k: 2.0, c: 0.05, EI: 20.0, rho: 0.5, m: 0.3}
gravity: [3.0, -9.81, 0]
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "EI", GJ: 10.0, rhoA: "rho", rhoIy: "0.001*rho", rhoIz: "0.001*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0, 0], mass: "m", inertia: [0.01, 0.01, 0.01]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: "c", rest_angle: 2.0, lock_at: 0.8}}
solve: {analysis: transient, dt: 0.01, t_end: 0.6, sensitivities: [k, c, EI, rho, m]}
output:
  probes:
    tip_y: {point: tip, quantity: position, component: y}
"""


def test_the_stiffness_derivative_is_the_parameter_derivative_of_the_evaluations_k_w_under_gravity():
    """(∂K/∂p) w of every parameter (section values generated, the rest differenced along w without the elements'
    gravity load) against central differences in the parameter of the impulse's K w at a fixed state, under
    gravity, with ρ also on the difference path (a load ``0*rho``: the static ∂r/∂p's −λ ∂Q/∂p differenced along
    w was 6.1e-4 of the ρ column off, planar, 1.1e-3 in 3D): planar (the latching arm; EI, ρ generated, k, c, m
    differenced; measured 1.8e-11, with the load 1.8e-11) and 3D (the heavy wheel under a skew gravity; measured
    1.6e-10, with the load 1.6e-10)."""
    with_load = "loads:\n  - {at: tip, force: [0, \"0*rho\", 0]}\noutput:"
    names, error = _check_stiffness_derivative(LATCH_PLANAR_GRAVITY, 9)
    assert names == ["EI", "rho"] and error < 1e-8, error
    names, error = _check_stiffness_derivative(LATCH_PLANAR_GRAVITY.replace("output:", with_load, 1), 9)
    assert names == ["EI"] and error < 1e-8, error
    _needs("default")
    names, error = _check_stiffness_derivative(WHEEL_UNDER_GRAVITY, 10)
    assert names == ["EI", "rho"] and error < 1e-8, error
    names, error = _check_stiffness_derivative(WHEEL_UNDER_GRAVITY.replace("output:", with_load.replace("tip", "wheel"),
                                                                           1), 10)
    assert names == ["EI"] and error < 1e-8, error


def _without_the_kernel(monkeypatch) -> None:
    """Every variant loaded from now on as if generated before ``beam_stiffness_D_q`` (its info without it)."""
    from latdyn.model import kernels as kernel_module

    loaded = kernel_module.load_kernels

    def without(*args, **kwargs):
        kernels = loaded(*args, **kwargs)
        monkeypatch.setattr(kernels, "info", {k: v for k, v in kernels.info.items() if k != "beam_stiffness_D_q"})
        return kernels

    monkeypatch.setattr("latdyn.assembly.prepare.load_kernels", without)


@pytest.mark.parametrize("method", ["forward", "adjoint"])
def test_a_variant_generated_before_the_kernel_is_refused_at_the_start_naming_the_command(monkeypatch, method):
    """A variant regenerated before ``beam_stiffness_D_q`` is refused at the sensitivities' start, before the first
    step (forward and adjoint: the adjoint's forward pass no longer runs whole before its reverse pass meets the
    event), with a SceneError naming ``solve.sensitivities`` and the command that makes the kernel."""
    from latdyn.analyses.adjoint_sensitivities import AdjointSensitivities
    from latdyn.analyses.transient_sensitivities import TransientSensitivities
    from latdyn.errors import SceneError
    from tests.test_sensitivities_events import LATCH_PLANAR

    _without_the_kernel(monkeypatch)
    prepared = prepare(latdyn.load_scene(yaml.safe_load(LATCH_PLANAR)))
    owner = (TransientSensitivities if method == "forward" else AdjointSensitivities)(prepared)
    with pytest.raises(SceneError, match=r"solve\.sensitivities.*python -m codegen --variant default_xy"):
        owner.start(prepared.state)
    text = LATCH_PLANAR.replace("analysis: transient,", f"analysis: transient, sensitivity_method: {method},")
    with pytest.raises(SceneError, match=r"solve\.sensitivities.*python -m codegen --variant default_xy"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def test_a_model_without_beam_elements_does_not_need_the_kernel(monkeypatch):
    """A mass on a cable (tests/test_sensitivities_cables.py DROP: no beam element) with the kernel missing: its H
    (the body's generated blocks, the cable's differenced) is made, not refused, and is the one with the kernel."""
    from tests.test_sensitivities_cables import DROP

    def tangent():
        prepared = prepare(latdyn.load_scene(yaml.safe_load(DROP)))
        assert not len(prepared.model.element_dofs)
        rng = np.random.default_rng(3)
        state = _moved_state(prepared, rng)
        w = rng.normal(size=prepared.model.n_dofs)
        return configuration_tangent_of_weight(prepared.assembler, state, w, 1e-4, True, 1e-5).toarray()

    expected = tangent()
    _without_the_kernel(monkeypatch)
    assert np.any(expected) and np.array_equal(tangent(), expected)


def test_the_explicit_time_copy_makes_its_own_caches_of_the_laws_in_t():
    """:class:`ExplicitTime` copies the sensitivities' owner with other derivatives (the laws in t): made after the
    owner's caches of its parameters' uses were filled (its load and section layouts), its ∂r/∂t is the one made
    before them, not the owner's layouts read with the laws in t (before: the load in t's column was lost)."""
    from latdyn.analyses.transient_sensitivities import ExplicitTime, TransientSensitivities
    from tests.test_sensitivities_events import LATCH_PLANAR

    text = LATCH_PLANAR.replace("solve:", 'loads:\n  - {at: tip, force: [0, "0.3*sin(5*t)", "0*EI"]}\nsolve:', 1)
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    owner = TransientSensitivities(prepared)
    state = _moved_state(prepared, np.random.default_rng(4))
    state.t = 0.2
    before = owner.explicit_time(state, inertia=True)
    owner.residual_derivatives(state, 1.0, inertia=True)   # the owner's caches of its uses, filled
    owner.by_sections_only()
    after = ExplicitTime.of(owner)(state, inertia=True)
    assert np.any(before) and np.array_equal(after, before)


def test_the_tangent_of_a_linked_model_is_refused_stating_its_assumption():
    """``configuration_tangent_of_weight`` on the gimbal of rigid links (tests/test_sensitivities_rigid_links.py):
    a ValueError saying it assumes no rigid links or guides, not an AttributeError."""
    from tests.test_sensitivities_rigid_links import GIMBAL

    prepared = prepare(latdyn.load_scene(yaml.safe_load(GIMBAL)))
    w = np.ones(prepared.model.n_dofs)
    with pytest.raises(ValueError, match="without rigid links or guides"):
        configuration_tangent_of_weight(prepared.assembler, prepared.state, w, 1e-4, True, 1e-5)
