"""The compiled time step: generalized-α with its Newton iteration in C
(``latdyn/assembly/csrc/newton_step.c``), and the loop of steps between rows in C too.

:class:`CompiledGeneralizedAlpha` is :class:`latdyn.step.integrators.GeneralizedAlpha` with
``step`` done by one call into C: the scene's laws at the step's end time (compiled by the code
generator, :mod:`codegen.laws`, or called back in Python where a law does not print in C:
:mod:`latdyn.assembly.native_model`), the configuration update on SO(3) with prescribed motion,
the one evaluation of ``csrc/evaluate.c`` that every analysis uses (generated kernels through
function pointers), the scatter of S = β′M + γ′C + K into a preallocated matrix, the one LU
factorization of ``csrc/factorization.c`` (dense or banded LAPACK, or the supernodal sparse LU
of ``csrc/sparse_lu.c``; storage, order and analysis chosen once per pattern by
:class:`latdyn.assembly.factorization.Factorization`, the class the analyses driven from Python
solve with), and the convergence test. The model's arrays and buffers are the assembler's
:class:`~latdyn.assembly.native_model.NativeModel`; this module adds the iteration matrix's
storage (:attr:`CompiledGeneralizedAlpha.factorization`) and the step's own structs.

:meth:`CompiledGeneralizedAlpha.advance` takes the steps from one recorded row to the next in
one call (``latdyn_advance``): each step on the time grid as ``step`` takes it, accepted as
the time loop (:mod:`latdyn.timeloop.loop`) accepts it (algorithmic acceleration carried over,
the external work and the dampers' dissipation as latdyn.timeloop.progress says). A step it
cannot accept as it comes (Newton fails; a hinge reaches lock_at or a stop) is handed back
to the time loop, which handles it as before (cuts, the inertia tangent, latches, impacts)
and calls the loop again once it is back on the grid at the nominal step. Python runs once
a call: events, output, checkpoints (``timeloop.transient.LOOP_BUDGET_S`` bounds a call, so that
interrupts and the progress bar are seen); without ``rows``, a call ends at the next row. With ``rows`` the loop steps on
through the recorded rows and records each on its way (``csrc/rows.c``: the state, the energies, the
section forces and the momenta, into :class:`RowBuffers`), so that Python takes them a block at a
time (:meth:`latdyn.timeloop.loop.TimeLoop._record_rows`). Adaptive steps take the steps
from Python, one call each.

This is the runtime's only Newton iteration of a time step. With ``newton: full`` it takes the same
iterations as the NumPy reference kept in the tests (``tests/reference_step.py``) and equals it to
round-off (``tests/test_engine.py``: 1e-10 relative), and the loop equals
the steps taken one by one from Python (``tests/test_compiled_loop.py``; bit for bit on the
shipped examples).
``newton: modified`` keeps the factorized iteration matrix from step to step while Newton
contracts (|Δx_k| ≤ ``contraction`` · |Δx_{k−1}|) and rebuilds it when it stops doing so
or the step size changes; only the residual is evaluated between rebuilds. It converges to the
same tolerance on the same invariant increment.

Threads: the element part of each evaluation (geometry and generated kernels) runs on OpenMP
threads, one contiguous range of elements each, from ``PARALLEL_ELEMENTS`` elements on
(:mod:`latdyn.assembly.library`; ``LATDYN_PARALLEL_ELEMENTS`` overrides it, 0 turns it off);
``OMP_NUM_THREADS`` sets the number of threads (default: the cores). The sums stay serial in
element order, so the results are equal whatever the threads (bit for bit on the tested beam, to
~1e-14 on a lattice). The library is built with ``-fopenmp`` where the compiler accepts it, else
serially (``openmp_threads`` says 0).

Models with rigid links take the same Newton iteration and loop of steps, in C too: after every
configuration update the dependent nodes are completed, and every evaluation is reduced onto the
minimum coordinates (``csrc/links.c`` with the generated edge kernels of ``codegen/joints.py``, laid
out by :mod:`latdyn.assembly.native_links` for the matrix's storage,
:meth:`~latdyn.assembly.native_model.NativeModel.hold_links`), the reduced iteration matrix written
into the same dense, band or sparse storage, on the pattern of Pᵀ A P (:func:`matrix_pattern`). No Python runs inside a
Newton iteration.
"""
from __future__ import annotations

import ctypes
import math

import numpy as np

from latdyn.assembly.assembler import State
from latdyn.assembly.factorization import Factorization
from latdyn.assembly.held_matrix import hold_matrix, matrix_pattern
from latdyn.assembly.library import (
    AdvanceData,
    StaticControlData,
    ConfigurationData,
    ControlData,
    RowsData,
    TrajectoryData,
    VectorsData,
    native_library,
    parallel_threshold,
)
from latdyn.assembly.native_model import STATE_FIELDS, state_shapes
from latdyn.records import record
from latdyn.step.integrators import GeneralizedAlpha, StepStats, increment_size


# ----------------------------------------------------------------------------- the step


