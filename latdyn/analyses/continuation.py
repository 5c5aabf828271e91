"""Static equilibrium paths: load control, arc-length continuation, displacement control.

The static residual is affine in the load factor λ (loads, gravity and hinge torques are their
values at t = 0 scaled by λ; :meth:`latdyn.assembly.assembler.Assembler.evaluate`):

    r(q, λ) = f_int(q) − λ q_ref(q) = 0,                 K = ∂r/∂q,   q_ref = r(q, λ) − r(q, λ + 1)

(q_ref depends on q for loads that turn with a body).  Every method below solves this with
Newton on the pair (Δq, Δλ) through the two solutions of one tangent

    K δq_r = −r,   K δq_λ = q_ref,   δq = δq_r + δλ δq_λ               (Batoz & Dhatt 1979)

and differs only in the equation that fixes δλ (``solve.method``, SCENE.md):

- ``load-control``: λ on the grid k/steps; δλ = 0 after the step.  A step whose Newton fails is
  cut in halves towards the *next grid point*, and the sub-steps climb back to it, so every
  requested row λ = k/steps is written (the rows are never shifted off the grid).
- ``arc-length``: Crisfield's cylindrical arc length (Crisfield 1981, Eq. 13):
  ΔqᵀWΔq = Δs², with Δq the increment of the step (the tangent-space difference of its ends: the
  Newton increments summed, their rotations composed in 3D, :meth:`Path.compose`) and W weighting
  translations by 1/ℓ² (ℓ the size of the scene) and rotations and hinge angles by 1, the norm of
  :func:`latdyn.step.integrators.increment_size`.
  Each iteration solves the quadratic a₁δλ² + a₂δλ + a₃ = 0 (Crisfield 1981, Eqs. 20–22) and
  takes the root whose increment turns least from the step so far.  The predictor
  Δλ = ±Δs/‖δq_λ‖_W takes its sign from the previous step's direction, sign(Δq_{n−1}ᵀ W δq_λ)
  (Feng, Perić & Owen 1996), which passes limit points and snap-backs alike, where the sign of
  det K fails at a snap-back (Crisfield 1981 §3; Riks 1979 uses the same constraint linearised).
  In 3D, Δq composes the rotation increments exactly (:meth:`Path.compose`): the constraint then
  measures the distance of the step's ends, a function of the ends alone and so of the parameters,
  not of the Newton iterates (the sum of rotation increments about different axes is not); with or
  without ``solve.sensitivities`` the same (docs/parameters.md, "Arc length").
  Δs adapts to the Newton iterations of the last step, Δs ← Δs·√(6/N), within [Δs₀/1024, Δs₀],
  Δs₀ being the arc length of a first step Δλ = 1/steps.  The run ends when λ reaches 1 (the
  last point is solved at λ = 1 exactly) or after ``max_steps`` path steps (a warning).
- ``displacement-control``: the displacement c(q) = e·(p(q) − p₀) of a point p along a unit
  vector e goes from 0 to ``to`` in ``steps`` equal increments; linearised, gᵀδq = c* − c(q) with
  g = ∂c/∂q (e on the node's translations, (T r) × e on its rotation for an offset r), so
  δλ = (c* − c − gᵀδq_r)/(gᵀδq_λ) (Batoz & Dhatt 1979).  λ may pass its maxima; c may not: where
  the controlled displacement turns back (a snap-back of c), no state on the path beyond has the
  next c, and Newton either fails or converges onto another stretch of the path, skipping the loop
  between.  So a converged step whose Δq differs from the tangent's prediction δλ δq_λ by more than
  :data:`BRANCH_MISMATCH` of the larger has left the path and is halved like a failed one; a run
  that cannot go on after a step left the path, or where the rate of c along the path (its share
  of the path's W-norm motion) has fallen below :data:`TURNING_RATE` of its largest, says that c
  turns back there and that arc length follows the path (exit 1).

The Newton iterations of all three are the static mode of the native Newton iteration
(:class:`latdyn.step.compiled.StaticNewton`, ``csrc/newton_step.c``): the evaluation at (q, λ) and at
λ + 1 for q_ref, K scattered into the time step's matrix storage (rigid links reduced as the step
reduces them), the step's LU solving both right-hand sides [−r, q_ref] with one factorization, and
the step's convergence test, increment_size(Δq) ≤ tol on the iteration's increment. Load control
runs its whole Newton at a fixed λ in one call into C; arc length and displacement control call one
iteration at a time and do their bordered update (a scalar equation for δλ) in Python, where it
costs a few dot products.

Along every path the number of negative eigenvalues of the symmetric part of K (evaluated at the
converged state) is counted at each converged point (models up to :data:`PIVOT_COUNT_LIMIT`
coordinates).  λ changing direction
is a *limit point*, located between the points about the turn (latdyn/analyses/limit_points.py;
where it cannot be, the vertex of the parabola λ(s) through the three points, flagged coarse);
the count changing while λ keeps its direction is a *bifurcation
point*.  Both go to ``summary.json`` (``limit_points``, ``bifurcation_points``).

Under follower loads (:func:`latdyn.analyses.followers.follower_loads`) K is unsymmetric and its
symmetric part says nothing about stability; there the count is of the *real* negative
eigenvalues of K itself (models up to :data:`NONSYMMETRIC_COUNT_LIMIT` coordinates), and a point
is reported only where a real eigenvalue passes through zero (*divergence*, ``kind:
divergence``): the count of real negative eigenvalues and that of all eigenvalues with a negative
real part change together.  Two real eigenvalues meeting and leaving the real axis change the
first count alone, a complex pair crossing the imaginary axis the second alone; neither is a
static instability (flutter is dynamic: ``analysis: buckling``, latdyn/analyses/stability.py).

Every converged state on the grid is a row of ``probes.csv`` (first column ``load_factor``); a
run that cannot go on writes its last converged state as a row before it fails (exit 1), with a
message in load factor.

References: E. Riks, Int. J. Solids Struct. 15 (1979) 529–551; M. A. Crisfield, Comput. Struct.
13 (1981) 55–62; J.-L. Batoz & G. Dhatt, Int. J. Numer. Meth. Eng. 14 (1979) 1262–1267;
Y. T. Feng, D. Perić & D. R. J. Owen, Comput. Methods Appl. Mech. Eng. 130 (1996) 341–359.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from latdyn.analyses.followers import REAL_TOL, follower_loads
from latdyn.analyses.mechanism import mechanism_message
from latdyn.analyses.sensitivities import ArcLengthSensitivities, ArcStep, StaticSensitivities
from latdyn.errors import SceneError, SolverError
from latdyn.numerics.linalg import single_thread_blas
from latdyn.numerics.so3 import compose_rotation_vectors
from latdyn.step.compiled import StaticNewton
from latdyn.step.integrators import newton_diagnosis

#: Most halvings of a load or displacement step (1/1024 of a grid step), of the arc length.
MAX_CUTS = 10
#: Newton iterations a path step aims at (arc length adapts towards it).
TARGET_ITERATIONS = 6
#: the W-norm of δq_λ = K⁻¹q_ref (the move of the full load: translations over the scene's size, rotations
#: in radians) at and below which the loads move nothing: arc length cannot start (its first arc length
#: Δs₀ = ‖δq_λ‖_W/steps); round-off of zero loads is ~1e-18
LOADS_MOVE_NOTHING = 1e-12
#: Largest model whose tangent's negative eigenvalues are counted at every path point (dense).
PIVOT_COUNT_LIMIT = 1000
#: The same under follower loads, where the count needs the eigenvalues of the unsymmetric K (dense).
NONSYMMETRIC_COUNT_LIMIT = 400


@dataclass
class PathPoint:
    """A converged point of the path: its step, load factor, arc length from the start (W-norm)
    and the number of negative eigenvalues of the symmetric part of K (None: not counted); under
    follower loads the number of real negative eigenvalues of K and, in ``negative_real_part``,
    of all its eigenvalues with a negative real part (module docstring)."""
    step: int
    load_factor: float
    arc: float
    negative: int | None
    negative_real_part: int | None = None
    #: where λ turns at this point: the limit point's load factor located between its neighbours
    #: (latdyn.analyses.limit_points), None where it could not be located (then estimated, coarse)
    limit: float | None = None


@dataclass
class Path:
    """What the path methods share: the model, the writer, counters, the points passed."""
    prepared: object
    probes: object
    writer: object
    length_scale: float
    tol: float = 1e-10
    max_iter: int = 30
    iterations: int = 0
    steps: int = 0
    rejected: int = 0
    points: list = field(default_factory=list)
    #: no load turns with a body: the symmetric part of K tells stability (module docstring)
    conservative: bool = True
    recorded_at: float | None = None  # load factor of the last row, the state it holds being `recorded`
    recorded: object = None
    weight: np.ndarray | None = None
    #: solve.sensitivities: a StaticSensitivities that records each row's (latdyn/analyses/sensitivities.py)
    sensitivities: object = None
    #: displacement control: the gradient of the controlled displacement, state -> (n_dofs,)
    constraint_gradient: object = None
    #: the static mode of the native Newton iteration (latdyn.step.compiled.StaticNewton)
    newton: object = None
    #: arc length in 3D: a step's Δq composed exactly in the tangent space (:meth:`compose`), so
    #: that its arc length is the distance of its ends (set by :func:`static_path`)
    exact_increments: bool = False
    #: the last step :meth:`left_the_path` judged a jump: (start, its load, the end's load, ‖Δq‖)
    _departure: tuple | None = None
    #: the states of the last three path points, to locate a limit point between them (:meth:`accept`)
    _recent: list = field(default_factory=list)
    #: each limit point :meth:`locate_turn` tried, by the turning point's load factor: (state, λ, cᵀW) where
    #: located, else None; the sensitivities' limit points take it (StaticSensitivities.limit_points)
    located_limits: dict = field(default_factory=dict)

    def __post_init__(self):
        scene = self.prepared.scene
        self.model, self.assembler = self.prepared.model, self.prepared.assembler
        self.tol = scene.solve.tol if scene.solve.tol is not None else 1e-10
        self.max_iter = max(scene.solve.max_iterations, 30)
        model = self.model
        self.weight = np.ones(model.n_dofs)
        translations = model.node_dofs[model.free_nodes, 0:3].ravel()
        self.weight[translations[translations < model.n_dofs]] = 1.0 / self.length_scale ** 2
        self.conservative = not follower_loads(model, self.prepared.state)
        self.newton = StaticNewton(self.assembler, self.tol, self.max_iter, self.length_scale)

    # ------------------------------------------------------------------ equations
    def evaluate(self, state, load_factor: float):
        """r(q, λ), K(q, λ) and q_ref(q) = r(q, λ) − r(q, λ + 1) (the residual is affine in λ) as
        matrices, for the diagnoses (a mechanism's free directions); Newton takes :meth:`iterate`."""
        ev = self.assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False)
        shifted = self.assembler.evaluate(state, matrices=False, load_factor=load_factor + 1.0, inertia=False)
        return ev.residual, ev.stiffness, ev.residual - shifted.residual

    def iterate(self, state, load_factor: float):
        """One iteration of the native static Newton at (state, λ): r, q_ref, δq_r = −K⁻¹r and
        δq_λ = K⁻¹q_ref from one factorization (:class:`latdyn.step.compiled.StaticIteration`;
        δq_r None where K is singular or a solution not finite)."""
        return self.newton.iteration(state, load_factor)

    def tangent(self, state, load_factor: float):
        """K(q, λ) as a matrix, for the eigenvalue counts at a converged point (the static mode's,
        :meth:`latdyn.step.compiled.StaticNewton.tangent`)."""
        return self.newton.tangent(state, load_factor)

    def increment_size(self, dq) -> float:
        """The time step's convergence measure of a Newton increment (latdyn.step.integrators.increment_size)."""
        return self.newton.increment_size(dq)

    def norm(self, dq) -> float:
        """‖Δq‖_W (translations over ℓ, rotations and hinge angles in radians)."""
        return math.sqrt(float(dq @ (self.weight * dq)))

    def compose(self, dq, increment):
        """The step's increment after one more Newton increment: the sum, and with
        :attr:`exact_increments` the rotations composed, log(exp(skew δπ) exp(skew Δπ)) at every free
        node (the update turns T ← exp(skew δπ) T), so that Δq is the tangent-space difference of the
        step's ends, which the sum of rotation increments about different axes is not."""
        total = dq + increment
        if self.exact_increments:
            dofs = self.model.node_dofs[self.model.free_nodes, 3:6]
            dofs = dofs[np.all(dofs < self.model.n_dofs, axis=1)]
            if len(dofs):
                total[dofs] = compose_rotation_vectors(increment[dofs], dq[dofs])
        return total

    def difference(self, start, end) -> np.ndarray:
        """Δq from ``start`` to ``end`` on the free coordinates (the inverse of :meth:`step_to`):
        x_end − x_start, log(T_end T_startᵀ) at every free node, θ_end − θ_start."""
        from scipy.spatial.transform import Rotation

        model, n = self.model, self.model.n_dofs
        dq = np.zeros(n + 1)  # slot n takes what is not a coordinate (out of the plane, locked)
        nodes = model.free_nodes
        dofs = np.minimum(model.node_dofs[nodes], n)
        dq[dofs[:, :3]] = end.x[nodes] - start.x[nodes]
        turn = np.einsum("nij,nkj->nik", end.T[nodes], start.T[nodes])
        dq[dofs[:, 3:]] = Rotation.from_matrix(turn).as_rotvec() if len(nodes) else 0.0
        hinges = model.free_hinges
        dq[np.minimum(model.hinge_dofs[hinges], n)] = end.theta[hinges] - start.theta[hinges]
        return dq[:n]

    def left_the_path(self, start, start_load: float, end, end_load: float) -> bool:
        """Whether a Newton solution ``end`` at load factor ``end_load``, started from the path point
        ``start``, converged onto another branch: its Δq differs from the tangent's prediction
        (end_load − start_load) K⁻¹q_ref by more than :data:`BRANCH_MISMATCH` of the larger and is the
        larger (a step past a limit point that lands on the far side of a snap-through, as a toggle's)
        or goes against the prediction (W-inner product < 0, however short: an imperfect column past
        its Euler load onto the near-straight branch bent the other way), and does not shrink with the
        step (judged from the same start at a longer step before, a step along the prediction would
        have shrunk at least halfway towards in proportion on a path that only softens: a kink, as
        where a cable goes slack).  Not judged
        from a start that is no equilibrium (the initial configuration of a preloaded hinge spring or
        a pretensioned cable: the path begins where the first step lands)."""
        iteration = self.iterate(start, start_load)
        tangent = iteration.dq_lambda
        if tangent is None or iteration.dq_r is None or self.increment_size(iteration.dq_r) > 10 * self.tol:
            return False
        predicted = (end_load - start_load) * tangent
        step = self.difference(start, end)
        off, size = self.norm(step - predicted), self.norm(step)
        if off <= SAME_BRANCH_DISTANCE:  # round-off of a state that hardly moves (no load on it)
            return False
        if off / max(size, self.norm(predicted), 1e-300) <= BRANCH_MISMATCH:
            return False  # on the path
        along = float(step @ (self.weight * predicted))  # W-inner product of the step and the prediction
        if size <= self.norm(predicted) and along > 0.0:
            return False  # stiffer than the tangent said (a cable going taut): no jump
        # moved further than the tangent said, or against it (an imperfect column past its Euler
        # load stepped back onto the near-straight branch bent the other way): a jump, unless the move
        # goes along the prediction and shrinks with the step as on a continuous path that softens (a
        # kink: a cable going slack), where the same start was judged before at a longer step
        last = self._departure
        self._departure = (start, start_load, end_load, size)
        if last is not None and last[0] is start and last[1] == start_load and along > 0.0:
            ratio = abs(end_load - start_load) / max(abs(last[2] - start_load), 1e-300)
            if ratio < 1.0 and size < 0.5 * (1.0 + ratio) * last[3]:
                return False  # shrank at least halfway towards in proportion: a kink, not a jump
        return True

    def step_to(self, state, dq):
        new = self.assembler.advance(state, dq)
        self.assembler.apply_prescribed(new, 0.0)
        return new

    def point(self, step: int, load_factor: float, arc: float, tangent) -> PathPoint:
        """The path point with the eigenvalue counts of K (:meth:`negative_eigenvalues`); ``tangent()``
        makes K, called only where the model is small enough for the counts."""
        n = self.model.n_dofs
        limit = PIVOT_COUNT_LIMIT if self.conservative else NONSYMMETRIC_COUNT_LIMIT
        K = tangent() if 0 < n <= limit else np.zeros((n, n)) if n == 0 else None
        if self.conservative:
            return PathPoint(step, float(load_factor), float(arc), None if K is None else self.negative_eigenvalues(K))
        return PathPoint(step, float(load_factor), float(arc),
                         *((None, None) if K is None else self.negative_real_eigenvalues(K)))

    def negative_real_eigenvalues(self, K) -> tuple[int | None, int | None]:
        """Under follower loads: the real negative eigenvalues of K and all its eigenvalues with a
        negative real part (None, None above NONSYMMETRIC_COUNT_LIMIT coordinates)."""
        n = K.shape[0]
        if n == 0 or n > NONSYMMETRIC_COUNT_LIMIT:
            return (None, None) if n else (0, 0)
        dense = K if isinstance(K, np.ndarray) else K.toarray()
        with single_thread_blas():
            mu = np.linalg.eigvals(dense)
        scale = max(float(np.max(np.abs(mu))), 1e-300)
        negative = mu.real < -1e-12 * scale
        real = np.abs(mu.imag) <= REAL_TOL * np.maximum(np.abs(mu), 1e-12 * scale)
        return int(np.sum(negative & real)), int(np.sum(negative))

    def negative_eigenvalues(self, K) -> int | None:
        """Negative eigenvalues of ½(K + Kᵀ) (None above PIVOT_COUNT_LIMIT coordinates)."""
        n = K.shape[0]
        if n == 0 or n > PIVOT_COUNT_LIMIT:
            return None if n else 0
        import scipy.linalg as sla

        dense = K if isinstance(K, np.ndarray) else K.toarray()
        # Sylvester's law of inertia: ½(K + Kᵀ) = L D Lᵀ (Bunch–Kaufman), D of 1×1 and 2×2 blocks
        with single_thread_blas():
            _, D, _ = sla.ldl(0.5 * (dense + dense.T), lower=True)
        eigenvalues = sla.eigvalsh_tridiagonal(np.diag(D).copy(), np.diag(D, 1).copy())
        scale = max(float(np.max(np.abs(eigenvalues))), 1e-300)
        return int(np.sum(eigenvalues < -1e-12 * scale))

    # ------------------------------------------------------------------ rows and summary
    def record(self, state, load_factor: float, step: ArcStep | None = None) -> None:
        """A row; ``step``: the arc-length step that led to it, for its sensitivities."""
        self.probes.load_factor = load_factor   # the joint forces' reactions at the row's λ
        self.writer.record(load_factor, self.probes.values(state), state=state.as_dict(),
                           frame=load_step_frame(self.assembler, self.writer, state))
        if self.sensitivities is not None:
            extra = {"step": step} if step is not None else {}
            self.sensitivities.record(state, load_factor, self.constraint_gradient, **extra)
        self.recorded_at, self.recorded = load_factor, state

    def accept(self, state, load_factor: float, arc: float) -> None:
        """A converged point of the path, its eigenvalues counted on K at the converged state; where λ
        turned at the point before, the limit point located between that point's neighbours
        (:meth:`locate_turn`)."""
        self.steps += 1
        self.points.append(self.point(self.steps, load_factor, arc, lambda: self.tangent(state, load_factor)))
        self.remember(state)
        self.locate_turn()
        self.summarize()

    def remember(self, state) -> None:
        """Keep the state of the newest path point (the last three are kept)."""
        self._recent = (self._recent + [state.copy()])[-3:]

    def locate_turn(self) -> None:
        """Where λ turns at the path point before the newest (above or below both its neighbours'), the
        limit point between the neighbours, on the hyperplanes through that point normal (in W) to the
        chord of its two steps (latdyn.analyses.limit_points); its load factor goes to the point's
        ``limit``.  One that cannot be located keeps the parabola's estimate, flagged coarse in
        ``limit_points`` and by a warning (docs/static_paths.md, "Limit points")."""
        if len(self.points) < 3 or len(self._recent) < 3:
            return
        before, turn, after = self.points[-3:]
        if not is_turn(before.load_factor, turn.load_factor, after.load_factor):
            return
        from latdyn.analyses.limit_points import locate_limit

        first, middle, last = self._recent
        into, out = self.difference(first, middle), self.difference(middle, last)
        chord = self.weight * (into + out)
        located = locate_limit(self, middle, turn.load_factor, chord, (-float(chord @ into), float(chord @ out)))
        self.located_limits[turn.load_factor] = None if located is None else (*located, chord)
        if located is not None:
            turn.limit = float(located[1])
            return
        message = (f"the limit point near load factor {turn.load_factor:.6g} (path step {turn.step}) could not be "
                   "located between the path points about it: limit_points gives the vertex of the parabola "
                   "through them (located: false), a coarse estimate; more steps (solve.steps) bring the points "
                   "closer to it")
        self.writer.warn(message)

    def summarize(self) -> None:
        limits, bifurcations = critical_points(self.points)
        last = self.points[-1].load_factor if self.points else 0.0
        self.writer.summary.update(
            steps=self.steps, newton_iterations=self.iterations, rejected_steps=self.rejected,
            newton_iterations_per_step=self.iterations / max(self.steps, 1), newton_tolerance=self.tol,
            method=self.prepared.scene.solve.method, load_factor_reached=last,
            limit_points=limits, bifurcation_points=bifurcations, conservative=self.conservative,
            negative_eigenvalues_counted=self.model.n_dofs <= (
                PIVOT_COUNT_LIMIT if self.conservative else NONSYMMETRIC_COUNT_LIMIT))

    def fail(self, state, load_factor: float, message: str, residual, at: float, step: float,
             diagnosis: str | None = None) -> None:
        """Write the last converged state as a row (unless it is the last row) and raise (with
        ``diagnosis``, else Newton's at ``at``)."""
        if self.recorded is not state:
            self.record(state, load_factor)
        self.summarize()
        free = mechanism_message(self, state, load_factor)  # a mechanism, not a limit point: say which
        if free is not None:
            raise SolverError(free, f"(the last converged state, at load factor {load_factor:.6g}, is the last row)")
        raise SolverError(message, diagnosis if diagnosis is not None else
                          newton_diagnosis(self.model, residual, at, step, variable="load factor"))


