"""What the time loop carries from one step to the next (checkpointed): the state, the step size,
the work and energy bookkeeping and the counters; the reports of cut steps."""
from __future__ import annotations

import math
import sys
from dataclasses import field

import numpy as np

from latdyn.assembly.assembler import State
from latdyn.assembly.library import native_library
from latdyn.records import record


#: strains of this many ulps: the round-off of a beam's configuration (:func:`energy_round_off`)
ROUND_OFF_ULPS = 8.0


def energy_round_off(model) -> float:
    """The strain energy of strains of :data:`ROUND_OFF_ULPS` ulps in every element, ½ Σ EA L (8 ε)²:
    what a structure at rest holds by round-off alone (a beam in its reference configuration computes
    strain energies of 1e-29 J and axial forces of 1e-10 N, not 0). Energies received up to it are
    none to the energy balance's unbounded test (docs/energy.md)."""
    sections, strain = model.element_sections, ROUND_OFF_ULPS * np.finfo(float).eps
    return float(0.5 * np.sum(np.abs(sections[:, 0] * sections[:, 1])) * strain * strain)


@record
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
    locked: np.ndarray  # latched hinges (and hinges stuck by friction)
    h: float  # step size to try next
    grid_index: int = 0  # nominal steps completed
    output_index: int = 1  # next recorded time is output_index · every
    external_work: float = 0.0
    power: float = 0.0  # power of the point loads at state.t
    #: the reactions of the prescribed motions at state.t, by prescribed coordinate (:func:`drive_forces`)
    drive_force: np.ndarray | None = None
    #: declared dissipation since t = 0: impacts on stops, latches and sticking (the energy each event
    #: removed, latdyn.timeloop.events.hinge_events), hinge dampers, compliant stops' damping and
    #: friction (∫ f dθ of their dissipative torque f over each step, :func:`hinge_work`) and cable
    #: dampers (∫ f dℓ over each step, :func:`cable_work`)
    dissipated: float = 0.0
    #: per cable element at state.t (ce, 4): [ℓ, L0, ∂U/∂L0, f] (:func:`cable_work`)
    cable_work: np.ndarray | None = None
    #: per hinge at state.t: the torque that does external work (with a continuous controller's
    #: output) and the dissipative torque (c θ̇, a compliant stop's damping, friction) (:func:`hinge_work`)
    hinge_work_torque: np.ndarray | None = None
    hinge_damper_torque: np.ndarray | None = None
    total0: float = 0.0  # kinetic + strain + potential at t = 0
    potential0: float = 0.0
    #: the energy the structure received (docs/energy.md): kinetic + strain at t = 0 (with a floor
    #: of 1e-8 |potential| at t = 0, the round-off of the energies), the largest |external work| and
    #: the largest |potential change| seen
    received0: float = 0.0
    #: the round-off of the energies of a structure at rest (:func:`energy_round_off`): received energy
    #: up to it is none (a beam's strain energy of 1e-29 J in its reference configuration)
    round_off: float = 0.0
    work_seen: float = 0.0
    potential_seen: float = 0.0
    balance_error: float = 0.0  # max |total − total0 − external_work + dissipated| over the rows
    energy_scale: float = 0.0  # max of kinetic, strain, |potential change|, |external work|, dissipated
    #: max of kinetic, strain, |potential change| and dissipated energy (what the structure held or dissipated)
    held_scale: float = 0.0
    balance_error_t: float | None = None  # the time of the row with the largest balance error
    #: consecutive rows, up to the last, whose energy gain passed :data:`UNBOUNDED` with the energy
    #: the integrator created growing from the row before (:meth:`balance`, :data:`UNBOUNDED_ROWS`)
    gain_rows: int = 0
    created: float = 0.0  # the energy the integrator created, at the last row
    steps: int = 0
    newton_iterations: int = 0
    rejected_steps: int = 0  # all rejected attempts: Newton failures and error-control rejections
    newton_cuts: int = 0  # steps halved because Newton did not converge
    far_roots: int = 0  # steps halved because Newton converged to a root a whole turn away (far_root)
    #: the sensitivities' smooth steps differentiated in the loop of steps in C (summary.json
    #: ``sensitivity_steps_in_loop``; here, not in the loop's own counter, so that a resumed run counts the run's)
    sensitivity_steps_in_loop: int = 0
    factorizations: int = 0  # iteration matrices factorized (modified Newton keeps one over steps)
    solver_s: float = 0.0  # wall time inside the integrator's steps
    cut_times: list = field(default_factory=list)  # the first times at which a step was cut
    #: summary.json ``joint_peaks``: {joint: {"peak": the force (torque) of largest magnitude the joint
    #: applied on its coordinate at a recorded row, signed, "t": its first time}} (:meth:`note_joint_forces`)
    joint_peaks: dict = field(default_factory=dict)
    inertia_tangent_from: float | None = None  # t from which Newton's matrix holds the inertia tangent
    #: the controllers' held outputs and states after the last sample (latdyn.timeloop.sampling;
    #: replaced, never changed in place, so that a kept copy of the progress keeps its own)
    controller_memory: np.ndarray | None = None
    stuck: np.ndarray | None = None  # the locked hinges that stick by friction (None: none)
    resting: np.ndarray | None = None  # the side of the rigid stop each locked hinge rests on (0: none)
    #: the events so far, summary.json ``events``: {joint, kind: latch|stop|slack|taut, t}, in time order
    #: (a new list on each event: checkpoints keep shallow copies)
    events: list = field(default_factory=list)
    #: per cable element, +1 taut or −1 slack at ``state`` (latdyn.timeloop.events.cable_events); None
    #: until the first step of a model with cables
    cable_sides: list | None = None
    #: solve.sensitivities of a transient run (latdyn/analyses/transient_sensitivities.py): δq, δv, δv̇, δa
    #: on the free coordinates (n, k) and the recorded rows; replaced, never changed in place
    sensitivities: dict | None = None
    #: per hinge (n_hinges, 6): the largest angle by which an accepted step's change of the hinge's rate
    #: turned it over the step, h |θ̇_{n+1} − θ̇_n|, with that step's end time and size, then the first past
    #: :data:`UNRESOLVED_TURN` with its (:meth:`note_rate_turns`; csrc/newton_step.c rate_turns for the
    #: steps taken in C); None until the first step
    rate_turns: np.ndarray | None = None
    #: the first landing whose step kept ended short of the event its trial crossed, as its warning says it
    #: (latdyn.timeloop.loop.TimeLoop._landing: closed less than half the gap); None: none
    short_landing: str | None = None
    #: steps of a run with solve.sensitivities that the sensitivities' rules took otherwise than a run without them
    #: would (an event or a cable's change landed on to 1e-12, or the step after one or after a step onto the grid
    #: restarted at dt where the run without would grow back from a shorter one: latdyn.timeloop.loop.TimeLoop._accept)
    steps_for_sensitivities: int = 0

    def count(self, stats) -> None:
        """Count a step's Newton iterations and factorizations (``stats``: a StepStats)."""
        self.newton_iterations += stats.iterations
        self.factorizations += factorizations(stats)

    def balance(self, t: float, energies: dict, external_work: float) -> float:
        """Take the energies of the row at ``t`` into the energy balance (docs/energy.md). Returns
        the energy gain that :data:`UNBOUNDED` judges, relative to the energy the structure received
        up to this row (:attr:`received0`, :attr:`work_seen`, :attr:`potential_seen`): the smaller
        of the energy the integrator created, total − total0 − external_work + dissipated, and the
        energy the structure gained, total − total0 + dissipated (so that noise in the work of a
        structure that holds no energy is not taken for a gain); NaN when an energy is not finite,
        0 when the structure received nothing, or no more than :attr:`round_off` (it is then judged
        on finite energies alone). Counts
        :attr:`gain_rows`: a gain past :data:`UNBOUNDED` with the created energy grown since the
        row before extends the streak, any other row ends it."""
        gained = sum(energies.values()) - self.total0 + self.dissipated
        created = gained - external_work
        potential_change = abs(energies["potential"] - self.potential0)
        self.held_scale = max(self.held_scale, energies["kinetic"], energies["strain"], potential_change,
                              self.dissipated)
        self.energy_scale = max(self.energy_scale, self.held_scale, abs(external_work))
        if abs(created) > self.balance_error:
            self.balance_error, self.balance_error_t = abs(created), float(t)
        self.work_seen = max(self.work_seen, abs(external_work))
        self.potential_seen = max(self.potential_seen, potential_change)
        received = self.received0 + self.work_seen + self.potential_seen
        if not math.isfinite(created):
            self.created = math.nan
            return math.nan
        gain = min(created, gained) / received if received > self.round_off else 0.0
        self.gain_rows = self.gain_rows + 1 if gain > UNBOUNDED and created > self.created else 0
        self.created = created
        return gain

    @property
    def unbounded(self) -> bool:
        """Whether the balance has broken (docs/energy.md): the energy gain of the last row is not
        finite, or it passed :data:`UNBOUNDED`, growing, at :data:`UNBOUNDED_ROWS` rows in a row."""
        return not math.isfinite(self.created) or self.gain_rows >= UNBOUNDED_ROWS

    @property
    def relative_balance_error(self) -> float:
        """``energy_balance_error`` of summary.json: max |total − total0 − external_work + dissipated|
        over the rows, divided by the largest of kinetic, strain, |potential change|, |external work|
        and dissipated energy seen; 0 where those stayed within the round-off of a structure at rest
        (:attr:`round_off`), whose balance is round-off over round-off, and where the structure held and
        dissipated nothing beyond it (:attr:`held_scale`): its created energy is then −external_work, so the
        ratio is 1 whatever the work, which equilibrium makes the round-off and the Newton tolerance of the
        applied forces' work (a massless slide held by a controller's negative stiffness, ∫ 0 ds: 4e-19 J
        "created" of 4e-19 J, tests/test_fuzz_run_findings6.py)."""
        if self.energy_scale <= self.round_off or self.held_scale <= self.round_off:
            return 0.0
        return self.balance_error / self.energy_scale

    def note_joint_forces(self, names, forces, t: float) -> None:
        """Keep each joint's peak force (:attr:`joint_peaks`) with the forces at the row at ``t``.

        A later row takes the peak only when it is larger by more than round-off
        (:data:`PEAK_ROUND_OFF` relative): a load held constant (a latch's reaction) has its peak at
        the first row that carries it, not at a later row whose last digit happens to be larger."""
        for name, value in zip(names, forces):
            peak = self.joint_peaks.get(name)
            if peak is None or abs(value) > abs(peak["peak"]) * (1.0 + PEAK_ROUND_OFF):
                self.joint_peaks[name] = {"peak": float(value), "t": float(t)}

    def note_rate_turns(self, native, old: State, new: State, h: float) -> None:
        """Keep each free hinge's largest h |θ̇_{n+1} − θ̇_n| (:attr:`rate_turns`) with the step ``old`` → ``new``
        of size ``h``, accepted from Python without an event (a stop's or latch's jump of the rate is on
        purpose, and not the step's): csrc/newton_step.c rate_turns, the loop of steps' own, through ``native``
        (:class:`latdyn.assembly.native_model.NativeModel`, the current numbering's)."""
        turns = self.kept_rate_turns(len(new.theta)).copy()
        native.rate_turns(old, new, h, UNRESOLVED_TURN, turns)
        self.rate_turns = turns

    def kept_rate_turns(self, n_hinges: int) -> np.ndarray:
        """:attr:`rate_turns`, made (zeros) at the first step (replaced, never changed in place: a copy of
        the progress kept as a checkpoint holds its own)."""
        if self.rate_turns is None or self.rate_turns.shape != (n_hinges, 6):
            self.rate_turns = np.zeros((n_hinges, 6))
        return self.rate_turns

    def unresolved_hinges(self, names, until: float = math.inf, first: bool = False) -> list[str]:
        """Warnings for the hinges whose largest :attr:`rate_turns` passed :data:`UNRESOLVED_TURN` (``first``:
        told by the first step past it, which a failure that follows is named by, the earliest hinge first;
        at a step ending no later than ``until``): the step did not resolve their motion (docs/energy.md, "Steps that do not resolve
        a hinge")."""
        warnings = []
        kept = self.rate_turns if self.rate_turns is not None else np.zeros((0, 6))
        for name, (turn, t, h) in zip(names, kept[:, 3:] if first else kept[:, :3]):
            if turn > UNRESOLVED_TURN and t <= until:
                warnings.append((t if first else 0.0,
                    f"hinge {name} is not resolved by the step: its rate changed by {turn / h:.4g} rad/s over the "
                    f"step of {h:.3g} s ending at t = {t:.6g}, which turns it by {turn:.3g} rad (> {UNRESOLVED_TURN:g}) "
                    f"over the step; its motion there (a fast swing, or a flip of the coordinates near a singular position "
                    f"such as gimbal lock) is not resolved and the results after it may be far off: "
                    f"rerun with a smaller dt (or error_tol, adaptive)"))
        return [warning for _, warning in sorted(warnings, key=lambda kept: kept[0])]  # first: earliest first

    def summary(self, tol: float, method: str) -> dict:
        """The counters and the energy balance, as summary.json reports them."""
        return dict(
            steps=self.steps, newton_iterations=self.newton_iterations, rejected_steps=self.rejected_steps,
            newton_cuts=self.newton_cuts, cut_times=self.cut_times, far_roots=self.far_roots,
            energy_balance_error=self.relative_balance_error, dissipated_energy=self.dissipated,
            newton_iterations_per_step=self.newton_iterations / max(self.steps, 1),
            newton_tolerance=tol, method=method, solver_s=self.solver_s, factorizations=self.factorizations,
            inertia_tangent_from=self.inertia_tangent_from, joint_peaks=self.joint_peaks, events=self.events)


