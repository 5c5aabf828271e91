"""The transient time loop (SCENE.md ``solve.analysis: transient``): steps on the time grid,
cut steps, error control, events, the loop of steps in C between rows, energies, rows,
checkpoints."""
from __future__ import annotations

import copy
import sys
import time

import numpy as np

from latdyn.assembly.assembler import State, pack
from latdyn.assembly.prepare import Prepared, length_scale
from latdyn.errors import SceneError, SolverError
from latdyn.model.model import Model
from latdyn.numerics.so3 import orthonormalize
from latdyn.results import paraview
from latdyn.results.probes import ProbeSet
from latdyn.results.writer import ResultWriter, progress_bar
from latdyn.step.integrators import (
    AlphaParameters,
    CentralDifference,
    GeneralizedAlpha,
    newton_diagnosis,
)
from latdyn.timeloop import checkpoint as checkpoints
from latdyn.timeloop.events import crossing_fraction, hinge_stops, latch_hinges
from latdyn.timeloop.progress import TransientProgress, report_cut

#: Default Newton tolerance on :func:`latdyn.step.integrators.increment_size` (see docs/verification.md).
DEFAULT_TOL = 1e-8



def drive_power(model: Model, state: State, reaction: np.ndarray) -> float:
    """Power of the constraint forces that impose prescribed motion."""
    velocities = pack(model, state.v, state.w, state.theta_dot)[model.n_dofs:model.n_total]
    return float(reaction @ velocities)


def grid_time(k: int, dt: float, t_end: float, n_grid: int) -> float:
    """t_k = k·dt, computed (the last grid point is t_end exactly)."""
    return t_end if k >= n_grid else k * dt


def implicit_integrator(prepared: Prepared, params: AlphaParameters, tol: float, length: float,
                         summary: dict) -> GeneralizedAlpha:
    """The generalized-α step in C (latdyn/step/compiled.py) where it covers the model, else in Python.

    ``solve.engine``: ``auto`` (C when it can), ``compiled`` (C, or exit 2 saying why not),
    ``python`` (the reference step, full Newton). ``solve.newton`` (C only): ``modified``
    keeps the factorized matrix while Newton contracts, ``full`` rebuilds it every iteration."""
    from latdyn.step import compiled as engine

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
    length = length_scale(model)
    tol = solve.tol if solve.tol is not None else DEFAULT_TOL
    if solve.method == "explicit":
        integrator = CentralDifference(assembler, tol, solve.max_iterations, length)
    else:
        integrator = implicit_integrator(prepared, AlphaParameters.for_method(solve.method, solve.rho_inf), tol,
                                          length, writer.summary)
    energies_of = assembler.energies
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
                                h=dt, power=ev0.external_power + drive_power(model, state, ev0.reaction),
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

    # modified Newton's held factorization (step.compiled.CompiledGeneralizedAlpha): a checkpoint of the
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
            while k > run.grid_index + 1 and grid_time(k - 1, dt, t_end, n_grid) >= due_at:
                k -= 1
            while k < n_grid and grid_time(k, dt, t_end, n_grid) < due_at:
                k += 1
        return min(k, n_grid, run.grid_index + 256 - run.steps % 256)

    # the loop of steps in C (step.compiled.CompiledGeneralizedAlpha.advance): from a grid point at the
    # nominal step, the steps up to the next row are taken and accepted in one call; a step it
    # cannot accept as it comes (Newton fails, a hinge event) comes back to the loop below
    loop = COMPILED_LOOP and hasattr(integrator, "advance") and not solve.adaptive
    writer.summary["time_loop"] = "compiled" if loop else "python"

    if resume_from is None:
        record(state, energy0)
    last = accepted()
    bar = progress_bar(t_end, enabled=progress)
    try:
        while run.grid_index < n_grid:
            state = run.state
            if loop and run.h == dt and state.t == grid_time(run.grid_index, dt, t_end, n_grid):
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
                target = grid_time(run.grid_index + 1, dt, t_end, n_grid)
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
                    # β′M dominates it (latdyn.step.integrators); take it from here on, same step
                    integrator.inertia_tangent = True
                    run.inertia_tangent_from = float(state.t)
                    print(f"latdyn: Newton did not converge in {stats.iterations} iterations at t = {state.t + h:.9g}; "
                          "its matrix now includes the inertia tangent (directions with little inertia)",
                          file=sys.stderr)
                    continue
                if h / 2 < dt_min:
                    raise SolverError("Newton failed below the minimum step",
                                      newton_diagnosis(model, stats.residual, state.t + h, h, assembler, state))
                report_cut(run, state.t + h, h, stats.iterations)
                run.h = h / 2
                continue
            # a hinge reaching lock_at inside the step: shorten the step to land on it (secant, ≤ 4 passes)
            for _ in range(4):
                fraction = crossing_fraction(model, state, new)
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
            latched = latch_hinges(prepared, integrator, state, new, h)
            stopped = hinge_stops(prepared, integrator, new)
            latched = stopped or latched
            # power of loads and prescribed motion: from the last Newton evaluation
            # (within the Newton tolerance of the converged state) when there is one
            ev = getattr(integrator, "last_evaluation", None)
            if ev is None or len(ev.reaction) != model.n_total - model.n_dofs:
                ev = assembler.evaluate(new, matrices=False)
            new_power = ev.external_power + drive_power(model, new, ev.reaction)
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
    except (KeyboardInterrupt, Exception) as failure:
        # interrupted or failed: a checkpoint of the last accepted step, to resume from
        if checkpointer is not None and not writer.closed:
            try:
                save_checkpoint(last)
                writer.summary["checkpoint_t"] = last[0].state.t
            except Exception as exc:  # noqa: BLE001 - the original error matters more
                print(f"latdyn: could not write a checkpoint: {type(exc).__name__}: {exc}", file=sys.stderr)
        # failed: the last converged state is always a row (after the checkpoint, whose bookmark a
        # resumed run returns to, so that the resumed files equal an uninterrupted run's)
        if isinstance(failure, SolverError) and not writer.closed and run.state is not None \
                and (last_recorded is None or last_recorded.t != run.state.t):
            record(run.state, energies_of(run.state))
        raise
    finally:
        bar.close()
        summarize()
    prepared.state = run.state
    return run