def critical_points(points: list[PathPoint]) -> tuple[list[dict], list[dict]]:
    """Limit points (λ turns) and bifurcation points (the count of negative eigenvalues changes
    while λ keeps its direction) along ``points`` (the start, λ = 0, first)."""
    lam = np.array([p.load_factor for p in points])
    arc = np.array([p.arc for p in points])
    d = np.diff(lam)
    limits, turns = [], set()
    for j in range(1, len(d)):
        if is_turn(*lam[j - 1:j + 2]):
            turns.add(j)
            located = points[j].limit is not None
            estimate = points[j].limit if located else parabola_vertex(arc[j - 1:j + 2], lam[j - 1:j + 2])
            limits.append({"load_factor": float(estimate), "recorded_load_factor": float(lam[j]),
                           "step": points[j].step, "kind": "maximum" if d[j - 1] > 0 else "minimum",
                           "located": located})
    bifurcations = []
    for j in range(1, len(points)):
        before, after = points[j - 1].negative, points[j].negative
        if before is None or after is None or before == after:
            continue
        if j - 1 in turns or j in turns or j + 1 >= len(points):
            continue  # the change of a limit point, or not yet known which
        follower = points[j].negative_real_part is not None
        if follower and points[j - 1].negative_real_part == points[j].negative_real_part:
            continue  # real eigenvalues that met and left the real axis: no divergence (module docstring)
        entry = {"load_factor": 0.5 * float(lam[j - 1] + lam[j]), "step": points[j].step,
                 "between_load_factors": [float(lam[j - 1]), float(lam[j])],
                 "negative_eigenvalues": [before, after]}
        if follower:
            entry["kind"] = "divergence"
        bifurcations.append(entry)
    return limits, bifurcations