def impacts_before(events: list, t: float) -> str:
    """What the drift warning adds where impacts on stops or latches came before the row of the largest balance
    error (``events``: the run's, dicts with "kind" and "t"), else "". An impact's velocity jump is weighted by
    M + dt²K (latdyn/timeloop/impulse.py, docs/energy.md "Impacts on flexible parts with inertia"): on flexible parts
    with inertia a smaller dt makes them less rigid through the jump, so it changes the impact itself and the
    vibration it leaves, whose integration error is what the balance then measures; the rerun at dt/2 does not
    halve that drift. Measured on the slider-crank of tests/test_energy_balance_linked.py (a flexible rod with
    inertia, a slider on stops, restitution 0.5): energy_balance_error 7.9e-5 at dt 0.005, 0.023 at 0.001, 0.050
    at 0.0005, 0.010 at 1e-4, 0.0075 at 2.5e-5, with the events' declared loss equal to the drop of E − W across
    each jump (to the 4 digits compared); the same scene without stops 5.4e-3, 2.2e-4, 5.3e-5 at dt 0.005, 0.001,
    0.0005 (second order), and with the rod's elements without inertia (rigid through the jump) 1.5e-4, 1.9e-5,
    9.8e-6."""
    hits = [e["t"] for e in events if e["kind"] in ("stop", "latch") and e["t"] <= t]
    if not hits:
        return ""
    return (f"; {len(hits)} impact{'s' if len(hits) > 1 else ''} on stops or latches came before it (the first at "
            f"t = {hits[0]:.6g}): an impact's jump is weighted by M + dt²K, so on flexible parts with inertia a "
            f"smaller dt changes the impact itself and the vibration it excites, and the drift need not fall with "
            f"dt (docs/energy.md, \"Impacts on flexible parts with inertia\")")