class CompiledGeneralizedAlpha(GeneralizedAlpha):
    """:class:`GeneralizedAlpha` whose step runs in C (see the module docstring)."""

    def __init__(self, assembler, params, tol, max_iterations, length_scale, newton: str = "full",
                 contraction: float = 0.5, parallel_elements: int | None = None, threads: int = 0):
        super().__init__(assembler, params, tol, max_iterations, length_scale)
        #: element count from which the element kernels run on threads (0: never), and how
        #: many threads (0: OMP_NUM_THREADS or the cores); the results do not depend on either
        self.parallel_elements = parallel_threshold() if parallel_elements is None else parallel_elements
        self.threads = threads
        self.modified = newton == "modified"
        self.contraction = contraction
        #: full Newton stops when the error left estimated from its contraction is ≤ tol (csrc/newton_step.c
        #: newton_converged), not |Δx_k| ≤ tol: measured and not the default (docs/performance.md, "Fewer
        #: iterations where they buy nothing"); benchmarks/newton_convergence_test.py switches it on
        self.estimate_error = False
        self.factorizations = 0
        #: bumped whenever the held factorization (Work matrix and pivots, factored_h) may change:
        #: before each call into C that steps, on a rebuild of the buffers, on a restore
        self._factor_version = 0
        self._native = self._setup_for = None
        #: the iteration matrix's storage and LU (set up with the native model): after a step that
        #: factorized, its ``solve`` solves with the factors the step held
        self.factorization = None
        self._library = native_library()
        self._last_trial = self._mass_for = None
        self._made = None  # (the arrays of the last state made, their C view)

    # -- the model as arrays, rebuilt when the numbering changes (a latch) --------------------
    def _setup(self) -> None:
        """The assembler's native model for the current numbering (latdyn/assembly/native_model.py),
        with the storage of the iteration matrix, and the step's own structs."""
        native = self.assembler.native(self.inertia_tangent)
        if self._setup_for == (native, self.inertia_tangent):
            return
        self._setup_for = (native, self.inertia_tangent)
        self._native = native
        self._factor_version += 1
        self._hold_matrix(native)
        native.model.parallel_elements, native.model.threads = self.parallel_elements, self.threads
        n = self.assembler.model.n_dofs
        self._control = ControlData(max_iterations=self.max_iterations, modified=int(self.modified),
                                    inertia_tangent=int(self.inertia_tangent),
                                    contraction=self.contraction, factored_h=0.0, tol=self.tol,
                                    length=self.length_scale, estimate_error=int(self.estimate_error))
        for name in ("alpha_m", "alpha_f", "gamma", "beta"):
            setattr(self._control, name, getattr(self.p, name))
        size = max(n, 1)
        self._step_vectors = {name: np.zeros(size) for name in VectorsData._fields_and_names()}
        self._a_n, self._a_new = self._step_vectors["a_n"], self._step_vectors["a_new"]
        self._vectors = VectorsData(**{name: b.ctypes.data for name, b in self._step_vectors.items()})
        self._model_ref, self._work_ref, self._buffers = native.model_ref, native.work_ref, native.buffers
        self._control_ref, self._vectors_ref = ctypes.byref(self._control), ctypes.byref(self._vectors)
        self._step = self._library.latdyn_newton_step
        self._layout()
        # the loop of steps (advance): its two scratch configurations and its counters
        self._scratch = [self._new_state(0.0) for _ in range(2)]
        self._scratch_c = (ConfigurationData * 2)(self._scratch[0][1], self._scratch[1][1])
        self._run = AdvanceData()
        self._run_ref = ctypes.byref(self._run)
        self._rows = None  # RowBuffers of this numbering (rows), made on the first loop that records rows

    def _hold_matrix(self, native) -> None:
        """The iteration matrix's storage in the native model (:func:`hold_matrix`)."""
        self.factorization = hold_matrix(self.assembler, native)

    def _layout(self) -> None:
        """Offsets of a state's arrays in one flat buffer (a new state per step: the loop
        keeps the old one for its events and checkpoints)."""
        shapes = state_shapes(self.assembler.model)
        self._shapes, self._offsets, offset = shapes, {}, 0
        for name in STATE_FIELDS:
            self._offsets[name] = offset
            offset += max(int(np.prod(shapes[name])), 1)
        self._state_size = offset
        self._slices = [(self._offsets[name], self._offsets[name] + int(np.prod(shapes[name])), shapes[name])
                        for name in STATE_FIELDS]

    def _new_state(self, t: float) -> tuple[State, ConfigurationData]:
        buffer = np.empty(self._state_size)
        base = buffer.ctypes.data
        state = State(t, *(buffer[start:stop].reshape(shape) for start, stop, shape in self._slices))
        return state, ConfigurationData(*(base + 8 * start for start, _, _ in self._slices))

    @staticmethod
    def _view(state: State, configuration: ConfigurationData) -> tuple:
        """What :meth:`_configuration_of` recognises a state this step made by: its arrays, and their C view."""
        return tuple(getattr(state, name) for name in STATE_FIELDS), configuration

    def _copy_into(self, source: State, state: State) -> None:
        """``state`` ← ``source``'s arrays, in place."""
        for name in STATE_FIELDS:
            np.copyto(getattr(state, name), getattr(source, name))

    def _configuration_of(self, state: State) -> ConfigurationData:
        """The C view of a state: the last state this step made is viewed in place while it still
        holds the arrays the view points into; any other state (the start, a state after an event,
        one whose arrays were replaced) through contiguous float64 copies of its arrays, kept alive
        until the next call. Nothing is attached to the state (it is pickled into checkpoints)."""
        if self._made is not None and all(getattr(state, name) is array
                                          for name, array in zip(STATE_FIELDS, self._made[0])):
            return self._made[1]
        return self._native.configuration(state)

    def start(self, state: State) -> None:
        """:meth:`GeneralizedAlpha.start`, and the rates dS/dt of the continuous controllers' states at
        ``state`` that the next step's trapezoidal rule starts from (their values kept)."""
        super().start(state)
        native = self.assembler.native(self.inertia_tangent)
        native.laws.bind_inputs()
        native.accept_controller_states(state, 0.0)

    def accept(self) -> None:
        """:meth:`GeneralizedAlpha.accept`, and the continuous controllers' states at the end of the step
        accepted (the last one taken: :meth:`step`, or the one :meth:`advance` gave back)."""
        super().accept()
        if self._last_trial is not None and self._native is not None:
            self._native.laws.bind_inputs()
            self._native.accept_controller_states(self._last_trial, self._last_h)

    def step(self, state: State, h: float, t_new: float | None = None) -> tuple[State, StepStats]:
        self._setup()
        model = self.assembler.model
        n = model.n_dofs
        t_new = state.t + h if t_new is None else t_new
        base = self._configuration_of(state)
        trial_state, trial = self._new_state(t_new)
        self._a_n[:n] = self.a
        control = self._control
        control.h = h
        control.t_new = t_new
        self._factor_version += 1
        self._native.laws.bind_inputs()  # this scene's input values (SceneLaws.bind_inputs)
        failed = self._step(self._model_ref, self._work_ref, self._control_ref, ctypes.byref(base),
                            ctypes.byref(trial), self._vectors_ref)
        self.factorizations += control.factorizations
        self._last_trial, self._last_h = trial_state, h
        self._made = self._view(trial_state, trial)
        total = self._buffers["total"]
        stats = StepStats(iterations=control.iterations, converged=bool(control.converged) and not failed,
                          factorizations=control.factorizations, contraction=control.contraction_seen)
        self.last_evaluation = _LastEvaluation(total, n, model.n_total, control.power, self._buffers)
        if not stats.converged:
            stats.residual = total[:n].copy()
            control.factored_h = 0.0  # a failed step may leave a partial factorization
        else:
            self.a_candidate = self._a_new[:n].copy()
        return trial_state, stats

    def advance(self, state: State, *, grid_index: int, stop_index: int, dt: float, t_end: float, n_grid: int,
                power: float, external_work: float, hinge_work_torque: np.ndarray, hinge_damper_torque: np.ndarray,
                drive_force: np.ndarray | None = None, cable_work: np.ndarray | None = None, dissipated: float = 0.0, budget_s: float = 0.25,
                rows: list[int] | None = None, momentum: bool = False, sections: bool = False,
                joints: bool = False, cables: bool = False, controller_states: bool = False,
                controller_outputs: bool = False, sample_tolerance: float = 0.0,
                rate_turns: np.ndarray | None = None, unresolved_turn: float = math.inf,
                sensitivities=None) -> "Advanced":
        """Steps on the time grid in one call into C (``latdyn_advance``), from ``state`` on grid
        point ``grid_index`` through ``stop_index``, each as :meth:`step` takes it with
        h = t_{k+1} − t_k and accepted as the time loop accepts it (algorithmic acceleration
        carried, the point loads' external work by the trapezoidal rule in time from ``power``, the
        prescribed motions' over each step's Δq from their reactions ``drive_force`` at ``state``, as
        latdyn.timeloop.progress.drive_work, the hinges' work and their dampers' dissipated energy over each step's Δθ from
        the torques ``hinge_work_torque`` and ``hinge_damper_torque`` at ``state``, as
        latdyn.timeloop.progress.hinge_work, and the cables' reels' work and dampers' dissipation over
        each step's ΔL0 and Δℓ from ``cable_work`` at ``state``, as latdyn.timeloop.progress.cable_work).
        The call returns at
        ``stop_index``, after ``budget_s`` of wall time, or at the first step that does not
        converge or holds a hinge event (lock_at, a stop): that step is given back, not
        accepted, for the time loop to handle as it handles any step (:attr:`Advanced.pending`).

        ``rows``: grid points (rising, each before ``stop_index``, at most :meth:`row_capacity`) after
        whose steps the loop records a row where it runs (csrc/rows.c): the state, the counters and
        energy accounts, the energies, and with ``momentum`` / ``sections`` / ``joints`` / ``cables`` the
        momenta, the section forces, the forces the joints apply (``latdyn_joint_forces``) and the cable
        elements' states, and with ``controller_states`` / ``controller_outputs`` the scene's arrays of
        controller states as accepted at the row and of controller outputs (the continuous ones evaluated
        there, ``latdyn_controller_outputs_at``); :attr:`Advanced.rows` holds those it recorded
        (a :class:`RowBlock`, valid until the next call).

        ``sample_tolerance`` > 0: the sampled controllers sample at the end of every accepted step that
        lands within it of one of their instants (csrc/sampling.c), and the accelerations restart there
        (:meth:`restarts_natively`); a model that does not restart natively ends the call after the
        sample (status 4) for the time loop to restart it (latdyn.timeloop.sampling).

        ``rate_turns`` (n_hinges, 6): each hinge's largest h |θ̇_{n+1} − θ̇_n| so far with its step's end
        time and size, and the first past ``unresolved_turn`` with its (latdyn.timeloop.progress.TransientProgress
        .rate_turns), carried on over the steps taken here into a copy, :attr:`Advanced.rate_turns` (None:
        not kept).

        ``sensitivities``: the transient sensitivities carried through each accepted step (a
        ``SensitivityLoopData`` of latdyn.assembly.library, laid out and read back by
        latdyn.analyses.sensitivities_in_loop; None: none); status 5: their step matrix was singular at the last
        accepted step, whose sensitivities are not carried on. A ``TrajectoryData`` instead: the discrete adjoint's
        forward pass, each accepted step stored (latdyn.analyses.adjoint_in_loop).
        """
        self._setup()
        model = self.assembler.model
        n = model.n_dofs
        base = self._configuration_of(state)
        out, out_c = self._new_state(state.t)
        self._a_n[:n] = self.a
        run = self._run
        run.dt, run.t_end, run.n_grid, run.grid_index, run.stop_index = dt, t_end, n_grid, grid_index, stop_index
        run.t, run.budget_s, run.power, run.external_work = state.t, budget_s, power, external_work
        work_torque = np.array(hinge_work_torque, dtype=float)  # carried in place by the loop (in/out)
        damper_torque = np.array(hinge_damper_torque, dtype=float)
        cable_accounts = np.array(np.zeros((0, 4)) if cable_work is None else cable_work, dtype=float)  # in/out
        run.dissipated = dissipated
        run.hinge_work_torque, run.hinge_damper_torque = work_torque.ctypes.data, damper_torque.ctypes.data
        if drive_force is None:   # none at ``state`` (the reactions by prescribed coordinate: 6 a prescribed body, 1 a hinge)
            drive_force = np.zeros(6 * int(self._native.model.n_prescribed) + len(model.hinges))
        drive = np.array(drive_force, dtype=float)  # in/out
        run.drive_force = drive.ctypes.data
        buffers = None
        if rows:
            buffers = self._row_buffers()
            buffers.plan(rows, momentum, sections, joints, cables, controller_states, controller_outputs)
        run.rows = buffers.reference if buffers is not None else None
        run.cable_work = cable_accounts.ctypes.data
        run.sample_tolerance = sample_tolerance
        run.native_restart = int(sample_tolerance > 0.0 and self.restarts_natively(state))
        turns = None if rate_turns is None else np.array(rate_turns, dtype=float)  # in/out, a copy
        run.rate_turns = turns.ctypes.data if turns is not None else None
        run.unresolved_turn = unresolved_turn
        stores = isinstance(sensitivities, TrajectoryData)   # the adjoint's forward pass (csrc/adjoint_trajectory.c)
        run.trajectory = ctypes.addressof(sensitivities) if stores else None
        run.sensitivities = None if sensitivities is None or stores else ctypes.addressof(sensitivities)
        self._factor_version += 1
        self._native.laws.bind_inputs()  # this scene's input values (SceneLaws.bind_inputs)
        self._library.latdyn_advance(self._model_ref, self._work_ref, self._control_ref, ctypes.byref(base),
                                     self._scratch_c, ctypes.byref(out_c), self._vectors_ref, self._run_ref)
        control = self._control
        self.factorizations += run.factorizations
        last = state
        if run.steps:
            last = out
            last.t = run.t_last
            self.a = self._a_n[:n].copy()
            self._made = self._view(last, out_c)
        pending = None
        kept = True  # the held factorization is that of the last accepted step (or of `state`)
        if run.status in (1, 2):
            k = grid_index + run.steps
            trial, trial_c = self._new_state(t_end if k + 1 >= n_grid else (k + 1) * dt)
            self._copy_into(self._scratch[run.pending][0], trial)
            stats = StepStats(iterations=control.iterations, converged=run.status == 2,
                              factorizations=control.factorizations, contraction=control.contraction_seen)
            self.factorizations += control.factorizations
            # the step given back ran on the held factorization: it is still the accepted step's
            # unless that step factorized (or failed, which drops the factorization)
            kept = stats.converged and control.factorizations == 0
            if stats.converged:
                self.a_candidate = self._a_new[:n].copy()
            else:
                stats.residual = self._buffers["total"][:n].copy()
                control.factored_h = 0.0  # a failed step may leave a partial factorization
            self._last_trial, self._last_h = trial, run.h_pending
            self._made = self._view(trial, trial_c)
            pending = (trial, stats, run.h_pending)
        self.last_evaluation = _LastEvaluation(self._buffers["total"], n, model.n_total, control.power,
                                               self._buffers)
        return Advanced(state=last, steps=run.steps, iterations=run.iterations, factorizations=run.factorizations,
                        power=run.power, external_work=run.external_work, status=run.status, pending=pending,
                        factorization_kept=kept, hinge_work_torque=work_torque,
                        hinge_damper_torque=damper_torque, drive_force=drive, cable_work=cable_accounts,
                        dissipated=run.dissipated, rows=buffers.block() if buffers is not None else None,
                        samples=run.samples, rate_turns=turns)

    def restarts_natively(self, state: State) -> bool:
        """Whether the loop of steps restarts the accelerations after a sample itself (csrc/sampling.c
        restart_after_sample: v̇ ← v̇ − M⁻¹ r, with rigid links and guides on the minimum coordinates with
        Pᵀ M P): for a numbering whose every direction has an inertia that does not depend on the state
        (planar, or 3D beams with rotary inertia ρI_y, ρI_z > 0: a 3D element's twist without it has an
        inertia ~ φ² of its bending, massless or not as the state goes, latdyn.numerics.inertia) and none
        without inertia (:func:`latdyn.numerics.inertia.split_inertia` of the (reduced) M at ``state``,
        once per numbering): there that restart is :func:`latdyn.step.integrators.consistent_acceleration`;
        else the time loop restarts with the split at each sample."""
        if getattr(self, "_restart_for", None) is not self._native:
            model = self.assembler.model
            rotary = model.element_sections[:, 6:8]  # rhoIy, rhoIz (latdyn.model.model)
            natively = model.n_dofs > 0 and (model.plane is not None or bool(np.all(rotary > 0.0)))
            if natively:
                from latdyn.numerics.inertia import split_inertia

                mass = self.assembler.evaluate(state, matrices=True).combined(1.0, 0.0, 0.0)
                natively = split_inertia(model, mass).n_massless == 0
            self._restart_for, self._restarts_natively = self._native, natively
        return self._restarts_natively

    def restart_after_sample(self, state: State) -> bool:
        """The restart after a sample from Python where the loop of steps takes it itself (:meth:`restarts_natively`):
        the same C (csrc/sampling.c sample_restart), into ``state`` and as the algorithmic acceleration.
        False where it does not apply or M did not factorize (the caller then restarts with the split)."""
        self._setup()
        if not self._native.model.n_sampled or not self.restarts_natively(state):
            return False
        a_n = self._native.sample_restart(state)
        if a_n is None:
            return False
        self.a = a_n
        return True

    def row_capacity(self) -> int:
        """The most rows one :meth:`advance` records (its buffers, :class:`RowBuffers`)."""
        self._setup()
        return self._row_buffers().capacity

    def _row_buffers(self) -> "RowBuffers":
        if self._rows is None or self._rows.native is not self._native:
            self._rows = RowBuffers(self._native, self._state_size, self._slices, self.assembler.model)
        return self._rows

    # -- the held factorization of modified Newton, for checkpoints (latdyn.timeloop.checkpoint) -------
    def factorization_mark(self) -> int:
        """A token that changes whenever the held factorization may have changed (a step or a
        loop of steps began, the buffers were rebuilt, a factorization was restored): equal
        tokens mean the same held factorization."""
        return self._factor_version

    def factorization_state(self) -> dict | None:
        """What modified Newton carries from one step to the next besides the state: the step
        size the held factorization belongs to (``factored_h``) and copies of the factorized
        matrix (dense LU, band LU or the sparse LU's numeric factor: all three factorize in
        place in Work's ``matrix``) and of the pivots (dense and band LU). None when there is
        nothing to carry: full Newton, no factorization held, or one of a numbering (a latch)
        or an iteration matrix (the inertia tangent) that the next step will rebuild anyway."""
        if not self.modified or self._setup_for != (self.assembler.current_native(), self.inertia_tangent):
            return None
        h = float(self._control.factored_h)
        if h == 0.0:
            return None
        return {"factored_h": h, "n_dofs": int(self.assembler.model.n_dofs),
                "matrix": self._buffers["matrix"].copy(), "pivots": self._buffers["pivots"].copy()}

    def restore_factorization(self, saved: dict | None) -> None:
        """Hold ``saved`` (:meth:`factorization_state`) as the factorization of the next step,
        after the buffers are set up for the model's current numbering (resume: latched hinges
        and the inertia tangent set first). None: nothing held, the next step factorizes.
        Raises ValueError when ``saved`` does not fit this model's matrix."""
        self._setup()
        self._factor_version += 1
        self._control.factored_h = 0.0
        if saved is None or not self.modified:
            return
        matrix, pivots = self._buffers["matrix"], self._buffers["pivots"]
        got_matrix = np.asarray(saved["matrix"])
        got_pivots = np.asarray(saved["pivots"])
        if (int(saved["n_dofs"]) != self.assembler.model.n_dofs or got_matrix.shape != matrix.shape
                or got_pivots.shape != pivots.shape):
            raise ValueError(f"the saved factorization ({saved['n_dofs']} coordinates, matrix of "
                             f"{got_matrix.size} entries, {got_pivots.size} pivots) does not fit this model "
                             f"({self.assembler.model.n_dofs} coordinates, {matrix.size} entries, "
                             f"{pivots.size} pivots)")
        matrix[:] = got_matrix
        pivots[:] = got_pivots
        self._control.factored_h = float(saved["factored_h"])

    def error_estimate(self, h: float) -> float:
        """As :meth:`GeneralizedAlpha.error_estimate`, with the mass matrix of the step's end
        state evaluated in Python (adaptive runs: once per step, outside the Newton iteration)."""
        if self.assembler.model.n_dofs == 0 or getattr(self, "_last_trial", None) is None:
            return 0.0
        if self._mass_for is not self._last_trial:
            self._mass_ev = self.assembler.evaluate(self._last_trial, matrices=True)
            self._mass_for = self._last_trial
        saved, self.last_evaluation = self.last_evaluation, self._mass_ev
        try:
            return super().error_estimate(h)
        finally:
            self.last_evaluation = saved