def is_turn(before: float, at: float, after: float) -> bool:
    """Whether λ turns at a path point: above or below both its neighbours' (by more than round-off)."""
    d0, d1 = at - before, after - at
    return d0 * d1 < 0 and abs(d0) > 1e-14 and abs(d1) > 1e-14


def parabola_vertex(s, y) -> float:
    """The coarse estimate of a limit point that could not be located: the vertex of the parabola λ(s)
    through the three path points about the turn (arc length s), where it lies between them, else the
    middle point's λ."""
    estimate = float(y[1])
    if np.ptp(s) > 0 and len(set(np.asarray(s).tolist())) == 3:
        a, b, c = np.polyfit(s - s[1], y, 2)
        if a != 0.0:
            vertex = -b / (2 * a)
            if s[0] - s[1] <= vertex <= s[2] - s[1]:
                estimate = float(c - b * b / (4 * a))
    return estimate


# ====================================================================== load control
def load_control(path: Path, state) -> object:
    """λ = k/steps, k = 1 … steps; a failed step is halved towards the next grid point."""
    steps = path.prepared.scene.solve.steps
    lam, k, h = 0.0, 0, 1.0 / steps
    jumped = False  # a cut step of this row converged onto another branch (:meth:`Path.left_the_path`)
    while k < steps:
        grid = (k + 1) / steps
        target = grid if lam + h >= grid - 1e-12 / steps else lam + h
        trial, _, residual, converged = newton_fixed(path, state, target)
        left = converged and path.left_the_path(state, lam, trial, target)  # snapped onto another branch
        jumped = jumped or left
        if not converged or left:
            path.rejected += 1
            h = min(h, target - lam) / 2
            if h < 1.0 / (steps * 2 ** MAX_CUTS):
                if jumped and turns_on(path, state, lam, target) is True:
                    # no snap-through: λ goes on past the target along the path, which turns too sharply for
                    # the load steps (a column's with a small imperfection near its Euler load)
                    path.fail(state, lam, f"static analysis could not reach load factor {grid:.6g} (row {k + 1} of "
                                          f"{steps}): the path turns sharply between load factors {lam:.6g} and "
                                          f"{target:.6g}, where the load factor goes on rising (a near-bifurcation, "
                                          "as of a column with a small imperfection near its Euler load), and "
                                          "Newton's solutions from the last point left it at every cut of the step "
                                          f"down to {target - lam:.3g}; the last converged load factor, {lam:.6g}, "
                                          "is the last row (shorter load steps, more solve.steps, may follow it)",
                              residual, target, target - lam, diagnosis="")  # Newton converged: no residuals
                how = "Newton converged only onto another branch of the path (a snap-through)" if left else (
                    "Newton failed" + (" (at longer steps it converged only onto another branch of the path: "
                                       "a snap-through)" if jumped else ""))
                path.fail(state, lam, f"static analysis could not reach load factor {grid:.6g} (row {k + 1} of "
                                      f"{steps}): {how} at load factor {target:.6g} after {MAX_CUTS} cuts "
                                      f"of the step; the last converged load factor, {lam:.6g}, is the last row (past a limit point "
                                      "load control cannot go on: solve.method: arc-length follows the path)",
                          residual, target, target - lam)
            continue
        state, lam = trial, target
        path.accept(state, lam, lam)
        h = min(2 * h, 1.0 / steps)
        if target == grid:
            k += 1
            jumped = snapped = False
            path.record(state, lam)
    return state