def far_root(native, old: State, new: State, h: float) -> tuple[int, float] | None:
    """The free hinge (revolute) whose angle at the end of the converged step ``old`` → ``new`` of size ``h`` lies
    farthest from where its rate at the step's start takes it, θ_n + h θ̇_n, and that distance, where it is more
    than π; else None.

    The step's equations hold a hinge's angle through rotations R(a, θ), periodic in 2π, while the rates the step
    gives it (θ̇_{n+1} from θ_{n+1} − θ_n) are not: Newton can converge to a root about a whole turn away, where the
    structure stands nearly where the rate would have put it and the hinge has turned once more within the step, at
    rates of order 2π/h (tests/test_far_roots.py: −6.17 rad where θ_n + h θ̇_n = 0.08, 413 rad/s after a rate of
    3.6, after algorithmic accelerations of undamped Newmark that alternated in sign, up to 1.4e4 rad/s²). A root more
    than π from θ_n + h θ̇_n is nearer to a whole turn of that configuration than to it. A step that resolves the
    hinge's motion departs from it by its quadratic term, ½ h |θ̇_{n+1} − θ̇_n| under Newmark, which the unresolved-step
    warning flags from ½ :data:`UNRESOLVED_TURN`, far below π: such a root is no motion, and the time loop cuts the
    step (:meth:`latdyn.timeloop.control.StepControl.after_far_root`) instead of landing on a stop it crossed.
    The test is csrc/newton_step.c far_root, the loop of steps' own, through ``native`` (the current numbering's
    :class:`latdyn.assembly.native_model.NativeModel`), over the revolute hinges (a guide's slide is not periodic)."""
    return native.far_root(old, new, h)


