"""Linear solves (dense / band / SuperLU, BLAS threads) and the held-coordinate check at any size."""
from __future__ import annotations

import time

import numpy as np
import pytest
import scipy.sparse as sps

import latdyn
from latdyn.assembly import factorization
from latdyn.assembly.factorization import Factorization
from latdyn.numerics import linalg as linalg
from latdyn.assembly.assembler import Assembler, unpack_free
from latdyn.model.kernels import load_kernels
from latdyn.assembly.factorization import solve_linear
from latdyn.numerics.linalg import DENSE_LIMIT, psd_null_direction, single_thread_blas
from latdyn.model.model import Model
from latdyn.scene.loader import load_scene
from latdyn.assembly.prepare import prepare

SECTION = {"EA": 1.0e5, "EIy": 50.0, "EIz": 80.0, "GJ": 40.0, "rhoA": 1.0}
SOLVE = {"analysis": "transient", "t_end": 0.01, "dt": 0.01}


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


RANDOM_DIRECTION = unit([0.37, -0.81, 0.45])


def lattice(n: int, layers: int, per_beam: int = 1) -> dict:
    """Joint bodies with mass on an n×n×layers grid, the bottom layer fixed, beams on the
    edges; beams along x end in a sprung hinge."""
    bodies, beams = {}, {}
    for i in range(n):
        for j in range(n):
            for k in range(layers):
                bodies[f"j{i}_{j}_{k}"] = {"at": [float(i), float(j), float(k)], "mass": 1.0,
                                           "inertia": [0.01, 0.01, 0.01], "fixed": k == 0}
    for i in range(n):
        for j in range(n):
            for k in range(layers):
                for d, (di, dj, dk) in enumerate(((1, 0, 0), (0, 1, 0), (0, 0, 1))):
                    a, b, c = i + di, j + dj, k + dk
                    if a >= n or b >= n or c >= layers or (k == 0 and dk == 0):
                        continue
                    beam = {"from": f"j{i}_{j}_{k}", "to": f"j{a}_{b}_{c}", "section": "s", "elements": per_beam}
                    if d == 0:
                        beam["end"] = {"hinge": {"axis": [0, 1, 0], "stiffness": 20.0}}
                    beams[f"b{i}_{j}_{k}_{d}"] = beam
    return {"sections": {"s": dict(SECTION, rhoIy=1e-3, rhoIz=1e-3)}, "bodies": bodies, "beams": beams,
            "initial_velocity": {"angular": [0.0, 0.0, 0.5]}, "solve": SOLVE}


def evaluation(raw: dict, seed: int = 0):
    """An evaluation with matrices at a perturbed, moving state (no held check)."""
    scene = load_scene(raw)
    model = Model.from_scene(scene)
    assembler = Assembler(model, load_kernels(variant=scene.solve.formulation), scene.gravity)
    rng = np.random.default_rng(seed)
    state = assembler.advance(assembler.initial_state(), 1e-3 * rng.standard_normal(model.n_dofs))
    unpack_free(model, 0.1 * rng.standard_normal(model.n_dofs), state.v, state.w, state.theta_dot)
    return model, assembler.evaluate(state, matrices=True)


def free_beam(elements: int, direction=(1.0, 0.0, 0.0), **section) -> dict:
    start = np.array([0.3, -0.2, 0.5])
    return {"sections": {"s": dict(SECTION, **section)}, "bodies": {"a": {"at": start.tolist()}},
            "beams": {"b": {"from": "a", "to": (start + 2.0 * np.asarray(direction)).tolist(), "section": "s",
                            "elements": elements}},
            "initial_velocity": {"angular": [0.2, 0.1, 1.0]}, "solve": SOLVE}


# ----------------------------------------------------------------------------- solves