#: Arc-length steps :func:`turns_on` takes from the last point of a load-control path to see whether λ
#: passes a maximum before the load factor the steps could not reach.
TURN_PROBE_STEPS = 40


def turns_on(path: Path, state, lam: float, target: float) -> bool | None:
    """Where load control's steps from (``state``, ``lam``) to ``target`` converged only onto another
    branch: whether the path itself, followed by arc length from there, reaches ``target`` with λ rising
    all the way (True: a sharp turn, no snap-through), λ passes a maximum first (False: a limit point, a
    snap-through), or neither is seen in :data:`TURN_PROBE_STEPS` steps (None).  The steps' arc length
    starts at the tangent's move to ``target`` and adapts as arc length's; nothing is recorded."""
    tangent = path.iterate(state, lam).dq_lambda
    if tangent is None or path.norm(tangent) == 0.0:
        return None
    ds0 = (target - lam) * path.norm(tangent)
    ds, previous, iterations = ds0, tangent / path.norm(tangent), path.iterations
    try:
        for _ in range(TURN_PROBE_STEPS):
            result = arc_length_step(path, state, lam, ds, previous)
            if result is None:
                ds /= 2
                if ds < ds0 / 2 ** MAX_CUTS:
                    return None
                continue
            new, new_lam, step_dq, n = result
            if new_lam < lam:
                return False  # λ passed a maximum
            if new_lam >= target:
                return True
            state, lam = new, new_lam
            previous = step_dq / max(path.norm(step_dq), 1e-300)
            ds *= min(2.0, math.sqrt(TARGET_ITERATIONS / max(n, 1)))
        return None
    finally:
        path.iterations = iterations  # a look ahead, not steps of the path


