"""``run(scene)``: model → analysis → result files (SCENE.md, "Commands and results")."""
from __future__ import annotations

import signal
import sys
import threading
import time

import numpy as np

from latdyn.assembly.prepare import length_scale, prepare
from latdyn.errors import ResultsError, SceneError
from latdyn.numerics.linalg import blas_on_one_thread
from latdyn.results import paraview as paraview
from latdyn.results.probe_labels import probe_labels
from latdyn.results.probes import ProbeSet
from latdyn.results.state_history import state_labels
from latdyn.results.writer import RUN_CHECKPOINT_MIN_SECONDS, ResultWriter
from latdyn.scene.loader import Scene, load_scene
from latdyn.timeloop import checkpoint as checkpoints
from latdyn.timeloop.transient import transient
from latdyn.version import __version__


def _compile_seconds() -> float:
    """Seconds this process has spent compiling C kernels and the step library (summary ``compile_s``)."""
    from latdyn.native import COMPILE_SECONDS

    return COMPILE_SECONDS["total"]


def _paraview_every(scene: Scene) -> float | None:
    """The time between ParaView frames (``output.paraview_every``; by default
    :func:`latdyn.results.paraview.default_every`); for static runs in load factor, a frame per load
    step thinned the same way; None for modal runs (no frames)."""
    solve, output = scene.solve, scene.output
    if solve.analysis in ("modes", "buckling"):
        return None
    if solve.analysis == "static":
        if output.paraview_every == 0:
            return 0.0
        if solve.method == "arc-length":  # λ goes up and down along the path: a frame per path point
            return None
        return paraview.default_every(1.0, 1.0 / solve.steps)
    if output.paraview_every is not None:
        return output.paraview_every
    return paraview.default_every(solve.t_end, output.every or solve.dt)


def run(scene, out_dir=None, backend: str = "auto", progress: bool = False, *, resume: bool = False,
        checkpoint_every: float | None = None):
    """Solve a scene and write its results; returns a :class:`latdyn.results.result.Result`.

    A transient run with an ``out_dir`` writes a checkpoint there (:mod:`latdyn.timeloop.checkpoint`)
    every ``checkpoint_every`` seconds of wall time (default 60; 0: every step), on
    Ctrl-C or SIGTERM and when the solver fails; ``resume=True`` continues from it
    (:class:`latdyn.timeloop.checkpoint.CheckpointError` when there is none or it belongs to
    another scene or package version).
    """
    wall0 = time.perf_counter()
    compiled0 = _compile_seconds()
    if checkpoint_every is not None and not checkpoint_every >= 0:
        raise ValueError(f"checkpoint_every must be a number of seconds >= 0, not {checkpoint_every!r}")
    with blas_on_one_thread():   # the same bits as ``latdyn run``, whatever the machine's cores
        return _run(scene, out_dir, backend, progress, resume, checkpoint_every, wall0, compiled0)


def _run(scene, out_dir, backend: str, progress: bool, resume: bool, checkpoint_every, wall0: float,
         compiled0: float):
    """:func:`run`'s body."""
    scene = load_scene(scene)
    if scene.solve.sensitivities:   # refused before anything is compiled or written
        from latdyn.analyses.sensitivities import refusal

        refused = refusal(scene)
        if refused is not None:
            raise refused
    analysis = scene.solve.analysis
    resume_from = _checkpoint_to_resume(scene, out_dir) if resume else None
    prepared, probes, writer = open_run(scene, out_dir, backend, resume_from)
    scene = prepared.scene
    kernel_backend = prepared.assembler.kernels.backend
    checkpointer = None
    if analysis == "transient" and out_dir is not None:
        checkpointer = checkpoints.Checkpointer(
            out_dir, checkpoints.DEFAULT_INTERVAL if checkpoint_every is None else checkpoint_every,
            checkpoints.identity(scene, kernel_backend), resumes=0 if resume_from is None else resume_from.resumes + 1)
    if resume_from is not None:
        writer.summary.update(resumed_from_t=resume_from.t, resumes=resume_from.resumes + 1)
    with writer, _sigterm_interrupts(enabled=checkpointer is not None):
        _analyse(prepared, probes, writer, out_dir, analysis, progress, checkpointer, resume_from)
        try:
            close_run(writer, wall0, compiled0)
        except KeyboardInterrupt:   # every step taken: the last one's checkpoint, from which --resume finishes the files
            _keep_the_last_step(checkpointer, writer)
            raise
    if checkpointer is not None:
        checkpointer.discard()  # finished: nothing to resume
    result = writer.result()
    if analysis == "modes":
        result.modes = np.asarray(writer.summary.get("modes_hz", []))
    return result


