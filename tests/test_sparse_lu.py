"""The one factorization (csrc/factorization.c, latdyn/assembly/factorization.py), its compiled sparse
LU (csrc/sparse_lu.c, latdyn/assembly/sparse_lu.py) and the wide models it brings into the compiled step.

The C factorization equals ``numpy.linalg.solve`` on random structurally symmetric, diagonally
dominant matrices, in each storage and for several right-hand sides at once; its analysis holds every entry and keeps the fill of SuperLU's minimum degree;
a zero or tiny pivot is reported, not solved.  3D lattices too wide for the band LU now run in the
compiled step and equal the reference step of tests/reference_step.py (SuperLU) to 1e-10 with full Newton, in a random
orientation; modified Newton, which keeps the factor over steps, reaches the Newton tolerance.
"""
from __future__ import annotations

import copy
import ctypes
import json

import numpy as np
import pytest
import scipy.sparse as sps
import scipy.sparse.linalg as spla

import latdyn
from reference_step import reference_engine
from latdyn.model.kernels import load_kernels
from latdyn.numerics.linalg import SUPERLU_OPTIONS
from latdyn.assembly.factorization import KINDS, Factorization
from latdyn.assembly.sparse_lu import PIVOT_TOLERANCE, PivotError, SupernodalAnalysis, minimum_degree

from test_inertia import rigid_motion
from test_linalg import evaluation, lattice

try:
    load_kernels("c", "default")
    HAVE_C = True
except RuntimeError:
    HAVE_C = False

needs_c = pytest.mark.skipif(not HAVE_C, reason="no C compiler: the sparse LU is compiled")


def random_symmetric_pattern(n: int, per_row: float, seed: int, blocks: int = 1) -> sps.csr_matrix:
    """A random structurally symmetric, numerically unsymmetric matrix made of blocks×blocks dense
    blocks (node-like), diagonally dominant by rows."""
    rng = np.random.default_rng(seed)
    nodes = n // blocks
    graph = sps.random(nodes, nodes, density=min(1.0, per_row / nodes), random_state=seed, format="coo")
    rows, cols = np.concatenate([graph.row, graph.col]), np.concatenate([graph.col, graph.row])
    r = (rows[:, None, None] * blocks + np.arange(blocks)[None, :, None]).repeat(blocks, 2).ravel()
    c = (cols[:, None, None] * blocks + np.arange(blocks)[None, None, :]).repeat(blocks, 1).ravel()
    A = sps.csr_matrix((rng.standard_normal(len(r)), (r, c)), shape=(nodes * blocks,) * 2)
    A.sum_duplicates()
    dominance = np.asarray(abs(A).sum(axis=1)).ravel() + rng.uniform(0.5, 2.0, A.shape[0])
    return (A + sps.diags(dominance * rng.choice([-1.0, 1.0], A.shape[0]))).tocsr()


def factorized(A, kind: str = "sparse") -> Factorization:
    """The factorization of the CSR matrix A in the storage ``kind``."""
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    return Factorization(rows, A.indices, A.shape[0], kind=kind).factor(A)


@needs_c
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n, per_row, blocks, seed", [(1, 1, 1, 0), (9, 2, 1, 1), (150, 3, 6, 4)])
def test_the_factorization_solves_several_right_hand_sides_in_each_storage(kind, n, per_row, blocks, seed):
    """One factorization, then many right-hand sides with the factors held (what linearisation and
    sensitivities ask for), in the dense, band and sparse storage alike; the values of the pattern
    are factorized as the matrix is."""
    A = random_symmetric_pattern(n, per_row, seed, blocks)
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((A.shape[0], 4))
    reference = np.linalg.solve(A.toarray(), B)
    lu = factorized(A, kind)
    assert lu.kind == kind
    X = lu.solve(B)
    assert X.shape == B.shape
    assert np.max(np.abs(X - reference)) <= 1e-12 * np.max(np.abs(reference))
    for k in range(B.shape[1]):  # one at a time: the same to round-off (LAPACK's kernels differ by count)
        np.testing.assert_allclose(lu.solve(B[:, k]), X[:, k], rtol=0, atol=1e-13 * np.max(np.abs(X)))
    np.testing.assert_array_equal(lu.factor(A.data).solve(B), X)