def newton_fixed(path: Path, state, load_factor: float):
    """Newton at a fixed load factor from ``state``, in one call into the native static Newton
    (:meth:`latdyn.step.compiled.StaticNewton.newton`): (state, None, residual, converged), the
    residual that of the last evaluation (the tangent is :meth:`Path.tangent`'s where it is needed)."""
    start = state.copy()
    path.assembler.apply_prescribed(start, 0.0)
    trial, residual, iterations, converged = path.newton.newton(start, load_factor)
    path.iterations += iterations
    return trial, None, residual, converged


# ====================================================================== arc length
def arc_length(path: Path, state) -> object:
    """Crisfield's cylindrical arc length (module docstring) until λ = 1 or ``max_steps``."""
    solve = path.prepared.scene.solve
    max_steps = solve.max_steps if solve.max_steps is not None else 20 * solve.steps
    model = path.model
    if model.n_dofs == 0:
        return load_control(path, state)
    start = path.iterate(state, 0.0)
    preloaded = start.dq_r is not None and path.increment_size(start.dq_r) > 10 * path.tol
    if path.sensitivities is None and preloaded:
        # A start that is no equilibrium (a preloaded hinge spring, a pretensioned cable: rest angles
        # and lengths are not ramped): the path begins at the equilibrium at λ = 0. From the start
        # itself the cylinder ‖Δq‖_W = Δs of the first steps may not reach the path (its Δs₀ is that
        # of the loads alone, the preload's move may be longer), and every step failed down to
        # Δs₀/1024 where load control solved. The row at λ = 0 stays the initial configuration, as
        # with load control (the path begins where its first step lands).
        settled, _, _, converged = newton_fixed(path, state, 0.0)
        if converged:
            state = settled
            start = path.iterate(state, 0.0)
            path.points[-1] = path.point(0, 0.0, 0.0, lambda: path.tangent(settled, 0.0))
            path._recent = [settled.copy()]
    if start.dq_lambda is None or path.norm(start.dq_lambda) <= LOADS_MOVE_NOTHING:
        free = mechanism_message(path, state, 0.0)
        if free is not None:
            raise SolverError(free)
        if start.dq_lambda is not None:
            # the round-off of loads that are zero: the first arc length was as small, and every step
            # failed down to 1/1024 of it ("… arc lengths down to 1.08e-21"), where load control
            # solved (nothing moves)
            raise SolverError(f"arc-length continuation cannot start: the loads move nothing (the full load moves "
                              f"the structure by {path.norm(start.dq_lambda):.3g} of its size, at most "
                              f"{LOADS_MOVE_NOTHING:g}; a static analysis takes the loads, gravity and torques at "
                              "t = 0, where a load in t may be zero): solve.method: load-control solves it")
        raise SolverError("arc-length continuation cannot start: the tangent at load factor 0 is singular "
                          "or the loads move nothing",
                          newton_diagnosis(model, start.residual, 0.0, 0.0, variable="load factor"))
    tangent = start.dq_lambda
    ds0 = path.norm(tangent) / solve.steps  # the first step: Δλ = 1/steps
    ds, lam, arc = ds0, 0.0, 0.0
    previous = tangent / path.norm(tangent)  # direction of the last step, W-unit
    while path.steps < max_steps:
        result = arc_length_step(path, state, lam, ds, previous)
        if result is not None and (lam - 1.0) * (result[1] - 1.0) <= 0.0 and lam != 1.0:
            # λ = 1 inside the step: its end solved at λ = 1 exactly
            landed, _, _, converged = newton_fixed(path, result[0], 1.0)
            result = (landed, 1.0, result[2], result[3]) if converged else None
            if result is not None:
                new, new_lam, step_dq, n = result
                path.accept(new, new_lam, arc + ds)
                path.record(new, new_lam, ArcStep(step_dq, ds, ds0, at_full_load=True))
                return new
        if result is None:
            path.rejected += 1
            ds /= 2
            if ds < ds0 / 2 ** MAX_CUTS:
                path.fail(state, lam, f"arc-length continuation could not go on from load factor {lam:.6g}: "
                                      f"Newton failed with arc lengths down to {ds0 / 2 ** MAX_CUTS:.3g} "
                                      f"(1/{2 ** MAX_CUTS} of the first step)" + (
                                          " from the initial configuration, which is no equilibrium (a preloaded "
                                          "hinge spring or a pretensioned cable): with solve.sensitivities arc "
                                          "length starts there, where the loads' first arc length may not reach "
                                          "the path; load control, displacement control and arc length without "
                                          "sensitivities solve such a start" if preloaded and lam == 0.0
                                          and path.sensitivities is not None else ""), None, lam, ds)
            continue
        new, new_lam, step_dq, n = result
        arc += path.norm(step_dq)
        state, lam = new, new_lam
        previous = step_dq / max(path.norm(step_dq), 1e-300)
        path.accept(state, lam, arc)
        path.record(state, lam, ArcStep(step_dq, ds, ds0))
        ds = min(ds0, ds * min(2.0, math.sqrt(TARGET_ITERATIONS / max(n, 1))))
    # the path is not completed: a failure, as load control's row not reached (it was `solved` with a
    # warning: an imperfect column past its Euler load stopped at λ = 0.645 of 1, its steps bounded by
    # the first's Δs₀ while the path past the turn is thousands of them long)
    path.writer.summary["end"] = "max_steps"
    path.fail(state, lam, f"arc-length continuation stopped after max_steps = {max_steps} path steps at load factor "
                          f"{lam:.6g}, before the load factor reached 1: the path is not completed (each step's arc "
                          f"length is at most the first step's, {ds0:.3g}, the full load's linear move over "
                          f"solve.steps; the path from the start is {arc:.3g} long); the last step is the last row "
                          "(a larger solve.max_steps goes on; load control may follow a path that does not turn "
                          "back)", None, lam, ds, diagnosis="")


