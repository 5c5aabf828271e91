"""The transient sensitivities' step matrix S = β′M + γ′C + K J assembled on its held pattern
(latdyn/analyses/step_matrix.py) against the same sum made by SciPy from Assembler.exact_matrices and
J's SciPy form: the values to the last bits, the solves to round-off; 3D (a skew hinge, a joint body
with mass, inertia and an offset centre of mass, beams with rotary inertia) and planar (rotation
coordinates off the plane are not coordinates), at a moved state with velocities and accelerations; and
the derivative laws of Parameters.derivative, which renames a text's parameters to share their parse."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from latdyn.analyses.step_matrix import ExactStepMatrix
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.factorization import solve_linear
from latdyn.assembly.prepare import prepare

SCENE_3D = """
parameters: {k: 40.0}
sections:
  s: {EA: 2.0e5, EIy: 30.0, EIz: 45.0, GJ: 25.0, rhoA: 1.2, rhoIy: 0.01, rhoIz: 0.015}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1.0, 0.4, 0.2], mass: 0.7, com: [0.05, -0.02, 0.03], inertia: [[0.02, 0.001, 0], [0.001, 0.03, 0], [0, 0, 0.025]]}
beams:
  upper: {from: base, to: knee, section: s, elements: 4}
  lower: {from: knee, to: [1.8, 1.1, -0.3], section: s, elements: 5,
         start: {hinge: {axis: [0.3, 0.5, 0.8], stiffness: k}}}
loads:
  - {at: lower.end, force: [0, 0, "-2*t"]}
solve: {analysis: transient, dt: 0.01, t_end: 0.02, sensitivities: [k]}
output: {probes: {tip: {point: lower.end, quantity: position, component: z}}}
"""

SCENE_PLANAR = """
parameters: {E: 40.0}
sections:
  s: {EA: 1.0e5, EIy: E, EIz: E, GJ: 20.0, rhoA: 0.9, rhoIy: 0.002, rhoIz: 0.002}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.5, 0.5, 0], mass: 0.3, inertia: [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]}
beams:
  arm: {from: base, to: tip, section: s, elements: 6}
