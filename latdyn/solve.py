"""``run(scene)``: model → analysis → result files (SCENE.md, "Commands and results")."""
from __future__ import annotations

import copy
import signal
import sys
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from . import __version__
from . import checkpoint as checkpoints
from . import linearise
from . import paraview
from .analysis import static_analysis
from .assembly import Assembler, State, advance, free_velocity, initial_state, orthonormalize, pack, unpack_free
from .errors import SceneError, SolverError
from .integrators import AlphaParameters, CentralDifference, GeneralizedAlpha, newton_diagnosis
from .kernels import load_kernels
from .model import Model
from .probes import ProbeSet
from .results import ResultsError, ResultWriter, progress_bar, state_labels
from .scene import Scene, load_scene


#: Default Newton tolerance on :func:`latdyn.integrators.increment_size` (see docs/verification.md).
DEFAULT_TOL = 1e-8


@dataclass
class Prepared:
    scene: Scene
    model: Model
    assembler: Assembler
    state: State


def prepare(scene, backend: str = "auto") -> Prepared:
    """Validate, build the model and refuse coordinates that nothing holds."""
    scene = load_scene(scene)
    model = Model.from_scene(scene)
    kernels = load_kernels(backend=backend, variant=model.kernel_variant)
    assembler = Assembler(model, kernels, scene.gravity)
    state = initial_state(model)
    if model.n_dofs > 0:  # any size: a sparse LU and a few inverse iterations (Model.check_held)
        at_rest = state.copy()
        at_rest.v[:] = at_rest.w[:] = 0.0
        at_rest.theta_dot[:] = 0.0
        # at rest without acceleration (K does not depend on it, but with rigid links the geometric
        # term ∂Jᵀ/∂q · r would carry the inertia forces of prescribed accelerations)
        at_rest.a[:] = at_rest.alpha[:] = 0.0
        at_rest.theta_ddot[:] = 0.0
        # material stiffness only: load terms (gravity, follower moments) hold nothing
        ev = assembler.evaluate(at_rest, matrices=True, load_factor=0.0)
        model.check_held(ev.mass, ev.stiffness, scene.file)
    return Prepared(scene, model, assembler, state)


def _compile_seconds() -> float:
    """Seconds this process has spent compiling C kernels and the step library (summary ``compile_s``)."""
    from .native import COMPILE_SECONDS

    return COMPILE_SECONDS["total"]


def _length_scale(model: Model) -> float:
    """The size ℓ of the scene: twice the largest distance of a node from the centroid
    (invariant under rigid motions, unlike extents along the global axes)."""
    points = np.array([n.position for n in model.nodes]).reshape(-1, 3)
    if len(points) == 0:
        return 1.0
    span = 2.0 * float(np.max(np.linalg.norm(points - points.mean(axis=0), axis=1)))
    return max(span, 1e-3)


def _paraview_every(scene: Scene) -> float | None:
    """The time between ParaView frames (``output.paraview_every``; by default
    :func:`latdyn.paraview.default_every`); for static runs in load factor, a frame per load
    step thinned the same way; None for modal runs (no frames)."""
    solve, output = scene.solve, scene.output
    if solve.analysis in ("modes", "buckling"):
        return None
    if solve.analysis == "static":
        return 0.0 if output.paraview_every == 0 else paraview.default_every(1.0, 1.0 / solve.steps)
    if output.paraview_every is not None:
        return output.paraview_every
    return paraview.default_every(solve.t_end, output.every or solve.dt)


