"""The joints' generated kernels called a batch of items at a time by the compiled evaluation
(csrc/evaluate.c, ITEMS_PER_BATCH) give what each item gives alone, to the bit.

A call of a generated kernel for one item fills every SIMD lane with that item; evaluate.c gathers
the element ends (hinged_end), joint bodies (joint_body), hinges (hinge_force) and the free nodes'
rotation updates (so3_exp) into batches instead. Each lane does the kernel's operations on its own
item, so nothing may change: here a genuinely 3D chain of 20 hinged beams with joint bodies (40 ends,
20 bodies, 27 hinges: full batches and tails) at a moving, twisted state, against the same C kernels
called item by item from Python.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.assembly.assembler import Assembler, unpack_free
from latdyn.assembly.native_model import hinge_coefficients, joint_contact_rows
from latdyn.model.model import Model
from latdyn.model.kernels import load_kernels

LINKS = 20


def chain_scene() -> str:
    """A 3D chain of LINKS beams between bodies with mass and inertia, each beam hinged at its start
    (spring, damper and a preload about a tilted axis), every third also at its end."""
    rng = np.random.default_rng(7)
    points = np.cumsum(np.vstack([np.zeros(3), 0.6 * rng.normal(size=(LINKS, 3)) + [1.0, 0.2, 0.1]]), axis=0)
    lines = ["sections:", "  s: {EA: 1.0e5, EIy: 300.0, EIz: 200.0, GJ: 150.0, rhoA: 0.4, rhoIy: 0.002, rhoIz: 0.001}", "bodies:",
             "  b0: {at: [0, 0, 0], fixed: true}"]
    for k in range(1, LINKS + 1):
        x, y, z = points[k]
        lines.append(f"  b{k}: {{at: [{x:.6f}, {y:.6f}, {z:.6f}], mass: {0.1 + 0.01 * k}, "
                     f"com: [0.01, -0.02, 0.03], inertia: [0.003, 0.002, 0.004]}}")
    lines.append("beams:")
    for k in range(LINKS):
        a = rng.normal(size=3)
        hinge = (f"{{hinge: {{axis: [{a[0]:.5f}, {a[1]:.5f}, {a[2]:.5f}], stiffness: {2.0 + k}, "
                 f"damping: 0.05, rest_angle: {0.1 * (k % 5) - 0.2}}}}}")
        end = f", end: {hinge}" if k % 3 == 0 else ""
        lines.append(f"  l{k}: {{from: b{k}, to: b{k + 1}, section: s, elements: 1, start: {hinge}{end}}}")
    lines += ["gravity: [0, 0, -9.81]", "solve: {t_end: 0.01, dt: 0.001}"]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def moving():
    scene = latdyn.load_scene(yaml.safe_load(chain_scene()))
    model = Model.from_scene(scene)
    assembler = Assembler(model, load_kernels(backend="c", variant=scene.solve.formulation), scene.gravity)
    state = assembler.initial_state()
    rng = np.random.default_rng(3)
    state = assembler.advance(state, 0.05 * rng.standard_normal(model.n_dofs))  # hinges turned, nodes moved
    unpack_free(model, rng.standard_normal(model.n_dofs), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.standard_normal(model.n_dofs), state.a, state.alpha, state.theta_ddot)
    return model, assembler, state


def test_the_chain_fills_batches_and_tails(moving):
    model, _, state = moving
    assert len(model.element_nodes) == LINKS and len(model.body_nodes) == LINKS and len(model.hinges) > 16
    assert np.all(np.abs(state.theta) > 0)  # every hinge turned: the sin and cos are not trivial


def test_element_ends_equal_hinged_end_end_by_end(moving):
    model, assembler, state = moving
    native, kernels = assembler.native(), assembler.kernels
    geometry, _, _ = native.element_inputs(state)
    geometry = geometry.reshape(len(model.element_nodes), 36)
    data = np.concatenate([model.element_axes, model.element_offsets, model.element_frames0.reshape(-1, 2, 9),
                           np.zeros((len(model.element_nodes), 2, 1))], axis=2)  # a r E0 θ: the kernel's input
    for e in range(len(model.element_nodes)):
        for end in range(2):
            node, hinge = model.element_nodes[e, end], model.element_hinges[e, end]
            row = data[e, end].copy()
            row[15] = state.theta[hinge] if hinge >= 0 else 0.0
            frame, offset, axis = kernels.hinged_end(state.T[node].reshape(1, 9), row.reshape(1, 16))
            assert np.array_equal(geometry[e, 12 + 9 * end:21 + 9 * end], frame.ravel())
            assert np.array_equal(geometry[e, 6 + 3 * end:9 + 3 * end], offset.ravel())
            assert np.array_equal(geometry[e, 30 + 3 * end:33 + 3 * end], axis.ravel())


def test_joint_bodies_and_hinges_equal_their_kernels_item_by_item(moving):
    model, assembler, state = moving
    native, kernels = assembler.native(), assembler.kernels
    native.evaluate(state, matrices=True, load_factor=1.0, inertia=True, inertia_tangent=False)
    b = native.buffers
    sections = np.concatenate([model.body_mass[:, None], model.body_com, model.body_inertia.reshape(-1, 9)], axis=1)
    gravity = np.array([[0.0, 0.0, -9.81]])
    for k, node in enumerate(model.body_nodes):
        motion = np.concatenate([state.w[node], state.a[node], state.alpha[node]]).reshape(1, 9)
        force, mass, gyroscopic, gravity_stiffness = kernels.joint_body(state.T[node].reshape(1, 9), motion,
                                                                       sections[k:k + 1], gravity)
        assert np.array_equal(b["body_vector"].reshape(-1, 6)[k], force.ravel())
        assert np.array_equal(b["body_mass"].reshape(-1, 36)[k], mass.ravel())
        assert np.array_equal(b["body_damping"].reshape(-1, 36)[k], gyroscopic.ravel())
        assert np.array_equal(b["body_stiffness"].reshape(-1, 36)[k], gravity_stiffness.ravel())
    contact = joint_contact_rows(model.hinges)
    stiffness, damping, rest, with_laws = hinge_coefficients(model.hinges)
    assert not with_laws
    forces = b["joint_forces"]
    for j in range(len(model.hinges)):
        state_row = np.array([[state.theta[j], state.theta_dot[j], rest[j], 1.0]])
        laws = np.zeros((1, 9))
        laws[0, 0], laws[0, 3] = stiffness[j], damping[j]
        out = kernels.hinge_force(state_row, laws, contact[j:j + 1])
        f, d_theta, d_rate = (np.ravel(o)[0] for o in out[:3])
        assert forces[j] == f
        assert b["hinge_d_theta"][j] == d_theta and b["hinge_d_rate"][j] == d_rate


def test_the_rotation_update_equals_so3_exp_node_by_node(moving):
    model, assembler, state = moving
    native, kernels = assembler.native(), assembler.kernels
    rng = np.random.default_rng(11)
    increment = 0.3 * rng.standard_normal(model.n_dofs)
    updated = state.copy()
    native.advance_free(updated, increment)
    rotations = np.zeros((len(model.nodes), 3))
    unpack_free(model, increment, np.zeros((len(model.nodes), 3)), rotations, np.zeros(len(model.hinges)))
    for node in model.free_nodes:
        (R,) = kernels.so3_exp(rotations[node].reshape(1, 3))
        expected = R.reshape(3, 3) @ state.T[node].reshape(3, 3)
        assert np.allclose(updated.T[node].reshape(3, 3), expected, rtol=0, atol=4e-16)
