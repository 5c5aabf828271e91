"""Time integration on the Lie group (R³ × SO(3))ⁿ × Rᵐ.

Default: Lie-group generalized-α (Arnold & Brüls 2007; Brüls, Cardona & Arnold
2012).  With v the velocities (spatial angular velocities for rotations), v̇
their derivatives and a the algorithmic acceleration:

    q_{n+1}   = q_n ∘ exp(h Δq_n),  Δq_n = v_n + h(½ − β) a_n + hβ a_{n+1}
    v_{n+1}   = v_n + h(1 − γ) a_n + hγ a_{n+1}
    (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) v̇_{n+1} + α_f v̇_n
    r(q_{n+1}, v_{n+1}, v̇_{n+1}, t_{n+1}) = 0      (equilibrium at t_{n+1})

Newton on v̇_{n+1} with the iteration matrix S = β′M + γ′C + K, β′ = (1 − α_m)/(h²β(1 − α_f)),
γ′ = γ/(hβ); the correction Δx updates Δq += Δx/h, v += γ′Δx, v̇ += β′Δx.
K omits the tangent operator of exp (T(hΔq) ≈ I) and, by default, the inertia
tangent ∂(Mv̇ + g − f_gravity)/∂q of the elements: on directions with inertia both
are O(h²) against β′M, cost a few Newton iterations at large steps, and leave the
converged solution exact (see benchmarks/newton_tangent.py).  On a direction with
no or little inertia nothing stands in for the inertia tangent: in a bent
Euler–Bernoulli element without rotary inertia the interpolated centreline turns
with the nodal twist (a twist inertia ~ φ², :mod:`latdyn.numerics.inertia`), so the inertia
and gravity forces change with the twist as much as the internal force does, in
opposite sense, and K alone makes Newton diverge on the twist at any step size
(D4, docs/verification.md).  When Newton fails, the time loop switches the run to
``inertia_tangent`` (the omitted term, exact: the generated kernel beam_inertia_tangent,
codegen/derivation.py, called element by element by ``inertia_tangent`` of
latdyn/assembly/csrc/evaluate.c) before it cuts the step.

The same scheme gives, by its parameters:
  ``generalized-alpha``: α_m = (2ρ∞ − 1)/(ρ∞ + 1), α_f = ρ∞/(ρ∞ + 1)
  ``hht-alpha``:         α_m = 0, α_f = (1 − ρ∞)/(1 + ρ∞) ∈ [0, ⅓] (HHT parameters, ρ∞ ≥ ½)
  ``newmark``:           α_m = α_f = 0, γ = ½, β = ¼ (trapezoidal rule)
with γ = ½ + α_f − α_m and β = ¼(γ + ½)².

``explicit``: a Lie-group Störmer–Verlet (central difference) step on the
directions with inertia; directions without inertia, and the light ones the
step cannot integrate (the twist of a bent Euler–Bernoulli element, inertia
~ φ², see :mod:`latdyn.numerics.inertia`), are condensed by a Newton solve of their
static equations at every step.

Directions without inertia (the twist of an Euler–Bernoulli beam without
rotary inertia, the spin of a massless joint about a hinge axis …) are found
joint by joint by :mod:`latdyn.numerics.inertia`, invariant under rigid motions; the
iteration matrix S stays regular on them through K, and only the start (and
the explicit step) needs the split.

Newton stops when the increment is small in :func:`increment_size`: per node
|Δd|/ℓ and |Δπ| in radians, per hinge |Δθ| — dimensionless, and invariant
under rigid motions of the scene (norms of 3-vectors, ℓ the scene's size).
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import (
    Assembler,
    State,
    free_acceleration,
    free_velocity,
    unpack_free,
)
from latdyn.errors import SolverError
from latdyn.numerics.inertia import (
    joint_blocks,
    joint_groups,
    joint_norms,
    largest_link_turn,
    link_hinge_coordinates,
    split_inertia,
)
from latdyn.assembly.factorization import solve_linear, solve_linear_csr
from latdyn.numerics.csr import CSR
from latdyn.numerics.linalg import DENSE_LIMIT, RCM_IN_PYTHON, issparse
from latdyn.records import record


@record(frozen=True)
class AlphaParameters:
    """The parameters α_m, α_f, γ, β of a generalized-α step (:meth:`for_method`)."""

    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float

    @classmethod
    def for_method(cls, method: str, rho_inf: float) -> "AlphaParameters":
        if method == "generalized-alpha":
            am = (2 * rho_inf - 1) / (rho_inf + 1)
            af = rho_inf / (rho_inf + 1)
        elif method == "hht-alpha":
            am = 0.0
            af = min((1 - rho_inf) / (1 + rho_inf), 1 / 3)
        elif method == "newmark":
            return cls(0.0, 0.0, 0.5, 0.25)
        else:
            raise ValueError(f"unknown implicit method {method!r}")
        gamma = 0.5 + af - am
        return cls(am, af, gamma, 0.25 * (gamma + 0.5) ** 2)


@record
class StepStats:
    """What one step's Newton iteration did: iterations, convergence, residual, factorizations, contraction."""

    iterations: int = 0
    converged: bool = False
    residual: np.ndarray | None = None
    factorizations: int | None = None  # iteration matrices factorized (None: one per iteration)
    contraction: float = 0.0  # largest |Δx_k| / |Δx_{k−1}| of the step's Newton increments


