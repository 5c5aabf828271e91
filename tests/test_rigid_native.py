"""Rigid links and guides evaluated natively (issue 31, item 2): the generated edge and wrench kernels
(codegen/joints.py, generated/joints.*; revolute, clamped and prismatic edges) against
latdyn.model.links' twists, a sliding point's kinematics and central differences, both backends; the compiled Newton iteration, which completes and reduces in C (csrc/links.c), against
the reference step of tests/reference_step.py, which reduces in Python (latdyn.assembly.linked);
and a rigid link against ever stiffer flexible beams; a linear model's inputs at a rigidly linked body
through the native links' J."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.linalg import expm

import latdyn

from latdyn.model.kernels import load_kernels
from latdyn.numerics.so3 import expm_so3, skew

from cli_runs import latdyn_run
from reference_step import reference_engine
from test_engine import loaded_arm
from test_initial_state import GYROSCOPE
from test_rigid import link_with_flexible_beam, tree_scene

RNG = np.random.default_rng(20261126)
BACKENDS = ["numpy", "c"]


def edge_inputs(clamped=False):
    """A random parent (position, frame, rates) and edge (axis, point, arm, sign, angle and rates)."""
    T = expm_so3(RNG.normal(size=3))
    parent = np.concatenate([RNG.normal(size=3), T.ravel(), RNG.normal(size=12)])
    axis = RNG.normal(size=3)
    axis /= np.linalg.norm(axis)
    sign = 0.0 if clamped else float(RNG.choice([-1.0, 1.0]))
    edge = np.concatenate([axis, RNG.normal(size=3), RNG.normal(size=3), [sign], RNG.normal(size=3)])
    return parent, edge


def spatial_cross(V, U):
    """(v, ω) ×̂ (v', ω') = (ω × v' + v × ω', ω × ω')."""
    return np.concatenate([np.cross(V[3:], U[:3]) + np.cross(V[:3], U[3:]), np.cross(V[3:], U[3:])])


def links_reference(parent, edge):
    """Child position, frame and rates by the twists of latdyn.model.links' module docstring, in NumPy:
    T_c = T_p R(a, sθ), x_c = x_p + T_p(o + R b), V_c = V_p + sθ̇ ξ, V̇_c = V̇_p + s(θ̈ ξ + θ̇ V_p ×̂ ξ)."""
    x, T = parent[:3], parent[3:12].reshape(3, 3)
    v, w, a, alpha = parent[12:15], parent[15:18], parent[18:21], parent[21:24]
    axis, point, arm, sign = edge[:3], edge[3:6], edge[6:9], edge[9]
    rate, accel = sign * edge[11], sign * edge[12]
    R = expm(skew(axis * sign * edge[10]))
    frame, position = T @ R, x + T @ (point + R @ arm)
    g = T @ axis
    xi = np.concatenate([np.cross(x + T @ point, g), g])
    V = np.concatenate([v - np.cross(w, x), w])
    V_dot = np.concatenate([a - np.cross(alpha, x) - np.cross(w, v), alpha])
    V_c, V_dot_c = V + rate * xi, V_dot + accel * xi + rate * spatial_cross(V, xi)
    v_c = V_c[:3] + np.cross(V_c[3:], position)
    a_c = V_dot_c[:3] + np.cross(V_dot_c[3:], position) + np.cross(V_c[3:], v_c)
    return position, frame, np.concatenate([v_c, V_c[3:], a_c, V_dot_c[3:]])


def slide_reference(parent, edge):
    """A guided body's position, frame and rates as a point sliding in a turning frame (textbook
    kinematics, not the twists): r = T_p(o + s θ a + b), g = T_p a, T_c = T_p, ω_c = ω_p, α_c = α_p,
    v_c = v_p + ω × r + s θ̇ g, a_c = a_p + α × r + ω × (ω × r) + 2 s θ̇ ω × g + s θ̈ g."""
    x, T = parent[:3], parent[3:12].reshape(3, 3)
    v, w, a, alpha = parent[12:15], parent[15:18], parent[18:21], parent[21:24]
    axis, point, arm, sign = edge[:3], edge[3:6], edge[6:9], edge[9]
    r, g = T @ (point + sign * edge[10] * axis + arm), T @ axis
    rate, accel = sign * edge[11], sign * edge[12]
    v_c = v + np.cross(w, r) + rate * g
    a_c = a + np.cross(alpha, r) + np.cross(w, np.cross(w, r)) + 2 * rate * np.cross(w, g) + accel * g
    return x + r, T, np.concatenate([v_c, w, a_c, alpha])


EDGE_KINDS = {"hinge": ("rigid_link_edge", links_reference), "clamped": ("rigid_link_edge", links_reference),
              "slide": ("prismatic_link_edge", slide_reference)}


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("kind", sorted(EDGE_KINDS))
def test_link_edge_kernel_against_links_and_differences(backend, kind):
    """rigid_link_edge (a hinge or a clamped edge) and prismatic_link_edge (a guide's slide): the child's
    frame, position and rates equal the twists' (links_reference) or a sliding point's in a turning frame
    (slide_reference: Coriolis and centrifugal terms written out) to 1e-11; child_transfer and child_joint
    are the derivatives of the child's configuration by the parent's (x += δd, T ← exp(skew δπ) T) and by
    θ, and of its velocity by the parent's and θ̇; child_convective the derivative of its acceleration by
    (v_p, ω_p, θ̇): all against central differences (1e-7)."""
    name, reference = EDGE_KINDS[kind]
    kernel = getattr(load_kernels(backend, "default"), name)
    eps = 1e-6
    for _ in range(3):
        parent, edge = edge_inputs(kind == "clamped")
        position, frame, rates, transfer, joint, convective = (o[0] for o in kernel(parent[None], edge[None]))
        x_ref, T_ref, rates_ref = reference(parent, edge)
        assert np.allclose(position, x_ref, rtol=0, atol=1e-12)
        assert np.allclose(frame.reshape(3, 3), T_ref, rtol=0, atol=1e-12)
        assert np.allclose(rates, rates_ref, rtol=0, atol=1e-11)

        def configuration(p, e):
            x, T = (o[0] for o in kernel(p[None], e[None])[:2])
            return x, T.reshape(3, 3)

        def moved_parent(k, h):  # parent moved along coordinate k (0-2 δd, 3-5 δπ) by h
            p = parent.copy()
            if k < 3:
                p[k] += h
            else:
                p[3:12] = (expm_so3(np.eye(3)[k - 3] * h) @ parent[3:12].reshape(3, 3)).ravel()
            return p

        def twist_difference(plus, minus):  # (δx, δπ) of the child between two configurations
            (xp, Tp), (xm, Tm) = plus, minus
            W = (Tp - Tm) / (2 * eps) @ frame.reshape(3, 3).T
            return np.concatenate([(xp - xm) / (2 * eps), [W[2, 1], W[0, 2], W[1, 0]]])

        by_parent = np.column_stack([twist_difference(configuration(moved_parent(k, eps), edge),
                                                      configuration(moved_parent(k, -eps), edge)) for k in range(6)])
        assert np.allclose(transfer, by_parent, rtol=0, atol=1e-7)
        up, down = edge.copy(), edge.copy()
        up[10] += eps
        down[10] -= eps
        assert np.allclose(joint, twist_difference(configuration(parent, up), configuration(parent, down)),
                           rtol=0, atol=1e-7)
        columns = []
        for k in range(7):  # v_p, ω_p, θ̇
            p_up, p_down, e_up, e_down = parent.copy(), parent.copy(), edge.copy(), edge.copy()
            if k < 6:
                p_up[12 + k] += eps
                p_down[12 + k] -= eps
            else:
                e_up[11] += eps
                e_down[11] -= eps
            rates_up, rates_down = kernel(p_up[None], e_up[None])[2][0], kernel(p_down[None], e_down[None])[2][0]
            columns.append((rates_up - rates_down) / (2 * eps))
        by_rates = np.column_stack(columns)
        assert np.allclose(by_rates[:6, :6], transfer, rtol=0, atol=1e-7)  # the velocity by the parent's
        assert np.allclose(by_rates[:6, 6], joint, rtol=0, atol=1e-7)
        assert np.allclose(by_rates[6:], convective, rtol=0, atol=1e-7)


@pytest.mark.parametrize("backend", BACKENDS)
def test_wrench_kernels_against_differences(backend):
    """hinge_wrench and root_wrench: Jᵀ(f, m) of a wrench at y on a hinge (s g·((y − o_g) × f + m)) and
    on a root (f, m + (y − x_r) × f), by hand; their derivatives by (δx_p, δπ_p, δy) and (δx_r, δy)
    against central differences (1e-7)."""
    ks = load_kernels(backend, "default")
    eps = 1e-6
    for _ in range(3):
        parent, edge = edge_inputs()
        T = parent[3:12].reshape(3, 3)
        wrench = RNG.normal(size=9)
        data = np.concatenate([edge[:6], edge[9:10]])
        value, derivative = (o[0] for o in ks.hinge_wrench(parent[None, :12], data[None], wrench[None]))
        g, o = T @ edge[:3], parent[:3] + T @ edge[3:6]
        y, f, m = wrench[:3], wrench[3:6], wrench[6:]
        assert value == pytest.approx(edge[9] * g @ (np.cross(y - o, f) + m), abs=1e-12)
        columns = []
        for k in range(9):
            p_up, p_down, w_up, w_down = parent[:12].copy(), parent[:12].copy(), wrench.copy(), wrench.copy()
            if k < 3:
                p_up[k] += eps
                p_down[k] -= eps
            elif k < 6:
                p_up[3:12] = (expm_so3(np.eye(3)[k - 3] * eps) @ T).ravel()
                p_down[3:12] = (expm_so3(-np.eye(3)[k - 3] * eps) @ T).ravel()
            else:
                w_up[k - 6] += eps
                w_down[k - 6] -= eps
            columns.append((ks.hinge_wrench(p_up[None], data[None], w_up[None])[0][0]
                            - ks.hinge_wrench(p_down[None], data[None], w_down[None])[0][0]) / (2 * eps))
        assert np.allclose(derivative, columns, rtol=0, atol=1e-7)

        root_input = RNG.normal(size=12)
        value, derivative = (o[0] for o in ks.root_wrench(root_input[None]))
        x_r, y, f, m = root_input[:3], root_input[3:6], root_input[6:9], root_input[9:]
        assert np.allclose(value, np.concatenate([f, m + np.cross(y - x_r, f)]), rtol=0, atol=1e-12)
        by_difference = np.column_stack([(ks.root_wrench((root_input + eps * np.eye(12)[k])[None])[0][0]
                                          - ks.root_wrench((root_input - eps * np.eye(12)[k])[None])[0][0])
                                         / (2 * eps) for k in range(6)])
        assert np.allclose(derivative, by_difference, rtol=0, atol=1e-7)
        assert np.allclose(derivative[3:], np.hstack([skew(f), -skew(f)]), rtol=0, atol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_slide_wrench_against_differences(backend):
    """slide_wrench: Jᵀ(f, m) of a wrench at y on a guide's slide, s g·f by hand (1e-12); its derivative by
    (δx_p, δπ_p, δy) against central differences (1e-7), and by hand: s (g × f) on δπ_p alone (1e-12)."""
    ks = load_kernels(backend, "default")
    eps = 1e-6
    for _ in range(3):
        parent, edge = edge_inputs()
        T = parent[3:12].reshape(3, 3)
        wrench = RNG.normal(size=9)
        data = np.concatenate([edge[:6], edge[9:10]])
        value, derivative = (o[0] for o in ks.slide_wrench(parent[None, :12], data[None], wrench[None]))
        g, f = T @ edge[:3], wrench[3:6]
        assert value == pytest.approx(edge[9] * g @ f, abs=1e-12)
        columns = []
        for k in range(9):
            p_up, p_down, w_up, w_down = parent[:12].copy(), parent[:12].copy(), wrench.copy(), wrench.copy()
            if k < 3:
                p_up[k] += eps
                p_down[k] -= eps
            elif k < 6:
                p_up[3:12] = (expm_so3(np.eye(3)[k - 3] * eps) @ T).ravel()
                p_down[3:12] = (expm_so3(-np.eye(3)[k - 3] * eps) @ T).ravel()
            else:
                w_up[k - 6] += eps
                w_down[k - 6] -= eps
            columns.append((ks.slide_wrench(p_up[None], data[None], w_up[None])[0][0]
                            - ks.slide_wrench(p_down[None], data[None], w_down[None])[0][0]) / (2 * eps))
        assert np.allclose(derivative, columns, rtol=0, atol=1e-7)
        assert np.allclose(derivative, np.concatenate([np.zeros(3), edge[9] * np.cross(g, f), np.zeros(3)]),
                           rtol=0, atol=1e-12)


def test_the_c_iteration_matrix_of_guides_and_links_is_the_python_one():
    """3D, at a random large-rotation state with random rates: a free body carrying a guided body (spring
    and damper on the slide) that carries a rigid link, with loads and gravity (tests/test_guides.py's
    tangent scene, whose Python reduction is checked there against central differences). The iteration
    matrix β′M + γ′C + K that csrc/links.c reduces and assembles (latdyn_iteration_matrix, unfactored: the
    slide's row through prismatic_link_edge and slide_wrench, the hinge's through rigid_link_edge and
    hinge_wrench) equals latdyn.assembly.linked's on every entry to 1e-12 of the largest (measured 7.1e-17
    for K alone, 1.4e-16 for C, 5.7e-17 at β′ = 400, γ′ = 20), and so does the reduced residual; the
    geometric term is K's largest entry there (C's slide_wrench swapped for hinge_wrench: 0.86 off)."""
    import ctypes

    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.linked import evaluate_linked
    from latdyn.assembly.prepare import prepare
    from latdyn.step.compiled import CompiledGeneralizedAlpha, matrix_pattern
    from latdyn.step.integrators import AlphaParameters
    raw = scene_yaml("""
gravity: [0.3, -1.0, -9.81]
sections:
  s: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.5, rhoIy: 0.01, rhoIz: 0.02}
bodies:
  A: {at: [0, 0, 0], mass: 3, inertia: [0.2, 0.3, 0.4], com: [0.1, 0, 0.05]}
  B:
    at: [0.4, 0.2, 0.1]
    mass: 0.7
    inertia: [0.01, 0.02, 0.03]
    com: [0, 0.1, 0]
    guide: {on: A, axis: [1, 0.5, -0.3], stiffness: 7.0, damping: 0.3}
beams:
  l: {from: B, to: [1.0, 0.8, 0.2], section: s, rigid: true, start: {hinge: {axis: [0, 1, 1]}}}
loads:
  - {at: B, force: [1, 2, 3], moment: [0.3, -0.2, 0.1]}
  - {at: l.end, force: [0, -4, 1]}
solve: {t_end: 0.1, dt: 0.01}
""")
    prepared = prepare(latdyn.load_scene(raw))
    model, assembler = prepared.model, prepared.assembler
    n = model.n_dofs
    assert n == 8 and any(e.prismatic for e in model.links.edges)
    rng = np.random.default_rng(7)
    state = assembler.advance(prepared.state, rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    python = evaluate_linked(model.links, assembler, state, True, 1.0, True)
    geometric = np.asarray(python.geometric.toarray() if hasattr(python.geometric, "toarray") else python.geometric)
    step = CompiledGeneralizedAlpha(assembler, AlphaParameters.for_method("generalized-alpha", 0.8), 1e-10, 25, 1.0)
    step._setup()
    native, factorization = step._native, step.factorization
    pattern_rows, pattern_cols = matrix_pattern(assembler)
    in_pattern = np.zeros((n, n), dtype=bool)
    in_pattern[pattern_rows, pattern_cols] = True
    rows, cols = np.nonzero(in_pattern)
    for beta_p, gamma_p in ((0.0, 0.0), (0.0, 1.0), (400.0, 20.0)):  # K alone, C alone, a Newton iteration's
        expected = np.asarray(python.combined(beta_p, gamma_p, 1.0, dense=True))
        if beta_p == gamma_p == 0.0:
            assert np.abs(geometric).max() > 0.1 * np.abs(expected).max()  # the geometric term counts in K
        native.complete_links(state)
        native.evaluate(state, matrices=True, load_factor=1.0, inertia=True, inertia_tangent=False)
        factorization.values[:] = np.nan  # every entry of the pattern is written
        native.library.latdyn_iteration_matrix(native.model_ref, native.work_ref,
                                               ctypes.byref(native.configuration(state)), beta_p, gamma_p, 0)
        matrix = np.zeros((n, n))
        matrix[rows, cols] = factorization.values[factorization.position(rows, cols)]
        assert np.abs(expected[~in_pattern]).max(initial=0.0) == 0.0
        assert np.abs(matrix - expected).max() <= 1e-12 * np.abs(expected).max(), (beta_p, gamma_p)
        residual = native.buffers["total"][:n]
        assert np.abs(residual - python.residual[:n]).max() <= 1e-12 * np.abs(python.residual).max()


def gimbal():
    """The gyroscope's gimbal of rigid links (tests/test_initial_state.py): a prescribed spin hinge on a
    dependent body, gravity, released at rest."""
    raw = yaml.safe_load(GYROSCOPE.format(rigid="true", precession=0.0))
    raw["solve"]["t_end"] = 0.1
    return raw


def transient_tree():
    """tests/test_rigid.py's tree, in motion: a free root body, links to a dependent body and on, loads on
    dependent nodes, a hinge spring, gravity."""
    raw = tree_scene()
    raw["solve"] = {"t_end": 0.1, "dt": 0.005}
    raw["output"] = {"probes": {"kinetic": {"energy": "kinetic"}, "a1": {"hinge": "l1.start", "quantity": "angle"},
                                "a2": {"hinge": "l1.end", "quantity": "rate"},
                                "a3": {"hinge": "l2.start", "quantity": "angle"},
                                "tip": {"point": "l2.end", "quantity": "position", "component": "y"}}}
    return raw


def arm_with_a_rigid_link():
    """tests/test_engine.py's loaded arm with beam b rigid: a prescribed hinge on the link, the elbow body
    dependent, a flexible beam hanging from it with a follower load, springs, dampers, torques."""
    raw = loaded_arm(t_end=0.1)
    raw["beams"]["b"]["rigid"] = True
    return raw


def link_carrying_a_long_beam():
    """tests/test_rigid.py's link carrying a flexible beam, the beam of 24 elements: 146 coordinates, past
    the dense limit (band or sparse storage in C, sparse products in Python)."""
    raw = link_with_flexible_beam()
    raw["beams"]["flex"]["elements"] = 24
    raw["solve"].update(t_end=0.004, dt=0.002)  # two steps (from t = 0.006 on its Newton cuts the step, on main too)
    return raw


def scene_yaml(text: str) -> dict:
    """A scene's YAML as latdyn.load_scene reads a file (``on`` a key, ``rod.node[2]`` one scalar)."""
    from latdyn.scene.loader import _yaml_loader

    loader = _yaml_loader()(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def guided_slider_crank():
    """examples/slider_crank.yaml to 0.1 s: a crank of a rigid link driven through its hinge, a flexible rod,
    the slider on a ground guide (a prismatic edge from a fixed node); the guide's probes."""
    raw = scene_yaml((Path(__file__).parents[1] / "examples" / "slider_crank.yaml").read_text())
    raw["solve"].update(t_end=0.1)
    return raw


def bead_on_a_swinging_pendulum():
    """3D, a prismatic edge below hinges: a rigid pendulum on a tilted hinge to a fixed hub carries a tip
    body, on which a bead slides along an oblique axis with a spring and a damper, under gravity."""
    return scene_yaml("""
gravity: [0, -9.81, 0]
sections:
  rod: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.5}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.5, 0.1, 0.2], mass: 0.4, inertia: [0.01, 0.02, 0.03]}
  bead:
    at: [0.6, 0.1, 0.25]
    mass: 0.3
    guide: {on: tip, axis: [1, 0.5, 0.5], stiffness: 40.0, damping: 0.2}
beams:
  arm:
    from: hub
    to: tip
    section: rod
    rigid: true
    start: {hinge: {axis: [0, 0.3, 1]}}
solve: {t_end: 0.1, dt: 0.005}
output:
  probes:
    s: {guide: bead, quantity: position}
    s_rate: {guide: bead, quantity: rate}
    f: {guide: bead, quantity: force}
    swing: {hinge: arm.start, quantity: angle}
    y: {point: bead, quantity: position, component: y}
""")


def controlled_hub():
    """3D, tests/test_controllers.py's hub (a rigid link to a tip mass on a hinge) slewed by a continuous PD
    on its hinge angle and on the tip's (a dependent node's) position and velocity: the controller's
    coupling entries of the iteration matrix at free and at dependent coordinates."""
    from test_controllers import SPATIAL, hub

    controller = """
  ctl:
    output: "-40*(th - 1) - 8*om - 30*(y - 0.2) - 5*vy"
"""
    probes = ("    y: {point: tip, quantity: position, component: y}\n"
              "    vy: {point: tip, quantity: velocity, component: y}\n    u: {controller: ctl}")
    return scene_yaml(hub(controller, axis=SPATIAL, solve="{t_end: 0.2, dt: 0.01}", probes=probes))


RIGID_SCENES = {"gimbal": gimbal, "transient_tree": transient_tree, "arm_with_a_rigid_link": arm_with_a_rigid_link,
                "link_carrying_a_long_beam": link_carrying_a_long_beam, "guided_slider_crank": guided_slider_crank,
                "bead_on_a_swinging_pendulum": bead_on_a_swinging_pendulum, "controlled_hub": controlled_hub}


def _run(raw, **solve):
    raw = copy.deepcopy(raw)
    raw["solve"].update(solve)
    return latdyn.run(latdyn.load_scene(raw))


@pytest.mark.parametrize("scene", sorted(RIGID_SCENES))
def test_the_native_reduction_steps_as_the_python_one(scene):
    """The compiled step completes and reduces in C; the reference step of tests/reference_step.py
    with latdyn.assembly.linked in Python: the same Newton iterations, probes equal to 1e-10 of their
    range (round-off: 2e-14 measured)."""
    raw = RIGID_SCENES[scene]()
    with reference_engine():
        python = _run(raw)
    native = _run(raw, engine="compiled", newton="full")
    assert native.summary["newton_iterations"] == python.summary["newton_iterations"]
    for name in python.probes:
        x, y = np.asarray(python.probes[name]), np.asarray(native.probes[name])
        assert np.max(np.abs(x - y)) <= 1e-10 * max(float(np.max(np.abs(x))), 1e-12), name


def gyroscope(rigid: bool, stiffness_scale: float = 1.0) -> dict:
    """The gyroscope's gimbal released at rest, of rigid links or of flexible beams whose EA, EI, GJ are
    scaled, at a step small enough (h = 0.0025) that the two models' discretization errors stay below
    the beams' compliance (the motion to 0.3 s: nutation about a precession of ~0.06 rad)."""
    raw = yaml.safe_load(GYROSCOPE.format(rigid="true" if rigid else "false", precession=0.0))
    section = raw["sections"]["stiff"]
    for key in ("EA", "EIy", "EIz", "GJ"):
        section[key] = float(section[key]) * stiffness_scale
    raw["solve"].update(t_end=0.3, dt=0.0025)
    raw["output"]["every"] = 0.01
    return raw


def test_a_rigid_gimbal_is_the_limit_of_stiffer_flexible_beams():
    """A gimbal of flexible beams moves as the gimbal of rigid links to the order of the beams'
    compliance, in 3D (a spinning rotor, precession and nutation): ten times stiffer beams, a ten times
    smaller difference of the tilt (measured 1.24e-2, 1.16e-3 of its range at EI = 1e4, 1e5) and of
    the precession angle (1.9e-3 at 1e4), until the time discretization's floor (1.0e-4 and 2.5e-4
    at EI = 1e6, h = 0.0025)."""
    rigid = latdyn.run(latdyn.load_scene(gyroscope(True)))

    def difference(scale, probe):
        beams = latdyn.run(latdyn.load_scene(gyroscope(False, scale)))
        x, y = np.asarray(rigid.probes[probe]), np.asarray(beams.probes[probe])
        return float(np.max(np.abs(x - y)) / np.max(np.abs(x)))

    tilt = [difference(scale, "tilt") for scale in (0.01, 0.1)]
    assert 5.0 < tilt[0] / tilt[1] < 20.0, tilt
    assert tilt[1] < 2e-3
    assert difference(0.01, "precession") < 3e-3
    assert difference(1.0, "precession") < 2e-4


@pytest.mark.parametrize("newton", ["full", "modified"])
def test_a_rigid_gimbal_resumes_bit_for_bit(newton, tmp_path, monkeypatch):
    """Interrupted (Ctrl-C) at t = 0.05 and resumed, the gimbal of rigid links writes the files of the
    uninterrupted run, bit for bit (modified Newton's held factorization of the reduced matrix included)."""
    from test_checkpoint import interrupt_at, relative_difference

    raw = gimbal()
    raw["solve"].update(newton=newton)
    latdyn.run(latdyn.load_scene(raw), tmp_path / "whole")
    with monkeypatch.context() as m:
        interrupt_at(m, 0.05)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(latdyn.load_scene(raw), tmp_path / "resumed")
    result = latdyn.run(latdyn.load_scene(raw), tmp_path / "resumed", resume=True)
    assert result.summary["resumed_from_t"] == pytest.approx(0.05, abs=1e-9)
    assert relative_difference(tmp_path / "whole", tmp_path / "resumed") == 0.0


LINKED_INPUTS = """
title: a body carried by a rigid arm on a skew spring hinge, pushed and turned at the body
sections: {link: {EA: 1.0e9, EIy: 1.0e9, EIz: 1.0e9, GJ: 1.0e9, rhoA: 0.0}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  panel: {at: [1, 0, 0], mass: 2.0, inertia: [0.5, 0.7, 0.9]}
beams:
  arm:
    from: base
    to: panel
    section: link
    rigid: true
    start: {hinge: {axis: [1, 2, 2], stiffness: 4.0}}
solve:
  analysis: modes
  count: 1
  linear_model: {inputs: [panel.force.z, panel.moment.x], outputs: [angle]}
output:
  probes:
    angle: {hinge: arm.start, quantity: angle}
"""


def test_linear_model_inputs_at_a_rigidly_linked_body_reach_the_hinge_through_j(tmp_path):
    """An input at a node that follows a rigid link reaches the minimum coordinates through the native
    links' J (linearise._dependent_input_force). About the skew axis a = [1, 2, 2]/3 through the origin,
    the body at p = [1, 0, 0]: I_a = m |a × p|² + aᵀ I a, poles ±i √(k/I_a); static gains of the angle
    a·(p × e_z)/k = −2/(3k) for the force along z and a·e_x/k = 1/(3k) for the moment about x (3D, CLI)."""
    done, out = latdyn_run(tmp_path, LINKED_INPUTS)
    assert done.returncode == 0, done.stderr
    model = np.load(out / "linear_model.npz")
    A, B, C, D = model["A"], model["B"], model["C"], model["D"]
    a, p, k = np.array([1.0, 2.0, 2.0]) / 3.0, np.array([1.0, 0.0, 0.0]), 4.0
    inertia = 2.0 * np.dot(np.cross(a, p), np.cross(a, p)) + a @ np.diag([0.5, 0.7, 0.9]) @ a
    np.testing.assert_allclose(np.sort(np.abs(np.linalg.eigvals(A).imag)), [np.sqrt(k / inertia)] * 2, rtol=1e-10)
    np.testing.assert_allclose(-C @ np.linalg.solve(A, B) + D, [[-2.0 / (3.0 * k), 1.0 / (3.0 * k)]], rtol=1e-10)


GUIDE_FRICTION = """
bodies:
  m: {at: [0.3, -0.2, 0.5], mass: 1.0, inertia: [0.1, 0.2, 0.3],
      guide: {axis: [1, 2, 2], stiffness: 100.0, rest: -0.105, friction: {coulomb: 1.0}}}
solve: {t_end: 2.0, dt: 0.002}
output:
  probes:
    s: {guide: m, quantity: position}
    rate: {guide: m, quantity: rate}
    total: {energy: total}
    dissipated: {energy: dissipated}
"""

GUIDE_STOP = """
bodies:
  m: {at: [0.3, -0.2, 0.5], mass: 2.0, inertia: [0.1, 0.2, 0.3],
      guide: {axis: [1, 2, 2], limits: [-1, 0.05], contact: {stiffness: 800.0}}}
initial_velocity: {linear: [0.3333333333333333, 0.6666666666666666, 0.6666666666666666]}
solve: {t_end: 0.3, dt: 0.001}
output:
  probes:
    s: {guide: m, quantity: position}
    rate: {guide: m, quantity: rate}
"""


def test_a_guide_with_coulomb_friction_and_one_on_a_compliant_stop():
    """Contact and friction at a guide, whose slider is a dependent node completed and reduced in C (3D:
    the axis [1, 2, 2]). Friction: m s̈ + k (s − r) + F sign ṡ = 0 from u = s − r = 0.105 (m 1, k 100,
    F 1): each half cycle π/ω the swing shrinks by 2F/k = 0.02 and the slider sticks at u = −0.005
    (k |u| < F) after five; measured at dt = 0.002: extremes and the rest within 1.1e-5, stuck from
    t = 1.570 (5π/10 = 1.5708), dissipated = lost to 1.1e-4. A linear compliant stop (k_c 800, m 2) hit
    at 1 m/s: the peak penetration v √(m/k_c) = 0.05 to 2.2e-6 and the rebound at −1 to 1.6e-5."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(GUIDE_FRICTION)))
    t, u, rate = result.t, result.probes["s"] + 0.105, result.probes["rate"]
    half = np.pi / 10.0
    for k, extreme in enumerate((-0.085, 0.065, -0.045, 0.025), start=1):
        window = np.abs(t - k * half) < 0.25 * half
        assert (u[window].min() if extreme < 0 else u[window].max()) == pytest.approx(extreme, abs=3e-5)
    moving = np.nonzero(rate != 0.0)[0]
    assert t[moving[-1] + 1] == pytest.approx(5 * half, abs=0.004) and np.any(rate[t < 1.5] != 0.0)
    assert u[-1] == pytest.approx(-0.005, abs=3e-5)
    lost = result.probes["total"][0] - result.probes["total"][-1]
    assert result.probes["dissipated"][-1] == pytest.approx(lost, rel=5e-4)

    result = latdyn.run(latdyn.load_scene(yaml.safe_load(GUIDE_STOP)))
    assert result.probes["s"].max() == pytest.approx(0.05 + 0.05, abs=1e-5)
    assert result.probes["rate"][-1] == pytest.approx(-1.0, abs=1e-4)