@needs_c
@pytest.mark.parametrize("n, per_row, blocks, seed", [(1, 1, 1, 0), (7, 2, 1, 1), (60, 3, 1, 2), (300, 4, 1, 3),
                                                      (600, 3, 6, 4), (1500, 2, 3, 5)])
def test_solve_equals_numpy_on_random_diagonally_dominant_matrices(n, per_row, blocks, seed):
    A = random_symmetric_pattern(n, per_row, seed, blocks)
    rng = np.random.default_rng(seed)
    b = rng.standard_normal(A.shape[0])
    lu = factorized(A)
    reference = np.linalg.solve(A.toarray(), b)
    assert np.max(np.abs(lu.solve(b) - reference)) <= 1e-12 * np.max(np.abs(reference))
    # the same analysis, other values (off-diagonal entries shrunk: still dominant)
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    B = A.copy()
    B.data *= np.where(rows == A.indices, 1.0, rng.uniform(0.5, 1.0, A.nnz))
    reference = np.linalg.solve(B.toarray(), b)
    assert np.max(np.abs(lu.factor(B).solve(b) - reference)) <= 1e-12 * np.max(np.abs(reference))


@needs_c
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n, per_row, blocks, seed", [(1, 1, 1, 0), (9, 2, 1, 1), (150, 3, 6, 4), (600, 3, 6, 8)])
def test_the_transposed_solve_equals_numpy_in_each_storage(kind, n, per_row, blocks, seed):
    """``Factorization.solve_transposed``: Aᵀx = b from A's factors (the discrete adjoint's solves), in
    the dense, band and sparse storage, one right-hand side and several, against NumPy's solve of the
    transposed dense matrix (measured ≤ 4.4e-16 of the solution's largest entry); A is unsymmetric."""
    A = random_symmetric_pattern(n, per_row, seed, blocks)
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((A.shape[0], 3))
    lu = factorized(A, kind)
    assert lu.kind == kind
    reference = np.linalg.solve(A.toarray().T, B)
    assert n == 1 or np.max(np.abs(reference - np.linalg.solve(A.toarray(), B))) > 1e-3   # Aᵀ is not A
    X = lu.solve_transposed(B)
    assert X.shape == B.shape
    assert np.max(np.abs(X - reference)) <= 1e-12 * np.max(np.abs(reference))
    x = lu.solve_transposed(B[:, 1])
    assert x.shape == (A.shape[0],)
    assert np.max(np.abs(x - reference[:, 1])) <= 1e-12 * np.max(np.abs(reference))


@needs_c
def test_the_transposed_solve_where_a_sparse_pivot_failed_is_the_pivoted_band_lus():
    """A tiny pivot the sparse LU refuses: the band LU with row exchanges stands in, transposed too."""
    B = sps.csr_matrix(np.array([[1e-14, 1.0], [3.0, 1.0]]))
    lu = factorized(B)
    b = np.array([1.0, 2.0])
    np.testing.assert_allclose(lu.solve_transposed(b), np.linalg.solve(B.toarray().T, b), rtol=1e-14)