#: Relative margin by which a row's joint force must exceed the kept peak to replace it in
#: ``joint_peaks`` (round-off of a constant reaction, several times the 2.2e-16 of a double).
PEAK_ROUND_OFF = 1e-12
#: The angle (rad) past which a step's change of a hinge's rate, h |θ̇_{n+1} − θ̇_n|, says the step did not
#: resolve the hinge's motion: a warning on stderr and in summary.json ``warnings`` (docs/energy.md says
#: how it was chosen).
UNRESOLVED_TURN = 0.25
#: ``energy_balance_error`` (relative) past which a run is flagged: a warning on stderr and in
#: summary.json ``warnings`` (docs/energy.md says how it was chosen).
DRIFT_WARNING = 1e-2
#: Energy created by the integrator, relative to the energy scale, past which a run ends as
#: ``unbounded`` (exit status 1; docs/energy.md).
UNBOUNDED = 1.0
#: Consecutive rows at which the gain must pass :data:`UNBOUNDED`, the created energy growing from
#: row to row, before a run ends as ``unbounded``: an instability grows from row to row, while an
#: error of the work's estimate at small energies (the first rows of a run) passes one row and not
#: the next (docs/energy.md).
UNBOUNDED_ROWS = 2


def factorizations(stats) -> int:
    """Iteration matrices a step factorized (StepStats; one per iteration where it does not say)."""
    return stats.iterations if stats.factorizations is None else stats.factorizations