def _keep_the_last_step(checkpointer: checkpoints.Checkpointer | None, writer: ResultWriter) -> None:
    """A run interrupted (Ctrl-C, SIGTERM) after its last step, while its files are finished: the checkpoint of
    that step (:attr:`latdyn.timeloop.checkpoint.Checkpointer.last_step`), so that ``--resume`` finishes the files
    as the uninterrupted run writes them, and summary.json's ``checkpoint_t`` says where it stands."""
    if checkpointer is None or checkpointer.last_step is None or writer.closed:
        return
    try:
        writer.summary["checkpoint_t"] = checkpointer.last_step()
    except Exception as exc:  # noqa: BLE001 - the interrupt matters more
        print(f"latdyn: could not write a checkpoint: {type(exc).__name__}: {exc}", file=sys.stderr)


def open_run(scene: Scene, out_dir, backend: str = "auto",
             resume_from: checkpoints.Checkpoint | None = None) -> tuple:
    """The loaded ``scene`` prepared, its probes and its result writer (open, ``summary.json``
    saying ``running``): ``(prepared, probes, writer)``, for :func:`run` and
    :class:`latdyn.stepping.simulation.Simulation`. A fresh run into ``out_dir`` removes the
    checkpoint of an earlier one; ``resume_from`` (a loaded checkpoint) must belong to this model."""
    prepared = prepare(scene, backend)
    scene = prepared.scene
    _check_linear_model(prepared)
    if resume_from is not None:
        checkpoints.check(resume_from, out_dir, {"backend": prepared.assembler.kernels.backend})
    elif out_dir is not None:
        checkpoints.discard(out_dir)  # a fresh run: a checkpoint of an earlier one is stale
    probes = ProbeSet(prepared.assembler, prepared.state)
    writer = _result_writer(prepared, probes, out_dir, scene.solve.analysis, resume_from)
    summary = {"latdyn_version": __version__, "scene_hash": scene.source_hash, "steps": 0,
               "newton_iterations": 0, "rejected_steps": 0, "energy_balance_error": None}
    writer.summary.update(summary)
    return prepared, probes, writer


def close_run(writer: ResultWriter, wall0: float, compiled0: float, status: str = "solved",
              error: str | None = None) -> None:
    """Finish the result files of a run begun at ``wall0`` (``time.perf_counter``) after
    ``compiled0`` seconds of compiling (:func:`_compile_seconds`): ``wall_time_s``, ``compile_s``
    and ``status`` (with ``error`` when given) into ``summary.json``."""
    writer.summary["wall_time_s"] = time.perf_counter() - wall0
    writer.summary["compile_s"] = _compile_seconds() - compiled0
    if error is not None:
        writer.summary["error"] = error
    writer.close(dict(writer.summary), status=status)


def write_linear_model_first(prepared, writer: ResultWriter, out_dir) -> None:
    """``solve.linear_model`` of a run that is not modal: about the chosen state, before the run."""
    if prepared.scene.solve.linear_model is not None and prepared.scene.solve.analysis != "modes":
        from latdyn.analyses import linearise  # on use: a transient run needs no analysis (docs/performance.md)

        linearise.write_linear_model(prepared, out_dir, writer.summary)


def _check_linear_model(prepared) -> None:
    """``solve.linear_model`` of a structure with no coordinates (every part fixed, prescribed or set
    by them) is refused before anything is written: it would have no states, and the file was once
    left out without a word (found by benchmarks/fuzz_runs.py)."""
    scene = prepared.scene
    if scene.solve.linear_model is not None and prepared.model.n_dofs == 0:
        raise SceneError(scene.file, "solve.linear_model",
                         "expected a structure that can move: every part of this one is fixed or prescribed "
                         "(it has no coordinates), so a linear model would have no states")