def arc_length_step(path: Path, state, lam: float, ds: float, previous):
    """One step of arc length ``ds`` from (state, λ): (state, λ, Δq, iterations) or None."""
    W = path.weight
    tangent = path.iterate(state, lam).dq_lambda
    if tangent is None:
        return None
    size = path.norm(tangent)
    if size == 0.0:
        return None
    sign = 1.0 if float(previous @ (W * tangent)) >= 0.0 else -1.0  # Feng et al. 1996
    dlam = sign * ds / size
    dq = dlam * tangent
    trial, trial_lam = path.step_to(state, dq), lam + dlam
    for n in range(1, path.max_iter + 1):
        iteration = path.iterate(trial, trial_lam)
        if iteration.dq_r is None:
            return None
        dq_r, dq_l = iteration.dq_r, iteration.dq_lambda
        a = dq + dq_r
        a1 = float(dq_l @ (W * dq_l))           # Crisfield 1981, Eq. 22
        a2 = 2.0 * float(dq_l @ (W * a))
        a3 = float(a @ (W * a)) - ds * ds
        disc = a2 * a2 - 4.0 * a1 * a3
        if a1 == 0.0 or disc < 0.0:
            return None
        roots = ((-a2 + math.sqrt(disc)) / (2 * a1), (-a2 - math.sqrt(disc)) / (2 * a1))
        # the root whose step turns least from the step so far (Crisfield 1981, Eq. 23)
        dl = max(roots, key=lambda root: float(dq @ (W * (a + root * dq_l))))
        increment = dq_r + dl * dq_l
        trial, trial_lam, dq = path.step_to(trial, increment), trial_lam + dl, path.compose(dq, increment)
        path.iterations += 1
        if path.increment_size(increment) <= path.tol:
            return trial, trial_lam, dq, n
    return None