def drive_forces(native, reaction: np.ndarray) -> np.ndarray:
    """The reactions of the prescribed motions by prescribed coordinate (``reaction``: an evaluation's,
    on the constrained coordinates n_dofs … n_total−1): the 6 of each prescribed body's node, in the
    model's order of nodes, then one per hinge or guide (0 where its angle or slide is not prescribed).
    A layout the numbering's changes at events (a latch, a stick) leave alone, so that the reactions at
    a step's start and end pair up (:func:`drive_work`). csrc/newton_step.c drive_forces, the loop of steps'
    own, through ``native`` (the current numbering's :class:`latdyn.assembly.native_model.NativeModel`)."""
    return native.drive_forces(reaction)


def drive_work(native, old: State, new: State, forces_old: np.ndarray, forces_new: np.ndarray,
               external_work: float) -> float:
    """``external_work`` with the work of the prescribed motions over the step from ``old`` to ``new`` added
    (docs/energy.md, "The work of a prescribed motion"): ½(r_n + r_{n+1}) Δq over each prescribed coordinate, with
    the reactions r of :func:`drive_forces` at the step's two ends and Δq the coordinate's change, Δx of a
    prescribed body's point, the spatial rotation vector of T_{n+1} T_nᵀ (the generated ``so3_log_increment``),
    and Δθ (Δs) of a prescribed hinge (guide). The trapezoidal rule in q as :func:`hinge_work`'s in θ: the work
    the discrete step received, where the time trapezoid ½h(r_n·q̇_n + r_{n+1}·q̇_{n+1}) of the power is not (a
    crank brought to 2 rad/s in one step, carrying a free rod, counted 0.014 J of the 1.17 J the rod received, and
    the run ended ``unbounded``). csrc/newton_step.c drive_work, the loop of steps' own, through ``native``."""
    return native.drive_work(old, new, forces_old, forces_new, external_work)


