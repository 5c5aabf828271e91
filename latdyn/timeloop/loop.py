"""The loop over rows and steps of one transient run (:func:`latdyn.timeloop.transient.transient`
starts it).

From a grid point at the nominal step, the loop of steps in C (step.compiled.CompiledGeneralizedAlpha.advance)
takes and accepts the steps up to the next row in one call, or, with rows recorded where the step runs
(:data:`NATIVE_ROWS`), through the rows up to the next multiple of 256 steps (t_end, a pause), recording
each row on the way into buffers (csrc/rows.c: the state, the energies, the momenta and section forces the
probes read, the joints' forces, the cable elements' and continuous controllers' states); this loop then
takes that block of rows in order as it takes one (:meth:`TimeLoop._record_rows`:
probes, writer, joint peaks, the energy balance judged row by row). A step it cannot accept as it comes
(Newton fails, a hinge event) comes back to this loop, which takes every other step from Python:

    try a step → count it → rejected by its error estimate? (adaptive steps) → Newton failed?
    (inertia tangent, cut: latdyn.timeloop.control) → shortened onto a hinge event → accepted:
    latches and stops (latdyn.timeloop.events), the work of loads, the row if one is due,
    the size of the next step, a checkpoint if one is due.

Interrupted or failed, the run leaves a checkpoint of the last accepted step and, failed, the
last converged state as a row."""
from __future__ import annotations

import copy
import math
import sys
import time
from typing import NamedTuple

import numpy as np

from latdyn.assembly.assembler import State
from latdyn.assembly.native_model import STATE_FIELDS
from latdyn.assembly.prepare import Prepared
from latdyn.errors import SolverError, UnboundedError
from latdyn.model.cables import slack_and_unheld
from latdyn.numerics.so3 import orthonormalize
from latdyn.results import paraview
from latdyn.results.probes import ProbeSet
from latdyn.results.progress import progress_bar
from latdyn.results.writer import ResultWriter
from latdyn.step.integrators import newton_diagnosis
from latdyn.timeloop import checkpoint as checkpoints
from latdyn.timeloop.control import Resize, StepControl
from latdyn.timeloop.impulse import prescribed_acceleration_jump, prescribed_velocity_jump
from latdyn.timeloop.jumps import acceleration_only_jumps, starts_on_a_jump
from latdyn.timeloop.landing import LANDING_PASSES, first_event, land
from latdyn.timeloop.events import (CABLE_LANDING, TAUT_JUMP_STEP, cable_events, cable_gaps, cable_sides, crossing_fraction, hinge_events,
                                   lock_events, restart_accelerations, stick_at_start, stop_crossings)
from latdyn.timeloop.progress import (DRIFT_WARNING, impacts_before, UNBOUNDED, UNBOUNDED_ROWS, UNRESOLVED_TURN, TransientProgress, cable_work,
                                      energy_round_off, factorizations, far_root, hinge_work, drive_forces, drive_work)
from latdyn.timeloop.sampling import controller_memory, restore_controller_memory


#: Whether a run with sensitivities in the loop of steps records its rows there too (False: the loop returns to
#: Python at each row, the reference it must equal: tests/test_sensitivities_in_loop_rows.py). Private.
SENSITIVITY_ROWS_IN_LOOP = True

#: Whether the loop of steps in C records the rows on its way (csrc/rows.c) instead of returning to
#: Python for each (False: a row at a time, the reference it must equal: tests/test_native_rows.py).
NATIVE_ROWS = True

#: passes at most of a landing on a cable element's change without sensitivities (:meth:`TimeLoop._cable_landing`)
CABLE_PASSES = 4


class Attempt(NamedTuple):
    """A step the integrator took from the run's state, not yet accepted."""

    new: State
    stats: object  # StepStats: converged, iterations, factorizations, residual
    h: float
    lands: bool  # on the next grid point


class _RowsAhead:
    """What StepControl.row_due and row_recorded read of a run's progress, for the rows ahead of it."""

    def __init__(self, output_index: int, grid_index: int):
        self.output_index, self.grid_index = output_index, grid_index


class LastAccepted(NamedTuple):
    """The last accepted step as a checkpoint keeps it."""

    #: a shallow copy of the run's progress (once a step is accepted the loop replaces states and
    #: arrays, never changes them in place); its external_work is the probes'
    progress: TransientProgress
    bookmark: dict  # the writer's
    last_recorded: State | None  # the last recorded state while its ParaView frame is not on disk
    #: the mark of the factorization the engine holds for this step (None: not this step's; a
    #: checkpoint then carries none)
    factorization_mark: int | None


class _BlockFrames:
    """The ParaView frames of a block of rows for the writer: one row's (``frame_of(r)``), or those of
    the rows it writes together (``many(rows)``: :func:`latdyn.results.paraview.frames`)."""

    def __init__(self, loop: "TimeLoop", block):
        self.loop, self.block = loop, block

    def __call__(self, r: int) -> dict:
        return self.loop._frame_of(self.block, r)

    def many(self, rows: list[int]) -> "paraview.FrameBlock | None":
        return self.loop._frames_of(self.block, rows)