@record
class Advanced:
    """What :meth:`CompiledGeneralizedAlpha.advance` did: the last accepted state, the steps
    accepted with their Newton iterations and factorizations, the power at that state and the
    external work since the start of the run, why it returned (0 at the stop, 1 a step did not
    converge, 2 a step holds a hinge event, 3 the wall-time budget, 4 the last accepted step ended
    on a sample whose restart the time loop takes) and, for 1 and 2, the step not accepted as
    ``(state, StepStats, h)``."""

    state: State
    steps: int
    iterations: int
    factorizations: int
    power: float
    external_work: float
    status: int
    pending: tuple | None = None
    #: whether the held factorization is still that of the last accepted step (False when the
    #: step given back factorized or failed): a checkpoint of that step can carry it
    factorization_kept: bool = True
    #: per hinge at that state: the torque that does external work and the damper's torque
    hinge_work_torque: np.ndarray | None = None
    hinge_damper_torque: np.ndarray | None = None
    #: the reactions of the prescribed motions at that state (latdyn.timeloop.progress.drive_forces)
    drive_force: np.ndarray | None = None
    cable_work: np.ndarray | None = None  # per cable element at that state: [ℓ, L0, ∂U/∂L0, f]
    dissipated: float = 0.0  # the energy the dampers dissipated since the start of the run
    #: the rows recorded on the way (``advance``'s ``rows``), None without
    rows: "RowBlock | None" = None
    samples: int = 0  # the sampled controllers' samples taken on the way (``sample_tolerance``)
    rate_turns: np.ndarray | None = None  # ``advance``'s ``rate_turns`` carried over the steps taken