# ====================================================================== displacement control
def displacement_control(path: Path, state) -> object:
    """The controlled displacement on the grid to·k/steps; a failed step is halved towards it."""
    solve = path.prepared.scene.solve
    control, steps = solve.control, solve.steps
    model = path.model
    node, offset = model.point(control.point)
    if node not in set(int(n) for n in model.free_nodes):
        raise SceneError(path.prepared.scene.file, "solve.control.point",
                         f"expected a point that moves (on a free node), got {control.point.text!r} (fixed, "
                         "prescribed or set by a rigid link)")
    origin = state.x[node] + state.T[node] @ offset

    def displacement(s) -> float:
        return float(control.direction @ (s.x[node] + s.T[node] @ offset - origin))

    def gradient(s) -> np.ndarray:
        g = np.zeros(model.n_total + 1)
        dofs = model.node_dofs[node]
        g[dofs[0:3]] += control.direction
        g[dofs[3:6]] += np.cross(s.T[node] @ offset, control.direction)  # δ(T r) = δπ × T r
        return g[:model.n_dofs]

    if not np.any(gradient(state)):
        raise SceneError(path.prepared.scene.file, "solve.control.direction",
                         f"expected a direction in which {control.point.text!r} can move, got {control.text} (out "
                         "of the plane of a planar model? planar: off solves it in 3D)")
    path.constraint_gradient = gradient
    start = path.iterate(state, 0.0)
    if start.dq_r is not None and path.increment_size(start.dq_r) > 10 * path.tol:
        # a start that is no equilibrium (a preloaded spring) is no point of the path: the path begins
        # where the first step lands (its load factor may be far from 0), and λ's change from the start
        # to it is no turn (a limit point was reported at the first step)
        path.points.clear()
        path._recent = []
    lam, reached, k, h = 0.0, 0.0, 0, 1.0 / steps
    left_path = False  # a step towards the next row converged off the path
    rates = []  # the displacement rate at the start of every accepted step
    while k < steps:
        grid = (k + 1) / steps
        fraction = grid if reached + h >= grid - 1e-12 / steps else reached + h
        result = displacement_step(path, state, lam, fraction * control.to, displacement, gradient)
        if result is None or result is LEFT_THE_PATH:
            path.rejected += 1
            left_path = left_path or result is LEFT_THE_PATH
            h = (fraction - reached) / 2
            if h < 1.0 / (steps * 2 ** MAX_CUTS):
                goal = f"{control.point.text} displaced by {grid * control.to:.6g} along {control.text}"
                if left_path or turning_back(path, state, lam, rates, gradient):
                    raise_snap_back(path, state, lam, goal, displacement(state), k, steps)
                path.fail(state, lam, f"displacement control could not reach {goal} (row {k + 1} of {steps}): "
                                      f"Newton failed after {MAX_CUTS} cuts; the last converged state, at load "
                                      f"factor {lam:.6g}, is the last row", None, lam, h)
            continue
        state, lam, rate = result
        rates.append(rate)
        reached = fraction
        path.accept(state, lam, fraction)
        h = min(2 * h, 1.0 / steps)
        if fraction == grid:
            k += 1
            left_path = False
            path.record(state, lam)
    path.writer.summary["control_displacement"] = displacement(state)
    return state


#: A displacement-control step whose converged Δq differs from the tangent's prediction by more
#: than this fraction of the larger of the two left the path (it is halved).
BRANCH_MISMATCH = 0.5
#: A step within this W-norm distance (translations over the scene's size, rotations in rad) of the
#: tangent's prediction is on the path whatever the ratio (:meth:`Path.left_the_path`).
SAME_BRANCH_DISTANCE = 1e-6
#: What :func:`displacement_step` returns for a step that converged off the path.
LEFT_THE_PATH = "left the path"


#: Displacement control that fails where the displacement rate has fallen below this fraction of
#: its largest along the path is at a turn of the controlled displacement.
TURNING_RATE = 0.1


def turning_back(path: Path, state, lam: float, rates: list, gradient) -> bool:
    """Whether the controlled displacement is about to turn back at ``state``: its rate there
    (:func:`displacement_rate`) below TURNING_RATE of the largest seen along the path."""
    tangent = path.iterate(state, lam).dq_lambda
    if tangent is None or not rates:
        return False
    rate = displacement_rate(path, float(gradient(state) @ tangent), tangent)
    return rate < TURNING_RATE * max(rates)