def run(scene, out_dir=None, backend: str = "auto", progress: bool = False, *, resume: bool = False,
        checkpoint_every: float | None = None):
    """Solve a scene and write its results; returns a :class:`latdyn.results.Result`.

    A transient run with an ``out_dir`` writes a checkpoint there (:mod:`latdyn.checkpoint`)
    every ``checkpoint_every`` seconds of wall time (default 60; 0: every step), on
    Ctrl-C or SIGTERM and when the solver fails; ``resume=True`` continues from it
    (:class:`latdyn.checkpoint.CheckpointError` when there is none or it belongs to
    another scene or package version).
    """
    wall0 = time.perf_counter()
    compiled0 = _compile_seconds()
    if checkpoint_every is not None and not checkpoint_every >= 0:
        raise ValueError(f"checkpoint_every must be a number of seconds >= 0, not {checkpoint_every!r}")
    scene = load_scene(scene)
    analysis = scene.solve.analysis
    resume_from = None
    if resume:
        if out_dir is None:
            raise checkpoints.CheckpointError("resuming needs the results folder of the run (out_dir)")
        if analysis != "transient":
            raise checkpoints.CheckpointError(f"{out_dir}: a {analysis} analysis is not checkpointed; "
                                              "there is nothing to resume")
        resume_from = checkpoints.load(out_dir, checkpoints.identity(scene))
    prepared = prepare(scene, backend)
    scene, model = prepared.scene, prepared.model
    kernel_backend = prepared.assembler.kernels.backend
    if resume_from is not None:
        checkpoints.check(resume_from, out_dir, {"backend": kernel_backend})
    elif out_dir is not None:
        checkpoints.discard(out_dir)  # a fresh run: a checkpoint of an earlier one is stale
    probes = ProbeSet(prepared.assembler, prepared.state)
    first = "load_factor" if analysis == "static" else "t"
    meta = {"analysis": analysis, "title": scene.title, "coordinates": model.n_dofs,
            "elements": len(model.element_nodes), "backend": kernel_backend,
            "formulation": scene.solve.formulation}
    try:
        writer = ResultWriter(out_dir, probes.names, first_column=first, mesh=paraview.parts(model, prepared.state),
                              meta=meta,
                              labels=state_labels([n.name for n in model.nodes],
                                                  [f"{h.beam}.{h.end}" for h in model.hinges]),
                              attributes={"nodes": [n.name for n in model.nodes],
                                          "hinges": [f"{h.beam}.{h.end}" for h in model.hinges],
                                          "coordinates": model.dof_names()},
                              paraview_every=_paraview_every(scene),
                              resume=None if resume_from is None else resume_from.writer)
    except ResultsError as exc:  # resuming: files that do not hold what the checkpoint recorded
        raise checkpoints.CheckpointError(f"{exc}") from exc
    summary = {"latdyn_version": __version__, "scene_hash": scene.source_hash, "steps": 0,
               "newton_iterations": 0, "rejected_steps": 0, "energy_balance_error": None}
    writer.summary.update(summary)
    checkpointer = None
    if analysis == "transient" and out_dir is not None:
        checkpointer = checkpoints.Checkpointer(
            out_dir, checkpoints.DEFAULT_INTERVAL if checkpoint_every is None else checkpoint_every,
            checkpoints.identity(scene, kernel_backend), resumes=0 if resume_from is None else resume_from.resumes + 1)
    if resume_from is not None:
        writer.summary.update(resumed_from_t=resume_from.t, resumes=resume_from.resumes + 1)
    with writer, _sigterm_interrupts(enabled=checkpointer is not None):
        if scene.solve.linear_model is not None and analysis != "modes":  # about the chosen state, before the run
            linearise.write_linear_model(prepared, out_dir, writer.summary)
        if analysis == "modes":  # about solve.about (latdyn/linearise.py)
            found, directions, lin = linearise.modal_analysis(prepared, scene.solve.count, scene.solve.about)
            frequencies = [m.frequency_hz for m in found]
            writer.write_modes(frequencies, linearise.modes_table(found, directions))
            writer.summary["modes_hz"] = [float(f) for f in frequencies]
            writer.summary["damping_ratios"] = [float(m.damping_ratio) for m in found]
            writer.summary["mode_directions"] = directions
            writer.summary["about"] = scene.solve.about
            writer.summary["linearisation_s"] = None if lin is None else lin.seconds
            if lin is not None and scene.solve.mode_shapes:  # the shapes, animated
                try:
                    writer.summary["mode_shapes"] = linearise.write_mode_shapes(lin, found, out_dir)
                except ImportError as exc:  # h5py (latdyn's ParaView output) not installed
                    writer.summary["mode_shapes"] = f"not written: {exc}"
            if scene.solve.linear_model is not None and lin is not None:
                linearise.write_linear_model(prepared, out_dir, writer.summary, lin)
        elif analysis == "buckling":
            writer.summary.update(linearise.buckling_analysis(prepared, scene.solve.count))
        elif analysis == "static":
            static_analysis(prepared, probes, writer, _length_scale(model))
        else:
            transient(prepared, probes, writer, progress, checkpointer, resume_from)
        writer.summary["wall_time_s"] = time.perf_counter() - wall0
        writer.summary["compile_s"] = _compile_seconds() - compiled0
        writer.close(dict(writer.summary), status="solved")
    if checkpointer is not None:
        checkpointer.discard()  # finished: nothing to resume
    result = writer.result()
    if analysis == "modes":
        result.modes = np.asarray(writer.summary.get("modes_hz", []))
    return result


