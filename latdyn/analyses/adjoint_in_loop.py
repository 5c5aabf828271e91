"""The discrete adjoint's forward pass inside the loop of steps in C, and its reverse pass's smooth steps in one native
call each (issue 34, item 6).

The adjoint (:mod:`latdyn.analyses.adjoint_sensitivities`) differentiates nothing on its forward pass: it stores,
per accepted step, the end state, the step's size and the algorithmic accelerations before and after it
(:meth:`AdjointSensitivities.step`), which its reverse pass reads. Taken from Python, that forward pass cost every
step its round trip (latdyn/timeloop/loop.py ``_python_step``). Here the loop of steps (csrc/newton_step.c
``latdyn_advance``) stores each step it accepts into blocks (csrc/adjoint_trajectory.c), and :meth:`AdjointLoop.carried_after`
turns them into the entries the Python path appends — the same states (the loop's Newton step is the Python
path's compiled step), sizes and accelerations, and where the scene has events the numbering the step was taken on and
the rule of its size's derivative (:meth:`AdjointSensitivities._size_rule` for a step landing on the grid).
Its rows are recorded on the loop's way (csrc/rows.c), each the index of the stored state it is
(:meth:`AdjointLoop.record_rows`). Every event, landing, Newton cut and the step after them takes the Python path as
before. The runs whose every step
is taken from Python are those the forward method's loop refuses whatever their parameters' kinds
(:func:`latdyn.analyses.sensitivities_in_loop.model_refusal`: controllers with states and sampled controllers —
continuous ones without states are taken, the loop evaluating them as the run without sensitivities does —, external
work or dissipated energy probes, NumPy kernels; the energies of the state, the momenta and geometry parameters are
taken, and explicit time dependence
beside events: the loop starts from a grid point, where δt is 0, and the steps whose end moves in time come from
Python) and those with cables, which :func:`refusal` refuses itself: decided once, at the start. On a model with
rigid links or guides the loop's step is the compiled step's reduction, as the forward method's loop takes it (its
stored state has the dependent nodes completed).

The reverse pass (:meth:`AdjointSensitivities._reverse_columns`) takes each smooth step — no event at its end, a size
that does not move with the parameters — in one call of csrc/adjoint_reverse.c (:class:`ReverseSteps`): M, C and the
exact K at the stored state, S factorised on its held pattern and storage, w = S⁻ᵀz̄ and the bars carried back, the
sums in NumPy's and SciPy's order; the contraction (∂r/∂p)ᵀw stays :meth:`AdjointSensitivities.residual_transposed_product`
(every parameter kind), and the events' pieces and the steps whose size moves stay on the NumPy path; a numbering
whose S takes the sparse LU is taken natively too, with the band LU with pivoting where a sparse pivot fails
(Factorization._factor_pivoted's, as the NumPy path's: sensitivities_in_loop.SensitivityLoop._pivoted). With rigid
links or guides M, C and the exact K are the compiled step's reduction on the minimum coordinates
(csrc/linked_matrices.c ``latdyn_linked_exact_values``, as the forward method's step: S on its dense pattern, or
above DENSE_LIMIT coordinates or on a sparse storage its reduced pattern; the NumPy path takes the same values,
``Assembler.linked_exact_matrix_values``, AdjointSensitivities._transposed_step_system); (∂r/∂p)ᵀw there is the
reduced ∂r/∂p's product, that ∂r/∂p left by the same native call where the forward method's loop would differentiate
the run (csrc/sensitivity_loop.c ``parameter_columns``: :class:`ReverseSteps`), else formed from Python. For the same
runs (:func:`refusal`).

The derivatives are those of the Python and NumPy paths to the bit (``ADJOINT_IN_LOOP`` and ``REVERSE_NATIVE`` off:
tests/test_adjoint_in_loop.py, tests/test_adjoint_in_loop_links.py; docs/performance.md, "The adjoint's passes in C",
"The adjoint on linked models in the loop of steps (issue 34)").
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import State
from latdyn.assembly.native_model import STATE_FIELDS, state_shapes

__all__ = ["ADJOINT_IN_LOOP", "REVERSE_NATIVE", "AdjointLoop", "ReverseSteps", "accepted", "refusal", "reverse_steps"]

#: Whether the adjoint's forward pass takes its smooth steps in the loop of steps where the run allows it (False:
#: every step from Python, the reference it must equal: tests/test_adjoint_in_loop.py). Private.
ADJOINT_IN_LOOP = True


def refusal(owner) -> str | None:
    """Why the forward pass of ``owner`` (an AdjointSensitivities) takes every step from Python, or None
    (module docstring). Once a run."""
    from latdyn.analyses.sensitivities_in_loop import model_refusal

    if owner.model.cables is not None:   # the forward step's loop takes them (csrc/cable_forces.c); this pass not yet
        return "cables"
    # laws in t beside events: the loop takes its steps from a grid point (δt = 0 there, each step's ∂r/∂t δt_n
    # nothing), the steps whose end moves in time come from Python (latdyn/analyses/adjoint_time.py)
    # continuous controllers without states: the loop evaluates them as the run without sensitivities does, and
    # neither pass keeps anything of theirs per step (their parameters' part is ∂r/∂p's, contracted as the others')
    return model_refusal(owner, timed=True, continuous_controllers=True)


def accepted(trajectory: list) -> list:
    """``trajectory`` without a last entry still pending (stored by :meth:`AdjointSensitivities.step`, its events
    not taken: the run failed in them)."""
    return trajectory[:-1] if trajectory and trajectory[-1].get("pending") else trajectory


class AdjointLoop:
    """The ``Trajectory`` blocks of csrc/adjoint_trajectory.c for ``owner``'s forward pass: sized before a call of the
    loop of steps (:meth:`prepared`), turned into the trajectory's entries after it (:meth:`carried_after`)."""

    def __init__(self, owner):
        from latdyn.assembly.library import TrajectoryData

        self.owner = owner
        self.data = TrajectoryData()
        self._blocks = None
        #: steps stored by the last call of the loop of steps (:meth:`steps_in_call`)
        self._stored = 0

    def prepared(self, carried: dict, grid_index: int, stop_index: int, control, rows: int = 0, state=None):
        """The blocks sized for a loop of steps from grid point ``grid_index`` (``state``: the state there, which the
        forward method's SensitivityLoop.prepared reads) through ``stop_index``; None where this
        step takes the Python path: no free coordinates, a last entry still pending (a run resumed from before its
        events), or with events a next step's size that moves with the parameters (the Python path's
        :meth:`AdjointSensitivities.resized` follows it, or refuses it)."""
        owner = self.owner
        model = owner.model
        if model.n_dofs == 0:
            return None
        trajectory = carried["trajectory"]
        if trajectory and trajectory[-1].get("pending"):
            return None
        if owner._with_events() and tuple(carried.get("next_size", (0.0, 0.0))) != (0.0, 0.0):   # noqa: SLF001
            return None
        capacity, n = max(stop_index - grid_index, 0), model.n_dofs
        shapes = state_shapes(model)
        sizes = [int(np.prod(shapes[name])) for name in STATE_FIELDS]
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        state_size = int(sum(sizes))
        blocks = {"offsets": offsets, "states": np.zeros((max(capacity, 1), state_size)),
                  "times": np.zeros(max(capacity, 1)), "sizes": np.zeros(max(capacity, 1)),
                  "a_old": np.zeros((max(capacity, 1), n)), "a_new": np.zeros((max(capacity, 1), n))}
        self._blocks = (blocks, shapes, sizes)
        d = self.data
        d.capacity, d.state_size, d.stored = capacity, state_size, 0
        for name, array in blocks.items():
            setattr(d, name, array.ctypes.data)
        return d

    def record_rows(self, carried: dict, block, rows: int) -> dict:
        """``carried`` with the first ``rows`` rows the last call of the loop of steps recorded on its way
        (``block``: a step.compiled.RowBlock), each as :meth:`AdjointSensitivities.record` records a row: the index
        of the stored state it is, the loop's steps up to it after the trajectory before the loop (whose entries
        :meth:`carried_after` appends next)."""
        before = len(accepted(carried["trajectory"]))
        carried["rows"].extend(before + int(steps) for steps in block.column("steps")[:rows])
        return carried

    def steps_in_call(self) -> int:
        """The steps the last call of the loop of steps stored (the run's count, summary.json
        ``sensitivity_steps_in_loop``, is carried by the checkpoint: TransientProgress)."""
        return self._stored

    def carried_after(self, carried: dict) -> dict:
        """``carried`` with the loop's accepted steps appended to its trajectory, each entry as
        :meth:`AdjointSensitivities.step` and :meth:`AdjointSensitivities.after_events` leave it for a step that lands on
        the grid with no event, and with events the next size's coefficients as :meth:`AdjointSensitivities.resized`
        leaves them after such a step (the control restarts at the nominal step: 0, 0)."""
        owner, d = self.owner, self.data
        stored = self._stored = int(d.stored)
        if stored == 0:
            return carried
        blocks, shapes, sizes = self._blocks
        self._blocks = None   # the entries hold views of these blocks: the next loop gets its own
        bounds = np.concatenate([[0], np.cumsum(sizes)])
        events = owner._with_events()   # noqa: SLF001
        trajectory = carried["trajectory"]
        for i in range(stored):
            row = blocks["states"][i]
            state = State(float(blocks["times"][i]), *(row[bounds[f]:bounds[f + 1]].reshape(shapes[name])
                                                        for f, name in enumerate(STATE_FIELDS)))
            h = float(blocks["sizes"][i])
            entry = {"state": state, "h": h, "a_old": blocks["a_old"][i], "a_new": blocks["a_new"][i]}
            if events:
                entry.update({"numbering": owner._numbering(), "event": None, "cable": None,   # noqa: SLF001
                              "rule": owner._size_rule(carried, h, True, None, None)})   # noqa: SLF001
                entry["numbering_end"] = owner._numbering()   # noqa: SLF001
                carried["next_size"] = (0.0, 0.0)
            trajectory.append(entry)
        return carried