def raise_snap_back(path: Path, state, lam: float, goal: str, reached: float, k: int, steps: int) -> None:
    """Displacement control that cannot go on because its displacement turns back: the last converged
    state as the last row, and a SolverError that says arc length is needed there."""
    path.fail(state, lam, f"displacement control could not reach {goal} (row {k + 1} of {steps}): the "
                          f"controlled displacement turns back at {reached:.6g} (a snap-back of it: the path "
                          "goes on to smaller displacements), where displacement control cannot follow the "
                          "path without leaving it; solve.method: arc-length follows it there", None, lam, 0.0,
              f"(the last converged state, at load factor {lam:.6g}, is the last row)")


def displacement_rate(path: Path, slope: float, tangent) -> float:
    """|dc/ds|/ℓ along the path's tangent δq_λ = K⁻¹q_ref at a state (``slope`` = gᵀδq_λ = dc/dλ, s the
    W-norm arc length): the share of the path's motion that is the controlled displacement, 0 where
    c turns back."""
    return abs(slope) / (path.length_scale * max(path.norm(tangent), 1e-300))


def displacement_step(path: Path, state, lam: float, goal: float, displacement, gradient):
    """Newton on (q, λ) with c(q) = goal from (state, λ): (state, λ, the displacement rate at the
    start, :func:`displacement_rate`); None where Newton fails;
    LEFT_THE_PATH where it converged far from the tangent's prediction Δq = δλ K⁻¹q_ref (or there
    was none: dc/dλ = 0), onto another branch of the path or across a snap-back of c."""
    start = path.iterate(state, lam)
    tangent = start.dq_lambda
    if tangent is None:
        return None
    # not judged from a start that is no equilibrium (a preloaded hinge spring, a pretensioned cable:
    # the step also takes the preload's move, which the tangent does not predict), as load control's
    # Path.left_the_path: every first step was judged off the path, and the run failed "the controlled
    # displacement turns back at 0 (a snap-back …)" where there was none
    judged = start.dq_r is not None and path.increment_size(start.dq_r) <= 10 * path.tol
    g = gradient(state)
    slope = float(g @ tangent)  # dc/dλ along the tangent
    rate = displacement_rate(path, slope, tangent)
    trial, trial_lam = state, lam
    predicted = np.zeros_like(tangent)  # the tangent's Δq to the goal
    if abs(slope) > 1e-14 * max(1.0, abs(goal)):
        dlam = (goal - displacement(state)) / slope
        predicted = dlam * tangent
        trial, trial_lam = path.step_to(state, predicted), lam + dlam
    step = predicted.copy()  # Δq of the step so far (increments summed in the tangent space)
    for _ in range(path.max_iter):
        iteration = path.iterate(trial, trial_lam)
        if iteration.dq_r is None:
            return None
        dq_r, dq_l = iteration.dq_r, iteration.dq_lambda
        g = gradient(trial)
        denominator = float(g @ dq_l)
        if denominator == 0.0:
            return None
        dl = (goal - displacement(trial) - float(g @ dq_r)) / denominator  # Batoz & Dhatt 1979
        increment = dq_r + dl * dq_l
        trial, trial_lam = path.step_to(trial, increment), trial_lam + dl
        step += increment
        path.iterations += 1
        if path.increment_size(increment) <= path.tol:
            # the converged step far from the tangent's: it left the path (module docstring)
            mismatch = path.norm(step - predicted) / max(path.norm(step), path.norm(predicted), 1e-300)
            return (trial, trial_lam, rate) if mismatch <= BRANCH_MISMATCH or not judged else LEFT_THE_PATH
    return None


METHODS = {"load-control": load_control, "arc-length": arc_length, "displacement-control": displacement_control}


def static_path(prepared, probes, writer, length_scale: float) -> None:
    """Solve the static analysis of ``prepared`` by its ``solve.method``; rows into ``writer``."""
    path = Path(prepared, probes, writer, length_scale)
    if prepared.scene.solve.sensitivities and prepared.scene.solve.analysis == "static":
        arc = prepared.scene.solve.method == "arc-length"
        path.sensitivities = ArcLengthSensitivities(prepared, path.weight) if arc else StaticSensitivities(prepared)
    # 3D arc length composes its steps' rotations, with or without sensitivities (Path.exact_increments)
    path.exact_increments = prepared.scene.solve.method == "arc-length" and prepared.model.plane is None
    state = prepared.state
    state.v[:] = state.w[:] = 0.0
    state.theta_dot[:] = 0.0
    path.record(state, 0.0)
    path.points.append(path.point(0, 0.0, 0.0, lambda: path.tangent(state, 0.0)))
    path.remember(state)
    path.summarize()
    # a static path asked for by another analysis (modes about: static, buckling) is load control
    method = prepared.scene.solve.method if prepared.scene.solve.method in METHODS else "load-control"
    prepared.state = METHODS[method](path, state)
    path.summarize()
    if path.sensitivities is not None:
        if isinstance(path.sensitivities, ArcLengthSensitivities):
            writer.summary["limit_point_sensitivities"] = path.sensitivities.limit_points(path)
        _write_sensitivities(path.sensitivities, writer)


def _write_sensitivities(sensitivities, writer) -> None:
    """sensitivities.csv, summary.json's probe_sensitivities (and event_sensitivities: a static path
    has no events), and the table the Result carries."""
    writer.sensitivities = sensitivities.table()
    recorded = writer.result()
    summary = sensitivities.summary(recorded.probes, recorded.t)
    writer.summary["probe_sensitivities"] = {k: v for k, v in summary.items() if k != "load_factor"}
    if "load_factor" in summary:   # displacement control, arc length: the load factor's own (the limit load's at max)
        writer.summary["load_factor_sensitivities"] = summary["load_factor"]
    writer.summary["event_sensitivities"] = []
    if writer.out_dir is not None:
        sensitivities.write(writer.out_dir)


def load_step_frame(assembler, writer, state):
    """The ParaView frame of a load step, computed only if the writer writes it."""
    from latdyn.results.paraview import frame

    snapshot = state.copy()
    return lambda: frame(assembler, writer.mesh, snapshot)