def increment_size(assembler, dx: np.ndarray, length: float) -> float:
    """The size of a Newton increment, dimensionless and invariant under rigid motions.

    Per free node, |Δd| / ℓ (ℓ the size of the scene) and |Δπ| (radians, the norm
    of the spatial rotation increment), per free hinge |Δθ|; the largest of them.
    Norms of 3-vectors do not depend on the frame, component maxima would. Written once, in
    C (csrc/newton_step.c increment_size, the time step's own test), for statics, continuation
    and steady motion too (``NativeModel.increment_size``).
    """
    return assembler.native().increment_size(dx, length)


def consistent_acceleration(model, ev) -> np.ndarray:
    """The correction Δv̇ that makes the accelerations consistent with the equations of motion.

    With Q = [Q_m, Q_c] from :func:`latdyn.numerics.inertia.split_inertia` (M Q_c = 0) and
    Δv̇ = Q_m y_m + Q_c y_c.  The directions without inertia carry no inertia force, so their
    equations are statics, Q_cᵀ r = 0, which the configuration need not satisfy yet (a torque
    that starts at t = 0 on a hinge between a joint body and a massless beam: nothing holds it
    until the beam winds up).  They take it within the first step, δq = Q_c d with
    Q_cᵀ K Q_c d = −Q_cᵀ r, and what they transmit then acts on the directions with inertia
    from the start: the residual is affine in v̇ with slope M, so

        Q_mᵀ M Q_m y_m = −Q_mᵀ (r + K Q_c d)      (statically condensed: Q_mᵀ r − K_mc K_cc⁻¹ r_c)

    (without it the massive directions start with the acceleration of the unloaded state and
    the run is first order from its start: tests/test_initial_state.py). The directions
    without inertia follow the massive ones as the time derivative of their static
    equilibrium prescribes to first order, Q_cᵀ K Q_c y_c = −Q_cᵀ K Q_m y_m.  No artificial
    inertia is added anywhere.
    """
    if start_without_scipy(model):
        M = ev.combined_csr(1.0, 0.0, 0.0)
        if not split_inertia(model, M).n_massless:
            return inverse_mass_times(M, -ev.residual)
    M = ev.combined(1.0, 0.0, 0.0)  # dense where the dense LU serves the model, else CSR
    split = split_inertia(model, M)
    Qm, Qc = split.massive, split.massless
    delta = np.zeros(model.n_dofs)
    residual = ev.residual
    K = Kcc = None
    if split.n_massless:
        K = ev.combined(0.0, 0.0, 1.0)
        Kcc = _csr(Qc.T @ K @ Qc)
        unbalanced = Qc.T @ residual
        if np.any(unbalanced):
            residual = residual + K @ (Qc @ solve_held(Kcc, -unbalanced))
    if split.n_massive:
        y_m = solve_linear(_csr(Qm.T @ M @ Qm), -(Qm.T @ residual))
        delta += Qm @ y_m
    if split.n_massless:
        delta += Qc @ solve_held(Kcc, -(Qc.T @ (K @ delta)))
    return delta