@needs_c
@pytest.mark.parametrize("seed", [5, 6])
def test_the_pivot_scales_are_the_largest_entry_of_each_row_and_column(seed):
    """The scale pass (csrc/sparse_lu.c ``matrix_scales``: a column's largest entry kept in a register)
    gives each pivot the largest |A(i, :)|, |A(:, i)| of its coordinate, a NaN passed over, on a
    matrix of wide supernodes with rows below them."""
    A = random_symmetric_pattern(200, 4, seed, blocks=6).tolil()
    rng = np.random.default_rng(seed)
    rows, cols = A.nonzero()
    for k in rng.choice(len(rows), 3, replace=False):
        A[rows[k], cols[k]] = np.nan if k % 2 else 1e6 * (1 + k)  # a NaN, and entries far above the rest
    A = A.tocsr()
    lu = Factorization(np.repeat(np.arange(A.shape[0]), np.diff(A.indptr)), A.indices, A.shape[0], kind="sparse")
    lu.load(A)
    lu._library.latdyn_factor(ctypes.byref(lu.structure), lu.values.ctypes.data, lu.pivots.ctypes.data)
    dense = np.abs(A.toarray())
    expected = np.maximum(np.nanmax(dense, axis=1), np.nanmax(dense, axis=0))
    np.testing.assert_array_equal(lu.analysis._scratch["scale"][lu.new], expected)


def test_positions_cover_every_entry_once():
    A = random_symmetric_pattern(240, 3, 7, blocks=6)
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    analysis = SupernodalAnalysis(rows, A.indices, A.shape[0])
    positions = analysis.position(rows, A.indices)
    assert np.all(positions >= 0) and len(np.unique(positions)) == A.nnz
    assert np.all(positions < analysis.size)
    assert np.all(analysis.position(np.array([A.shape[0], 0]), np.array([0, A.shape[0] + 3])) == -1)
    # a node's six coordinates stay together and in their order
    assert np.all(np.diff(analysis.new.reshape(-1, 6), axis=1) == 1)


def test_minimum_degree_eliminates_a_star_from_its_leaves():
    """The centre of a star has the largest degree: eliminating it first would fill the whole
    matrix, minimum degree leaves it (nearly) to the end and there is no fill."""
    leaves = 6
    adjacency = [set(range(1, leaves + 1))] + [{0} for _ in range(leaves)]
    order, structure = minimum_degree(adjacency, np.ones(leaves + 1))
    assert order.index(0) >= leaves - 1  # at most one leaf left when the centre goes (a tie)
    assert all(len(structure[v]) <= 1 for v in range(leaves + 1))  # no fill


@needs_c
def test_zero_and_tiny_pivots_are_reported_and_pivoted_where_that_helps():
    A = random_symmetric_pattern(120, 3, 11, blocks=3).tolil()
    A[5, :] = 0.0  # a zero row: singular, the pivot of coordinate 5 vanishes (and the band LU's too)
    A = A.tocsr()
    A.eliminate_zeros()
    with pytest.raises(PivotError, match="coordinate 5 is 0 ×"):
        factorized(A)
    # a structurally nonzero but tiny pivot that row exchanges avoid: the sparse LU reports it, and
    # the factorization stands in the band LU with LAPACK's partial pivoting (an indefinite static
    # stiffness past a limit point, say), which solves it exactly
    B = sps.csr_matrix(np.array([[1e-14, 1.0], [1.0, 1.0]]))
    lu = factorized(B)
    assert "singular or needs pivoting" in lu.analysis.pivot_failure()
    b = np.array([1.0, 2.0])
    np.testing.assert_allclose(lu.solve(b), np.linalg.solve(B.toarray(), b), rtol=1e-14)
    assert PIVOT_TOLERANCE < 1e-6


@needs_c
def test_fill_is_that_of_superlu_minimum_degree_on_a_lattice():
    """On a 3D lattice (pattern from the Assembler) the node-graph minimum degree keeps the fill
    within 10 % of SuperLU's MMD on AᵀA + A (measured: 0.98–1.02×, benchmarks/sparse_lu.py), and
    the solve equals SuperLU's."""
    model, ev = evaluation(lattice(5, 4))
    S = ev.combined(1e4, 100.0, 1.0, dense=False).tocsr()
    lu = factorized(S)
    superlu = spla.splu(S.tocsc(), permc_spec="MMD_AT_PLUS_A", **SUPERLU_OPTIONS)
    reference_fill = superlu.L.nnz + superlu.U.nnz - S.shape[0]
    assert lu.analysis.nonzeros < 1.1 * reference_fill
    b = np.random.default_rng(2).standard_normal(S.shape[0])
    reference = superlu.solve(b)
    assert np.max(np.abs(lu.solve(b) - reference)) <= 1e-10 * np.max(np.abs(reference))