class TimeLoop:
    """One transient run: the integrator, the state it carries from step to step
    (:class:`TransientProgress`), its rows (writer, probes) and its checkpoints.

    ``compiled_loop``: whether steps between rows run in C where the integrator can;
    ``loop_budget_s``: wall time after which that loop comes back to Python before the next row;
    ``drive_jumps``: the instants a prescribed acceleration alone jumps
    (latdyn.timeloop.jumps.acceleration_only_jumps of the start's search), None: searched at the first restart."""

    def __init__(self, prepared: Prepared, integrator, probes: ProbeSet, writer: ResultWriter,
                 control: StepControl, *, tol: float, checkpointer: checkpoints.Checkpointer | None = None,
                 compiled_loop: bool = True, loop_budget_s: float = 0.25, sampler=None, sensitivities=None,
                 drive_jumps: np.ndarray | None = None):
        self.prepared, self.model, self.assembler = prepared, prepared.model, prepared.assembler
        self.integrator, self.probes, self.writer, self.control = integrator, probes, writer, control
        self.tol, self.checkpointer = tol, checkpointer
        self.compiled_loop, self.loop_budget_s = compiled_loop, loop_budget_s
        #: the sampled controllers (latdyn.timeloop.sampling), None without
        self.sampler = sampler if sampler else None
        #: solve.sensitivities (latdyn.analyses.transient_sensitivities.TransientSensitivities, handed in
        #: by latdyn.solve): differentiated once per accepted step, on the per-step path or, its smooth steps, in the
        #: loop of steps in C (:attr:`sensitivities_in_loop`)
        self.sensitivities = sensitivities
        if sensitivities is not None:
            sensitivities.bind(integrator)
        self.energies_of = prepared.assembler.energies
        # modified Newton's held factorization (step.compiled.CompiledGeneralizedAlpha): a checkpoint of the
        # last accepted step carries it when the engine still holds that step's (its mark unchanged)
        self.factorization_mark = getattr(integrator, "factorization_mark", None)
        self.progress: TransientProgress | None = None
        self.bookmark: dict | None = None
        self.last_recorded: State | None = None
        self.last: LastAccepted | None = None
        self.compiled = False
        #: the sensitivities' smooth steps in the loop of steps (latdyn.analyses.sensitivities_in_loop.SensitivityLoop),
        #: None: every step from Python (:meth:`begin` decides)
        self.sensitivities_in_loop = None
        #: the state of the last trial step the integrator took (:meth:`_step`; what it holds is that trial's)
        self._last_trial: State | None = None
        self.unbounded = False  # the energy balance broke (_judge_balance)
        self._drive_jumps = drive_jumps  # the instants a prescribed acceleration alone jumps (_drive_alone_jumped)
        self.bar = None

    # ------------------------------------------------------------------------- start, resume
    def begin(self, resume_from: checkpoints.Checkpoint | None = None) -> None:
        """Start from ``prepared.state`` (its row recorded), or go on from a loaded checkpoint,
        the writer having been reopened at its bookmark."""
        energy0 = self._start() if resume_from is None else self._resume(resume_from)
        self.bookmark = self.writer.bookmark()
        self.last_recorded = None if resume_from is None else resume_from.last_recorded
        if self.last_recorded is not None:
            self.writer.reattach_last_frame(
                lambda snapshot=self.last_recorded: paraview.frame(self.assembler, self.writer.mesh, snapshot))
        # sampled controllers: the loop of steps in C samples on each instant itself, or (a probe read
        # without a C sensor) stops there and the sample is taken from here (_after_accepted); instants
        # off the grid k·dt: one step at a time; a law that jumps in t (latdyn.timeloop.jumps) at a point
        # k·dt: the loop of steps in C up to the grid point before it (StepControl.loop_end), the step that
        # lands before the jump, the restart after it and the step from there to the next grid point from
        # Python (_next_step), then the loop in C again; a jump off k·dt: every step from Python (sensitivities
        # beside a jump are refused before the run, latdyn.analyses.sensitivities)
        jumps = len(self.control.jump_indices) > 0
        eligible = (self.compiled_loop and hasattr(self.integrator, "advance") and not self.control.adaptive
                    and ((self.sampler is None and not jumps) or self.control.instants_on_nominal_grid))
        # solve.sensitivities: the smooth steps' derivative in the loop of steps where every term of it is native
        # (latdyn/analyses/sensitivities_in_loop.py), decided here once for the run; else every step from Python
        self.sensitivities_in_loop = self.sensitivities.in_loop() if self.sensitivities is not None and eligible \
            else None
        self.compiled = eligible and (self.sensitivities is None or self.sensitivities_in_loop is not None)
        # (with sensitivities carried in the loop of steps, each sample instant is handed back to Python, where the
        # sample and its restart are differentiated: TransientSensitivities.after_sample)
        self.control.samples_in_loop = (self.compiled and self.sampler is not None and self.sampler.in_loop
                                        and self.sensitivities_in_loop is None)
        self.writer.summary["time_loop"] = "compiled" if self.compiled else "python"
        # rows where the step runs (with sensitivities in the loop, the carried columns at each row recorded there
        # too and the rows' sensitivities taken from them: SensitivityLoop.record_rows, AdjointLoop.record_rows)
        self.native_rows = (self.compiled and NATIVE_ROWS and hasattr(self.integrator, "row_capacity")
                            and (self.sensitivities is None or SENSITIVITY_ROWS_IN_LOOP))
        if resume_from is None:
            self._record(self.progress.state, energy0)
        self.last = self._accepted()

    def _start(self) -> dict:
        """The run's progress at t = 0; the energies there."""
        state = self.prepared.state
        self.model.scene.controller_states.reset()  # continuous states from `initial` (sampled: start, below)
        if self.sampler is not None:
            self.sampler.start(state, 1e-9 * self.control.dt)
        # a law that jumps at t = 0 (2*Heaviside(t) is 1 there): the start from the law as it is just
        # after 0, at JUMP_SIDE · dt (the state held across it), the row at t = 0
        right_of_jump = starts_on_a_jump(self.model.scene, self.control.jump_side)
        if right_of_jump:
            state.t = self.control.jump_side
        self.integrator.start(state)
        stick_at_start(self.prepared, self.integrator, state)
        evaluation = self.assembler.evaluate(state, matrices=False)
        if right_of_jump:
            state.t = 0.0
        energy0 = self.energies_of(state)
        self.progress = TransientProgress(
            state=state, algorithmic_acceleration=self.integrator.a, locked=self.model.locked.copy(),
            stuck=self.model.stuck.copy(), resting=self.model.resting.copy(),
            h=self.control.dt, power=evaluation.external_power,
            drive_force=drive_forces(self.assembler.native(), evaluation.reaction),
            cable_work=evaluation.cable_work.copy(),
            hinge_work_torque=evaluation.hinge_work_torque.copy(),
            hinge_damper_torque=evaluation.hinge_damper_torque.copy(),
            total0=sum(energy0.values()), potential0=energy0["potential"],
            received0=energy0["kinetic"] + energy0["strain"] + 1e-8 * abs(energy0["potential"]),
            round_off=energy_round_off(self.model),
            inertia_tangent_from=0.0 if getattr(self.integrator, "inertia_tangent", False) else None,
            controller_memory=controller_memory(self.model.scene))
        if self.sensitivities is not None:
            self.progress.sensitivities = self.sensitivities.start(state)
        return energy0

    def _resume(self, checkpoint: checkpoints.Checkpoint) -> None:
        """The run's progress as the checkpoint keeps it: the latched hinges renumber the coordinates,
        then the loop goes on as it was."""
        self.progress = checkpoint.progress
        restore_controller_memory(self.model.scene, self.progress.controller_memory)
        self.model.locked[:] = self.progress.locked
        if self.progress.stuck is not None:
            self.model.stuck[:] = self.progress.stuck
        if self.progress.resting is not None:
            self.model.resting[:] = self.progress.resting
        self.model.number_coordinates()
        self.assembler.reindex()
        self.integrator.a = self.progress.algorithmic_acceleration
        self.integrator.inertia_tangent = self.progress.inertia_tangent_from is not None
        self.probes.external_work = checkpoint.external_work
        self.probes.dissipated = self.progress.dissipated
        if self.progress.drive_force is None:   # a checkpoint written before the drives' reactions were kept
            self.progress.drive_force = drive_forces(self.assembler.native(), self.assembler.evaluate(
                self.progress.state, matrices=False).reaction)
        if hasattr(self.integrator, "restore_factorization"):  # modified Newton's held matrix, as it was
            try:
                self.integrator.restore_factorization(checkpoint.factorization)
            except ValueError as exc:
                raise checkpoints.CheckpointError(f"{exc}; the checkpoint does not belong to this model") from exc

    # ------------------------------------------------------------------------- the loop
    def run(self, show_progress: bool) -> TransientProgress:
        """Step to t_end (after :meth:`begin`); the progress at the end."""
        self.bar = progress_bar(self.control.t_end, enabled=show_progress)
        try:
            self._steps()
        finally:
            self.bar.close()
            self._summarize()
        if self.checkpointer is not None:   # the steps all taken: an interrupt while the files close keeps this one
            self.checkpointer.last_step = self._checkpoint_the_last_step
        return self.progress

    def _checkpoint_the_last_step(self) -> float:
        """Write the checkpoint of the last accepted step (the run's last); its time."""
        self._save_checkpoint(self.last)
        return float(self.last.progress.state.t)

    def advance_to(self, t: float) -> TransientProgress:
        """Step on from where the loop is (after :meth:`begin`) to time ``t`` (≤ t_end) and pause
        there, the steps as :meth:`run` takes them save the one shortened to land on ``t``
        (:meth:`StepControl.pause_at`); the loop goes on with a later call, or :meth:`end`.
        Failed or interrupted, it leaves what :meth:`run` leaves."""
        if self.bar is None:
            self.bar = progress_bar(self.control.t_end, enabled=False)
        self.control.pause_at(t)
        try:
            self._steps()
        finally:
            self.control.pause_at(None)
        return self.progress

    def end(self) -> None:
        """After the last :meth:`advance_to`: the run's counters and balance into the summary."""
        self._summarize()

    def record_last(self) -> None:
        """The state the loop stands at as a row, unless it is one already (a run ended at a pause)."""
        state = self.progress.state
        if not self._row_at(state):
            self._record(state, self.energies_of(state))

    def _row_at(self, state: State) -> bool:
        """Whether the last row is at ``state``'s time: the writer's rows, this loop's and those of the run
        a resumed one goes on from (which the writer took back)."""
        return self.writer.last_time == state.t

    def stored_energy(self, state: State) -> float:
        """The strain and gravity potential energy at ``state`` under the laws as they are now (cables'
        rest lengths and hinge springs at their current values): what a jump of the laws at a fixed
        configuration changes (:meth:`_add_jump_work`)."""
        energies = self.energies_of(state)
        return energies["strain"] + energies["potential"]

    def _add_jump_work(self, stored_before: float | None, state: State) -> None:
        """The work of a jump of the laws at the fixed configuration ``state`` (a sample of a sampled
        controller, a law of t that jumps, an input set from outside): the change of the stored energy
        it made, from ``stored_before`` (:meth:`stored_energy` under the laws before it) to the laws'
        after it, is external work (docs/energy.md, "Jumps of the laws"). A winch's rest length or a
        servo's spring that a sample moves changes the strain energy at the sample with no motion: the
        structure received that energy from whatever drives the law, and the balance counts it so."""
        if stored_before is None:
            return
        work = self.stored_energy(state) - stored_before
        if work:
            progress = self.progress
            progress.external_work = self.probes.external_work = progress.external_work + work

    def restart(self, stored_before: float | None = None) -> None:
        """The laws jumped at the state the loop stands at (an input set from outside at a pause):
        the integrator goes on from the accelerations of the equations of motion under the new
        laws, with the directions that are stiff at the scale of dt taken quasi-statically, as after
        an impact (:func:`latdyn.timeloop.events.restart_accelerations`: a torque that jumps on a
        hinge of a flexible beam would otherwise give its directions of little inertia the jump over
        their inertia, 1e7 rad/s² on a 3-element arm, and Newton failed in the steps after it); and
        the power of the loads and dampers that starts the next step's work and dissipation is the
        new laws'. Before the first step the start is made again as :meth:`begin` made it (consistent
        accelerations, as at t = 0 of a run whose scene gives the new values).

        K here is Newton's, which on a rigid link carrying a point mass holds the velocity term ω²
        of its projection: there the restart is not exact for a rigid rotor, off by O((ω dt)²) of
        the jump (1.1e-6 rad at dt = 0.03 on tests/test_controllers.py's hub; 1.3e-5 rad at dt 0.01
        on an arm spinning at 20 rad/s). A structure of rigid links, bodies, hinges and guides only
        (no elastic element, no cable: :meth:`_rigid_only`), which has no directions of little
        inertia to take quasi-statically, restarts from the integrator's start instead, M⁻¹f, exact
        there (tests/test_jump_mends.py: the spinning arm, planar and on a skew hinge, 4e-10 rad:
        the motion the state held across the 2e-9·dt skipped at a jump misses). The sample of a
        sampled controller (latdyn.timeloop.sampling) restarts from M⁻¹f instead (``start``),
        exact there, but on a 3-element arm a PD at 100 Hz so restarted went through 245 rejected
        steps and a 4.6 % energy drift where this restart took none and 0.25 % (and then equals the
        same PD stepped from Python to 2e-13)."""
        progress = self.progress
        state = progress.state.copy()  # accepted states are replaced, never changed in place
        # the prescribed motions as their laws are at the restart's time: an acceleration that jumps there (a
        # ramp's end, latdyn.timeloop.jumps.prescribed_acceleration_jumps) takes its new value, whose reaction
        # starts the next step's work; a rate that jumps (a kink, or an input set from outside that a rate
        # names) gives the free rates the jump of its impulse, whose work is the drive's
        held = state.copy()
        self.assembler.apply_prescribed(state, state.t)
        kicked = prescribed_velocity_jump(self.assembler, held, state, self.control.dt)
        if kicked:
            progress.external_work = self.probes.external_work = progress.external_work + kicked
        shift = None
        if self._drive_alone_jumped(state.t):   # a prescribed acceleration alone: the free ones follow it
            shift = prescribed_acceleration_jump(self.assembler, held, state, self.control.dt)
        if shift is not None:
            if getattr(self.integrator, "a", None) is not None:
                self.integrator.a = self.integrator.a + shift
        elif progress.steps == 0 or self._rigid_only():  # before the first step: the start, as if the scene
            # had said so; a structure of rigid links and bodies only: the exact M⁻¹f (no directions of
            # little inertia to take quasi-statically, and Newton's K would put its ω² terms in)
            self.integrator.start(state)
        else:
            restart_accelerations(self.prepared, self.integrator, state, self.control.dt)
        evaluation = self.assembler.evaluate(state, matrices=False)
        progress.state = self.prepared.state = state
        progress.algorithmic_acceleration = getattr(self.integrator, "a", None)
        self._torques_from(evaluation)
        self._add_jump_work(stored_before, state)

    def _drive_alone_jumped(self, t: float) -> bool:
        """Whether the restart at ``t`` follows a jump of a prescribed acceleration alone
        (latdyn.timeloop.jumps.acceleration_only_jumps, from the run's start's search of the laws)."""
        if self._drive_jumps is None:
            self._drive_jumps = acceleration_only_jumps(self.model.scene, self.control.t_end)
        near = 1e-12 * self.control.t_end + 2.0 * self.control.jump_side
        return bool(np.any(np.abs(self._drive_jumps - t) <= near))

    def _rigid_only(self) -> bool:
        """Whether the structure has no elastic element and no cable (rigid links, bodies, hinges and
        guides only): its restart after a jump of the laws is the integrator's start, M⁻¹f."""
        return len(self.model.element_nodes) == 0 and self.model.cables is None

    def _steps(self) -> None:
        """Steps until t_end or the pause; interrupted or failed: :meth:`_stopped_by`."""
        try:
            while not self.control.finished(self.progress) and not self.control.paused(self.progress):
                self._next_step()
        except (KeyboardInterrupt, Exception) as failure:
            self._stopped_by(failure)
            self._name_unresolved(failure)
            raise
        self.prepared.state = self.progress.state

    def _name_unresolved(self, failure: BaseException) -> None:
        """A solver's failure (Newton, a crawling step) after a step that did not resolve a hinge
        (:meth:`TransientProgress.unresolved_hinges`) names that hinge on a line of its message, as an
        unbounded run's does (:meth:`_judge_balance`): the failure often follows from it."""
        if not isinstance(failure, SolverError) or isinstance(failure, UnboundedError) or not self.model.hinges:
            return
        unresolved = self.progress.unresolved_hinges([h.name for h in self.model.hinges],
                                                     until=self.progress.state.t, first=True)
        if unresolved and failure.args:
            failure.args = (f"{failure.args[0]}\nbefore it, {unresolved[0]}",) + tuple(failure.args[1:])

    def _next_step(self) -> None:
        """Steps in C up to the next row, or one step from Python; the step that comes back is
        rejected (error estimate), tried again (Newton failed) or accepted."""
        progress, control = self.progress, self.control
        self._hold_cable_sides()
        # a hinge stuck by friction or resting on its stop is checked for release after every step: those
        # steps from Python
        compiled = self.compiled and control.on_grid(progress) and not control.before_pause(progress) \
            and not control.before_jump(progress) and not self.model.stuck.any() and not self.model.resting.any()
        attempt = self._compiled_steps() if compiled else self._python_step()
        if attempt is None:
            return
        progress.count(attempt.stats)
        if attempt.stats.converged and control.rejects(progress, self.integrator, attempt.h):
            if self.sensitivities is not None:   # the next trial's size follows this one's error estimate
                progress.sensitivities = self.sensitivities.rejected(progress.sensitivities, progress, attempt,
                                                                     self.integrator, control)
            return
        if not attempt.stats.converged:
            if not control.after_newton_failure(progress, self.integrator, attempt.h, attempt.stats.iterations):
                state, h = progress.state, attempt.h
                raise SolverError("Newton failed below the minimum step", newton_diagnosis(
                    self.model, attempt.stats.residual, state.t + h, h, self.assembler, state))
            if self.sensitivities is not None:
                progress.sensitivities = self.sensitivities.resized(progress.sensitivities, control, attempt.lands)
            return
        far = far_root(self.assembler.native(), progress.state, attempt.new, attempt.h)
        if far is not None:  # a root a whole turn away: cut, never landed on as a crossing
            control.after_far_root(progress, attempt.h, self.model.hinges[far[0]].name, far[1])
            if self.sensitivities is not None:
                progress.sensitivities = self.sensitivities.resized(progress.sensitivities, control, attempt.lands)
            return
        self._accept(self._land_on_event(attempt))

    def _compiled_steps(self) -> Attempt | None:
        """The loop of steps in C from a grid point: the steps up to the next row, taken and accepted
        in one call; the step it could not accept as it came (None: none)."""
        progress, control = self.progress, self.control
        self._loop_began = (progress.steps, progress.grid_index, progress.newton_iterations, progress.factorizations)
        # back in Python at least every loop_budget_s (interrupts, progress) and when a checkpoint is due
        budget = self.loop_budget_s if self.checkpointer is None else min(self.loop_budget_s,
                                                                          self.checkpointer.remaining())
        stop, rows = (control.next_row(progress) if budget > 0 else progress.grid_index + 1), []
        if self.native_rows and budget > 0:
            stop, rows = self._rows_on_the_way()
        carried = None
        if self.sensitivities is not None:   # carried through the steps in C, or (this numbering) a step from Python
            carried = self.sensitivities_in_loop.prepared(progress.sensitivities, progress.grid_index, stop, control,
                                                          len(rows), progress.state)
            if carried is None:
                return self._python_step()
        # the section forces for the probes and the ParaView frames
        momentum, sections = self.probes.needs[0], len(self.model.element_nodes) > 0
        started = time.perf_counter()
        done = self.integrator.advance(
            progress.state, grid_index=progress.grid_index, stop_index=stop, dt=control.dt,
            t_end=control.t_end, n_grid=control.n_grid, power=progress.power,
            external_work=progress.external_work, hinge_work_torque=progress.hinge_work_torque,
            hinge_damper_torque=progress.hinge_damper_torque, drive_force=progress.drive_force,
            cable_work=progress.cable_work,
            dissipated=progress.dissipated, budget_s=budget, rows=rows, momentum=momentum, sections=sections,
            joints=bool(self.model.hinges), cables=self.probes.needs_cables,
            controller_states=self.probes.needs_controller_states,
            controller_outputs=self.probes.needs_controller_outputs,
            sample_tolerance=1e-9 * control.dt if control.samples_in_loop else 0.0,
            rate_turns=progress.kept_rate_turns(len(progress.state.theta)) if self.model.hinges else None,
            unresolved_turn=UNRESOLVED_TURN, sensitivities=carried)
        progress.solver_s += time.perf_counter() - started
        if done.status == 5:   # the run ends at the loop's start, whose sensitivities are carried (the Python step's error)
            t = control.grid_time(self._loop_began[1] + done.steps)
            raise SolverError(f"the sensitivities at t = {t:.6g} need the step's exact iteration matrix, which is "
                              "singular there")
        if done.rate_turns is not None:  # before the rows: an unbounded balance at one of them names them
            progress.rate_turns = done.rate_turns
        ended_on_a_row = False
        if done.rows is not None and len(done.rows):
            self._record_rows(done.rows)
            ended_on_a_row = int(done.rows.column("steps")[-1]) == done.steps
        if done.steps:
            progress.steps, progress.grid_index = self._loop_began[0] + done.steps, self._loop_began[1] + done.steps
            progress.newton_iterations = self._loop_began[2] + done.iterations
            progress.factorizations = self._loop_began[3] + done.factorizations
            progress.power = done.power
            progress.external_work = self.probes.external_work = done.external_work
            progress.hinge_work_torque, progress.hinge_damper_torque = done.hinge_work_torque, done.hinge_damper_torque
            progress.drive_force = done.drive_force
            progress.cable_work = done.cable_work
            progress.dissipated = self.probes.dissipated = done.dissipated
            if carried is not None:   # the sensitivities at the last accepted state, before its row
                progress.sensitivities = self.sensitivities_in_loop.carried_after(progress.sensitivities)
                progress.sensitivity_steps_in_loop += self.sensitivities_in_loop.steps_in_call()
            before, progress.state = progress.state, done.state   # a refusal in _track_cables ends at done's rows
            self._track_cables(before, done.state)
            progress.algorithmic_acceleration = self.integrator.a
            if done.samples:  # the sampled controllers sampled on the way (restarted there, or status 4)
                progress.controller_memory = self.sampler.memory()
                if done.status == 4:
                    self._restart_after_sample(done.state)
            self._after_accepted(done.state, recorded=ended_on_a_row, sampled=control.samples_in_loop)
            self._keep_accepted(done.factorization_kept)
        if done.pending is None:
            return None
        new, stats, h = done.pending
        return Attempt(new, stats, h, lands=True)

    def _rows_on_the_way(self) -> tuple[int, list[int]]:
        """The loop of steps with rows recorded where it runs: the grid point it stops at (the loop's end,
        :meth:`StepControl.loop_end`, or the row after the buffers' last) and the grid points of the rows
        it records on the way, before that stop (the row at the stop is :meth:`_after_accepted`'s, after
        the rotations are put back on SO(3) there). The rows due as :meth:`StepControl.row_due` says,
        on a stand-in of the run's progress."""
        progress, control = self.progress, self.control
        end, capacity = control.loop_end(progress), self.integrator.row_capacity()
        if control.every is None:  # a row every step
            rows = list(range(progress.grid_index + 1, min(end, progress.grid_index + 1 + capacity)))
            return (rows[-1] + 1 if len(rows) == capacity else end), rows
        ahead = _RowsAhead(progress.output_index, progress.grid_index)
        rows = []
        for k in range(progress.grid_index + 1, end):
            t = control.grid_time(k)
            ahead.grid_index = k
            if control.row_due(ahead, t):
                if len(rows) == capacity:
                    return k, rows
                rows.append(k)
                control.row_recorded(ahead, t)
        return end, rows

    def _record_rows(self, block) -> None:
        """The rows the loop of steps recorded on its way (a step.compiled.RowBlock), in order, as
        :meth:`_record` records each: the run's counters and energy accounts as they were at each row,
        its energies into the balance, the joint peaks, the balance judged row by row (an unbounded run
        ends at the same row as row by row); then the rows up to there written in one block (probes,
        state history, ParaView frames from the block's states and section forces), nothing past it."""
        progress, probes, began, model = self.progress, self.probes, self._loop_began, self.model
        k = len(block)
        times, counters, energies = block.column("t").tolist(), block.counters.tolist(), block.energies.tolist()
        names = [h.name for h in model.hinges] if model.hinges else None
        end, gain = k, 0.0
        for r in range(k):
            steps, iterations, factorizations, external_work, dissipated = counters[r]
            progress.steps, progress.grid_index = began[0] + int(steps), began[1] + int(steps)
            progress.newton_iterations, progress.factorizations = began[2] + int(iterations), began[3] + int(factorizations)
            progress.external_work = probes.external_work = external_work
            progress.dissipated = probes.dissipated = dissipated
            kinetic, strain, potential = energies[r]
            gain = progress.balance(times[r], {"kinetic": kinetic, "strain": strain, "potential": potential},
                                    external_work)
            if names:  # summary.json joint_peaks, over the recorded rows
                progress.note_joint_forces(names, block.joint_forces[r], times[r])
            self.control.row_recorded(progress, times[r])
            if progress.unbounded:
                end = r + 1
                break
        if self.sensitivities is not None:   # the rows' sensitivities, from the columns carried to each
            progress.sensitivities = self.sensitivities_in_loop.record_rows(progress.sensitivities, block, end)
        values = probes.rows(block.states, block.energies, block.column("external_work"),
                             block.column("dissipated"), block.momenta if probes.needs[0] else None,
                             block.section_forces if probes.needs[1] else None, block.joint_forces,
                             block.cable_states, block.controller_states, block.controller_outputs)
        # the rows up to there, views of the loop's buffers: what is written below reads them now (the state
        # history and the frames copy what they keep); the last row's state, which a checkpoint keeps, is copied
        kept = block if end == len(block) else block.first(end)
        s = kept.states
        history = {name: array.reshape(end, -1) for name, array in
                   (("x", s.x), ("T", s.T), ("v", s.v), ("w", s.w), ("theta", s.theta), ("theta_dot", s.theta_dot))
                   if array[0].size}  # State.as_dict of each row
        self.writer.record_rows(times[:end], values[:end], history, _BlockFrames(self, kept))
        self.last_recorded = kept.state(end - 1).copy()
        self.bookmark = self.writer.bookmark()
        self._judge_balance(times[end - 1], gain)

    def _frames_of(self, block, rows: list[int]) -> "paraview.FrameBlock | None":
        """The ParaView frames of several rows of a block, computed together (None: one by one)."""
        s = block.states
        if rows == list(range(rows[0], rows[-1] + 1)):  # consecutive (every row's frame): views, not copies
            rows = slice(rows[0], rows[-1] + 1)
        states = State(s.t[rows], *(getattr(s, name)[rows] for name in STATE_FIELDS))
        sections = None if block.section_forces is None else block.section_forces[rows]
        return paraview.frames(self.assembler, self.writer.mesh, states, kernel_sections=sections)

    def _frame_of(self, block, r: int) -> dict:
        """The ParaView frame of row ``r`` of a block of rows (its section forces the rows')."""
        sections = None if block.section_forces is None else block.section_forces[r]
        return paraview.frame(self.assembler, self.writer.mesh, block.state(r), kernel_sections=sections)

    def _python_step(self) -> Attempt:
        """One step from Python, of the size the step control says, landing on the grid if it reaches it."""
        h, lands, t_new = self.control.next_step(self.progress)
        if self.control.halved and self.sensitivities is not None:   # half the way to the grid point: its δh
            self.progress.sensitivities = self.sensitivities.halved(self.progress.sensitivities)
        new, stats = self._step(h, t_new=t_new)
        return Attempt(new, stats, h, lands)

    def _step(self, h: float, t_new: float | None = None):
        """The integrator's step of size ``h`` from the run's state, timed (the last trial the integrator took:
        ``_last_trial``)."""
        started = time.perf_counter()
        new, stats = self.integrator.step(self.progress.state, h, t_new=t_new)
        self.progress.solver_s += time.perf_counter() - started
        self._last_trial = new
        return new, stats

    def _land_on_event(self, attempt: Attempt) -> Attempt:
        """A hinge reaching lock_at or a stop, or a cable going slack or taut, inside the step: the step
        shortened to land on the first (latdyn.timeloop.landing.first_event, with sensitivities or without): a
        hinge's to 1e-12 (latdyn.timeloop.landing.land, never shorter than dt_min), a cable's by the regula falsi
        on the trial ends (:meth:`_cable_landing`, never shorter than CABLE_LANDING · dt) or, with sensitivities,
        to 1e-12 · EA; the last shorter step that converged."""
        self._last_trial = attempt.new
        if self.sensitivities is not None:  # their derivative is that of a step landing exactly on the event
            landed = Attempt(*self.sensitivities.land(self._step, self.progress.state, attempt))
        else:
            landed = self._landing(attempt)
        return self._taken_again_after_a_failed_retry(landed)

    def _taken_again_after_a_failed_retry(self, landed: Attempt) -> Attempt:
        """The landing's step taken again where a retry after it failed Newton: the integrator holds what its
        last trial left (the continuous controllers' states it accepts, its last evaluation, whose power and
        joint torques start the next step, the accelerations), which a failed trial must not hand on to the
        step accepted (tests/test_step_control.py::test_a_landing_whose_retry_fails_accepts_the_step_it_keeps)."""
        if self._last_trial is landed.new:
            return landed
        new, stats = self._step(landed.h, t_new=landed.new.t)
        self.progress.factorizations += factorizations(stats)
        self.progress.newton_iterations += stats.iterations
        if not stats.converged:  # the same step from the same state: converged once, it converges again
            raise SolverError("Newton failed on a step it had converged", newton_diagnosis(
                self.model, stats.residual, new.t, landed.h, self.assembler, self.progress.state))
        return Attempt(new, stats, landed.h, landed.lands)

    def _landing(self, attempt: Attempt) -> Attempt:
        """:meth:`_land_on_event` without sensitivities: the first event of the step (latdyn.timeloop.landing
        first_event, the rule the sensitivities' landing takes too); a hinge's landed on as the sensitivities'
        landing lands on it (latdyn.timeloop.landing.land to :data:`latdyn.timeloop.landing.LANDING`, at most
        :data:`LANDING_PASSES` retries, none shorter than dt_min), a cable's by :meth:`_cable_landing`."""
        progress = self.progress
        old = progress.state
        event = first_event(self.assembler, old, attempt.new, reached=False)
        if event is None:
            return attempt
        if event.hinge is not None:
            def step(h):
                retry, retry_stats = self._step(h)
                progress.factorizations += factorizations(retry_stats)
                if retry_stats.converged:
                    progress.newton_iterations += retry_stats.iterations
                return retry, retry_stats
            landed = Attempt(*land(step, old, attempt, event.gap(self.assembler), event.tight(self.assembler), LANDING_PASSES,
                                   shortest=self.control.dt_min))
            if landed.new is not attempt.new:
                self._note_short_landing(old, attempt, landed.new)
            return landed
        return self._cable_landing(attempt)

    def _cable_landing(self, attempt: Attempt) -> Attempt:
        """A cable element's change first in the step (no hinge event before it): the secant on the bracket
        [short, past] of the trial ends (regula falsi), so that the landing does not end short of the change, which
        left the next step a sliver of 1e-7 s to land on (docs/cables.md: after such slivers Newton failed on the
        example truss with damped cables), at most :data:`CABLE_PASSES` passes."""
        progress = self.progress
        new, stats, h, lands = attempt
        old = progress.state
        short, past = old, new
        for _ in range(CABLE_PASSES):
            floor = CABLE_LANDING * self.control.dt / (past.t - short.t) if short is old else 0.0
            fraction = crossing_fraction(self.assembler, short, past, cables=True, cable_floor=floor)
            if fraction is None:
                break
            shorter = max(short.t - old.t + (past.t - short.t) * fraction, self.control.dt_min)
            if shorter >= past.t - old.t:
                break
            retry, retry_stats = self._step(shorter)
            progress.factorizations += factorizations(retry_stats)
            if not retry_stats.converged:
                break
            progress.newton_iterations += retry_stats.iterations
            if crossing_fraction(self.assembler, old, retry, cables=True) is not None:
                past = retry  # the change is in the retried step
            else:
                short = retry
            new, stats, h, lands = retry, retry_stats, shorter, False
        if new is not attempt.new:
            self._note_short_landing(old, attempt, new)
        return Attempt(new, stats, h, lands)

    def _note_short_landing(self, old: State, trial: Attempt, kept: State) -> None:
        """The first landing on a stop or lock_at crossed by a trial that did not resolve the hinge (its rate turned
        it by more than :data:`UNRESOLVED_TURN` over the trial, h |θ̇_{n+1} − θ̇_n|) whose step kept ends short of
        it, having closed less than half the gap from the step's start, is said at the end of the run (a warning):
        the secant takes the angle as linear in t over the step, and a shorter step that does not get even half-way
        says the crossing was the unresolved trial's alone. Landings that end a little short (1e-4 to 1e-2 of the
        gap on the event tests), or more where a body settling on its stop bounces within a step (a guide's
        rattle, tests/test_guides_acceptance.py: up to 1.1 of the gap), are taken on by the next step, which lands
        again; their trials turn the joint by at most 3.1e-4 (71 landings of the event tests), and they are not
        said."""
        if self.progress.short_landing is not None:
            return
        model = self.model
        targets = [(k, model.hinges[k].limits[0 if side < 0 else 1], "stop")
                   for k, side, _ in stop_crossings(self.assembler, old, trial.new)]
        targets += [(k, model.hinges[k].lock_at, "lock_at") for k, _ in lock_events(self.assembler, old, trial.new)[1]]
        for k, target, kind in targets:
            turn = trial.h * abs(float(trial.new.theta_dot[k] - old.theta_dot[k]))
            before, after = float(old.theta[k] - target), float(kept.theta[k] - target)
            if turn > UNRESOLVED_TURN and before * after > 0.0 and abs(after) > 0.5 * abs(before):
                unit = "m/s" if model.hinges[k].kind == "guide" else "rad/s"
                self.progress.short_landing = (
                    f"the step from t = {old.t:.6g} of {trial.h:.3g} s crossed the {kind} {target:.6g} of "
                    f"{model.hinges[k].name} (its angle {float(trial.new.theta[k]):.4g} at the trial's end) without "
                    f"resolving it (its rate changed by {turn / trial.h:.4g} {unit} over the step, which turns it by "
                    f"{turn:.3g} > {UNRESOLVED_TURN:g}), and no shorter step reached it: the step kept, "
                    f"{kept.t - old.t:.3g} s, ends {abs(after):.3g} short of it, having closed less than half the gap "
                    f"({abs(before):.3g}); the crossing was the trial's alone, and the run went on from the step kept: "
                    f"rerun with a smaller dt")
                return

    def _accept(self, attempt: Attempt) -> None:
        """Accept the converged step: its events, the work of loads over it, the row if one is due,
        the size of the next step, a checkpoint if one is due."""
        progress, model, integrator = self.progress, self.model, self.integrator
        new, h = attempt.new, attempt.h
        self.control.estimate_accepted(integrator, h)   # before accept(), after which the estimate reads 0
        integrator.accept()
        theta_end = new.theta.copy()  # the step's own end, before an event puts a hinge on its stop
        if self.sensitivities is not None:  # the step differentiated, with its events' jumps (before they renumber)
            carried = self.sensitivities.step(progress.sensitivities, progress.state, new, h,
                                              progress.algorithmic_acceleration, integrator.a, attempt.lands)
        events = hinge_events(self.prepared, integrator, progress.state, new, h)
        if not events.any and model.hinges:
            progress.note_rate_turns(self.assembler.native(), progress.state, new, h)
        if events.log:
            progress.events = progress.events + [{"joint": joint, "kind": kind, "t": float(new.t)}
                                                 for joint, kind in events.log]
        held_sides = progress.cable_sides
        tension_jumped = self._track_cables(progress.state, new)
        turned = held_sides is not None and list(held_sides) != list(progress.cable_sides)
        # power of point loads and prescribed motion: from the last Newton evaluation
        # (within the Newton tolerance of the converged state) when there is one
        evaluation = getattr(integrator, "last_evaluation", None)
        # the step's end evaluated again, after the events: where their renumbering changed the reactions' count (a
        # latch, a stick, a release) and resting on a stop (the step ends where the projection put it back,
        # events.HingeEvents); the sensitivities are told so (after_events: the work's terms at the step's end)
        end_after_events = (evaluation is None or len(evaluation.reaction) != model.n_total - model.n_dofs
                            or events.resting)
        if end_after_events:
            evaluation = self.assembler.evaluate(new, matrices=False)
        new_power = evaluation.external_power
        external_work = self.probes.external_work + 0.5 * h * (progress.power + new_power)
        progress.power = new_power
        # the work of the hinges' torques (progress.hinge_work): external work and the joints'
        # dissipation over the step's own Δθ, the torques at its end from its last evaluation, before
        # the events' jump and their putting a hinge back on its stop (resting on a stop: after it, where
        # the step moved nothing, events.HingeEvents); the cables' reels and dampers over the step's
        # ΔL0 and Δℓ (progress.cable_work); then the events' loss; the torques and forces after the
        # jump start the next step. A cable that changed side at the step's end starts the next step
        # from its forces on the side it was held on, as the integrator does (its acceleration carries
        # them): measured on docs/cables.md's damped truss, forces re-evaluated on the new side gave
        # a balance error 2.4 times larger
        ended = evaluation if events.resting else getattr(integrator, "last_evaluation", None) or evaluation
        # the prescribed motions' work over the step's Δq (progress.drive_work), their reactions at its end
        # from the same evaluation as the power's
        native = self.assembler.native()
        ended_drive = drive_forces(native, evaluation.reaction)
        external_work = drive_work(native, progress.state, new, progress.drive_force, ended_drive, external_work)
        external_work, dissipated = hinge_work(
            progress.state.theta, new.theta if events.resting else theta_end,
            (progress.hinge_work_torque, progress.hinge_damper_torque),
            (ended.hinge_work_torque, ended.hinge_damper_torque), external_work, progress.dissipated)
        external_work, dissipated = cable_work(progress.cable_work, ended.cable_work, external_work, dissipated)
        progress.external_work = self.probes.external_work = external_work
        after = evaluation
        if events.any and evaluation is ended and not events.resting:  # the velocities jumped
            after = self.assembler.evaluate(new, matrices=False)
            progress.power = after.external_power
        self._torques_from(after, ended_drive if after is evaluation else None)
        progress.dissipated = self.probes.dissipated = dissipated + events.loss
        if self.sensitivities is not None:   # after the events: their renumbering and restarted accelerations
            progress.sensitivities = self.sensitivities.after_events(carried, new, end_after_events)
        progress.state = new
        progress.algorithmic_acceleration = integrator.a
        progress.locked, progress.stuck, progress.resting = model.locked.copy(), model.stuck.copy(), model.resting.copy()
        progress.steps += 1
        if attempt.lands:
            progress.grid_index += 1
        self._after_accepted(new)
        # with sensitivities an event (a cable's change too), and a step onto the grid, restart at the nominal
        # step as a stop does:
        # the step after an event lands on the grid and the next ones are nominal, their sizes smooth in the
        # parameters (latdyn/analyses/transient_sensitivities.py)
        restarted = events.stopped or (self.sensitivities is not None and (events.any or attempt.lands or turned))
        # a run without sensitivities steps otherwise here (_summarize): it lands on a cable's change by its own
        # passes, and where it grows its steps back from a short one, the step after it ends short of the grid point
        # that the restart at dt reaches (a hinge's event it lands on as this run does: latdyn.timeloop.landing)
        if self.sensitivities is not None and (turned or (restarted and not events.stopped and
                                                          self.control.restart_differs(progress, h, attempt.lands))):
            progress.steps_for_sensitivities += 1
        self.control.after_accepted(progress, integrator, h, events.any, restarted, attempt.lands)
        if tension_jumped and progress.h > TAUT_JUMP_STEP * self.control.dt:
            # the steps after a damped cable's jump of tension grow from TAUT_JUMP_STEP · dt
            progress.h, self.control.resize = TAUT_JUMP_STEP * self.control.dt, Resize(0.0, 0.0, 0.0)
        if self.sensitivities is not None:   # the next step's size as the control chose it, differentiated
            progress.sensitivities = self.sensitivities.resized(progress.sensitivities, self.control,
                                                                integrator=integrator)
        self._keep_accepted()

    def _torques_from(self, evaluation, drive_force: np.ndarray | None = None) -> None:
        """The hinges' work and dissipative torques, the cables' work forces and the drives' reactions at the
        state of ``evaluation`` (``drive_force``: :func:`drive_forces` of it, where the step's work took them
        already), which the next step's work and dissipation start from (progress.hinge_work,
        progress.cable_work, progress.drive_work)."""
        progress = self.progress
        progress.power = evaluation.external_power
        progress.drive_force = (drive_forces(self.assembler.native(), evaluation.reaction) if drive_force is None
                                else drive_force)
        progress.cable_work = evaluation.cable_work.copy()
        progress.hinge_work_torque = evaluation.hinge_work_torque.copy()
        progress.hinge_damper_torque = evaluation.hinge_damper_torque.copy()

    def _hold_cable_sides(self) -> None:
        """The side each cable element is held on through the next step (latdyn.timeloop.events): the
        progress's (from the state at t = 0 the first time), into the model's array the evaluation reads."""
        cables, progress = self.model.cables, self.progress
        if cables is None:
            return
        if progress.cable_sides is None:
            progress.cable_sides = cable_sides(self.assembler, progress.state)
        cables.sides[:] = progress.cable_sides

    def _track_cables(self, old: State, new: State) -> bool:
        """The cables' slack and taut changes over the accepted step(s) old → new, into the events
        (latdyn.timeloop.events.cable_events: the step landed on each); whether a damped element went
        taut (its tension jumped from 0 to c ℓ̇)."""
        if self.model.cables is None:
            return False
        progress = self.progress
        held = progress.cable_sides
        progress.cable_sides, changes = cable_events(self.assembler, progress.cable_sides, old, new)
        self.model.cables.sides[:] = progress.cable_sides
        damping = self.model.cables.damping
        jumped = any(a < 0 < b and damping[e] > 0 for e, (a, b) in enumerate(zip(held, progress.cable_sides)))
        if changes and old.t == 0.0:
            changes = self._changes_after_the_start(old, changes)
        if changes:
            progress.events = progress.events + [{"joint": name, "kind": kind, "t": float(new.t)}
                                                 for name, kind in changes]
            self._refuse_unheld_cable_ends(new, progress.cable_sides)
        return jumped

    def _changes_after_the_start(self, start: State, changes: list) -> list:
        """``changes`` of the steps from t = 0 less those of cables whose every element is on its boundary at
        t = 0 (its gap within the tolerance: a cable that starts at its rest length, the default): such a cable
        has no side to change from, and the side its first step takes it to is its state at the start, not a
        change after t = 0 (SCENE.md ``cable_events``). A cable hung at its rest length under gravity reported
        'taut' at t = dt/1000 (the landing's floor, CABLE_LANDING · dt)."""
        gaps, tol = cable_gaps(self.assembler, start)
        cables = self.model.cables
        on_boundary = {name for k, name in enumerate(cables.names)
                       if np.all(np.abs(gaps[cables.cable == k]) <= tol[cables.cable == k])}
        return [(name, kind) for name, kind in changes if name not in on_boundary]

    def _refuse_unheld_cable_ends(self, state: State, sides) -> None:
        """End the run (SolverError naming the cable) where a massless cable whose free end only its
        tension holds is slack in ``sides`` (latdyn.model.cables.slack_and_unheld): nothing holds
        that end's coordinates from here on."""
        for name, ends in slack_and_unheld(self.model.cables, sides):
            raise SolverError(
                f"cables.{name} went slack at t = {float(state.t):.6g}, and nothing holds its free end "
                f"{' and '.join(ends)} while it is slack (a massless cable's end given as a point)",
                "A slack massless cable holds nothing: give the cable a mass per length (rhoA > 0), end it at "
                "a body with mass ({body: NAME}), or keep it taut (a load that keeps pulling its end, a "
                "shorter rest_length).")

    def _after_accepted(self, state: State, recorded: bool = False, sampled: bool = False) -> None:
        """After the accepted step(s) that ended at ``state``: the sampled controllers' sample if one
        is due (``sampled``: the loop of steps took it already), rotations back on SO(3) every 256
        steps, the row if one is due (``recorded``: the loop of steps recorded it already) and the
        progress bar (the summary: once, when the loop ends, :meth:`run`; nothing reads it before the
        writer closes)."""
        progress, model = self.progress, self.model
        tolerance = 1e-9 * self.control.dt
        after_jump = self.control.jump_reached(progress)
        stored = None
        if after_jump is not None:  # a law jumped: the run goes on after it (JUMP_SIDE · dt), where a
            # sample due at the jump's instant is taken too (within twice the side), then one restart
            stored = self.stored_energy(state)
            progress.state = state = state.copy()
            state.t = after_jump
            tolerance = 2.5 * self.control.jump_side
        due = [] if sampled or self.sampler is None else [c.name for c in self.sampler.due(state.t, tolerance)]
        if due and stored is None:
            stored = self.stored_energy(state)
        sampled_now = bool(due) and self.sampler.sample(state, state.t, tolerance)
        if sampled_now:
            progress.controller_memory = self.sampler.memory()
        if after_jump is not None:  # from the accelerations of the new laws (and the new held outputs)
            self.restart(stored)
            state = progress.state
        elif sampled_now:
            self._restart_after_sample(state)
            self._add_jump_work(stored, state)
        if sampled_now and self.sensitivities is not None:  # the sample and its restart differentiated
            progress.sensitivities = self.sensitivities.after_sample(progress.sensitivities, state, due)
        if progress.steps % 256 == 0:  # exp updates keep T on SO(3) to round-off; remove the drift of long runs
            state.T[model.free_nodes] = orthonormalize(state.T[model.free_nodes])
        if not recorded and self.control.row_due(progress, state.t):
            self._record(state, self.energies_of(state))
            self.control.row_recorded(progress, state.t)
        self.bar.update(state.t)

    def _restart_after_sample(self, state: State) -> None:
        """The held outputs jumped (an event of the laws): the accelerations go on from those consistent
        with the new outputs, as after a latch (the integrator's start; where the loop of steps in C takes the
        restart itself, its C: CompiledGeneralizedAlpha.restart_after_sample, latdyn.timeloop.sampling), and the
        power of the loads after the jump starts the next step."""
        progress = self.progress
        restart = getattr(self.integrator, "restart_after_sample", None)  # the loop of steps' own, where it has one
        if restart is None or not restart(state):
            self.integrator.start(state)
        progress.algorithmic_acceleration = self.integrator.a
        evaluation = self.assembler.evaluate(state, matrices=False)
        self._torques_from(evaluation)

    # ------------------------------------------------------------------------- rows, summary
    def _record(self, state: State, energies: dict) -> None:
        """A row at ``state`` (probes, state, ParaView frame when due), its energies in the balance;
        then the balance judged (:meth:`_judge_balance`). A block of rows recorded in C:
        :meth:`_record_rows`."""
        gain = self.progress.balance(state.t, energies, self.probes.external_work)
        if self.model.hinges:  # summary.json joint_peaks, over the recorded rows
            self.progress.note_joint_forces([h.name for h in self.model.hinges], self.probes.joint_forces(state),
                                            state.t)
        snapshot = state.copy()
        if self.sensitivities is not None:
            self.progress.sensitivities = self.sensitivities.record(self.progress.sensitivities, state)
        self.writer.record(state.t, self.probes.values(state, energies), state=state.as_dict(),
                           frame=lambda: paraview.frame(self.assembler, self.writer.mesh, snapshot))
        self.bookmark, self.last_recorded = self.writer.bookmark(), snapshot
        self._judge_balance(state.t, gain)

    def _judge_balance(self, t: float, gain: float) -> None:
        """The energy balance at the row at ``t`` (docs/energy.md): an energy gain (``gain``: the
        energy created and held, relative to the energy received, :meth:`TransientProgress.balance`)
        past :data:`UNBOUNDED`, growing, at :data:`UNBOUNDED_ROWS` rows in a row, or not finite,
        ends the run as unbounded, the row at ``t`` recorded first; a hinge that a step up to ``t`` did
        not resolve (:meth:`TransientProgress.unresolved_hinges`) is named in the message."""
        if self.progress.unbounded:
            self.unbounded = True
            progress = self.progress
            received = progress.received0 + progress.work_seen + progress.potential_seen
            if math.isnan(gain):
                what = "the energies are not finite"
            else:
                what = (f"the integrator created {gain:.3g} times the energy the structure received "
                        f"({received:.4g}; a run ends past {UNBOUNDED:g} times at {UNBOUNDED_ROWS} rows in a row)")
            unresolved = progress.unresolved_hinges([h.name for h in self.model.hinges], until=t, first=True)
            before = f"; before it, {unresolved[0]}" if unresolved else ""
            raise UnboundedError(f"unbounded: the energy balance broke at t = {t:.6g}: {what}; a smaller step or "
                                 f"numerical dissipation (rho_inf < 1) may keep it bounded{before}", t)

    def _summarize(self) -> None:
        """The run's counters and energy balance into the summary; a balance error past
        :data:`DRIFT_WARNING` is a warning on stderr and in summary.json ``warnings``. The warning
        says what the drift is and no more: the run cannot tell the step's error from a start or a
        model that does not keep energy, so it names the rerun that can."""
        progress, summary = self.progress, self.writer.summary
        summary.update(progress.summary(self.tol, self.prepared.scene.solve.method))
        if self.sensitivities is not None and progress.sensitivities is not None and not self.writer.closed:
            self.sensitivities.finish(progress.sensitivities, self.writer)
            # the smooth steps differentiated in the loop of steps in C (0: every step from Python)
            summary["sensitivity_steps_in_loop"] = progress.sensitivity_steps_in_loop
        if self.model.cables is not None:
            summary["cable_events"] = [{"cable": e["joint"], "t": e["t"], "state": e["kind"]} for e in progress.events
                                       if e["kind"] in ("slack", "taut")]
        error = progress.relative_balance_error
        if error > DRIFT_WARNING and progress.balance_error_t is not None and not self.unbounded:
            warning = (f"the energy balance drifts: energy_balance_error {error:.3g} (> {DRIFT_WARNING:g}), "
                       f"largest at t = {progress.balance_error_t:.6g}: energy created or lost beyond the work "
                       f"received; a smaller step reduces the part that is the step's error, not a part from the "
                       f"start or the model (a rerun at dt/2 tells them apart)")
            self.writer.warn(warning + impacts_before(progress.events, progress.balance_error_t))
        if not self.unbounded:
            for warning in progress.unresolved_hinges([h.name for h in self.model.hinges]):
                self.writer.warn(warning)
        if progress.short_landing is not None:
            self.writer.warn(progress.short_landing)
        if progress.steps_for_sensitivities:
            self.writer.warn(
                f"{progress.steps_for_sensitivities} of the run's steps are the sensitivities' own: each event and "
                "cable change ends a step to 1e-12, and the step after it, or after a step onto the grid, restarts at "
                "solve.dt; the same scene without solve.sensitivities lands on a hinge's event as this run does, on "
                "a cable's change by at most 4 passes of its own, and grows its steps back from the short one, so its "
                "probes differ from these (by at most 0.16 of "
                "the step's own error on the scenes measured: docs/parameters.md, \"Sensitivities through events\")")

    # ------------------------------------------------------------------------- checkpoints
    def _accepted(self, kept_factorization: bool = True) -> LastAccepted:
        """The last accepted step as a checkpoint keeps it (``kept_factorization``: whether the
        engine holds this step's factorization)."""
        kept = copy.copy(self.progress)  # dataclasses.replace without its per-field checks (once a row)
        kept.cut_times = list(self.progress.cut_times)
        kept.controller_memory = controller_memory(self.model.scene)  # continuous states change every step
        mark = self.factorization_mark() if self.factorization_mark is not None and kept_factorization else None
        unwritten = (self.bookmark["paraview"] or {}).get("unwritten") is not None
        return LastAccepted(kept, self.bookmark, self.last_recorded if unwritten else None, mark)

    def _keep_accepted(self, kept_factorization: bool = True) -> None:
        """Keep the step just accepted as the last one, and write its checkpoint when one is due."""
        self.last = self._accepted(kept_factorization)
        if self.checkpointer is not None and self.checkpointer.due():
            self._save_checkpoint(self.last)

    def _save_checkpoint(self, kept: LastAccepted) -> None:
        """Write the checkpoint of ``kept``, with the held factorization while the engine has not
        moved on from that step (else without: the resumed run rebuilds it)."""
        factorization = None
        if kept.factorization_mark is not None and kept.factorization_mark == self.factorization_mark():
            factorization = self.integrator.factorization_state()
        self.checkpointer.save(kept.progress, kept.progress.external_work, kept.bookmark, kept.last_recorded,
                               self.writer, factorization)

    def _stopped_by(self, failure: BaseException) -> None:
        """Interrupted or failed: a checkpoint of the last accepted step, to resume from; failed: the
        last converged state is always a row (after the checkpoint, whose bookmark a resumed run
        returns to, so that the resumed files equal an uninterrupted run's). Unbounded: the run is
        over (resuming would go on from the broken balance), so no checkpoint is left."""
        if isinstance(failure, UnboundedError):
            if self.checkpointer is not None:
                self.checkpointer.discard()
            return
        if self.checkpointer is not None and not self.writer.closed:
            try:
                self._save_checkpoint(self.last)
                self.writer.summary["checkpoint_t"] = self.last.progress.state.t
            except Exception as exc:  # noqa: BLE001 - the original error matters more
                print(f"latdyn: could not write a checkpoint: {type(exc).__name__}: {exc}", file=sys.stderr)
        state = self.progress.state
        if isinstance(failure, SolverError) and not self.writer.closed and state is not None and not self._row_at(state):
            self._record(state, self.energies_of(state))