def inverse_mass_times(M, vector: np.ndarray) -> np.ndarray:
    """M⁻¹ ``vector`` for a mass matrix M (a :class:`latdyn.numerics.csr.CSR`) whose every direction has
    inertia: :func:`consistent_acceleration`'s Δv̇ = Q_m (Q_mᵀ M Q_m)⁻¹ Q_mᵀ (−r) where Q_m is all of Q (square
    and invertible), so Δv̇ = −M⁻¹ r; solved as D (D M D)⁻¹ D with D = diag(M)^−½, the unit-diagonal scaling
    that Q_m's columns D_g^−½ u give joint by joint, on M's own pattern (the assembler's, which the held check
    and the step's matrix order and factorize too: the same reverse Cuthill–McKee order, found once). Equal
    to the split's products to round-off (tests/test_light_run.py), without forming them (two sparse
    products, ≈ 10 ms of the 16-bay lattice's start; docs/performance.md, "Seventh pass")."""
    scale = 1.0 / np.sqrt(M.diagonal())
    scaled = CSR(M.shape, M.indptr, M.indices, M.data * scale[M.rows] * scale[M.indices])
    return scale * solve_linear_csr(scaled, scale * vector)


def start_without_scipy(model) -> bool:
    """Whether the start solves for its accelerations on the mass matrix's own CSR without SciPy
    (:func:`inverse_mass_times` where every direction has inertia; latdyn.numerics.csr): a model above
    the dense LU's size, without rigid links, whose step's band LU orders its pattern without SciPy too
    (numerics.linalg.RCM_IN_PYTHON); importing scipy.sparse costs ≈0.1 s of CPU. The transient sensitivities'
    start takes its M the same way (:meth:`latdyn.analyses.transient_sensitivities.TransientSensitivities.start`)."""
    return model.links is None and DENSE_LIMIT < model.n_dofs <= RCM_IN_PYTHON


def _csr(A):
    """A sparse product in the CSR form the sparse LU takes; a dense one as it is."""
    return A.tocsr() if issparse(A) else A


def solve_held(matrix, rhs: np.ndarray) -> np.ndarray:
    """matrix⁻¹ rhs for a matrix whose rows of the directions without inertia are their statics
    (K_cc, or a block system with it): singular when no stiffness holds such a direction, and
    then refused with the message that says so. ``matrix`` may be a :class:`latdyn.numerics.csr.CSR`
    (:func:`latdyn.assembly.factorization.solve_linear_csr`: the impulse without SciPy)."""
    try:
        return solve_linear_csr(matrix, rhs) if isinstance(matrix, CSR) else solve_linear(matrix, rhs)
    except np.linalg.LinAlgError as exc:
        raise SolverError("a coordinate without inertia is held by no stiffness",
                          "directions of the model carry neither inertia nor stiffness; "
                          "`latdyn check` names the coordinate") from exc


