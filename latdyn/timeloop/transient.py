"""The transient analysis (SCENE.md ``solve.analysis: transient``): the integrator the scene asks
for, and the time loop that drives it (:mod:`latdyn.timeloop.loop`; its step sizes:
:mod:`~latdyn.timeloop.control`, its events: :mod:`~latdyn.timeloop.events`, what it carries from
step to step: :mod:`~latdyn.timeloop.progress`, its checkpoints: :mod:`~latdyn.timeloop.checkpoint`)."""
from __future__ import annotations


from latdyn.assembly.control import refuse_states_without_step
from latdyn.assembly.prepare import Prepared, length_scale
from latdyn.errors import SceneError
from latdyn.results.probes import ProbeSet
from latdyn.results.writer import ResultWriter
from latdyn.step.integrators import AlphaParameters, CentralDifference, newmark_warning
from latdyn.timeloop import checkpoint as checkpoints
from latdyn.timeloop.control import StepControl
from latdyn.timeloop.jumps import acceleration_only_jumps, jump_times, prescribed_position_jump, searched_jumps
from latdyn.timeloop.loop import TimeLoop
from latdyn.timeloop.progress import TransientProgress
from latdyn.timeloop.sampling import SampledControllers

#: Default Newton tolerance on :func:`latdyn.step.integrators.increment_size` (see docs/verification.md).
DEFAULT_TOL = 1e-8


def implicit_integrator(prepared: Prepared, params: AlphaParameters, tol: float, length: float,
                        summary: dict):
    """The generalized-α step, its Newton iteration in C (latdyn/step/compiled.py).

    ``solve.newton``: ``modified`` keeps the factorized matrix while Newton contracts, ``full``
    rebuilds it every iteration, ``exact`` adds the elements' inertia tangent from the start."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha  # the native library, loaded when a run steps

    solve = prepared.scene.solve
    integrator = CompiledGeneralizedAlpha(prepared.assembler, params, tol, solve.max_iterations, length,
                                          newton=solve.newton)
    summary.update(engine="compiled", newton=solve.newton)
    integrator.inertia_tangent = solve.newton == "exact"
    return integrator


#: Whether the compiled step runs its loop of steps in C between rows (engine.advance); False
#: takes every step from Python, one call into C each (the reference the loop must equal:
#: tests/test_compiled_loop.py).
COMPILED_LOOP = True


#: Wall time after which the loop of steps in C returns to Python even before the next row.
LOOP_BUDGET_S = 0.25


def integrator_for(prepared: Prepared, tol: float, length: float, summary: dict):
    """The step of ``solve.method``: the central difference (explicit), else generalized-α (implicit_integrator)."""
    solve = prepared.scene.solve
    refuse_states_without_step(prepared.scene, solve.method)
    if solve.method == "explicit":
        return CentralDifference(prepared.assembler, tol, solve.max_iterations, length)
    return implicit_integrator(prepared, AlphaParameters.for_method(solve.method, solve.rho_inf), tol, length,
                               summary)


def transient(prepared: Prepared, probes: ProbeSet, writer: ResultWriter, progress: bool,
              checkpointer: checkpoints.Checkpointer | None = None,
              resume_from: checkpoints.Checkpoint | None = None, sensitivities=None) -> TransientProgress:
    """Run the time loop to ``solve.t_end``; the progress at the end. With a ``checkpointer``, a
    checkpoint of the last accepted step is written at its interval, on an interrupt and on a
    failure; ``resume_from`` (a loaded checkpoint) continues from one, the writer having been
    reopened at its bookmark. ``progress``: show a progress bar. ``sensitivities``: solve.sensitivities
    (latdyn.analyses.transient_sensitivities.TransientSensitivities), None without."""
    return start_transient(prepared, probes, writer, checkpointer, resume_from, sensitivities).run(progress)


def start_transient(prepared: Prepared, probes: ProbeSet, writer: ResultWriter,
                    checkpointer: checkpoints.Checkpointer | None = None,
                    resume_from: checkpoints.Checkpoint | None = None, sensitivities=None) -> TimeLoop:
    """The time loop of the scene's transient run, begun (its first row recorded, or reopened at
    the checkpoint ``resume_from``): :meth:`TimeLoop.run` steps it to ``solve.t_end``,
    :meth:`TimeLoop.advance_to` to a time where it pauses (latdyn.stepping)."""
    scene = prepared.scene
    if scene.solve.sensitivities and sensitivities is None:   # latdyn.solve hands them in; nothing else does yet
        raise SceneError(scene.file, "solve.sensitivities",
                         "sensitivities are computed by latdyn.run and latdyn run only, not for a run stepped from "
                         "Python (latdyn.Simulation) yet; expected no solve.sensitivities here")
    length = length_scale(prepared.model)
    tol = scene.solve.tol if scene.solve.tol is not None else DEFAULT_TOL
    integrator = integrator_for(prepared, tol, length, writer.summary)
    sampler = SampledControllers(scene, probes)
    t_end = float(scene.solve.t_end)
    found = searched_jumps(scene, t_end)   # searched once: the refusal below, the steps' landings, the restarts
    jumped = prescribed_position_jump(scene, t_end, found)
    if jumped is not None:
        raise SceneError(scene.file, jumped[0],
                         f"the prescribed position jumps at t = {jumped[1]:.9g}: a joint or body would move a finite "
                         "distance in no time (an infinite rate); expected a law continuous in t (a steep ramp "
                         "where a fast move is meant; a jump of the rate, a kink, is allowed)")
    control = StepControl(scene.solve, scene.output.every, length,
                          instants=sampler.instants(t_end) if sampler else None, jumps=jump_times(scene, t_end, found))
    loop = TimeLoop(prepared, integrator, probes, writer, control, tol=tol, checkpointer=checkpointer,
                    compiled_loop=COMPILED_LOOP, loop_budget_s=LOOP_BUDGET_S, sampler=sampler,
                    sensitivities=sensitivities, drive_jumps=acceleration_only_jumps(scene, t_end, found))
    loop.begin(resume_from)
    for warning in prepared.assembler.initial_warnings:  # loops the initial velocity does not close (a resumed
        writer.warn(warning)  # run's summary says so as the whole run's does)
    undamped = scene.solve.method == "newmark" or (scene.solve.method in ("generalized-alpha", "hht-alpha")
                                                   and scene.solve.rho_inf >= 1.0)
    if undamped:   # no numerical damping of the directions without inertia (newmark_warning)
        state = loop.progress.state
        warning = newmark_warning(prepared.model, prepared.assembler.evaluate(state, matrices=True).mass,
                                  scene.solve.method if scene.solve.method == "newmark"
                                  else f"{scene.solve.method} with rho_inf 1")
        if warning is not None:
            writer.warn(warning)
    return loop