#: The columns of a row's scalars (csrc/rows.c ROW_SCALARS): its time, the loop call's steps, Newton
#: iterations and factorizations up to it, the run's external work and dissipated energy, the energies
#: of ``latdyn_energies`` and the momenta [P, H] (0 unless asked for).
ROW_SCALARS = ("t", "steps", "iterations", "factorizations", "external_work", "dissipated",
               "kinetic", "strain", "potential", "Px", "Py", "Pz", "Hx", "Hy", "Hz")

#: The bytes of row buffers one loop call may hold (its rows: at most this, at least one).
ROW_BUFFER_BYTES = 8 << 20
#: The most rows of one loop call (the loop returns every 256 steps anyway, timeloop.control.next_row).
MAX_ROWS = 256


@record
class RowBlock:
    """Rows recorded in one loop call, in order: ``scalars`` (k, :data:`ROW_SCALARS`), ``states``
    (the state arrays of every row with a leading row axis: ``states.x`` (k, n, 3), ``states.T``
    (k, n, 3, 3), …, ``states.t`` (k,)), ``section_forces`` (k, n_elements, 4, as the strain-energy
    kernel gives them), ``joint_forces`` (k, joints, as ``latdyn_joint_forces`` gives them) and
    ``cable_states`` (k, cable elements, 5: [ℓ, ℓ̇, ℓ − L0, N_el, N]), ``controller_states`` (k, the
    scene's controller states, in the order of ``scene.controller_states``) and ``controller_outputs``
    (k, in the order of ``scene.controller_outputs``) or None where not recorded.
    Views of the buffers: valid until the next loop call."""

    scalars: np.ndarray
    states: State
    section_forces: np.ndarray | None
    joint_forces: np.ndarray | None = None
    cable_states: np.ndarray | None = None
    controller_states: np.ndarray | None = None
    controller_outputs: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.scalars)

    def column(self, name: str) -> np.ndarray:
        return self.scalars[:, ROW_SCALARS.index(name)]

    @property
    def counters(self) -> np.ndarray:
        """(k, 5): steps, Newton iterations and factorizations of the loop call up to each row, the
        external work and the dissipated energy since the start of the run."""
        return self.scalars[:, 1:6]

    @property
    def energies(self) -> np.ndarray:
        """(k, 3): kinetic, strain and potential energy (latdyn_energies)."""
        return self.scalars[:, 6:9]

    @property
    def momenta(self) -> np.ndarray:
        """(k, 6): [P, H] (zeros unless the loop call was asked for them)."""
        return self.scalars[:, 9:15]

    def state(self, r: int) -> State:
        """Row ``r``'s state (views of the buffers)."""
        s = self.states
        return State(float(s.t[r]), *(getattr(s, name)[r] for name in STATE_FIELDS))

    def first(self, rows: int) -> "RowBlock":
        """The first ``rows`` rows (views of the same buffers: valid until the next loop call)."""
        def first(array):
            return None if array is None else array[:rows]

        s = self.states
        return RowBlock(self.scalars[:rows], State(s.t[:rows], *(getattr(s, name)[:rows] for name in STATE_FIELDS)),
                        first(self.section_forces), first(self.joint_forces), first(self.cable_states),
                        first(self.controller_states), first(self.controller_outputs))