def newmark_warning(model, mass, method: str = "newmark") -> str | None:
    """What a Newmark run of a 3D model with directions without inertia must say (None otherwise);
    so must generalized-α and HHT-α with ρ∞ = 1 (``method`` names which), whose double root on
    those directions is −ρ∞ = −1 as well (HHT-α with ρ∞ = 1 is Newmark's trapezoidal rule): found by
    the whole-run fuzzer's step check (seed 106 case 20: a hinge rate of a 3D arm alternating
    +11.9, −8.4, +12.9 … rad/s from step to step under generalized-α with ``rho_inf: 1``, no warning).

    The trapezoidal rule (γ = ½, β = ¼) determines the rate and acceleration of a direction
    without inertia only through their own recursion: with its configuration fixed by statics,
    (v, h a) go on by the matrix [[−1, 0], [−4, −1]] a step, a double eigenvalue −1 — undamped,
    alternating in sign, growing linearly — where generalized-α (ρ∞ < 1) has a double root −ρ∞.
    The same holds for the directions whose inertia is tiny against their stiffness (the twist
    of a bent Euler–Bernoulli element without rotary inertia, inertia ~ φ²: ωh ≫ 1, amplification
    (1 − (ωh)²/4)/(1 + (ωh)²/4) → −1).  In a 3D model those rates enter the forces that depend on
    velocities (the element's inertia forces through its twist-dependent centreline, gyroscopic
    terms of joint bodies), so round-off on them grows instead of staying at round-off: D4 in 3D
    with ρI = 0 goes out of plane from 1e-20 m to 1e-2 m by 1 s with 65 step cuts, not converging
    as dt shrinks (docs/verification.md, "D4 in 3D: out-of-plane motion").  Generalized-α, or a
    rotary inertia (rhoIy, rhoIz) on the beams, gives results the package stands behind; the
    method is not changed here, the run says so."""
    if model.plane is not None or model.n_dofs == 0:
        return None
    split = split_inertia(model, mass)
    if not split.n_massless:
        return None
    return (f"method {method} on a 3D model with {split.n_massless} direction(s) without inertia (the twist "
            "of beams without rhoIy/rhoIz, joints without mass or inertia): without numerical damping "
            "(a double root -1 on them) their rates are left undamped, ringing from round-off, and through "
            "velocity-dependent forces that can grow into motion no step size converges (docs/verification.md, "
            "'D4 in 3D: out-of-plane motion'); method generalized-alpha with rho_inf < 1, or rotary inertia "
            "on the beams, avoids it")


class GeneralizedAlpha:
    """The Lie-group generalized-α family between steps: its parameters, the algorithmic acceleration
    a_n carried from step to step, the consistent start, the acceptance and the local error estimate.
    The step itself, Newton iteration included, is native: :class:`latdyn.step.compiled.CompiledGeneralizedAlpha`
    (tests/reference_step.py restates it in NumPy, as the reference it must equal)."""

    def __init__(self, assembler: Assembler, params: AlphaParameters, tol: float, max_iterations: int,
                 length_scale: float):
        self.assembler = assembler
        self.p = params
        self.tol = tol
        self.max_iterations = max_iterations
        self.length_scale = length_scale
        self.a = None  # algorithmic acceleration (free coordinates)
        #: add the elements' inertia tangent to the iteration matrix (module docstring);
        #: switched on by the time loop when Newton fails without it
        self.inertia_tangent = False

    def start(self, state: State) -> None:
        """Accelerations consistent with the equations of motion at ``state`` (see
        :func:`consistent_acceleration`), in the state and as the algorithmic acceleration: at t = 0,
        and again after a latch (:func:`latdyn.timeloop.events.latch_hinges`)."""
        model = self.assembler.model
        if model.n_dofs:
            ev = self.assembler.evaluate(state, matrices=True)
            vdot0 = free_acceleration(model, state) + consistent_acceleration(model, ev)
            unpack_free(model, vdot0, state.a, state.alpha, state.theta_ddot)
        self.a = free_acceleration(model, state)

    def accept(self) -> None:
        self.a = self.a_candidate

    def error_estimate(self, h: float) -> float:
        """Local error of the position update, h²|β − 1/6| ‖a_{n+1} − a_n‖ (Géradin & Cardona).

        The norm is the largest inertia-weighted joint norm (:func:`latdyn.numerics.inertia.joint_norms`):
        a length, over every direction with inertia (rotations of joints without translational
        mass, such as the hinge of a rigid link on a fixed body, included), blind to
        directions without inertia (whose algorithmic accelerations carry no dynamics) and
        invariant under rigid motions of the scene; or, where it is larger, the largest change of a
        rigid link's hinge acceleration counted as a rotation, ℓ |Δθ̈|
        (:func:`latdyn.numerics.inertia.largest_link_turn`): the inertia-weighted norm does not see a
        hinge whose direction has almost no inertia at the moment, the outer ring of a gimbal-locked top,
        whose angle then sets where the motion goes on (docs/energy.md, "Steps that do not resolve a hinge").
        """
        ev = getattr(self, "last_evaluation", None)
        if ev is None or self.assembler.model.n_dofs == 0:
            return 0.0
        x = self.a_candidate - self.a
        blocks = joint_blocks(self.assembler.model, ev.combined(1.0, 0.0, 0.0), self.groups())
        size = float(np.max(joint_norms(blocks, x, self.length_scale), initial=0.0))
        turn, _ = largest_link_turn(self.link_hinges(), x, self.length_scale)
        return h * h * abs(self.p.beta - 1 / 6) * max(size, turn)

    def groups(self) -> np.ndarray:
        """Joint groups of the current numbering (rebuilt after a latch, with :meth:`link_hinges`)."""
        model = self.assembler.model
        key = (model.n_dofs, tuple(model.free_hinges))
        if getattr(self, "_groups_key", None) != key:
            self._groups, self._groups_key = joint_groups(model), key
            self._link_hinges = link_hinge_coordinates(model)
        return self._groups

    def link_hinges(self) -> np.ndarray:
        """The free coordinates of rigid links' hinges in the current numbering (rebuilt after a latch)."""
        self.groups()
        return self._link_hinges