@pytest.mark.parametrize("raw, kind", [
    (free_beam(12), "dense"),            # 78 coordinates
    (free_beam(60), "band"),             # 366, bandwidth 11 after RCM
    (lattice(5, 4), "sparse"),           # 3D lattice: RCM bandwidth beyond BAND_LIMIT
])
def test_solve_linear_matches_a_reference_and_reuses_its_analysis(raw, kind):
    model, ev = evaluation(raw)
    n = model.n_dofs
    S = ev.combined(4e4, 200.0, 1.0)  # as the Newton iteration assembles it
    assert isinstance(S, np.ndarray) == (n <= DENSE_LIMIT)
    if kind != "dense":
        assert n > DENSE_LIMIT
    dense = ev.combined(4e4, 200.0, 1.0, dense=True)
    rhs = np.random.default_rng(3).standard_normal(n)
    reference = np.linalg.solve(dense, rhs)
    factorization._held.clear()
    for _ in range(3):  # first call analyses the pattern, later ones reuse it
        x = solve_linear(ev.combined(4e4, 200.0, 1.0), rhs)
        np.testing.assert_allclose(x, reference, rtol=0, atol=1e-9 * np.max(np.abs(reference)))
    held = [f for v in factorization._held.values() for f in v]
    assert [f.kind for f in held] == [kind]
    # a sparse matrix of any size is also solved right, and new values on the same pattern too
    sparse = ev.combined(1e3, 10.0, 1.0, dense=False)
    np.testing.assert_allclose(solve_linear(sparse, rhs), np.linalg.solve(sparse.toarray(), rhs),
                               rtol=0, atol=1e-9 * np.max(np.abs(np.linalg.solve(sparse.toarray(), rhs))))