loads:
  - {at: tip, force: [0, "-3*t", 0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.02, sensitivities: [E]}
output: {probes: {tip: {point: tip, quantity: position, component: y}}}
"""


def _moved_state(prepared, seed: int):
    """The initial state moved by a random free increment (large rotations), with random free
    velocities and accelerations."""
    model, assembler = prepared.model, prepared.assembler
    rng = np.random.default_rng(seed)
    n = model.n_dofs
    state = assembler.advance(assembler.initial_state(), 0.3 * rng.standard_normal(n))
    unpack_free(model, rng.standard_normal(n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.standard_normal(n), state.a, state.alpha, state.theta_ddot)
    return state


@pytest.mark.parametrize("text", [SCENE_3D, SCENE_PLANAR], ids=["3d", "planar"])
def test_the_step_matrix_on_its_held_pattern_is_scipys_sum(text):
    prepared = prepare(yaml.safe_load(text))
    sensitivities = TransientSensitivities(prepared)
    model, assembler = prepared.model, prepared.assembler
    n = model.n_dofs
    state = _moved_state(prepared, 3)
    increment = 0.2 * np.random.default_rng(4).standard_normal(n)
    _, tangent = sensitivities._rotation_operators(increment)
    beta_p, gamma_p = 1.7e4, 1.3e2
    # the reference: SciPy's sum of Assembler.exact_matrices and J as a sparse matrix
    M, C, K = assembler.exact_matrices(state, dense=False)
    reference = (beta_p * M + gamma_p * C + K @ tangent.matrix).toarray()
    values = assembler.exact_matrix_values(state)
    for made, ref in zip(values, (M, C, K)):
        indptr, indices = assembler.pattern()
        rows = np.repeat(np.arange(n), np.diff(indptr))
        dense = np.zeros((n, n))
        dense[rows, indices] = made
        assert np.max(np.abs(dense - ref.toarray())) <= 1e-13 * np.max(np.abs(ref.toarray()))
    step = ExactStepMatrix(*assembler.pattern(), n, tangent.slots)
    assembled = np.zeros((n, n))
    assembled[step.rows, step.cols] = step.values(values, tangent.blocks, beta_p, gamma_p)
    scale = np.max(np.abs(reference))
    assert np.max(np.abs(assembled - reference)) <= 1e-14 * scale
    factorization = step.factor(values, tangent.blocks, beta_p, gamma_p)
    rhs = np.random.default_rng(5).standard_normal((n, 3))
    solved = factorization.solve(rhs)
    expected = solve_linear(reference, rhs)
    assert np.max(np.abs(solved - expected)) <= 1e-10 * np.max(np.abs(expected))
    assert np.max(np.abs(reference @ solved - rhs)) <= 1e-10 * scale * np.max(np.abs(solved))
    # values() sums alone (latdyn_sensitivity_step with k < 0): the factors held stay those of factor()
    step.values(values, tangent.blocks, 2.0 * beta_p, gamma_p)
    assert np.array_equal(factorization.solve(rhs), solved)
    # C and K kept for the right-hand sides: exact_matrices' own
    assert np.max(np.abs(step.stiffness.toarray() - K.toarray())) <= 1e-13 * np.max(np.abs(K.toarray()))
    assert np.max(np.abs(step.damping.toarray() - C.toarray())) == 0.0


@pytest.mark.parametrize("kind", [None, "dense", "sparse", "pivoted"])
@pytest.mark.parametrize("text", [SCENE_3D, SCENE_PLANAR], ids=["3d", "planar"])
def test_the_native_step_solves_the_columns_as_the_factors_and_scipy_do(text, kind):
    """ExactStepMatrix.solve_step (csrc/sensitivity_step.c: S summed, factorised, −(∂r/∂p + K δq⁰ + C δv⁰)
    formed and solved in one call) gives, bit for bit, what its factorization's solve gives for the right-hand
    sides SciPy forms from the held C and K, and SciPy's solve of the same sum to round-off; in the storage the
    pattern chooses, dense, the supernodal sparse LU, and the band LU with pivoting the sparse LU falls back to
    where its pivot fails ("pivoted": every pivot refused)."""
    prepared = prepare(yaml.safe_load(text))
    sensitivities = TransientSensitivities(prepared)
    assembler, n = prepared.assembler, prepared.model.n_dofs
    state = _moved_state(prepared, 8)
    _, tangent = sensitivities._rotation_operators(0.2 * np.random.default_rng(9).standard_normal(n))
    beta_p, gamma_p = 2.1e4, 1.1e2
    M, C, K = assembler.exact_matrices(state, dense=False)
    reference = (beta_p * M + gamma_p * C + K @ tangent.matrix).toarray()
    values = assembler.exact_matrix_values(state)
    step = ExactStepMatrix(*assembler.pattern(), n, tangent.slots, kind="sparse" if kind == "pivoted" else kind)
    if kind == "pivoted":
        step.factorization.structure.sparse_lu.contents.pivot_tolerance = 1e300
    rng = np.random.default_rng(10)
    explicit, dq0, dv0 = (rng.standard_normal((n, 4)) for _ in range(3))
    z = step.solve_step(values, tangent.blocks, beta_p, gamma_p, explicit, dq0, dv0)
    assert (step.factorization._pivoted is not None) == (kind == "pivoted")
    rhs = -(explicit + step.stiffness @ dq0 + step.damping @ dv0)
    assert np.array_equal(z, step.factor(values, tangent.blocks, beta_p, gamma_p).solve(rhs))
    expected = np.linalg.solve(reference, -(explicit + K @ dq0 + C @ dv0))
    assert np.max(np.abs(z - expected)) <= 1e-10 * np.max(np.abs(expected))


@pytest.mark.parametrize("text", [SCENE_3D, SCENE_PLANAR], ids=["3d", "planar"])
def test_the_native_predicted_parts_and_update_are_the_steps_formulas(text):
    """_StepColumns (csrc/sensitivity_step.c latdyn_sensitivity_predict and _update) against the step's
    derivative written out in NumPy (latdyn/analyses/transient_sensitivities.py, module docstring) with R and J
    applied as 3 × 3 blocks on each free node's rotation coordinates: δa⁰ = (α_f δv̇ − α_m δa)/(1 − α_m),
    δ(hΔq)⁰ = h(δv + h(½ − β)δa + hβ δa⁰) (+ ∂(hΔq)/∂h in the step size's column), δq⁰ = R δq + J δ(hΔq)⁰,
    δv⁰ = δv + h(1 − γ)δa + hγ δa⁰ (+ ∂v/∂h), then δq⁰ + J z, δv⁰ + γ′z, β′z, δa⁰ + (1 − α_f)/(1 − α_m) β′z; 3D
    (large rotations, a hinge) and planar (R = J = I)."""
    from latdyn.analyses.transient_sensitivities import _StepColumns
    from latdyn.numerics.so3 import dexp_so3, expm_so3

    prepared = prepare(yaml.safe_load(text))
    sensitivities = TransientSensitivities(prepared)
    model, n, k = prepared.model, prepared.model.n_dofs, 3
    rng = np.random.default_rng(11)
    increment = 0.4 * rng.standard_normal(n)
    turn, tangent = sensitivities._rotation_operators(increment)
    h, am, af, gamma, beta = 0.003, 0.2, 0.3, 0.6, 0.3
    v_old, a_old, a_new = (rng.standard_normal(n) for _ in range(3))
    dq, dv, dvdot, da = (rng.standard_normal((n, k)) for _ in range(4))
    z = rng.standard_normal((n, k + 1))
    beta_p, gamma_p = 4.0e5, 6.0e2
    step = _StepColumns(sensitivities, n, k, (h, am, af, gamma, beta), turn, tangent)
    da0, dq0, dv0 = step.predict(v_old, a_old, a_new, dq, dv, dvdot, da)
    out = step.update(z, beta_p, gamma_p)
    # the reference, written out: R and J from the maps themselves, node by node
    slots = model.node_dofs[model.free_nodes, 3:6]
    psi = np.append(increment, 0.0)[np.where(slots < n, slots, n)]

    def rotated(blocks, columns):
        moved = columns.copy()
        for f, s in enumerate(slots):
            on = s < n
            moved[s[on]] = blocks[f][np.ix_(on, on)] @ columns[s[on]]
        return moved

    pad = lambda a: np.hstack([a, np.zeros((n, 1))])  # noqa: E731
    ref_da0 = (af * pad(dvdot) - am * pad(da)) / (1 - am)
    du0 = h * (pad(dv) + h * (0.5 - beta) * pad(da) + h * beta * ref_da0)
    du0[:, k] += v_old + 2 * h * (0.5 - beta) * a_old + 2 * h * beta * a_new
    ref_dq0 = rotated(expm_so3(psi), pad(dq)) + rotated(dexp_so3(psi), du0)
    ref_dv0 = pad(dv) + h * (1 - gamma) * pad(da) + h * gamma * ref_da0
    ref_dv0[:, k] += (1 - gamma) * a_old + gamma * a_new
    expected = {"dq": ref_dq0 + rotated(dexp_so3(psi), z), "dv": ref_dv0 + gamma_p * z, "dvdot": beta_p * z,
                "da": ref_da0 + (1 - af) / (1 - am) * beta_p * z}
    for got, ref in ((da0, ref_da0), (dq0, ref_dq0), (dv0, ref_dv0), *((out[key], expected[key]) for key in expected)):
        assert np.max(np.abs(got - ref)) <= 1e-14 * np.max(np.abs(ref))
    moved = np.max(np.abs(ref_dq0 - (pad(dq) + du0)))   # the rotations matter in 3D, not in the plane
    assert (moved > 1e-3) == (text is SCENE_3D)


def test_a_planar_models_rotation_operators_are_the_maps_identity_on_its_coordinates():
    """Where each free node has one rotation coordinate (the planar model's, about the normal),
    _rotation_operators takes R = exp(skew hΔq) and J = dexp(hΔq) as the identity without computing them:
    the maps computed are that on the coordinates bit for bit (small, moderate and many-turn increments),
    and the 3D model's are not the identity."""
    from latdyn.numerics.so3 import dexp_so3, expm_so3

    for text, planar in ((SCENE_PLANAR, True), (SCENE_3D, False)):
        prepared = prepare(yaml.safe_load(text))
        sensitivities = TransientSensitivities(prepared)
        model = prepared.model
        n = model.n_dofs
        slots = model.node_dofs[model.free_nodes, 3:6]
        on = slots < n
        both = on[:, :, None] & on[:, None, :]
        for scale in (1e-4, 0.3, 40.0):
            increment = scale * np.random.default_rng(6).standard_normal(n)
            psi = np.append(increment, 0.0)[np.where(on, slots, n)]
            turn, tangent = sensitivities._rotation_operators(increment)
            exponential = np.asarray(sensitivities.kernels.so3_exp(np.ascontiguousarray(psi))[0]).reshape(-1, 3, 3)
            assert np.max(np.abs(exponential - expm_so3(psi))) <= 1e-15   # the kernel's backends alike
            for taken, computed in ((turn, exponential), (tangent, dexp_so3(psi))):
                assert taken.is_identity == planar
                assert np.array_equal(taken.blocks[both], computed[both])
                assert np.array_equal(computed[both], np.broadcast_to(np.eye(3), computed.shape)[both]) == planar
                assert np.array_equal(np.asarray(taken(np.eye(n))), np.eye(n)) == planar


@pytest.mark.parametrize("text", [SCENE_3D, SCENE_PLANAR], ids=["3d", "planar"])
def test_exact_matrix_values_are_the_evaluations_blocks_scattered(text):
    """Assembler.exact_matrix_values reads the native Work buffers straight (no Evaluation): M, C and K
    equal, bit for bit, the scatter of the Evaluation's blocks (Evaluation._flat, as the step's own matrix
    assembles them) with the joint bodies' inertia stiffness added."""
    prepared = prepare(yaml.safe_load(text))
    assembler, model = prepared.assembler, prepared.model
    state = _moved_state(prepared, 7)
    values = assembler.exact_matrix_values(state)
    evaluation = assembler.evaluate(state, matrices=True, inertia=True, inertia_tangent=True)
    parts = [evaluation._flat(kind) for kind in ("mass", "damping", "stiffness")]
    parts[2][1] = parts[2][1] + assembler.joint_body_inertia_stiffness(state)[assembler._body_mask]
    for made, kind in zip(values, parts):
        assert np.array_equal(made, assembler.assemble_csr(kind).data)
    assert len(model.body_nodes) and np.any(values[2] != assembler.evaluate(state, matrices=True).combined(
        0.0, 0.0, 1.0, dense=False).tocsr().data)


RENAMED = """
parameters: {F0: 5.0, F1: 7.0, k: 30.0, th0: 0.2, p__1: 2.0, q: 3.0}
sections:
  s: {EA: 1.0e4, EIy: 20.0, EIz: 20.0, GJ: 15.0, rhoA: 1.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: base, to: [1, 0, 0], section: s, elements: 2,
        start: {hinge: {axis: [0, 0, 1], stiffness: "k*(1 + (theta - th0)**2)", rest_angle: th0}}}
loads:
  - {at: arm.end, force: ["0.1*F0*t", "0.1*F1*t", "p__1*q*t"]}
solve: {analysis: static, sensitivities: [F0]}
"""


@pytest.mark.parametrize("key, name, expected", [
    ("loads[0].force[0]", "F0", "0.1*t"),
    ("loads[0].force[1]", "F1", "0.1*t"),                      # the same text but for its parameter: one parse
    ("beams.arm.start.hinge.stiffness", "th0", "-30.0*(2*theta - 0.4)"),
    ("beams.arm.start.hinge.stiffness", "k", "(theta - 0.2)**2 + 1"),
    ("loads[0].force[2]", "q", "2.0*t"),                       # a parameter named like a placeholder
    ("loads[0].force[2]", "p__1", "3.0*t"),
])
def test_derivative_laws_of_renamed_texts_are_those_of_the_texts(key, name, expected):
    """Parameters.derivative renames a text's parameters by their order to share the parse and the
    derivative between texts alike (latdyn/scene/parameters.py): each derivative is still its own text's at
    its parameters' values, a parameter named ``p__1`` (renamed ``p__0``, ``q`` renamed ``p__1``) included
    (SymPy's difference of the two is 0)."""
    import sympy as sp

    from latdyn.scene.loader import load_scene

    parameters = load_scene(yaml.safe_load(RENAMED)).parameters
    got = sp.sympify(parameters.derivative(key, name))
    assert sp.simplify(got - sp.sympify(expected)) == 0