def _mass_and_stiffness(ev):
    """M and K of an evaluation, assembled once (dense for small models, see latdyn.numerics.linalg)."""
    cached = getattr(ev, "_explicit_matrices", None)
    if cached is None:
        cached = ev.combined(1.0, 0.0, 0.0), ev.combined(0.0, 0.0, 1.0)
        ev._explicit_matrices = cached
    return cached


def explicit_acceleration(model, ev, split, vdot: np.ndarray) -> np.ndarray:
    """The accelerations of an explicit step at a configuration whose directions Q_c are condensed.

    ``vdot`` holds the accelerations the residual of ``ev`` was evaluated with.  The
    residual is affine in v̇ with slope M (Eq. 58), so r₀ = r − M v̇ is the residual
    at zero free acceleration, and the new accelerations v̇ = Q_m y_m + Q_c y_c are
    computed afresh from it, not as an increment of the last step's: the split
    turns with the configuration, and an increment carries the previous step's
    Q_c component into the next step's split (1.8e-10 m on the L-frame's tip over
    0.1 s: not the cause of the former blow-up, but no part of the method either).

        Q_mᵀ M (Q_m y_m + Q_c y_c) = −Q_mᵀ r₀     (motion of the directions with inertia)
        Q_cᵀ K (Q_m y_m + Q_c y_c) = 0           (Q_c follows its statics, linearised)

    For exactly massless Q_c, Q_mᵀ M Q_c = 0 and this is :func:`consistent_acceleration`
    applied from v̇ = 0 at a configuration in equilibrium along Q_c (where the step's Newton
    iteration on Q_c leaves it);
    for light Q_c (:func:`latdyn.numerics.inertia.split_inertia` with a step) the coupling term
    keeps the inertia that the massive directions feel from the condensed motion,
    and only Q_c's own inertia force, Q_cᵀ M v̇ (relative size ≤ λ), is dropped.
    """
    M, K = _mass_and_stiffness(ev)
    r0 = ev.residual - M @ vdot
    Qm, Qc = split.massive, split.massless
    if split.n_massless == 0:
        return Qm @ solve_linear(Qm.T @ M @ Qm, -(Qm.T @ r0))
    blocks = [[Qm.T @ M @ Qm, Qm.T @ M @ Qc], [Qc.T @ K @ Qm, Qc.T @ K @ Qc]]
    if issparse(M):
        import scipy.sparse as sps  # on use: the dense LU's models run without it

        A = sps.bmat(blocks, format="csr")
    else:
        A = np.block(blocks)
    rhs = np.concatenate([-(Qm.T @ r0), np.zeros(split.n_massless)])
    return split.basis @ solve_held(A, rhs)


