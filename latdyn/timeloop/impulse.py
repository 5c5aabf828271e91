"""The response of the free coordinates to impulses on hinges: impacts on stops and latches, and the
impulse of a prescribed velocity that jumps (:func:`prescribed_velocity_jump`).

An impact lasts no time: the configuration, and so every finite force (elastic, applied,
gravity), is continuous through it, and only inertia forces take the impulse. The velocities
jump by Newton's impulse law, Δv = X (NᵀX)⁻¹ (u − Nᵀv⁻) for the hinge rates Nᵀv brought to u
(−e times their rate into a stop; 0 for a latch), X the *impulse response*, the velocity change
per unit impulse on each hinge. What X is where parts carry no inertia:

- **Elements without inertia** (``rhoA: 0``) are rigid through the jump. An element can pass an
  impulse from one part with inertia to another only as a rigid body: passing it elastically
  would take an impulsive strain. (Their statics alone, below, would let a body's translation
  turn the end of a massless arm through its bending, 1.5 rad per m of a cantilever's tip: the
  jump then set the body ringing on the arm, and the run ended unbounded.) They are made rigid
  by a stiffness :data:`RIGID` times the inertia they move, extrapolated to the rigid limit.
- **The other directions without inertia** (Q_c of :func:`latdyn.numerics.inertia.split_inertia`,
  M Q_c = 0: the twist of an Euler–Bernoulli beam without rotary inertia, a joint without
  inertia about its hinge) take no impulse and stay in their statics, Q_cᵀ r = 0, through it:
  their velocities are those the massive ones imply, Δy_c = −K_cc⁻¹ K_cm Δy_m (K_ab = Q_aᵀ K Q_b;
  static condensation, as in :func:`latdyn.step.integrators.consistent_acceleration`). A hinge
  constraint acts on the massive directions through the condensed Jacobian
  Ñ = Q_mᵀN − K_cmᵀ K_cc⁻ᵀ Q_cᵀN (an impulse on a direction without inertia passes statically to
  the massive ones, by virtual work), and M_mm Δy_m = Ñ λ.
- **Directions with inertia** jump as the impulse law weights them, by M_mm + h² K_red (h the
  nominal step, K_red = K_mm − K_mc K_cc⁻¹ K_cm the condensed stiffness), as the projection with
  M + h²K did before: stiff elastic modes with inertia take the impact quasi-statically (with
  M_mm alone the pendulum of tests/test_hinges.py, EI = 1e9, rang at ω ~ 1e5 rad/s after its
  impact and the run ended unbounded). On a mechanism direction (a hinge spring k, a body of
  inertia I) this changes the jump by O(h² k / I), second order. Modes with inertia whose
  frequency ω is near 1/h are weighted by how the step resolves them: a latch or an impact on a
  flexible structure with inertia converges at second order only once the step resolves them or
  is far from them (docs/initial_state.md).

Where a hinge's rate moves no direction with inertia (NᵀX singular: parts without inertia on
both sides of it), nothing takes an impulse, and its stop acts as a static constraint: X is
then (M + h²K)⁻¹ N, whose K-weighted projection keeps those parts in their statics against it.

The kinetic energy the jump removes: with one hinge moving into its stop at u⁻, restitution e
and the weight M_mm, (1 − e²) · ½ u⁻² / (Ñᵀ M_mm⁻¹ Ñ), the kinetic energy of the impacting
motion (docs/energy.md).

(Before, X was (M + h²K)⁻¹ N everywhere: the directions without inertia took part of the jump
with weight h²K against the inertia of the massive ones, so a body bounced off a stop behind a
massless beam came out with answers that changed with the step and converged to nothing:
tests/test_impacts.py.)
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import State, free_acceleration, free_velocity, pack, unpack_free
from latdyn.assembly.evaluation import Evaluation
from latdyn.assembly.factorization import solve_linear, solve_linear_csr
from latdyn.numerics import csr
from latdyn.numerics.csr import CSR
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.linalg import DENSE_LIMIT, RCM_IN_PYTHON
from latdyn.step.integrators import solve_held


def hinge_directions(model, hinges) -> np.ndarray:
    """N: one column per hinge, the unit vector of its free coordinate (Nᵀv are the hinge rates)."""
    N = np.zeros((model.n_dofs, len(hinges)))
    N[model.hinge_dofs[list(hinges)], np.arange(len(hinges))] = 1.0
    return N


#: How much stiffer than the inertia it moves an element without inertia is made through an
#: impulse (relative to the largest diagonals of M and of the elements' K); the response is
#: extrapolated to the rigid limit from this stiffness and twice it (module docstring).
RIGID = 1e8


def massless_element_stiffness(ev):
    """K of the elements without inertia alone (``rhoA: 0``, no rotary inertia: their mass blocks
    are zero), on the free coordinates; None where there are none."""
    element_mass = np.asarray(ev.blocks["mass"][0])
    massless = ~np.any(element_mass != 0.0, axis=(1, 2)) if element_mass.size else np.zeros(0, bool)
    if not massless.any():
        return None
    element, body, hinge, loads, couplings = ev.blocks["stiffness"]
    blocks = dict(ev.blocks)
    blocks["stiffness"] = (np.asarray(element) * massless[:, None, None], np.zeros_like(body),
                           np.zeros_like(hinge), np.zeros_like(np.asarray(loads)), np.zeros_like(couplings))
    massless = Evaluation(residual=None, reaction=None, blocks=blocks, assembler=ev.assembler)
    projection = getattr(ev, "projection", None)  # rigid links: onto the minimum coordinates
    if projection is None and without_scipy(ev.assembler.model):
        return massless.combined_csr(0.0, 0.0, 1.0)
    K = massless.combined(0.0, 0.0, 1.0, dense=False)
    if projection is None:
        return K
    import scipy.sparse as sps  # on use (an impact with rigid links): a run without events never loads it

    return sps.csr_matrix(projection.T @ K @ projection)


def impulse_response(model, ev, N: np.ndarray, step: float) -> np.ndarray:
    """X: the change of the free velocities per unit impulse on the constraint directions N (n × k):
    the elements without inertia rigid, the other directions without inertia in their statics
    (module docstring). The elements without inertia are made rigid by adding s K_massless to K,
    s h² = RIGID m / k (m, k the largest diagonals of M and K_massless), and the response is
    extrapolated to s → ∞ from s and 2s (X(s) = X(∞) + O(1/s): 2 X(2s) − X(s) leaves O(1/s²))."""
    Kml = massless_element_stiffness(ev)
    if not without_scipy(model) or (model.links is not None and Kml is not None):
        M, K = ev.mass, ev.stiffness   # (elements without inertia beside rigid links: SciPy's, as before)
    elif model.links is None:  # the assembler's CSR (latdyn.numerics.csr): the same entries as SciPy's
        M, K = ev.combined_csr(1.0, 0.0, 0.0), ev.combined_csr(0.0, 0.0, 1.0)
    else:  # rigid links, small: the dense reduced matrices (SciPy's CSR of each) on one pattern
        M, K = csr.of_dense(ev.combined(1.0, 0.0, 0.0, dense=True), ev.combined(0.0, 0.0, 1.0, dense=True))
    split = split_inertia(model, M)  # M is the same for every stiffness tried below
    if Kml is not None:
        m = float(np.max(np.abs(M.diagonal()), initial=0.0))
        k = float(np.max(np.abs(Kml.diagonal()), initial=0.0))
        if m > 0.0 and k > 0.0:
            s = RIGID * m / (step * step * k)
            if isinstance(K, CSR):  # K + f s K_massless on the assembler's pattern (SciPy drops its zeros)
                stiff, stiffer = (_response(split, M, _same_pattern(K, K.data + f * s * Kml.data), N, step)
                                  for f in (1.0, 2.0))
            else:
                stiff, stiffer = (_response(split, M, (K + f * s * Kml).tocsr(), N, step) for f in (1.0, 2.0))
            return 2.0 * stiffer - stiff
    return _response(split, M, K, N, step)


def without_scipy(model) -> bool:
    """Whether an impulse is solved on latdyn's own CSR (:class:`_OwnMatrices`) rather than SciPy's matrices: a
    model without rigid links whose LU (dense, or band ordered in Python up to
    :data:`latdyn.numerics.linalg.RCM_IN_PYTHON` coordinates) needs no SciPy sparse matrix (the assembler's CSR),
    or one with rigid links or guides small enough for their dense reduction (latdyn.assembly.linked). Importing
    scipy.sparse at a model's first latch or impact cost ≈ 0.08 s of CPU (docs/performance.md, "The latch
    without SciPy's sparse package (issue 31/34)")."""
    if model.links is None:
        return model.n_dofs <= RCM_IN_PYTHON
    return model.n_assembled <= DENSE_LIMIT


def _same_pattern(a: CSR, values: np.ndarray) -> CSR:
    return CSR(a.shape, a.indptr, a.indices, values)


def _response(split, M, K, N: np.ndarray, step: float) -> np.ndarray:
    """X for the stiffness K (:func:`impulse_response`):

        [ Q_mᵀ(M + h²K)Q_m   h² Q_mᵀK Q_c ] [y_m]   [Ñ]
        [ Q_cᵀK Q_m            Q_cᵀK Q_c  ] [y_c] = [0],      X = Q_m y_m + Q_c y_c,

    h the nominal step; the second row is the statics of the directions without inertia, the
    first the impulse law on the massive ones, M_mm + h² K_red (K_red = K_mm − K_mc K_cc⁻¹ K_cm,
    never formed) weighting what the step does not resolve as in the integrator's iteration
    matrix. Without directions without inertia X = (M + h²K)⁻¹ N. Where a hinge's rate moves no
    direction with inertia (NᵀX singular: massless parts on both sides of it), nothing takes an
    impulse and its stop acts as a static constraint: X = (M + h²K)⁻¹ N, whose K-weighted
    projection keeps the massless parts in their statics against the stop.

    On SciPy's sparse matrices (:class:`_SciPyMatrices`) or on :class:`latdyn.numerics.csr.CSR` matrices of the
    assembler's pattern without SciPy (:class:`_OwnMatrices`: the same sums in the same order, and the same zeros
    dropped, as SciPy's products and sums, so X is the same to the bit)."""
    ops = _OwnMatrices if isinstance(K, CSR) else _SciPyMatrices
    h2 = step * step
    quasi_static = ops.quasi_static(M, K, h2)
    if split.n_massless == 0 or split.n_massive == 0:
        return ops.solve(quasi_static, N).reshape(N.shape)
    n_massive = split.n_massive
    Qm, Qc = ops.bases(split)
    Kcc, Kcm = ops.statics(K, Qc, Qm)  # Q_cᵀK Q_c, Q_cᵀK Q_m
    # Ñ = Q_mᵀN − K_cmᵀ K_cc⁻ᵀ Q_cᵀN: the impulse on the massless directions, passed on statically
    passed = solve_held(ops.transposed(Kcc), ops.transposed_times(Qc, N))
    condensed = (ops.transposed_times(Qm, N).reshape(n_massive, -1)
                 - ops.transposed_times(Kcm, passed).reshape(n_massive, -1))
    B = ops.blocks(quasi_static, K, Qm, Qc, Kcm, Kcc, h2)
    rhs = np.vstack([condensed, np.zeros((split.n_massless, condensed.shape[1]))])
    X = ops.times(split.basis, ops.solve(B, rhs)).reshape(N.shape)
    NtX = N.T @ X
    scale = max(float(np.max(np.abs(np.diag(NtX)), initial=0.0)), 1e-300)
    if not np.all(np.isfinite(NtX)) or np.linalg.matrix_rank(NtX, tol=1e-10 * scale) < N.shape[1]:
        return ops.solve(quasi_static, N).reshape(N.shape)
    return X


class _SciPyMatrices:
    """:func:`_response`'s operations on SciPy's sparse matrices (M, K and the split's bases)."""

    solve = staticmethod(solve_linear)

    @staticmethod
    def quasi_static(M, K, h2):
        return (M + h2 * K).tocsr()

    @staticmethod
    def bases(split):
        return split.massive, split.massless

    @staticmethod
    def statics(K, Qc, Qm):
        return (Qc.T @ K @ Qc).tocsr(), (Qc.T @ K @ Qm).tocsr()

    @staticmethod
    def transposed(A):
        return A.T.tocsr()

    @staticmethod
    def transposed_times(A, x):
        return np.asarray(A.T @ x)

    @staticmethod
    def blocks(quasi_static, K, Qm, Qc, Kcm, Kcc, h2):
        import scipy.sparse as sps  # on use (an impact next to directions without inertia)

        return sps.bmat([[Qm.T @ quasi_static @ Qm, h2 * (Qm.T @ K @ Qc)], [Kcm, Kcc]], format="csr")

    @staticmethod
    def times(A, x):
        return np.asarray(A @ x)


class _OwnMatrices:
    """:func:`_response`'s operations on :class:`latdyn.numerics.csr.CSR` matrices, without SciPy (the split's basis
    a CSR too); solved by :func:`latdyn.assembly.factorization.solve_linear_csr` (the same storage, order and
    factors as :func:`~latdyn.assembly.factorization.solve_linear`)."""

    solve = staticmethod(solve_linear_csr)
    transposed = staticmethod(csr.transposed)
    transposed_times = staticmethod(csr.transposed_times)
    times = staticmethod(csr.times)

    @staticmethod
    def quasi_static(M, K, h2):
        return csr.nonzero(_same_pattern(M, M.data + h2 * K.data))

    @staticmethod
    def bases(split):
        n_massive = split.n_massive
        return csr.columns(split.basis, 0, n_massive), csr.columns(split.basis, n_massive, split.basis.shape[1])

    @staticmethod
    def statics(K, Qc, Qm):
        Kc = csr.transposed_product(Qc, K)  # Q_cᵀ K
        return csr.product(Kc, Qc), csr.product(Kc, Qm)

    @staticmethod
    def blocks(quasi_static, K, Qm, Qc, Kcm, Kcc, h2):
        coupling = csr.product(csr.transposed_product(Qm, K), Qc)
        return csr.blocks(csr.product(csr.transposed_product(Qm, quasi_static), Qm),
                          _same_pattern(coupling, coupling.data * h2), Kcm, Kcc)


def jump(X: np.ndarray, N: np.ndarray, v: np.ndarray, target: np.ndarray) -> np.ndarray:
    """v⁺ = v⁻ + X (NᵀX)⁻¹ (target − Nᵀv⁻): the velocities after the impulses that bring the hinge
    rates Nᵀv to ``target``."""
    return v + X @ np.linalg.solve(N.T @ X, target - N.T @ v)


def prescribed_velocity_jump(assembler, before: State, state: State, step: float) -> float:
    """The free velocities of ``state`` after the impulse that a jump of the prescribed velocities implies
    (a kink of a prescribed angle, slide or motion: its rate jumps from ``before``'s to ``state``'s at the
    same configuration), in place; returns the work that impulse did, the drive's.

    A prescribed velocity is a velocity constraint: the drive applies whatever impulse J on its coordinates c
    makes their rates jump by Δv_c, and none acts on the free coordinates f, so their momentum is kept,
    M_ff Δv_f + M_fc Δv_c = 0 (restitution has no say: the rate after is the law's). M_fc Δv_c is the change
    of the free residual when the prescribed accelerations are Δv_c (the residual is affine in the
    accelerations, with rigid links' dependent nodes completed from them); Δv_f is the impulse law's response
    to −M_fc Δv_c (:func:`impulse_response`: directions without inertia in their statics, stiff ones weighted
    by M + h²K as at a latch). The impulse on c, J = M_cf Δv_f + M_cc Δv_c, is the change of the reactions
    with accelerations (Δv_f, Δv_c), and its work ½(v_c⁻ + v_c⁺)·J, the kinetic energy it gives (exactly so
    where M weights the jump). The crank kinked to 2 rad/s carrying a free rigid rod: the hinge's rate −5
    rad/s, 1.1667 J, Goldstein's impulse on a free rod (tests/test_prescribed_motion_work.py)."""
    model = assembler.model
    rows = model.prescribed_coordinates()
    jump_c = (pack(model, state.v - before.v, state.w - before.w, state.theta_dot - before.theta_dot)[rows])
    scale = np.max(np.abs(pack(model, state.v, state.w, state.theta_dot)[rows]), initial=0.0)
    # a jump of 1e-9 of the rates is none (the rates' own change over the 2e-9·dt a landed jump skips is smaller)
    if len(rows) == 0 or not np.any(np.abs(jump_c) > 1e-9 * max(scale, 1.0)):
        return 0.0
    at_rest = state.copy()
    for name in ("a", "alpha", "theta_ddot"):
        getattr(at_rest, name)[...] = 0.0
    prescribed = at_rest.copy()
    for name, rate in (("a", "v"), ("alpha", "w"), ("theta_ddot", "theta_dot")):
        np.copyto(getattr(prescribed, name), getattr(state, rate) - getattr(before, rate))
    free = _free_mask(model)
    for name, mask in zip(("a", "alpha", "theta_ddot"), free):
        getattr(prescribed, name)[mask] = 0.0
    zero = assembler.evaluate(at_rest, matrices=False)
    coupled = assembler.evaluate(prescribed, matrices=False)
    impulse = -(np.asarray(coupled.residual) - np.asarray(zero.residual))
    X = impulse_response(model, assembler.evaluate(state, matrices=True), impulse[:, None], step)
    jump_f = X[:, 0]
    unpack_free(model, free_velocity(model, state) + jump_f, state.v, state.w, state.theta_dot)
    assembler.complete_links(state)
    unpack_free(model, jump_f, prescribed.a, prescribed.alpha, prescribed.theta_ddot)
    reaction = np.asarray(assembler.evaluate(prescribed, matrices=False).reaction) - np.asarray(zero.reaction)
    mean = 0.5 * (pack(model, before.v, before.w, before.theta_dot) + pack(model, state.v, state.w, state.theta_dot))
    return float(mean[rows] @ reaction[rows - model.n_dofs])


def prescribed_acceleration_jump(assembler, before: State, state: State, step: float) -> np.ndarray | None:
    """The change of the free accelerations of ``state`` that a jump of the prescribed accelerations alone
    implies (a ramp's end: from ``before``'s to ``state``'s at the same configuration and velocities), added
    in place; returns it (free coordinates), or None where no prescribed acceleration changed. The free
    equations hold on both sides, so M_ff Δv̇_f = −M_fc Δv̇_c, the change of the free residual with the
    prescribed accelerations, solved by :func:`impulse_response` as a jump of the rates is
    (:func:`prescribed_velocity_jump`: the same linear algebra). A restart that solved the accelerations
    again from scratch (``restart_accelerations``: (M + dt²K) v̇ = −r₀) set a flexible slider-crank's
    drive reaction ringing from step to step after its crank's acceleration jumped (−0.47, −1.00, −0.16,
    −0.64 N m), and the trapezoid of that ringing lost 4.4e-3 J of its work (examples/slider_crank.yaml)."""
    model = assembler.model
    rows = model.prescribed_coordinates()
    after = pack(model, state.a, state.alpha, state.theta_ddot)[rows]
    held = pack(model, before.a, before.alpha, before.theta_ddot)[rows]
    if len(rows) == 0 or not np.any(after != held):
        return None
    previous = state.copy()
    free = _free_mask(model)
    for name, mask in zip(("a", "alpha", "theta_ddot"), free):
        np.copyto(getattr(previous, name), getattr(before, name))
        getattr(previous, name)[mask] = getattr(state, name)[mask]
    change = np.asarray(assembler.evaluate(state, matrices=False).residual) \
        - np.asarray(assembler.evaluate(previous, matrices=False).residual)
    shift = impulse_response(model, assembler.evaluate(state, matrices=True), -change[:, None], step)[:, 0]
    unpack_free(model, free_acceleration(model, state) + shift, state.a, state.alpha, state.theta_ddot)
    assembler.complete_links(state)
    return shift


def _free_mask(model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which node translations, node rotations and hinge rates are free coordinates (n_nodes × 3 twice,
    n_hinges): those a prescribed velocity's jump leaves to the impulse law."""
    node = model.node_dofs < model.n_dofs
    hinge = model.hinge_dofs < model.n_dofs
    return node[:, :3], node[:, 3:], hinge