def _checkpoint_to_resume(scene: Scene, out_dir) -> checkpoints.Checkpoint:
    """The checkpoint in ``out_dir`` that a resumed run of ``scene`` goes on from
    (:class:`latdyn.timeloop.checkpoint.CheckpointError` when there is none to resume)."""
    analysis = scene.solve.analysis
    if out_dir is None:
        raise checkpoints.CheckpointError("resuming needs the results folder of the run (out_dir)")
    if analysis != "transient":
        raise checkpoints.CheckpointError(f"{out_dir}: a {analysis} analysis is not checkpointed; "
                                          "there is nothing to resume")
    return checkpoints.load(out_dir, checkpoints.identity(scene))


def _result_writer(prepared, probes: ProbeSet, out_dir, analysis: str,
                   resume_from: checkpoints.Checkpoint | None) -> ResultWriter:
    """The result writer of the run (reopened at the checkpoint's bookmark when resuming)."""
    scene, model = prepared.scene, prepared.model
    first = "load_factor" if analysis == "static" else "t"
    # summary.json: what the run is; probe_labels {probe: "name: what it measures (unit)"}
    # (latdyn/results/probe_labels.py) names the probe plots' axes (latdyn plot, docs/usage.md)
    meta = {"analysis": analysis, "title": scene.title, "coordinates": model.n_dofs,
            "elements": len(model.element_nodes), "backend": prepared.assembler.kernels.backend,
            "formulation": scene.solve.formulation, "probe_labels": probe_labels(scene.output.probes)}
    try:
        return ResultWriter(out_dir, probes.names, first_column=first, mesh=paraview.parts(model, prepared.state),
                            meta=meta,
                            labels=state_labels([n.name for n in model.nodes],
                                                [f"{h.beam}.{h.end}" for h in model.hinges]),
                            attributes={"nodes": [n.name for n in model.nodes],
                                        "hinges": [f"{h.beam}.{h.end}" for h in model.hinges],
                                        "coordinates": model.dof_names()},
                            paraview_every=_paraview_every(scene), checkpoint_min_seconds=RUN_CHECKPOINT_MIN_SECONDS,
                            resume=None if resume_from is None else resume_from.writer)
    except ResultsError as exc:  # resuming: files that do not hold what the checkpoint recorded
        raise checkpoints.CheckpointError(f"{exc}") from exc


def _analyse(prepared, probes: ProbeSet, writer: ResultWriter, out_dir, analysis: str, progress: bool,
             checkpointer: checkpoints.Checkpointer | None, resume_from: checkpoints.Checkpoint | None) -> None:
    """The analysis of ``solve.analysis``, its results into ``writer``.

    ``summary.json`` ``solver_s``: the wall time of the solution itself — a transient run's inside
    the integrator's steps (:mod:`latdyn.timeloop`); a static, buckling or modal run's of its
    analysis (the path with its rows; the stepping along the path and the eigenproblems; the state
    the modes are about and the eigenproblem), without preparing the model, compiling kernels or a
    linear model written before it. Failed runs report it too."""
    scene = prepared.scene
    if analysis != "transient" or scene.solve.linear_model is not None:
        _hold_sampled_controllers(prepared, probes, writer)
    write_linear_model_first(prepared, writer, out_dir)
    if analysis == "transient":
        sensitivities = None
        if scene.solve.sensitivities:   # exact sensitivities of the run (docs/parameters.md)
            if scene.solve.sensitivity_method == "adjoint":   # end, max, min by the discrete adjoint
                from latdyn.analyses.adjoint_sensitivities import AdjointSensitivities as TransientSensitivities
            else:
                from latdyn.analyses.transient_sensitivities import TransientSensitivities
            sensitivities = TransientSensitivities(prepared)
        transient(prepared, probes, writer, progress, checkpointer, resume_from, sensitivities)
        return
    started = time.perf_counter()
    try:
        if analysis == "modes":  # about solve.about (latdyn/analyses/linearise.py)
            _modes(prepared, writer, out_dir)
        elif analysis == "buckling":
            from latdyn.analyses import linearise

            found = linearise.buckling_analysis(prepared, scene.solve.count)
            warnings = found.pop("warnings", [])
            writer.summary.update(found)
            for warning in warnings:
                _warn(writer, warning)
        else:
            from latdyn.analyses.continuation import static_path
            from latdyn.analyses.not_equilibria import states_not_at_rest, stops_passed

            static_path(prepared, probes, writer, length_scale(prepared.model))
            for warning in stops_passed(prepared.model, prepared.state, bool(scene.solve.sensitivities)):
                _warn(writer, warning)
            for warning in states_not_at_rest(prepared.assembler, prepared.state, "the static state"):
                _warn(writer, warning)
    finally:
        writer.summary["solver_s"] = time.perf_counter() - started