class CentralDifference:
    """Explicit Lie-group Störmer–Verlet; directions without inertia condensed statically each step.

    Per step (v the velocities, spatial angular velocities for rotations, v̇ their rates):

        v_{n+½} = v_n + ½h v̇_n,   q_{n+1} = q_n ∘ exp(h v_{n+½})            (drift)
        Q_cᵀ r(q_{n+1}, ṽ_{n+1}) = 0  by Newton along Q_c                    (statics)
        v̇_{n+1} from :func:`explicit_acceleration`,  v_{n+1} = v_{n+½} + ½h v̇_{n+1} + c/h

    with c the Newton correction of the configuration along Q_c (their rates are
    the displacement that took over the step).  The residual at t_{n+1} is
    evaluated with the second-order velocity predictor ṽ_{n+1} = v_{n+½} + ½h v̇_n + c/h,
    so velocity-dependent forces (gyroscopic, hinge dampers) keep the scheme of
    order two.

    Q_c holds the directions without inertia *and* the light directions that the
    step cannot integrate (:mod:`latdyn.numerics.inertia`: the twist of a bent
    Euler–Bernoulli element has an inertia ~ φ² that no explicit step resolves;
    counting it as massive made every run blow up as soon as the bending lifted
    its eigenvalue over ``MASSLESS_TOL``, at the same physical time whatever h).
    ``max_light`` records the most light directions condensed in one step.
    """

    def __init__(self, assembler: Assembler, tol: float, max_iterations: int, length_scale: float):
        self.assembler = assembler
        self.tol = tol
        self.max_iterations = max_iterations
        self.length_scale = length_scale
        self.a = None
        self.max_light = 0

    def start(self, state: State) -> None:
        """Accelerations consistent with the equations of motion (exact null space: no step yet)."""
        model = self.assembler.model
        if model.n_dofs:
            ev = self.assembler.evaluate(state, matrices=True)
            vdot = free_acceleration(model, state)
            unpack_free(model, vdot + consistent_acceleration(model, ev), state.a, state.alpha, state.theta_ddot)

    @staticmethod
    def _check_finite(ev, h: float, t_new: float) -> None:
        if not np.all(np.isfinite(ev.residual)):
            raise SolverError(
                f"explicit integration became unstable at t = {t_new:.6g}",
                f"the step {h:.3g} exceeds the stability limit 2/ω_max of the stiffest mode with inertia; "
                "reduce solve.dt or use an implicit method")

    def _split(self, ev, h: float):
        M, K = _mass_and_stiffness(ev)
        split = split_inertia(self.assembler.model, M, stiffness=K, step=h)
        self.max_light = max(self.max_light, split.n_light)
        return split

    def step(self, state: State, h: float, t_new: float | None = None) -> tuple[State, StepStats]:
        model = self.assembler.model
        t_new = state.t + h if t_new is None else t_new
        stats = StepStats(converged=True)
        if model.n_dofs == 0:
            trial = state.copy()
            self.assembler.apply_prescribed(trial, t_new)
            return trial, stats
        v = free_velocity(model, state)
        vdot = free_acceleration(model, state)
        v_half = v + 0.5 * h * vdot
        trial = self.assembler.advance(state, h * v_half)
        self.assembler.apply_prescribed(trial, t_new)
        correction = np.zeros(model.n_dofs)

        def predicted() -> np.ndarray:
            return v_half + 0.5 * h * vdot + correction / h

        unpack_free(model, predicted(), trial.v, trial.w, trial.theta_dot)
        ev = self.assembler.evaluate(trial, matrices=True)
        self._check_finite(ev, h, t_new)
        split = self._split(ev, h)
        if split.n_massless:
            Qc = split.massless
            for _ in range(self.max_iterations):
                Kcc = Qc.T @ _mass_and_stiffness(ev)[1] @ Qc
                try:
                    dx = Qc @ solve_linear(Kcc, -(Qc.T @ ev.residual))
                except np.linalg.LinAlgError:
                    stats.converged = False
                    break
                trial = self.assembler.advance(trial, dx)
                correction += dx
                unpack_free(model, predicted(), trial.v, trial.w, trial.theta_dot)
                stats.iterations += 1
                ev = self.assembler.evaluate(trial, matrices=True)
                if increment_size(self.assembler, dx, self.length_scale) <= self.tol or not np.all(np.isfinite(dx)):
                    break
            else:
                stats.converged = False
            self._check_finite(ev, h, t_new)
            split = self._split(ev, h)  # the split of the configuration the accelerations belong to
        stats.residual = ev.residual
        if not stats.converged:
            return trial, stats
        vdot_new = explicit_acceleration(model, ev, split, vdot)
        unpack_free(model, vdot_new, trial.a, trial.alpha, trial.theta_ddot)
        v_new = v_half + 0.5 * h * vdot_new + correction / h
        unpack_free(model, v_new, trial.v, trial.w, trial.theta_dot)
        return trial, stats

    def accept(self) -> None:
        pass

    def error_estimate(self, h: float) -> float:
        return 0.0