def hinge_work(theta_old: np.ndarray, theta_new: np.ndarray, torques_old: tuple, torques_new: tuple,
               external_work: float, dissipated: float) -> tuple[float, float]:
    """``external_work`` and ``dissipated`` with the work of the hinges' torques over the step from
    the hinge angles ``theta_old`` to ``theta_new`` added (docs/energy.md): ½(τ_n + τ_{n+1}) Δθ of each torque that does external
    work, and ½(c θ̇_n + c θ̇_{n+1}) Δθ of each damper (its declared dissipation); ``torques_*`` are
    (work torques, damper torques) per hinge at each end. The trapezoidal rule in θ, not in time: the
    work ∫ τ dθ the discrete step received whatever the integrator's Δθ is (with generalized-α,
    Δθ ≠ h (θ̇_n + θ̇_{n+1})/2, and the trapezoid of the power τ θ̇ in time is not that work); for
    Newmark's average acceleration and a linear hinge it closes the balance to round-off.
    csrc/newton_step.c hinge_work, the loop of steps' own, through the native library."""
    return _sums(native_library().latdyn_hinge_work, len(theta_new),
                 (theta_old, theta_new, *torques_old, *torques_new), external_work, dissipated)


def cable_work(old: np.ndarray, new: np.ndarray, external_work: float, dissipated: float) -> tuple[float, float]:
    """``external_work`` and ``dissipated`` with the cable elements' work over a step added, from
    [ℓ, L0, ∂U/∂L0, f] of each element at its start (``old``) and end (``new``), (ce, 4) each
    (latdyn.assembly.evaluation.Evaluation.cable_work): ½(r_n + r_{n+1}) ΔL0 of the rest length's
    generalized force r = ∂U/∂L0 (a reel's work, external: U the strain energy) and ½(f_n + f_{n+1}) Δℓ
    of each damper's dissipative force f (c ℓ̇ taut, −N_el while the damper cancels the elastic
    tension, 0 slack). The trapezoidal rule in L0 and ℓ, as :func:`hinge_work`'s in θ: the work the
    discrete step received, which the time trapezoid of the powers r L̇0 and f ℓ̇ is not
    (docs/cables.md measures the two). csrc/newton_step.c cable_work, the loop of steps' own, through the native
    library."""
    return _sums(native_library().latdyn_cable_work, len(new), (old, new), external_work, dissipated)


def _sums(function, count: int, arrays: tuple, external_work: float, dissipated: float) -> tuple[float, float]:
    """(external work, dissipated) after ``function`` (latdyn_hinge_work, latdyn_cable_work) of ``count`` items
    over ``arrays`` added its sums to them."""
    if count == 0:
        return external_work, dissipated
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in arrays]
    sums = np.array([external_work, dissipated], dtype=np.float64)
    function(count, *(a.ctypes.data for a in arrays), sums.ctypes.data, sums[1:].ctypes.data)
    return float(sums[0]), float(sums[1])


#: Cut steps reported on stderr one by one up to this many, then only counted.
CUTS_REPORTED = 10


def report_cut(progress: TransientProgress, t: float, h: float, iterations: int) -> None:
    progress.newton_cuts += 1
    if len(progress.cut_times) < 100:
        progress.cut_times.append(float(t))
    if progress.newton_cuts <= CUTS_REPORTED:
        tail = "" if progress.newton_cuts < CUTS_REPORTED else " (further cuts are only counted in summary.json)"
        print(f"latdyn: Newton did not converge in {iterations} iterations at t = {t:.9g} with step {h:.3g}; "
              f"step cut to {h / 2:.3g}{tail}", file=sys.stderr)