def _modes(prepared, writer: ResultWriter, out_dir) -> None:
    """The modal analysis about ``solve.about``: modes.csv, the summary's frequencies and damping
    ratios, the mode shapes (animated) and the linear model where the scene asks for them."""
    from latdyn.analyses import linearise  # on use: a transient run needs no analysis (docs/performance.md)
    from latdyn.analyses.not_equilibria import states_not_at_rest, stops_passed

    scene = prepared.scene
    if scene.solve.about == "initial":
        _warn_moving(scene, writer)
    found, directions, lin, report = linearise.modal_analysis(prepared, scene.solve.count, scene.solve.about)
    if "steady_state" in report:  # stable or not, how it was found (latdyn/analyses/steady.py)
        writer.summary["steady_state"] = report["steady_state"]
    for warning in report.get("warnings", []):
        _warn(writer, warning)
    if scene.solve.about == "static" and lin is not None:
        for warning in stops_passed(prepared.model, lin.state):
            _warn(writer, warning)
    if scene.solve.about in ("static", "steady") and lin is not None:
        for warning in states_not_at_rest(lin.assembler, lin.state, f"modes about {scene.solve.about}"):
            _warn(writer, warning)
    frequencies = [m.frequency_hz for m in found]
    writer.write_modes(frequencies, linearise.modes_table(found, directions))
    writer.summary["modes_hz"] = [float(f) for f in frequencies]
    writer.summary["damping_ratios"] = [float(m.damping_ratio) for m in found]
    writer.summary["mode_directions"] = directions
    writer.summary["about"] = scene.solve.about
    writer.summary["linearisation_s"] = None if lin is None else lin.seconds
    if lin is not None:  # the frame the modes are seen in: the steady spin's, else at rest
        writer.summary["frame_omega"] = [float(w) for w in lin.frame.omega]  # rad/s, global axes
        writer.summary["spin_rate"] = float(np.linalg.norm(lin.frame.omega))  # rad/s
    if lin is not None and scene.solve.mode_shapes:  # the shapes, animated
        try:
            writer.summary["mode_shapes"] = linearise.write_mode_shapes(lin, found, out_dir)
        except ImportError as exc:  # h5py (latdyn's ParaView output) not installed
            writer.summary["mode_shapes"] = f"not written: {exc}"
    if scene.solve.linear_model is not None and lin is not None:
        linearise.write_linear_model(prepared, out_dir, writer.summary, lin)


def _hold_sampled_controllers(prepared, probes: ProbeSet, writer: ResultWriter) -> None:
    """Sampled controllers in an analysis that is not a transient run (and in a linear model): their
    output sampled at the initial state and held (a state reached by a transient, ``about: {t: T}``,
    holds its own last samples); ``summary.json`` ``warnings`` says so (SCENE.md ``controllers``)."""
    from latdyn.timeloop.sampling import SampledControllers

    sampler = SampledControllers(prepared.scene, probes)
    if not sampler:
        return
    sampler.start(prepared.state, 1e-12)
    names = ", ".join(c.name for c in sampler.controllers)
    _warn(writer, f"sampled controllers ({names}) are held at their output in this analysis (sampled at the "
                  "initial state, or the last sample of the transient that reaches the state it is about); the "
                  "linearisation holds only the continuous controllers' feedback")


def _warn_moving(scene: Scene, writer) -> None:
    """A modal analysis about the initial configuration of a scene that moves says so (issue 22)."""
    from latdyn.analyses.moving import modes_warning

    warning = modes_warning(scene)
    if warning is not None:
        _warn(writer, warning)


def _warn(writer, warning: str) -> None:
    """A warning of the analysis: on stderr and in summary.json ``warnings``."""
    writer.warn(warning)


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