# ----------------------------------------------------------------------------- the compiled step


def oriented_lattice(seed: int, n: int = 5, layers: int = 4, t_end: float = 0.03, dt: float = 0.005) -> dict:
    """test_linalg.lattice moved by a random rotation and translation, with gravity and a
    moving top, probes on a top body and a hinge."""
    raw = lattice(n, layers)
    R, shift = rigid_motion(seed)
    for body in raw["bodies"].values():
        body["at"] = (R @ np.asarray(body["at"], float) + shift).tolist()
        body["inertia"] = (R @ np.diag([0.01, 0.02, 0.015]) @ R.T).tolist()
    for beam in raw["beams"].values():
        if "end" in beam:
            beam["end"]["hinge"]["axis"] = (R @ np.array([0.0, 1.0, 0.3])).tolist()
            beam["end"]["hinge"]["damping"] = 0.2
    raw["initial_velocity"] = {"angular": (R @ np.array([0.1, -0.2, 0.5])).tolist()}
    raw["gravity"] = (R @ np.array([0.0, 0.0, -9.81])).tolist()
    top = f"j{n - 1}_{n - 1}_{layers - 1}"
    raw["loads"] = [{"at": top, "force": [0.0, "30*t", 5.0]}]
    raw["solve"] = {"analysis": "transient", "t_end": t_end, "dt": dt, "method": "generalized-alpha"}
    raw["output"] = {"probes": {"top_x": {"point": top, "quantity": "position", "component": "x"},
                                "top_vz": {"point": top, "quantity": "velocity", "component": "z"},
                                "hinge": {"hinge": "b0_1_1_0.end", "quantity": "rate"},
                                "kinetic": {"energy": "kinetic"}}}
    return raw


def _run(raw, tmp_path, name, **solve):
    raw = copy.deepcopy(raw)
    if solve.get("engine") == "reference":  # the Newton iteration of tests/reference_step.py
        solve.pop("engine")
        with reference_engine():
            return _run(raw, tmp_path, name, **solve)
    raw["solve"].update(solve)
    result = latdyn.run(latdyn.load_scene(raw), tmp_path / name)
    return result, json.loads((tmp_path / name / "summary.json").read_text())


def _relative_difference(a, b):
    return max(float(np.max(np.abs(np.asarray(a.probes[k]) - np.asarray(b.probes[k]))))
               / max(float(np.max(np.abs(a.probes[k]))), 1e-12) for k in a.probes)


@needs_c
@pytest.mark.parametrize("seed", [3, 8])
def test_wide_lattice_runs_compiled_and_equals_the_reference_step(seed, tmp_path):
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.step.integrators import AlphaParameters
    from latdyn.assembly.prepare import prepare

    raw = oriented_lattice(seed)
    prepared = prepare(latdyn.load_scene(raw))
    step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                    1e-8, 25, 1.0)
    step._setup()
    assert step.factorization.kind == "sparse"  # the RCM band is wider than BAND_LIMIT

    python, python_summary = _run(raw, tmp_path, "python", engine="reference")
    compiled, compiled_summary = _run(raw, tmp_path, "compiled", engine="compiled", newton="full")
    assert python_summary["engine"] == "reference" and compiled_summary["engine"] == "compiled"
    for key in ("steps", "newton_iterations", "rejected_steps"):
        assert compiled_summary[key] == python_summary[key], key
    assert np.any(np.asarray(python.probes["hinge"]) != 0.0)
    assert _relative_difference(python, compiled) <= 1e-10