class RowBuffers:
    """The preallocated buffers of the rows the loop of steps records (``Rows`` of csrc/rows.c): the
    states in the step's own layout, one row after the other, the scalars, the section forces, the
    joints' forces, the cable elements' states and the scene's controller states and outputs (with one
    more state, the scratch of ``latdyn_joint_forces``)."""

    def __init__(self, native, state_size: int, slices, model):
        self.native = native
        self.n_elements = len(model.element_nodes)
        self.n_joints, self.n_cables = len(model.hinges), len(native.buffers["cable_state"])
        row_bytes = 8 * (state_size + len(ROW_SCALARS) + 4 * self.n_elements + self.n_joints + 5 * self.n_cables)
        self.capacity = max(1, min(MAX_ROWS, ROW_BUFFER_BYTES // row_bytes))
        self.state_buffer = np.zeros((self.capacity + 1, state_size))  # the last: latdyn_joint_forces' scratch
        self.joint_forces = np.zeros((self.capacity, max(self.n_joints, 1)))
        self.cable_states = np.zeros((self.capacity, max(self.n_cables, 1), 5))
        self.saved = np.zeros(model.n_total + 2 + 2 * self.n_joints)
        # the controllers' states: the scene's array that the runtime writes in place (a continuous
        # controller's states every step, a sampled one's at its samples on the way)
        self.n_controller_values = (len(model.scene.controller_states.values)
                                    if native.model.n_controller_states or native.model.n_sampled else 0)
        self.controller_states = np.zeros((self.capacity, max(self.n_controller_values, 1)))
        self.n_output_values = (len(model.scene.controller_outputs.values) if getattr(model.scene, "controllers", None)
                                else 0)
        self.controller_outputs = np.zeros((self.capacity, max(self.n_output_values, 1)))
        self.scalars = np.zeros((self.capacity, len(ROW_SCALARS)))
        self.section_forces = np.zeros((self.capacity, max(self.n_elements, 1), 4))
        self.grid_point = np.zeros(self.capacity, np.int64)
        base, stride = self.state_buffer.ctypes.data, 8 * state_size
        self.configurations = (ConfigurationData * (self.capacity + 1))(
            *(ConfigurationData(*(base + r * stride + 8 * start for start, _, _ in slices))
              for r in range(self.capacity + 1)))
        self.slices = slices
        self.data = RowsData(capacity=self.capacity, grid_point=self.grid_point.ctypes.data,
                             scalars=self.scalars.ctypes.data, section_forces=self.section_forces.ctypes.data,
                             states=ctypes.cast(self.configurations, ctypes.c_void_p),
                             joint_forces=self.joint_forces.ctypes.data,
                             held=ctypes.addressof(self.configurations[self.capacity]), saved=self.saved.ctypes.data,
                             cable_states=self.cable_states.ctypes.data,
                             controller_states=self.controller_states.ctypes.data,
                             controller_outputs=self.controller_outputs.ctypes.data)
        self.reference = ctypes.addressof(self.data)
        self.sections = self.joints = self.cables = self.controllers = self.outputs = False

    def plan(self, rows: list[int], momentum: bool, sections: bool, joints: bool = False,
             cables: bool = False, controller_states: bool = False, controller_outputs: bool = False) -> None:
        if len(rows) > self.capacity:
            raise ValueError(f"{len(rows)} rows planned, the buffers hold {self.capacity}")
        self.grid_point[:len(rows)] = rows
        self.data.planned, self.data.recorded = len(rows), 0
        self.joints, self.cables = joints and self.n_joints > 0, cables and self.n_cables > 0
        self.data.momentum, self.data.sections = int(momentum), int(sections)
        self.data.joints, self.data.cables = int(self.joints), int(self.cables)
        self.controllers = controller_states and self.n_controller_values > 0
        self.data.controller_values = self.n_controller_values if self.controllers else 0
        self.outputs = controller_outputs and self.n_output_values > 0
        self.data.output_values = self.n_output_values if self.outputs else 0
        self.sections = sections

    def block(self) -> RowBlock:
        k = self.data.recorded
        states = self.state_buffer[:k]
        arrays = [states[:, start:stop].reshape(k, *shape) for start, stop, shape in self.slices]
        return RowBlock(self.scalars[:k], State(self.scalars[:k, 0], *arrays),
                        self.section_forces[:k, :self.n_elements] if self.sections else None,
                        self.joint_forces[:k] if self.joints else None,
                        self.cable_states[:k] if self.cables else None,
                        self.controller_states[:k] if self.controllers else None,
                        self.controller_outputs[:k] if self.outputs else None)


class _LastEvaluation:
    """What the time loop reads of the last Newton evaluation: the reaction on the
    constrained coordinates, the point loads' power, the hinges' work and damper torques and the
    cables' [ℓ, L0, ∂U/∂L0, f] (the residual only on failure)."""

    def __init__(self, total, n, n_total, external_power, buffers):
        self.reaction = total[n:n_total].copy()
        self.external_power = external_power
        self.hinge_work_torque = buffers["hinge_work_torque"].copy()
        self.hinge_damper_torque = buffers["hinge_damper_torque"].copy()
        self.cable_work = buffers["cable_work"].copy()


# ----------------------------------------------------------------------------- the static mode
@record
class StaticIteration:
    """One static iteration at a state (:meth:`StaticNewton.iteration`): r(q, λ), q_ref(q) (None
    unless asked for), δq_r = −K⁻¹r, δq_λ = K⁻¹q_ref; None in their place where K is singular or a
    solution not finite. ``size``: increment_size(δq_r)."""
    residual: np.ndarray
    reference: np.ndarray | None
    dq_r: np.ndarray | None
    dq_lambda: np.ndarray | None
    size: float


class StaticNewton:
    """The static mode of the native Newton iteration (``latdyn_static_iteration`` and
    ``latdyn_static_newton`` of csrc/newton_step.c): the static residual r(q, λ) at t = 0 without
    inertia, K = ∂r/∂q scattered into the time step's matrix storage (:func:`hold_matrix`, β′ = γ′ = 0,
    rigid links reduced as the step reduces them), factorized and solved by the step's LU, and the
    step's convergence test (increment_size). latdyn/analyses/continuation.py drives it: load control
    runs its whole Newton at a fixed load factor in one call, arc length and displacement control one
    call per iteration (their bordered update is two right-hand sides of the one factorization).

    A sparse LU whose static pivots fail (:class:`~latdyn.assembly.sparse_lu.PivotError`) has no
    fallback in C: such an iteration is solved from Python by :class:`Factorization` (its pivoted
    band LU stands in), with the same evaluation."""

    def __init__(self, assembler, tol: float, max_iterations: int, length_scale: float):
        self.assembler = assembler
        self.control = StaticControlData(tol=tol, length=length_scale, max_iterations=max_iterations)
        self._library = native_library()
        self._setup_for = None

    def _setup(self):
        native = self.assembler.native()
        if self._setup_for is not native:
            self._setup_for = native
            self.factorization = hold_matrix(self.assembler, native)
            self._out = np.zeros(6 * max(self.assembler.model.n_dofs, 1))
        return native

    def iteration(self, state, load_factor: float, reference: bool = True) -> StaticIteration:
        """r, q_ref, δq_r, δq_λ at ``state`` and λ (one evaluation at λ with K, one at λ + 1 for q_ref);
        the dependent nodes of rigid links in ``state`` are completed first, in place."""
        native = self._setup()
        n = self.assembler.model.n_dofs
        control = self.control
        control.load_factor, control.reference = float(load_factor), int(reference)
        native.laws.bind_inputs()
        status = self._library.latdyn_static_iteration(native.model_ref, native.work_ref, ctypes.byref(control),
                                                       ctypes.byref(native.configuration(state)),
                                                       self._out.ctypes.data)
        native._written_back(state)  # the dependent nodes of rigid links completed (the same values)
        out = self._out
        residual, q_ref = out[:n].copy(), (out[n:2 * n].copy() if reference else None)
        if status == 1 and self.factorization.kind == "sparse":
            return self._pivoted(state, load_factor, residual, q_ref)
        if status:
            return StaticIteration(residual, q_ref, None, None, math.inf)
        return StaticIteration(residual, q_ref, out[2 * n:3 * n].copy(),
                               out[3 * n:4 * n].copy() if reference else None, float(control.size))

    def _pivoted(self, state, load_factor: float, residual, q_ref) -> StaticIteration:
        """An iteration whose sparse LU failed on its static pivots, solved by :class:`Factorization`."""
        from latdyn.assembly.factorization import solve_linear

        K = self.assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False).stiffness
        rhs = np.column_stack([-residual] + ([q_ref] if q_ref is not None else []))
        try:
            x = solve_linear(K, rhs)
        except np.linalg.LinAlgError:
            return StaticIteration(residual, q_ref, None, None, math.inf)
        if not np.all(np.isfinite(x)):
            return StaticIteration(residual, q_ref, None, None, math.inf)
        dq_r = x[:, 0].copy()
        return StaticIteration(residual, q_ref, dq_r, x[:, 1].copy() if q_ref is not None else None,
                               self.increment_size(dq_r))

    def tangent(self, state, load_factor: float):
        """K(q, λ) at ``state`` as a matrix: in the dense storage, the matrix the static iteration
        assembles there (copied before it is factorized); in the band and sparse storages, the
        evaluation's from Python (:meth:`Assembler.evaluate`)."""
        self._setup()
        n = self.assembler.model.n_dofs
        if self.factorization.kind != "dense" or n == 0:
            return self.assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False).stiffness
        copy = np.empty(self.factorization.size)
        self.control.matrix_copy = copy.ctypes.data
        try:
            self.iteration(state, load_factor, reference=False)
        finally:
            self.control.matrix_copy = None
        return copy.reshape((n, n), order="F")

    def newton(self, state, load_factor: float) -> tuple[object, np.ndarray, int, bool]:
        """Newton at the fixed load factor λ from ``state`` in one call (q ← q ∘ exp(δq_r) until
        increment_size(δq_r) ≤ tol): (the state reached, the last residual, iterations, converged)."""
        native = self._setup()
        n = self.assembler.model.n_dofs
        trial = state.copy()
        trial.t = 0.0
        control = self.control
        control.load_factor = float(load_factor)
        native.laws.bind_inputs()
        configuration = native.configuration(trial)
        status = self._library.latdyn_static_newton(native.model_ref, native.work_ref, ctypes.byref(control),
                                                    ctypes.byref(configuration), self._out.ctypes.data)
        native._written_back(trial)
        residual = self._out[:n].copy()
        if status == 1 and self.factorization.kind == "sparse":
            return self.newton_from_python(trial, load_factor, int(control.iterations))
        return trial, residual, int(control.iterations), bool(control.converged) and not status

    def newton_from_python(self, trial, load_factor: float, done: int = 0):
        """:meth:`newton` on from ``trial`` after ``done`` iterations, one :meth:`iteration` a call (the
        same update and test; where the sparse LU's static pivots failed, :meth:`_pivoted` solves)."""
        residual = None
        for iteration in range(done + 1, int(self.control.max_iterations) + 1):
            step = self.iteration(trial, load_factor, reference=False)
            residual = step.residual
            if self.assembler.model.n_dofs == 0:
                return trial, residual, iteration - 1, True
            if step.dq_r is None:
                return trial, residual, iteration - 1, False
            trial = self.assembler.advance(trial, step.dq_r)
            if step.size <= self.control.tol:
                return trial, residual, iteration, True
        return trial, residual, int(self.control.max_iterations), False

    def increment_size(self, dx: np.ndarray) -> float:
        """The time step's convergence measure of an increment (:func:`latdyn.step.integrators.increment_size`)."""
        return increment_size(self.assembler, np.asarray(dx, dtype=float), float(self.control.length))