class _sigterm_interrupts:
    """SIGTERM raises KeyboardInterrupt inside the block (main thread only), so that a
    terminated run checkpoints and ends as interrupted, like Ctrl-C."""

    def __init__(self, enabled: bool):
        self.enabled = enabled and threading.current_thread() is threading.main_thread()
        self.previous = None

    @staticmethod
    def _handler(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    def __enter__(self):
        if self.enabled:
            self.previous = signal.signal(signal.SIGTERM, self._handler)
        return self

    def __exit__(self, *exc):
        if self.enabled:
            signal.signal(signal.SIGTERM, self.previous)
        return False


def _drive_power(model: Model, state: State, reaction: np.ndarray) -> float:
    """Power of the constraint forces that impose prescribed motion."""
    velocities = pack(model, state.v, state.w, state.theta_dot)[model.n_dofs:model.n_total]
    return float(reaction @ velocities)


def _lock_tolerance(lock: float) -> float:
    return 1e-7 * max(1.0, abs(lock))


def _lock_events(model: Model, old: State, new: State) -> tuple[list[int], list[tuple[int, float]]]:
    """Free hinges with a lock_at, over the step old → new: those that reach it (started on
    it, or ended within tolerance), and those that cross it with the fraction of the step
    at the crossing (linear interpolation of the angle)."""
    reached, crossing = [], []
    for k in model.free_hinges:
        lock = model.hinges[k].lock_at
        if lock is None:
            continue
        before, after = old.theta[k] - lock, new.theta[k] - lock
        if before == 0.0 or abs(after) <= _lock_tolerance(lock):
            reached.append(k)
        elif before * after < 0.0:
            crossing.append((k, before / (before - after)))
    return reached, crossing


def _crossing_fraction(model: Model, old: State, new: State) -> float | None:
    """The fraction of the step at which the first hinge crosses its lock_at or a stop, or None."""
    _, crossing = _lock_events(model, old, new)
    fractions = [f for _, f in crossing] + [f for _, _, f in _stop_crossings(model, old, new)]
    return min(fractions) if fractions else None


# ----------------------------------------------------------------------------- hard stops
# Hinge ``limits: [lo, hi]`` with ``restitution`` e are events, like lock_at: a step in which
# a hinge crosses a stop from inside is shortened to land on it (secant on the angle, as for
# latches); then, for every free hinge on or beyond a stop and moving into it, the
# configuration is projected onto the stop, Δq = −A⁻¹N μ with Nᵀ(q + Δq) = stop, and the
# velocities jump so that the hinge rate reverses, θ̇⁺ = −e θ̇⁻ (Newton's impact law), by the
# impulsive projection that conserves momentum, v⁺ = v⁻ − A⁻¹N λ, Nᵀv⁺ = −e Nᵀv⁻, A = M + dt²K (M alone may be singular; directions
# without inertia and modes faster than the nominal step dt take the impact quasi-statically,
# as in the integrator's own iteration matrix); the hinge's acceleration is set to zero. A hinge pushed against its stop (e = 0, or a load that holds it there) ends
# each step slightly beyond it and is put back with θ̇ = 0: a unilateral constraint enforced
# by projection at the end of every step, released by itself as soon as the load pulls away.
# Events rather than a penalty: exact landing on the stop and no contact stiffness that the
# step would have to resolve; rather than a complementarity solve inside Newton: the time
# step (shared with the compiled step of solve.py) stays as it is.
def _stop_crossings(model: Model, old: State, new: State) -> list[tuple[int, int, float]]:
    """(hinge, side, fraction of the step) for free hinges that crossed a stop from inside during the
    step (side −1 lower, +1 upper), the angle interpolated linearly."""
    out = []
    for k in model.free_hinges:
        limits = model.hinges[k].limits
        if limits is None:
            continue
        for side, stop in ((-1, limits[0]), (1, limits[1])):
            before, after = side * (old.theta[k] - stop), side * (new.theta[k] - stop)  # > 0: beyond
            if before < -_lock_tolerance(stop) and after > _lock_tolerance(stop):
                out.append((int(k), side, before / (before - after)))
    return out


def _hinge_stops(prepared: Prepared, integrator, new: State) -> bool:
    """Impacts on hinge stops at the end of an accepted step (see above); True when any."""
    import scipy.sparse as sps
    from scipy.sparse.linalg import splu

    model, assembler = prepared.model, prepared.assembler
    hits, stops = [], []
    for k in model.free_hinges:
        limits = model.hinges[k].limits
        if limits is None:
            continue
        for side, stop in ((-1, limits[0]), (1, limits[1])):
            if side * (new.theta[k] - stop) >= -_lock_tolerance(stop) and side * new.theta_dot[k] >= 0.0:
                hits.append(int(k))
                stops.append(stop)
    if not hits:
        return False
    dt = prepared.scene.solve.dt
    target = -np.array([model.hinges[k].restitution for k in hits]) * new.theta_dot[hits]
    A = assembler.evaluate(new, matrices=True).combined(1.0, 0.0, dt * dt)
    N = np.zeros((model.n_dofs, len(hits)))
    N[model.hinge_dofs[hits], np.arange(len(hits))] = 1.0
    AiN = np.linalg.solve(A, N) if isinstance(A, np.ndarray) else splu(sps.csc_matrix(A)).solve(N)
    NtAiN = N.T @ AiN
    # the same projection onto the stops for the configuration: what is rigid at the scale of
    # the step moves with the hinge, so that no strain is made
    moved = advance(model, new, -AiN @ np.linalg.solve(NtAiN, new.theta[hits] - np.array(stops)))
    new.x, new.T, new.theta = moved.x, moved.T, moved.theta
    new.theta[hits] = stops
    v = free_velocity(model, new)
    unpack_free(model, v - AiN @ np.linalg.solve(NtAiN, N.T @ v - target), new.v, new.w, new.theta_dot)
    # the hinge's acceleration into the stop ends with the impact
    if getattr(integrator, "a", None) is not None:  # the explicit step keeps no algorithmic acceleration
        integrator.a[model.hinge_dofs[hits]] = 0.0
    new.theta_ddot[hits] = 0.0
    return True


def _latch_hinges(prepared: Prepared, integrator, old: State, new: State, h: float) -> bool:
    """Latch every free hinge whose angle crossed its lock_at during the step.

    The latch is a perfectly plastic impulsive constraint θ̇ = 0: the free
    velocities jump by the projection that conserves momentum,
    v⁺ = v⁻ − A⁻¹n (nᵀA⁻¹n)⁻¹ nᵀv⁻, with A = M + h²K (M alone may be singular).
    """
    model, assembler = prepared.model, prepared.assembler
    reached, crossing = _lock_events(model, old, new)
    latched = reached + [k for k, _ in crossing]
    if not latched:
        return False

    ev = assembler.evaluate(new, matrices=True)
    A = ev.combined(1.0, 0.0, h * h, dense=True)
    v = free_velocity(model, new)
    Nmat = np.zeros((model.n_dofs, len(latched)))
    for j, k in enumerate(latched):
        Nmat[model.hinge_dofs[k], j] = 1.0
    AiN = np.linalg.solve(A, Nmat)
    lam = np.linalg.solve(Nmat.T @ AiN, Nmat.T @ v)
    v = v - AiN @ lam
    unpack_free(model, v, new.v, new.w, new.theta_dot)
    # carry the algorithmic acceleration across the renumbering
    a_lin, a_ang, a_h = np.zeros_like(new.v), np.zeros_like(new.w), np.zeros_like(new.theta)
    unpack_free(model, integrator.a, a_lin, a_ang, a_h)
    for k in latched:
        model.locked[k] = True
        new.theta_dot[k] = new.theta_ddot[k] = 0.0
        a_h[k] = 0.0
    model.number_coordinates()
    assembler.reindex()
    integrator.a = pack(model, a_lin, a_ang, a_h)[: model.n_dofs]
    return True


@dataclass
class TransientProgress:
    """Everything the time loop carries from one step to the next, besides the model.

    Explicit and picklable, so that a run can be checkpointed and resumed: the
    state of the nodes and hinges, the integrator's algorithmic acceleration, the
    step size, the latched hinges, the work and energy bookkeeping, and counters.
    Times are computed from the grid index, never accumulated: the nominal step
    k lands exactly on t_k = k·dt (the last one on t_end).
    """

    state: State
    algorithmic_acceleration: np.ndarray | None
    locked: np.ndarray  # latched hinges
    h: float  # step size to try next
    grid_index: int = 0  # nominal steps completed
    output_index: int = 1  # next recorded time is output_index · every
    external_work: float = 0.0
    power: float = 0.0  # power of loads and prescribed motion at state.t
    total0: float = 0.0  # kinetic + strain + potential at t = 0
    potential0: float = 0.0
    balance_error: float = 0.0  # max |Δ(total − external_work)|
    energy_scale: float = 0.0  # max of kinetic, strain, |potential change|, |external work|
    steps: int = 0
    newton_iterations: int = 0
    rejected_steps: int = 0  # all rejected attempts: Newton failures and error-control rejections
    newton_cuts: int = 0  # steps halved because Newton did not converge
    factorizations: int = 0  # iteration matrices factorized (modified Newton keeps one over steps)
    solver_s: float = 0.0  # wall time inside the integrator's steps
    cut_times: list = field(default_factory=list)  # the first times at which a step was cut
    inertia_tangent_from: float | None = None  # t from which Newton's matrix holds the inertia tangent


#: Cut steps reported on stderr one by one up to this many, then only counted.
CUTS_REPORTED = 10


def _report_cut(progress: TransientProgress, t: float, h: float, iterations: int) -> None:
    progress.newton_cuts += 1
    if len(progress.cut_times) < 100:
        progress.cut_times.append(float(t))
    if progress.newton_cuts <= CUTS_REPORTED:
        tail = "" if progress.newton_cuts < CUTS_REPORTED else " (further cuts are only counted in summary.json)"
        print(f"latdyn: Newton did not converge in {iterations} iterations at t = {t:.9g} with step {h:.3g}; "
              f"step cut to {h / 2:.3g}{tail}", file=sys.stderr)


def _grid_time(k: int, dt: float, t_end: float, n_grid: int) -> float:
    """t_k = k·dt, computed (the last grid point is t_end exactly)."""
    return t_end if k >= n_grid else k * dt


def _implicit_integrator(prepared: Prepared, params: AlphaParameters, tol: float, length: float,
                         summary: dict) -> GeneralizedAlpha:
    """The generalized-α step in C (latdyn/engine.py) where it covers the model, else in Python.

    ``solve.engine``: ``auto`` (C when it can), ``compiled`` (C, or exit 2 saying why not),
    ``python`` (the reference step, full Newton). ``solve.newton`` (C only): ``modified``
    keeps the factorized matrix while Newton contracts, ``full`` rebuilds it every iteration."""
    from . import engine

    solve, assembler = prepared.scene.solve, prepared.assembler
    reason = "solve.engine is python" if solve.engine == "python" else engine.unsupported(assembler)
    if reason is not None and solve.engine == "compiled":
        raise SceneError(prepared.scene.file, "solve.engine", f"the compiled step cannot run this scene: {reason}")
    if reason is None:
        integrator = engine.CompiledGeneralizedAlpha(assembler, params, tol, solve.max_iterations, length,
                                                     newton=solve.newton)
        summary.update(engine="compiled", newton=solve.newton)
    else:
        integrator = GeneralizedAlpha(assembler, params, tol, solve.max_iterations, length)
        summary.update(engine="python", newton="exact" if solve.newton == "exact" else "full", engine_reason=reason)
    integrator.inertia_tangent = solve.newton == "exact"
    return integrator


#: Whether the compiled step runs its loop of steps in C between rows (engine.advance); False
#: takes every step from Python, one call into C each (the reference the loop must equal:
#: tests/test_compiled_loop.py).
COMPILED_LOOP = True
#: Wall time after which the loop of steps in C returns to Python even before the next row.
LOOP_BUDGET_S = 0.25


def transient(prepared: Prepared, probes: ProbeSet, writer: ResultWriter, progress: bool,
              checkpointer: checkpoints.Checkpointer | None = None,
              resume_from: checkpoints.Checkpoint | None = None) -> TransientProgress:
    """The time loop. With a ``checkpointer``, a checkpoint of the last accepted step is
    written at its interval, on an interrupt and on a failure; ``resume_from`` (a loaded
    checkpoint) continues from one, the writer having been reopened at its bookmark."""
    scene, model, assembler = prepared.scene, prepared.model, prepared.assembler
    solve = scene.solve
    length = _length_scale(model)
    tol = solve.tol if solve.tol is not None else DEFAULT_TOL
    if solve.method == "explicit":
        integrator = CentralDifference(assembler, tol, solve.max_iterations, length)
    else:
        integrator = _implicit_integrator(prepared, AlphaParameters.for_method(solve.method, solve.rho_inf), tol,
                                          length, writer.summary)
    energies_of = getattr(integrator, "energies", assembler.energies)  # the compiled step has its own
    t_end, dt = float(solve.t_end), float(solve.dt)
    n_grid = max(1, int(np.ceil(t_end / dt - 1e-9)))
    dt_min = solve.dt_min if solve.dt_min is not None else dt * 1e-6
    every = scene.output.every

    if resume_from is None:
        state = prepared.state
        integrator.start(state)
        ev0 = assembler.evaluate(state, matrices=False)
        energy0 = energies_of(state)
        run = TransientProgress(state=state, algorithmic_acceleration=integrator.a, locked=model.locked.copy(),
                                h=dt, power=ev0.external_power + _drive_power(model, state, ev0.reaction),
                                total0=sum(energy0.values()), potential0=energy0["potential"],
                                inertia_tangent_from=0.0 if getattr(integrator, "inertia_tangent", False) else None)
    else:  # resumed: the latched hinges renumber the coordinates, then the loop goes on as it was
        run = resume_from.progress
        model.locked[:] = run.locked
        model.number_coordinates()
        assembler.reindex()
        integrator.a = run.algorithmic_acceleration
        integrator.inertia_tangent = run.inertia_tangent_from is not None
        probes.external_work = resume_from.external_work
        if hasattr(integrator, "restore_factorization"):  # modified Newton's held matrix, as it was
            try:
                integrator.restore_factorization(resume_from.factorization)
            except ValueError as exc:
                raise checkpoints.CheckpointError(f"{exc}; the checkpoint does not belong to this model") from exc

    # the last accepted step, as a checkpoint keeps it: a shallow copy of `run` (the loop
    # replaces states and arrays, never changes them in place, once a step is accepted),
    # the writer's bookmark and, while its ParaView frame is not on disk, the last recorded state
    bookmark = writer.bookmark()
    last_recorded = None if resume_from is None else resume_from.last_recorded
    if last_recorded is not None:
        writer.reattach_last_frame(lambda snapshot=last_recorded: paraview.frame(assembler, writer.mesh, snapshot))

    # modified Newton's held factorization (engine.CompiledGeneralizedAlpha): a checkpoint of the
    # last accepted step carries it when the engine still holds that step's (its mark unchanged)
    factorization_mark = getattr(integrator, "factorization_mark", None)

    def accepted(kept_factorization: bool = True) -> tuple:
        """The last accepted step as a checkpoint keeps it, and the mark of the factorization the
        engine holds for it (None: not that step's, a checkpoint then carries none)."""
        kept = copy.copy(run)  # dataclasses.replace without its per-field checks (once a row)
        kept.cut_times = list(run.cut_times)
        mark = factorization_mark() if factorization_mark is not None and kept_factorization else None
        return (kept, run.external_work, bookmark,
                last_recorded if (bookmark["paraview"] or {}).get("unwritten") is not None else None, mark)

    def save_checkpoint(kept: tuple) -> None:
        """Write the checkpoint of ``kept`` (accepted()), with the held factorization while the
        engine has not moved on from that step (else without: the resumed run rebuilds it)."""
        *fields, mark = kept
        factorization = None
        if mark is not None and mark == factorization_mark():
            factorization = integrator.factorization_state()
        checkpointer.save(*fields, writer, factorization)

    def record(s: State, energies: dict) -> None:
        nonlocal bookmark, last_recorded
        # SCENE.md: max |Δ(total − external_work)| over the largest of kinetic, strain,
        # |potential change| and |external work| seen
        run.balance_error = max(run.balance_error,
                                abs(sum(energies.values()) - run.total0 - probes.external_work))
        run.energy_scale = max(run.energy_scale, energies["kinetic"], energies["strain"],
                               abs(energies["potential"] - run.potential0), abs(probes.external_work))
        snapshot = s.copy()
        writer.record(s.t, probes.values(s, energies), state=s.as_dict(),
                      frame=lambda: paraview.frame(assembler, writer.mesh, snapshot))
        bookmark, last_recorded = writer.bookmark(), snapshot

    def summarize() -> None:
        writer.summary.update(
            steps=run.steps, newton_iterations=run.newton_iterations, rejected_steps=run.rejected_steps,
            newton_cuts=run.newton_cuts, cut_times=run.cut_times,
            energy_balance_error=run.balance_error / run.energy_scale if run.energy_scale > 0 else 0.0,
            newton_iterations_per_step=run.newton_iterations / max(run.steps, 1),
            newton_tolerance=tol, method=solve.method, solver_s=run.solver_s, factorizations=run.factorizations,
            inertia_tangent_from=run.inertia_tangent_from)

    def after_accepted(state: State) -> None:
        """After the accepted step(s) that ended at ``state``: rotations back on SO(3) every 256
        steps, the row if one is due, the summary and the progress bar."""
        if run.steps % 256 == 0:  # exp updates keep T on SO(3) to round-off; remove the drift of long runs
            state.T[model.free_nodes] = orthonormalize(state.T[model.free_nodes])
        finished = run.grid_index >= n_grid
        due = every is None or state.t >= run.output_index * every - 1e-9 * dt
        if due or finished:  # every output time, and t_end always
            record(state, energies_of(state))
            if every:
                run.output_index = int(np.floor(state.t / every + 1e-9 * dt / every)) + 1
        summarize()
        bar.update(state.t)

    def keep_accepted(kept_factorization: bool = True) -> tuple:
        """The last accepted step as a checkpoint keeps it, written when one is due."""
        kept = accepted(kept_factorization)
        if checkpointer is not None and checkpointer.due():
            save_checkpoint(kept)
        return kept

    def next_row() -> int:
        """The grid point of the next recorded row (solve.output.every; every step without), and
        at most the step that ends on a multiple of 256 steps (see after_accepted)."""
        k = run.grid_index + 1
        if every is not None:
            due_at = run.output_index * every - 1e-9 * dt
            k = max(k, min(n_grid, int(np.floor(due_at / dt))))
            while k > run.grid_index + 1 and _grid_time(k - 1, dt, t_end, n_grid) >= due_at:
                k -= 1
            while k < n_grid and _grid_time(k, dt, t_end, n_grid) < due_at:
                k += 1
        return min(k, n_grid, run.grid_index + 256 - run.steps % 256)

    # the loop of steps in C (engine.CompiledGeneralizedAlpha.advance): from a grid point at the
    # nominal step, the steps up to the next row are taken and accepted in one call; a step it
    # cannot accept as it comes (Newton fails, a hinge event) comes back to the loop below
    loop = (COMPILED_LOOP and hasattr(integrator, "advance") and not solve.adaptive
            and integrator.loop_reason is None)
    writer.summary["time_loop"] = "compiled" if loop else "python"

    if resume_from is None:
        record(state, energy0)
    last = accepted()
    bar = progress_bar(t_end, enabled=progress)
    try:
        while run.grid_index < n_grid:
            state = run.state
            pending = None
            if loop and run.h == dt and state.t == _grid_time(run.grid_index, dt, t_end, n_grid):
                # back in Python at least every LOOP_BUDGET_S (interrupts, progress) and when a checkpoint is due
                budget = LOOP_BUDGET_S if checkpointer is None else min(LOOP_BUDGET_S, checkpointer.remaining())
                started = time.perf_counter()
                done = integrator.advance(state, grid_index=run.grid_index,
                                          stop_index=next_row() if budget > 0 else run.grid_index + 1, dt=dt,
                                          t_end=t_end, n_grid=n_grid, power=run.power,
                                          external_work=run.external_work, budget_s=budget)
                run.solver_s += time.perf_counter() - started
                if done.steps:
                    run.steps += done.steps
                    run.grid_index += done.steps
                    run.newton_iterations += done.iterations
                    run.factorizations += done.factorizations
                    run.power = done.power
                    run.external_work = probes.external_work = done.external_work
                    run.state = state = done.state
                    run.algorithmic_acceleration = integrator.a
                    after_accepted(state)
                    last = keep_accepted(done.factorization_kept)
                if done.pending is None:
                    continue
                new, stats, h = done.pending
                lands = True
            else:
                target = _grid_time(run.grid_index + 1, dt, t_end, n_grid)
                h = run.h
                lands = h >= (target - state.t) * (1 - 1e-9)
                if lands:
                    h = target - state.t
                started = time.perf_counter()
                new, stats = integrator.step(state, h, t_new=target if lands else None)
                run.solver_s += time.perf_counter() - started
            run.newton_iterations += stats.iterations
            run.factorizations += stats.iterations if stats.factorizations is None else stats.factorizations
            if stats.converged and solve.adaptive:
                error = integrator.error_estimate(h) / (solve.error_tol * length)
                if error > 1.0:
                    run.rejected_steps += 1
                    run.h = max(h * max(0.2, 0.9 * error ** (-1 / 3)), dt_min)
                    continue
            if not stats.converged:
                run.rejected_steps += 1
                if not getattr(integrator, "inertia_tangent", True):
                    # the iteration matrix leaves out the inertia tangent, which is exact only where
                    # β′M dominates it (latdyn.integrators); take it from here on, same step
                    integrator.inertia_tangent = True
                    run.inertia_tangent_from = float(state.t)
                    print(f"latdyn: Newton did not converge in {stats.iterations} iterations at t = {state.t + h:.9g}; "
                          "its matrix now includes the inertia tangent (directions with little inertia)",
                          file=sys.stderr)
                    continue
                if h / 2 < dt_min:
                    raise SolverError("Newton failed below the minimum step",
                                      newton_diagnosis(model, stats.residual, state.t + h, h, assembler, state))
                _report_cut(run, state.t + h, h, stats.iterations)
                run.h = h / 2
                continue
            # a hinge reaching lock_at inside the step: shorten the step to land on it (secant, ≤ 4 passes)
            for _ in range(4):
                fraction = _crossing_fraction(model, state, new)
                if fraction is None:
                    break
                started = time.perf_counter()
                retry, retry_stats = integrator.step(state, h * max(fraction, 1e-6))
                run.solver_s += time.perf_counter() - started
                run.factorizations += (retry_stats.iterations if retry_stats.factorizations is None
                                       else retry_stats.factorizations)
                if not retry_stats.converged:
                    break
                run.newton_iterations += retry_stats.iterations
                new, stats, h, lands = retry, retry_stats, h * max(fraction, 1e-6), False
            integrator.accept()
            latched = _latch_hinges(prepared, integrator, state, new, h)
            stopped = _hinge_stops(prepared, integrator, new)
            latched = stopped or latched
            # power of loads and prescribed motion: from the last Newton evaluation
            # (within the Newton tolerance of the converged state) when there is one
            ev = getattr(integrator, "last_evaluation", None)
            if ev is None or len(ev.reaction) != model.n_total - model.n_dofs:
                ev = assembler.evaluate(new, matrices=False)
            new_power = ev.external_power + _drive_power(model, new, ev.reaction)
            probes.external_work += 0.5 * h * (run.power + new_power)
            run.power = new_power
            run.external_work = probes.external_work
            run.state = state = new
            run.algorithmic_acceleration = integrator.a
            run.locked = model.locked.copy()
            run.steps += 1
            if lands:
                run.grid_index += 1
            after_accepted(state)
            if solve.adaptive:
                # after a latch the last Newton evaluation has the old numbering (estimate taken as 0,
                # which is what error_estimate gives after accept() for a step without a latch)
                error = 0.0 if latched else integrator.error_estimate(h) / (solve.error_tol * length)
                run.h = min(dt, h * min(2.0, 0.9 * max(error, 1e-10) ** (-1 / 3)))
            elif stopped:
                run.h = dt  # after an impact on a stop the integrator restarted: the nominal step
            elif h < dt:
                run.h = min(dt, 2 * h)  # recover the nominal step after a cut or a shortened step
            last = keep_accepted()
    except (KeyboardInterrupt, Exception):
        # interrupted or failed: a checkpoint of the last accepted step, to resume from
        if checkpointer is not None and not writer.closed:
            try:
                save_checkpoint(last)
                writer.summary["checkpoint_t"] = last[0].state.t
            except Exception as exc:  # noqa: BLE001 - the original error matters more
                print(f"latdyn: could not write a checkpoint: {type(exc).__name__}: {exc}", file=sys.stderr)
        raise
    finally:
        bar.close()
        summarize()
    prepared.state = run.state
    return run