def test_singular_sparse_matrices_raise_what_the_newton_loop_catches():
    n = 400
    for bandwidth in (1, 100):
        A = sps.diags([np.ones(n - k) for k in range(bandwidth + 1)], list(range(bandwidth + 1))).tolil()
        A[n // 2, :] = 0.0
        with pytest.raises(np.linalg.LinAlgError):
            solve_linear(A.tocsr(), np.ones(n))


def test_blas_is_pinned_to_one_thread_only_inside_the_solve():
    threadpoolctl = pytest.importorskip("threadpoolctl")
    with threadpoolctl.threadpool_limits(2, user_api="blas"):
        before = [lib.get_num_threads() for lib in linalg._blas_controllers()]
        with single_thread_blas():
            assert all(lib.get_num_threads() == 1 for lib in linalg._blas_controllers())
        assert [lib.get_num_threads() for lib in linalg._blas_controllers()] == before


def test_psd_null_direction_finds_an_oblique_null_vector():
    rng = np.random.default_rng(1)
    n = 500
    Q = sps.random(n, n, density=0.01, random_state=2) + sps.identity(n)
    A = (Q @ Q.T).tocsc()
    rho, _ = psd_null_direction(A / A.diagonal().max(), Factorization)
    assert rho > 1e-6  # positive definite: nothing found
    v = rng.standard_normal(4)  # a null vector spread over 4 coordinates
    P = sps.identity(n).tolil()
    P[:4, :4] = np.eye(4) - np.outer(v, v) / (v @ v)
    B = (P @ A @ P.T).tocsc()
    d = 1.0 / np.sqrt(B.diagonal())
    B = sps.diags(d) @ B @ sps.diags(d)
    rho, x = psd_null_direction(B.tocsc(), Factorization)
    assert rho < 1e-13
    expected = v / d[:4]
    expected = expected / np.max(np.abs(expected))
    np.testing.assert_allclose(np.abs(x[:4]), np.abs(expected), atol=1e-6)
    assert np.max(np.abs(x[4:])) < 1e-6



def test_psd_null_direction_of_a_dense_matrix_is_its_smallest_eigenpair():
    """A NumPy array (a model the dense LU serves): the smallest eigenvalue and its vector, an
    oblique null vector found as in the sparse case; a definite matrix gives its λ_min."""
    rng = np.random.default_rng(4)
    n = 40
    Q = rng.standard_normal((n, n)) / np.sqrt(n) + np.eye(n)
    A = Q @ Q.T
    rho, _ = psd_null_direction(A / A.diagonal().max(), Factorization)
    assert rho == pytest.approx(np.linalg.eigvalsh(A / A.diagonal().max())[0], rel=1e-12) and rho > 1e-6
    v = rng.standard_normal(4)
    P = np.eye(n)
    P[:4, :4] -= np.outer(v, v) / (v @ v)
    B = P @ A @ P.T
    d = 1.0 / np.sqrt(B.diagonal())
    rho, x = psd_null_direction(d[:, None] * B * d[None, :], Factorization)
    assert abs(rho) < 1e-13
    expected = v / d[:4]
    np.testing.assert_allclose(np.abs(x[:4]), np.abs(expected / np.max(np.abs(expected))), atol=1e-8)
    assert np.max(np.abs(x[4:])) < 1e-8


# ----------------------------------------------------------------------------- the held check


def refused(raw, *keys):
    with pytest.raises(latdyn.SceneError, match="nothing holds") as info:
        prepare(raw)
    assert any(k in str(info.value) for k in keys), str(info.value)
    return str(info.value)


def test_massless_body_held_by_nothing():
    raw = free_beam(4)
    raw["bodies"]["lonely"] = {"at": [5.0, 5.0, 5.0]}
    refused(raw, "bodies.lonely")


def test_free_hinge_with_nothing_attached():
    # a hinge between a wall and a massless joint body with nothing else on it
    raw = {"sections": {"s": SECTION}, "bodies": {"wall": {"at": [0, 0, 0], "fixed": True},
                                                  "joint": {"at": [1, 0, 0]}},
           "beams": {"b": {"from": "wall", "to": "joint", "section": "s", "end": {"hinge": {"axis": [0, 0, 1]}}}},
           "solve": SOLVE}
    refused(raw, "bodies.joint", "beams.b.end.hinge")
    # a hinge carrying a massless beam with a free end: hinge angle and beam swing together
    raw = {"sections": {"s": dict(SECTION, rhoA=0.0)}, "bodies": {"wall": {"at": [0, 0, 0], "fixed": True}},
           "beams": {"b": {"from": "wall", "to": [1.0, 0.5, 0.2], "section": "s", "elements": 3,
                           "start": {"hinge": {"axis": [0, 0, 1]}}}},
           "solve": SOLVE}
    refused(raw, "beams.b")
    # the same with mass is held
    raw["sections"]["s"]["rhoA"] = 1.0
    prepare(raw)


def test_rotated_beam_without_rotary_inertia_is_held_by_its_torsion():
    """Along a random direction, no rhoIy/rhoIz: twist has no inertia but GJ holds it."""
    raw = free_beam(40, RANDOM_DIRECTION)
    raw["bodies"]["a"]["fixed"] = True
    prepare(raw)
    # free-free, the rigid spin about its own (oblique) axis has neither inertia nor stiffness
    message = refused(free_beam(40, RANDOM_DIRECTION), "beams.b", "bodies.a")
    assert ":r" in message  # named by rotation coordinates
    # with rotary inertia it is held again
    prepare(free_beam(40, RANDOM_DIRECTION, rhoIy=1e-2, rhoIz=1e-2))


def test_unheld_direction_not_along_a_coordinate_axis():
    """A massless joint body carrying one beam through a hinge whose axis is the beam's:
    body spin about that axis plus the opposite hinge angle move nothing."""
    wall = np.array([0.1, 0.2, -0.3])
    joint = wall + 1.5 * RANDOM_DIRECTION
    raw = {"sections": {"s": SECTION},
           "bodies": {"wall": {"at": wall.tolist(), "fixed": True}, "joint": {"at": joint.tolist()}},
           "beams": {"b": {"from": "wall", "to": "joint", "section": "s", "elements": 4,
                           "end": {"hinge": {"axis": RANDOM_DIRECTION.tolist()}}}},
           "solve": SOLVE}
    # every single coordinate is held (nonzero diagonal): only a combination is free
    scene = load_scene(raw)
    model = Model.from_scene(scene)
    assembler = Assembler(model, load_kernels(), scene.gravity)
    ev = assembler.evaluate(assembler.initial_state(), matrices=True)
    assert np.all(ev.stiffness.diagonal() > 0)
    refused(raw, "bodies.joint", "beams.b.end.hinge")
    # with rotary inertia on the joint its spin is held, and the hinge angle by the beam's torsion
    raw["bodies"]["joint"]["inertia"] = [1e-3, 1e-3, 1e-3]
    prepare(raw)


def test_large_models_are_checked():
    """More than 3000 coordinates (the former limit of the dense check)."""
    raw = lattice(6, 5, per_beam=2)  # ≈ 7000 coordinates, held
    t0 = time.perf_counter()
    prepared = prepare(raw)
    assert prepared.model.n_dofs > 3000
    assert time.perf_counter() - t0 < 60
    raw["bodies"]["loose"] = {"at": [10.0, 0.0, 0.0]}
    raw["beams"]["tail"] = {"from": "j0_0_1", "to": "loose", "section": "s", "elements": 2,
                            "end": {"hinge": {"axis": [1, 0, 0]}}}  # the tail's own axis: spin unheld
    refused(raw, "bodies.loose", "beams.tail.end.hinge")


# ----------------------------------------------------------------------------- small band matrices
def _chain(nodes: int, dofs: int = 6):
    """The pattern of a chain of beams (node blocks of ``dofs`` coupled to their neighbours),
    numbered out of order as a scene's two legs meeting at an elbow are."""
    order = np.r_[np.arange(0, nodes, 2), np.arange(1, nodes, 2)]  # even nodes first: a wide natural band
    place = np.empty(nodes, np.int64)
    place[order] = np.arange(nodes)
    rows, cols = [], []
    for a in range(nodes):
        for b in (a - 1, a, a + 1):
            if 0 <= b < nodes:
                i, j = np.meshgrid(place[a] * dofs + np.arange(dofs), place[b] * dofs + np.arange(dofs), indexing="ij")
                rows.append(i.ravel())
                cols.append(j.ravel())
    return np.concatenate(rows), np.concatenate(cols), nodes * dofs


@pytest.mark.parametrize("nodes", [4, 8, 16, 20])
def test_small_rcm_band_is_a_permutation_as_narrow_as_scipys(nodes):
    rows, cols, n = _chain(nodes)
    perm, new, lower, upper = linalg.small_rcm_band(rows, cols, n)
    assert sorted(perm.tolist()) == list(range(n)) and np.array_equal(new[perm], np.arange(n))
    assert lower == int(np.max(new[rows] - new[cols])) and upper == int(np.max(new[cols] - new[rows]))
    assert max(lower, upper) == 11  # the chain's band: a node's 6 coordinates and the next node's
    assert max(lower, upper) <= max(linalg.rcm_band(rows, cols, n)[2:])  # SciPy's RCM, the large models'


def test_a_narrow_band_of_few_coordinates_takes_the_band_lu_and_solves_exactly():
    """Within DENSE_LIMIT, a pattern whose RCM band is at most SMALL_BAND_FRACTION of n takes
    LAPACK's band LU (docs/performance.md, "Small models"); a wider one the dense LU; both solve
    like NumPy's dense solve."""
    rng = np.random.default_rng(7)
    for nodes, kind in ((16, "band"), (8, "band"), (4, "dense")):  # n = 96 (band 11), 48 (11 <= 12), 24 (11 > 6)
        rows, cols, n = _chain(nodes)
        assert n <= DENSE_LIMIT
        values = rng.standard_normal(len(rows)) + np.where(rows == cols, 40.0, 0.0)
        A = np.zeros((n, n))
        np.add.at(A, (rows, cols), values)
        made = factorization.Factorization(rows, cols, n)
        assert made.kind == kind
        b = rng.standard_normal((n, 3))
        x = made.factor(values).solve(b)
        np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=0, atol=1e-12 * np.abs(np.linalg.solve(A, b)).max())