def newton_diagnosis(model, residual: np.ndarray | None, t: float, h: float, assembler=None,
                     state=None, variable: str = "t") -> str:
    """Name the coordinates, bodies and beams with the largest residual (cf. Exudyn's SolverErrorMessage);
    ``variable`` names what ``t`` is (``load factor`` in a static analysis)."""
    if residual is None or len(residual) == 0:
        return f"at {variable} = {t:.6g} with step {h:.3g}: Newton did not converge or the linear system could not be solved"
    names = model.dof_names()
    worst = np.argsort(-np.abs(residual))[:5]
    lines = [f"Newton did not converge at {variable} = {t:.6g} with step {h:.3g}; largest residual entries:"]
    for i in worst:
        lines.append(f"  {names[i]}: {residual[i]:.3e}")
    if assembler is not None and state is not None and len(model.element_nodes):
        psi, _ = assembler.kernels.beam_deformation(assembler.element_geometry(state), model.element_sections)
        rotation = np.max(np.abs(psi[:, :5]), axis=1)  # φ = sines of the element's end rotations (Eqs. 14-16)
        e = int(np.argmax(rotation))
        beam = model.element_beam[e]
        index = e - int(model.beam_elements[beam][0])
        lines.append(f"  largest element rotation relative to its chord: beam {beam!r}, element {index}: "
                     f"sin φ = {rotation[e]:.3f}")
        if rotation[e] > 0.5:
            lines.append("  CR-4402 assumes small rotations within an element (Eq. 6): refine the mesh of "
                         f"beam {beam!r}.")
    lines.append(_USUAL_CAUSES.get(variable, _USUAL_CAUSES["t"]))
    return "\n".join(lines)


#: What most often stops Newton, in a time step and on a static path (``newton_diagnosis``'s ``variable``).
_USUAL_CAUSES = {
    "t": "Usual causes: a step too large for the fastest mode, a coordinate held only by a tiny stiffness, a "
         "load or prescribed motion that jumps, or a structure that buckles.",
    "load factor": "Usual causes: a load step past a limit point or a bifurcation (solve.method: arc-length "
                   "follows the path past limit points), a coordinate held only by a tiny stiffness (a mechanism "
                   "the loads move), or rotations within an element too large for the mesh.",
}