@needs_c
def test_modified_newton_keeps_the_sparse_factor_and_reaches_the_tolerance(tmp_path):
    raw = oriented_lattice(5, t_end=0.05)
    full, full_summary = _run(raw, tmp_path, "full", engine="compiled", newton="full")
    modified, modified_summary = _run(raw, tmp_path, "modified", engine="compiled", newton="modified")
    assert modified_summary["engine"] == "compiled" and modified_summary["newton"] == "modified"
    assert modified_summary["factorizations"] < full_summary["factorizations"]
    assert _relative_difference(full, modified) < 1e-5


@needs_c
@pytest.mark.parametrize("threads", [2, 3])
def test_threaded_elements_of_a_lattice_equal_the_serial_step(threads):
    """Element ranges that start at any element read their own section rows (the sections have
    latdyn.model.model.SECTION_WIDTH columns: a stride of 8 read misaligned sections from the second
    range on whenever 8 × its first element was not a multiple of 10, as here with 195 elements:
    errors of 1e-3).  The states agree to round-off, not bit for bit: measured 6e-14 in v after
    three steps (the kernels' arithmetic depends on where a range starts)."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.assembly.library import openmp_threads
    from latdyn.step.integrators import AlphaParameters
    from latdyn.assembly.prepare import prepare

    if openmp_threads() == 0:
        pytest.skip("the compiled step was built without OpenMP")
    prepared = prepare(latdyn.load_scene(oriented_lattice(4)))
    assert len(prepared.model.element_nodes) == 195
    runs = []
    for parallel in (0, 1):
        step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                        1e-8, 25, 1.0, parallel_elements=parallel, threads=threads)
        state = prepared.state
        step.start(state)
        iterations = []
        for _ in range(3):
            state, stats = step.step(state, 0.005)
            assert stats.converged
            step.accept()
            iterations.append(stats.iterations)
        runs.append((state, iterations))
    (serial, serial_iterations), (threaded, threaded_iterations) = runs
    assert threaded_iterations == serial_iterations
    for name in ("x", "T", "v", "w", "theta"):
        a, b = getattr(serial, name), getattr(threaded, name)
        assert np.max(np.abs(a - b)) <= 1e-11 * max(np.max(np.abs(a)), 1.0), name


def planar_grid(n: int = 18, per_beam: int = 2) -> dict:
    """An n × n frame in the xy-plane (joint bodies, the row y = 0 fixed, beams on the edges, a
    sprung hinge about z at the end of every beam along x), loaded and spun in its plane: the
    planar model (3 coordinates a node), too wide for the band LU."""
    section = dict(SECTION_PLANAR)
    bodies, beams = {}, {}
    for i in range(n):
        for j in range(n):
            bodies[f"j{i}_{j}"] = {"at": [float(i), float(j), 0.0], "mass": 0.5, "inertia": [0.01, 0.01, 0.02],
                                   "fixed": j == 0}
    for i in range(n):
        for j in range(n):
            for d, (di, dj) in enumerate(((1, 0), (0, 1))):
                a, b = i + di, j + dj
                if a >= n or b >= n or (j == 0 and dj == 0):
                    continue
                beam = {"from": f"j{i}_{j}", "to": f"j{a}_{b}", "section": "s", "elements": per_beam}
                if d == 0:
                    beam["end"] = {"hinge": {"axis": [0, 0, 1], "stiffness": 20.0, "damping": 0.1}}
                beams[f"b{i}_{j}_{d}"] = beam
    top = f"j{n - 1}_{n - 1}"
    return {"sections": {"s": section}, "bodies": bodies, "beams": beams,
            "initial_velocity": {"angular": [0.0, 0.0, 0.3]},
            "loads": [{"at": top, "force": ["40*t", -3.0, 0.0]}],
            "solve": {"analysis": "transient", "t_end": 0.02, "dt": 0.005, "method": "generalized-alpha"},
            "output": {"probes": {"top_x": {"point": top, "quantity": "position", "component": "x"},
                                  "top_vy": {"point": top, "quantity": "velocity", "component": "y"},
                                  "hinge": {"hinge": f"b0_{n - 1}_0.end", "quantity": "rate"}}}}


SECTION_PLANAR = {"EA": 1.0e5, "EIy": 60.0, "EIz": 60.0, "GJ": 40.0, "rhoA": 1.0, "rhoIy": 1e-3, "rhoIz": 1e-3}


@needs_c
def test_a_wide_planar_model_runs_compiled_and_equals_the_python_step(tmp_path):
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.step.integrators import AlphaParameters
    from latdyn.assembly.prepare import prepare

    raw = planar_grid()
    prepared = prepare(latdyn.load_scene(raw))
    model = prepared.model
    assert model.n_dofs < 3 * len(model.nodes) + len(model.hinges)  # the planar model
    step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                    1e-8, 25, 1.0)
    step._setup()
    assert step.factorization.kind == "sparse"
    python, python_summary = _run(raw, tmp_path, "python", engine="reference")
    compiled, compiled_summary = _run(raw, tmp_path, "compiled", engine="compiled", newton="full")
    assert compiled_summary["engine"] == "compiled"
    assert compiled_summary["newton_iterations"] == python_summary["newton_iterations"]
    assert _relative_difference(python, compiled) <= 1e-10


@needs_c
def test_a_failed_pivot_fails_the_compiled_step_and_says_where():
    """The compiled step's latdyn_factor returns the sparse LU's failure: the step is reported not
    converged (the time loop then cuts it, as for a singular band LU), never solved with a
    bad factor. Forced here by a pivot tolerance no pivot can pass."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.step.integrators import AlphaParameters
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(oriented_lattice(6)))
    step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                    1e-8, 25, 1.0)
    step.start(prepared.state)
    _, stats = step.step(prepared.state, 0.005)
    assert stats.converged
    analysis = step.factorization.analysis
    assert analysis.pivot_failure() is None
    step.factorization.structure.sparse_lu.contents.pivot_tolerance = 1e300
    _, stats = step.step(prepared.state, 0.005)
    assert not stats.converged and stats.factorizations == 1
    assert "singular or needs pivoting" in analysis.pivot_failure()