#: Whether the reverse pass takes its smooth steps in one native call each where the run allows it (False: from
#: NumPy and SciPy, the reference it must equal: tests/test_adjoint_in_loop.py). Private.
REVERSE_NATIVE = True


class ReverseSteps:
    """The reverse pass's smooth steps in one native call each (csrc/adjoint_reverse.c ``latdyn_adjoint_reverse_step``:
    M, C, the exact K, S factorised, w = S⁻ᵀz̄ and the bars carried back), for ``owner``'s runs that
    :func:`refusal` lets through. Laid out per numbering as the forward method's loop lays out its struct
    (:class:`latdyn.analyses.sensitivities_in_loop.SensitivityLoop`), on the sparse LU too (a failed pivot: the band
    LU that stands in, as on the NumPy path). The contraction with ∂r/∂p: on a model with rigid links or guides whose
    parameters the forward method's loop differentiates in C (``sensitivities_in_loop.refusal`` None), the reduced
    ∂r/∂p that loop forms (csrc/sensitivity_loop.c ``parameter_columns``, in the same call, the derivative laws'
    values of t tabulated at the stored states' times, ``times``), contracted here
    (:meth:`residual_transposed_product`: the Python path's ``residual_derivatives(…).T @ w`` on the same array, to
    the bit); else the caller's (:meth:`AdjointSensitivities.residual_transposed_product`), and the layout without
    the parameters' section and load parts."""

    def __init__(self, owner, times: list):
        from latdyn.analyses import sensitivities_in_loop

        class _Layout(sensitivities_in_loop.SensitivityLoop):   # the step's matrices and S; no section or load
            def _sections(self) -> None:                          # forces (the caller contracts)
                self.data.n_uses = 0

            def _loads(self) -> None:
                self.data.n_pairs = 0

        self.owner = owner
        #: whether each native step leaves the reduced ∂r/∂p for :meth:`residual_transposed_product`
        self.contracts = owner.model.links is not None and sensitivities_in_loop.refusal(owner) is None
        self.layout = (sensitivities_in_loop.SensitivityLoop if self.contracts else _Layout)(owner)
        self._times = list(times)   # row i of the laws' tables: the stored state i + 1's time
        self._tabulated_for = None
        self._scheme = None
        self._work = np.zeros(0)
        self._grid = -1
        #: reverse steps taken natively over the run
        self.steps = 0

    def step(self, new, h: float, rotations: tuple, bars: list, stored: int):
        """w (n, m) of the reverse step at the stored end state ``new`` (the trajectory's entry ``stored``) of a step
        of size ``h`` (``rotations``: its (J, Jᵀ, Rᵀ) operators), ``bars`` [q̄, v̄, v̇̄, ā] replaced by their values
        before the step; None where this numbering takes the NumPy path (nothing changed). A singular S raises
        SolverError as that path does."""
        import ctypes

        from latdyn.errors import SolverError

        layout, owner = self.layout, self.owner
        if not layout._layout():   # noqa: SLF001 - per numbering
            return None
        if self.contracts and self._tabulated_for is not layout._for:   # noqa: SLF001 - a numbering's layout: its
            layout.tabulate_at(self._times, 0)                         # uses' tables at the stored states' times
            self._tabulated_for = layout._for   # noqa: SLF001
        if self.contracts and (layout.data.n_partials or layout.data.n_hinge_uses):   # the inputs and controllers'
            if layout.data.n_partials:                                                # outputs their laws read
                owner.controllers.compiled.bind()
            if owner.derivative_laws is not None:
                owner.derivative_laws.bind()
        self._grid = stored if self.contracts else -1
        tangent, tangent_t, turn_t = rotations
        n, m = owner.model.n_dofs, bars[0].shape[1]
        for index, bar in enumerate(bars):
            bars[index] = np.ascontiguousarray(bar, dtype=float)
        if self._scheme is None:
            p = owner.params
            self._scheme = np.array([p.alpha_m, p.alpha_f, p.gamma, p.beta])
        if self._work.size < 5 * n * m:
            self._work = np.zeros(5 * n * m)
        w = np.empty((n, m))
        d = layout.data
        if getattr(tangent, "is_identity", False):
            f, blocks, blocks_t, turned_t = 0, d.blocks, d.blocks, d.blocks
        else:
            f = len(tangent.blocks)
            held = [np.ascontiguousarray(b, dtype=float) for b in (tangent.blocks, tangent_t.blocks, turn_t.blocks)]
            self._held = held
            blocks, blocks_t, turned_t = (b.ctypes.data for b in held)
        owner.assembler.complete_links(new)   # rigid links or guides: as Assembler.linked_exact_matrix_values
        native = owner.assembler.native(True)
        native.laws.bind_inputs()
        info = native.library.latdyn_adjoint_reverse_step(
            native.model_ref, native.work_ref, ctypes.addressof(d), ctypes.byref(native.configuration(new)),
            float(new.t), float(h), self._scheme.ctypes.data, m, f, blocks, blocks_t, turned_t,
            *(bar.ctypes.data for bar in bars), w.ctypes.data, self._work.ctypes.data, self._grid)
        if info != 0:
            raise SolverError(f"the adjoint sensitivities at t = {new.t:.6g} need the step's exact iteration "
                              "matrix, which is singular there")
        self.steps += 1
        return w

    def residual_transposed_product(self, w: np.ndarray):
        """(k, m): (∂r/∂p)ᵀ w of the last :meth:`step`, from the reduced ∂r/∂p it left (the forward method's loop's
        columns, ``parameter_columns``), as the Python path contracts the same array
        (AdjointSensitivities.residual_transposed_product); None where the caller contracts (:attr:`contracts`)."""
        if self._grid < 0:
            return None
        owner = self.owner
        n, k = owner.model.n_dofs, len(owner.names)
        return self.layout._buffers["total"].reshape(owner.model.n_total + 1, k)[:n].T @ w   # noqa: SLF001


def reverse_steps(owner, times: list):
    """:class:`ReverseSteps` for ``owner`` (an AdjointSensitivities; ``times``: its stored states' after the start),
    or None where its reverse pass takes every step from NumPy and SciPy (:func:`refusal`, or the private switch
    off). Once a run."""
    if not REVERSE_NATIVE or refusal(owner) is not None:
        return None
    return ReverseSteps(owner, times)