@needs_c
def test_a_latch_in_a_wide_lattice_reanalyses_the_pattern(tmp_path, monkeypatch):
    """A hinge that latches removes its coordinate: the compiled step re-runs its set-up and the
    sparse LU's analysis for the new pattern. The latch is located by secant passes to 1e-7 rad,
    so the engines agree to that (as tests/test_engine.py's latch), not to 1e-10."""
    raw = oriented_lattice(3, t_end=0.1)
    raw["beams"]["b0_1_1_0"]["end"]["hinge"]["lock_at"] = 0.1  # reached at t ≈ 0.07
    raw["output"]["probes"]["latched"] = {"hinge": "b0_1_1_0.end", "quantity": "rate"}
    import latdyn.assembly.factorization

    analysed = []

    class Counted(SupernodalAnalysis):
        def __init__(self, rows, cols, n):
            analysed.append(n)
            super().__init__(rows, cols, n)

    monkeypatch.setattr(latdyn.assembly.factorization, "SupernodalAnalysis", Counted)
    python, python_summary = _run(raw, tmp_path, "python", engine="reference")
    compiled, compiled_summary = _run(raw, tmp_path, "compiled", engine="compiled", newton="full")
    assert compiled_summary["engine"] == "compiled"
    assert len(analysed) >= 2 and analysed[-1] == analysed[0] - 1  # one coordinate fewer after the latch
    rate = np.asarray(compiled.probes["latched"])
    assert np.any(rate != 0.0) and rate[-1] == 0.0  # moved, then latched
    assert compiled_summary["steps"] == python_summary["steps"]
    assert np.max(np.abs(np.asarray(python.t) - np.asarray(compiled.t))) < 1e-7
    assert _relative_difference(python, compiled) < 1e-5
