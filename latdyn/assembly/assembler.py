"""State, element evaluation and sparse assembly (Eqs. 58 and 62, summed over elements).

The equations of motion on the free coordinates are

    r(q, v, v̇, t) = Σ_e L_eᵀ [M_e a_e + g_e + F_e − Q_e^grav] + rigid bodies + hinges − loads = 0

with a_e the element accelerations: free entries from v̇, prescribed ones from
their laws, so prescribed motion drives the inertia forces (it is known
kinematics, not a penalty).  Scatter indices are computed once; element
kernels are called once per evaluation for the whole batch.
"""
from __future__ import annotations

import ctypes
from dataclasses import replace

import numpy as np

from latdyn.assembly.evaluation import Evaluation
from latdyn.assembly.initial import initial_velocities
from latdyn.assembly.linked import evaluate_linked
from latdyn.assembly.control import wiring
from latdyn.assembly.native_model import NativeModel
from latdyn.model.model import Model
from latdyn.numerics.csr import CSR
from latdyn.numerics.linalg import DENSE_LIMIT
from latdyn.records import record

# ----------------------------------------------------------------------------- state


@record
class State:
    """Explicit, picklable state of every node and hinge (free and constrained)."""

    t: float
    x: np.ndarray  # (n_nodes, 3) reference points
    T: np.ndarray  # (n_nodes, 3, 3) rotations
    v: np.ndarray  # (n_nodes, 3)
    w: np.ndarray  # (n_nodes, 3) spatial angular velocities
    a: np.ndarray  # (n_nodes, 3) accelerations
    alpha: np.ndarray  # (n_nodes, 3) spatial angular accelerations
    theta: np.ndarray  # (n_hinges,)
    theta_dot: np.ndarray
    theta_ddot: np.ndarray

    def copy(self) -> "State":
        return replace(self, **{k: np.array(getattr(self, k)) for k in
                                ("x", "T", "v", "w", "a", "alpha", "theta", "theta_dot", "theta_ddot")})

    def as_dict(self) -> dict[str, np.ndarray]:
        """Flat arrays for the state history file."""
        out = {"x": self.x.ravel(), "T": self.T.ravel(), "v": self.v.ravel(), "w": self.w.ravel(),
               "theta": self.theta.copy(), "theta_dot": self.theta_dot.copy()}
        return {k: v for k, v in out.items() if v.size}


# ----------------------------------------------------------------------------- coordinates ↔ state


def pack(model: Model, node_lin: np.ndarray, node_ang: np.ndarray, hinge: np.ndarray) -> np.ndarray:
    """Node/hinge arrays -> the vector of all coordinates (free first), length n_total + 1."""
    out = np.zeros(model.n_total + 1)
    out[model.node_dofs[:, 0:3]] = node_lin
    out[model.node_dofs[:, 3:6]] = node_ang
    out[model.hinge_dofs] = hinge
    return out


def padded(model: Model, vector: np.ndarray) -> np.ndarray:
    """A free-coordinate vector extended by zeros to all coordinates (n_total + 1), so that
    node slots that are not coordinates (out of plane, :meth:`Model.node_slots`) read 0."""
    if len(vector) == model.n_total + 1:
        return vector
    out = np.zeros(model.n_total + 1)
    out[:model.n_dofs] = vector[:model.n_dofs]
    return out


def unpack_free(model: Model, vector: np.ndarray, node_lin: np.ndarray, node_ang: np.ndarray,
                hinge: np.ndarray) -> None:
    """Write a free-coordinate vector into node/hinge arrays (in place)."""
    free = model.free_nodes
    vector = padded(model, vector)
    node_lin[free] = vector[model.node_dofs[free, 0:3]]
    node_ang[free] = vector[model.node_dofs[free, 3:6]]
    fh = model.free_hinges
    hinge[fh] = vector[model.hinge_dofs[fh]]


def free_velocity(model: Model, state: State) -> np.ndarray:
    return pack(model, state.v, state.w, state.theta_dot)[: model.n_dofs]


def free_acceleration(model: Model, state: State) -> np.ndarray:
    return pack(model, state.a, state.alpha, state.theta_ddot)[: model.n_dofs]


# ----------------------------------------------------------------------------- evaluation


class Assembler:
    """Updates the configuration of a model and evaluates its equations of motion natively
    (:mod:`latdyn.assembly.native_model`), and assembles their blocks on the free coordinates."""

    def __init__(self, model: Model, kernels, gravity: np.ndarray):
        self.model = model
        self.kernels = kernels
        self.gravity = np.asarray(gravity, float)
        self.has_gravity = bool(np.any(self.gravity != 0))
        self.loads = model.scene.loads
        points = [model.point(load.at) for load in self.loads]
        self._load_nodes = np.array([node for node, _ in points], np.int64)
        self._load_offsets = np.array([r for _, r in points], float).reshape(-1, 3)
        self._load_frames = np.array([model.body_node[load.frame] if load.frame != "global" else node
                                      for load, (node, _) in zip(self.loads, points)], np.int64)
        self._native = None
        #: every native model built with the inertia tangent's buffers from the start: the transient
        #: sensitivities (latdyn/analyses/transient_sensitivities.py) evaluate the tangent between the run's
        #: steps, and a model rebuilt then would drop the factorization modified Newton holds
        self.inertia_tangent_buffers = False
        #: the warnings of the loops that the initial velocity does not close (:meth:`initial_state`;
        #: a transient run gives them)
        self.initial_warnings: list[str] = []
        self.reindex()

    def native(self, inertia_tangent: bool = False) -> NativeModel:
        """The model as the C library reads it, for the current numbering (rebuilt after a latch,
        or when the inertia tangent's buffers are first needed; once there, they stay; with
        ``inertia_tangent_buffers``, there from the first)."""
        native = self._native
        with_tangent = (inertia_tangent or self.inertia_tangent_buffers
                        or (native is not None and native.has_inertia_tangent))
        if self.current_native() is None or with_tangent != native.has_inertia_tangent:
            self._native = native = NativeModel(self, with_tangent)
        return native

    def current_native(self) -> NativeModel | None:
        """The native model built for the current numbering, or None (none yet, or a latch since)."""
        m, native = self.model, self._native
        return native if native is not None and native.model_key == (m.n_dofs, m.locked.tobytes()) else None

    # -- the configuration (csrc/evaluate.c) ------------------------------------
    def initial_state(self) -> State:
        """The state at t = 0: nodes at their positions, prescribed motion at t = 0, the free
        coordinates' rates (node velocities, hinge rates) from the scene's rigid motion carried
        through the joints with the prescribed rates (:func:`latdyn.assembly.initial.initial_velocities`),
        dependent nodes of rigid links completed. Accelerations: those of the prescribed motion, zero
        on the free coordinates until the integrator makes them consistent (its ``start``)."""
        model = self.model
        n, h = len(model.nodes), len(model.hinges)
        state = State(0.0, np.array([nd.position for nd in model.nodes], float).reshape(n, 3),
                      np.tile(np.eye(3), (n, 1, 1)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
                      np.zeros((n, 3)), np.zeros(h), np.zeros(h), np.zeros(h))
        self.apply_prescribed(state, 0.0)
        self.initial_warnings = initial_velocities(model, state, self.complete_links)
        self.complete_links(state)
        return state

    def complete_links(self, state: State) -> None:
        """The dependent nodes of rigid links completed from the independent coordinates, in place
        (:meth:`NativeModel.complete_links`); nothing without rigid links."""
        if self.model.links is not None:
            self.native().complete_links(state)

    def apply_prescribed(self, state: State, t: float) -> None:
        """Set the time, prescribed bodies and hinge angles to their laws at t, locked hinges at
        rest (in place; ``latdyn_prescribe``, csrc/evaluate.c)."""
        state.t = t
        self.native().prescribe(state, t)
        self.complete_links(state)

    def advance(self, state: State, increment: np.ndarray) -> State:
        """q ∘ exp(Δ) on the free coordinates: x += Δd, T ← exp(skew Δπ) T, θ += Δθ, into a new state
        (``latdyn_advance_free``, csrc/evaluate.c); time, prescribed bodies and rates stay. Δ is a
        free-coordinate vector: node slots that are not coordinates (:meth:`Model.node_slots`) read 0."""
        new = state.copy()
        self.native().advance_free(new, increment)
        self.complete_links(new)  # dependent nodes: forward kinematics, never integrated
        return new

    def _load_columns(self) -> np.ndarray:
        """The columns of each load's stiffness block (l, 6): its node's rotations, then its frame
        body's (the node's again for a global load, whose frame block is zero)."""
        dofs = self.model.node_dofs
        return np.concatenate([dofs[self._load_nodes, 3:6], dofs[self._load_frames, 3:6]], axis=1)

    def cable_dofs(self) -> np.ndarray:
        """(ce, 12) the coordinates of each cable element's block: [d, π] of its two end nodes."""
        cables = self.model.cables
        if cables is None:
            return np.zeros((0, 12), np.int64)
        return self.model.node_dofs[cables.nodes].reshape(-1, 12)

    def reindex(self) -> None:
        """Scatter maps for the current coordinate numbering (rebuilt when a hinge latches)."""
        m = self.model
        n = m.n_assembled  # = n_dofs, plus the dependent nodes' coordinates with rigid links
        rows, cols = [], []

        def block_pattern(dofs, column_dofs=None):
            """Mask and (row, col) of the free×free entries of blocks over ``dofs`` (b, k) × ``column_dofs``
            (b, j; default: ``dofs``, square blocks)."""
            column_dofs = dofs if column_dofs is None else column_dofs
            r = np.broadcast_to(dofs[:, :, None], dofs.shape + (column_dofs.shape[1],))
            c = np.broadcast_to(column_dofs[:, None, :], dofs.shape + (column_dofs.shape[1],))
            mask = (r < n) & (c < n)
            rows.append(r[mask])
            cols.append(c[mask])
            return mask

        self._elem_mask = block_pattern(m.element_dofs)
        self._body_mask = block_pattern(m.node_dofs[m.body_nodes].reshape(-1, 6))
        hd = m.hinge_dofs[m.free_hinges]
        rows.append(hd)
        cols.append(hd)
        # a load's block: the node's rows × the rotations of the node, then of its frame body
        self._load_mask = block_pattern(m.node_dofs[self._load_nodes], self._load_columns())
        self._cable_mask = block_pattern(self.cable_dofs())  # cable elements: [d, π] of both ends, squared
        # continuous controllers: each actuator's rows × its sensors' coordinates (latdyn.assembly.control)
        self.control = wiring(m, self)
        self._coupling_mask = block_pattern(self.control.coupling_rows[:, None],
                                            self.control.coupling_cols[:, None])[:, 0, 0]
        rows = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        cols = np.concatenate(cols) if cols else np.zeros(0, np.int64)
        key = rows * max(n, 1) + cols
        unique, self._position = np.unique(key, return_inverse=True)
        self._positions3 = None  # exact_matrix_values' scatter of M, C and K at once, and its layout (made on use)
        self._csr_rows, self._csr_cols = unique // max(n, 1), unique % max(n, 1)
        self._nnz = len(unique)
        counts = np.bincount(self._csr_rows, minlength=n)
        self._indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self._indices = self._csr_cols.astype(np.int64)

    def assemble(self, parts: list, dense: bool | None = None):
        """Scatter masked block data (in the order of :meth:`reindex`) into a matrix on
        the free coordinates: a dense array for small models, CSR otherwise."""
        n = self.model.n_assembled
        values = self.assemble_csr(parts).data
        if dense is None:
            dense = n <= DENSE_LIMIT
        if dense:
            out = np.zeros((n, n))
            out[self._csr_rows, self._csr_cols] = values
            return out
        import scipy.sparse as sps  # on use: the dense LU's models run without it

        return sps.csr_matrix((values, self._indices, self._indptr), shape=(n, n))

    def assemble_csr(self, parts: list) -> CSR:
        """:meth:`assemble`'s sparse matrix as :class:`latdyn.numerics.csr.CSR` (the same entries,
        the structural zeros kept), without SciPy."""
        n = self.model.n_assembled
        data = np.concatenate([np.ravel(p) for p in parts]) if parts else np.zeros(0)
        values = np.bincount(self._position, weights=data, minlength=self._nnz)
        return CSR((n, n), self._indptr, self._indices, values)

    def element_geometry(self, state: State) -> np.ndarray:
        """The element kernels' geometry block (codegen/conventions.py GEOMETRY) at ``state``: reference
        points, offsets (Eq. 2), nodal frames (Eq. 17) and hinge axes (Eq. 9) of both ends."""
        return self.native().element_inputs(state)[0]

    # -- the equations of motion ------------------------------------------------
    def evaluate(self, state: State, matrices: bool = True, load_factor: float = 1.0,
                 inertia: bool = True, inertia_tangent: bool = False) -> Evaluation:
        """Residual r(q, v, v̇, t) on the free coordinates (and, with ``matrices``, the blocks of M, C, K);
        ``inertia=False``: the static residual; ``load_factor`` scales loads, gravity and hinge torques;
        ``inertia_tangent``: K includes the elements' exact ∂(M v̇ + g − f_gravity)/∂q (the generated
        kernel beam_inertia_tangent; latdyn/step/integrators.py says when).
        With rigid links the dependent nodes are completed first and the result is reduced to the
        minimum coordinates (:func:`latdyn.assembly.linked.evaluate_linked`)."""
        if self.model.links is not None:
            return evaluate_linked(self.model.links, self, state, matrices, load_factor, inertia,
                                   inertia_tangent)
        return self.evaluate_assembled(state, matrices, load_factor, inertia, inertia_tangent)

    def exact_matrices(self, state: State, load_factor: float = 1.0, inertia: bool = True,
                       dense: bool | None = None):
        """(M, C, K) on the free coordinates at ``state``, K the EXACT ∂r/∂q at fixed velocities and
        accelerations, for the analyses that need the derivative itself rather than a Newton matrix
        (linearisation, transient sensitivities): the evaluation with the elements' inertia tangent
        (``inertia_tangent``) plus the joint bodies' (the generated ``joint_body_inertia_stiffness``,
        under gravity times ``load_factor``), both of which the time step's Newton matrix leaves out.
        With rigid links or guides, the reduction with them and the dependent rates' q-dependence
        (:func:`latdyn.assembly.linked.evaluate_linked` with ``inertia_tangent``)."""
        model = self.model
        if model.links is not None:  # the static residual's dampers move with the dependent rates too
            ev = evaluate_linked(model.links, self, state, True, load_factor, inertia, inertia_tangent=inertia,
                                 rates_term=True)
            return tuple(ev.combined(*c, dense=dense) for c in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))
        ev = self.evaluate(state, matrices=True, load_factor=load_factor, inertia=inertia, inertia_tangent=inertia)
        M, C, K = (ev.combined(*c, dense=dense) for c in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))
        if not (inertia and len(model.body_nodes)):
            return M, C, K
        nodes = model.body_nodes
        blocks = self.joint_body_inertia_stiffness(state, load_factor)
        dofs = model.node_dofs[nodes]
        rows = np.broadcast_to(dofs[:, :, None], blocks.shape)
        cols = np.broadcast_to(dofs[:, None, :], blocks.shape)
        free = (rows < model.n_dofs) & (cols < model.n_dofs)
        from latdyn.numerics.linalg import issparse

        if issparse(K):
            import scipy.sparse as sps  # on use, as in matrix()

            K = (K + sps.csr_matrix((blocks[free], (rows[free], cols[free])), shape=K.shape)).tocsr()
        else:
            np.add.at(K, (rows[free], cols[free]), blocks[free])
        return M, C, K

    def exact_matrix_values(self, state: State) -> np.ndarray:
        """(3, nnz): :meth:`exact_matrices`' M, C and K of the equations of motion (load factor 1) as the
        values of this assembler's pattern (``pattern()``: CSR indptr and indices, structural zeros
        kept), the joint bodies' inertia stiffness added to K's body blocks before the scatter: one
        native evaluation, one native scatter (``latdyn_exact_matrix_values``, in np.bincount's order of the
        blocks concatenated: :meth:`_segments_of`), no SciPy (the transient sensitivities' step,
        :class:`latdyn.analyses.step_matrix.ExactStepMatrix`). Without rigid links and guides only."""
        if self.model.links is not None:
            raise ValueError("exact_matrix_values: a model with rigid links or guides (use exact_matrices)")
        return self.assembled_exact_values(state)[1]

    def assembled_exact_values(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """(the residual r_all on the assembled coordinates (n_assembled,), M, C and the exact K on them (3, nnz) as the
        values of :meth:`pattern`) at ``state``, load factor 1, with the inertia: :meth:`exact_matrix_values`' one
        native evaluation and one native scatter; with rigid links or guides before their reduction, the dependent
        nodes completed first — the values :func:`latdyn.assembly.linked.evaluate_before_reduction`'s blocks assemble
        to (their ``combined``), to the bit (the same additions in the same order), without copying the blocks out (a
        shift of the dependent nodes on a part that turns: latdyn/analyses/geometry_sensitivities.py
        ``ReferenceGeometry._add_shifts``)."""
        native = self.native(True)
        self.complete_links(state)
        total, _ = native.evaluate(state, True, 1.0, True, True)
        m = self.model
        arguments, stiffness = self.exact_segments(native)
        if len(m.body_nodes):   # K's body blocks with the bodies' inertia stiffness (the second part of their segment)
            stiffness[...] = self.joint_body_inertia_stiffness(state)
        out = np.empty((3, self._nnz))
        native.library.latdyn_exact_matrix_values(*arguments, out.size, out.ctypes.data)
        return total[:m.n_assembled], out

    def linked_exact_layout(self, native: NativeModel):
        """The arrays ``latdyn_linked_exact_matrices`` (csrc/linked_matrices.c) reads for ``native`` (a model with
        rigid links or guides: its links laid out for the compiled step's iteration matrix, which this holds where the
        step has not yet: ``latdyn.assembly.held_matrix.hold_matrix``), made once per native model: (each entry's offset in
        that storage, n² row-major, −1 off the pattern; a storage of its size other than the step's, the one
        :func:`latdyn.assembly.linked.linked_pattern` gathers from; the joint bodies' inertia
        stiffness, 36 each). Up to DENSE_LIMIT coordinates on a dense or band storage the offsets are n², row-major,
        −1 off the pattern (M, C and K dense n × n); above it or on a sparse storage they are the pattern's own entries
        row by row, M, C and K values of that pattern (:meth:`linked_exact_pattern`). None without free coordinates."""
        held = self.__dict__.get("_linked_exact_layout")
        if held is not None and held[0] is native:
            return held[1]
        layout = pattern = None
        n = self.model.n_dofs
        if self.model.links is not None and 0 < n:
            from latdyn.assembly.linked import linked_pattern
            from latdyn.assembly.held_matrix import hold_matrix   # on use: the compiled step's storage, shared with it

            kind = hold_matrix(self, native).kind
            (rows, cols, indptr), offsets, storage = linked_pattern(self, native)   # the entries the reduction writes
            if n <= DENSE_LIMIT and kind in ("dense", "band"):
                gather = np.full(n * n, -1, np.int64)
                gather[rows * n + cols] = offsets
            else:   # the reduced pattern's entries: S on it (transient_sensitivities._step_matrix), sparse or band
                gather, pattern = np.ascontiguousarray(offsets, np.int64), (indptr, np.asarray(cols, np.int64))
            layout = (gather, storage, np.zeros(max(36 * len(self.model.body_nodes), 1)))
        self._linked_exact_layout = (native, layout)
        self._linked_exact_pattern = pattern
        return layout

    def linked_exact_pattern(self, native: NativeModel):
        """The CSR pattern (indptr, column indices) on the minimum coordinates whose values
        :meth:`linked_exact_matrix_values` gives for ``native`` (a model with rigid links or guides above DENSE_LIMIT
        coordinates or on a sparse storage: the iteration matrix's, latdyn.assembly.linked.linked_pattern), or None
        where they are dense n × n (:meth:`linked_exact_layout`)."""
        self.linked_exact_layout(native)
        return self._linked_exact_pattern

    def linked_exact_matrix_values(self, state: State):
        """(3, n²): M, C and the exact K on the minimum coordinates of a model with rigid links or guides at ``state``
        (:meth:`exact_matrices`' with the inertia, load factor 1), row-major, from the reduction the compiled step
        uses (``latdyn_linked_exact_values``, csrc/linked_matrices.c: the same call the transient sensitivities'
        step makes in the loop of steps); (3, nnz), values of :meth:`linked_exact_pattern`, where that is not None;
        None where :meth:`linked_exact_layout` is None."""
        native = self.native(True)
        layout = self.linked_exact_layout(native)
        if layout is None:
            return None
        gather, storage, body_D = layout
        self.complete_links(state)
        out = np.empty((3, gather.size))
        kernel = self._body_stiffness_kernel() if len(self.model.body_nodes) else None
        rows, gravity = self.body_stiffness_inputs(1.0) if kernel is not None else (body_D, body_D)
        scratch = np.empty(max(18 * len(self.model.body_nodes), 1))
        native.laws.bind_inputs()
        native.library.latdyn_linked_exact_values(
            native.model_ref, native.work_ref, ctypes.byref(native.configuration(state)), float(state.t), kernel,
            rows.ctypes.data, gravity.ctypes.data, scratch.ctypes.data, body_D.ctypes.data, gather.ctypes.data,
            gather.size, storage.ctypes.data, out.ctypes.data)
        return out

    def exact_segments(self, native: NativeModel) -> tuple:
        """(the first arguments of ``latdyn_exact_matrix_values`` for ``native``'s buffers, the array of the joint
        bodies' inertia stiffness it adds to K's body blocks): :meth:`_segments_of`, laid out once per numbering and
        native model (:meth:`exact_matrix_values`; the sensitivities' step in the loop of steps,
        latdyn/analyses/sensitivities_in_loop.py)."""
        if self._positions3 is None:   # where the blocks' kept entries lie (reindex's masks, flat) and M's zeros
            flat = [np.flatnonzero(mask) for mask in (self._elem_mask, self._body_mask, self._load_mask,
                                                      self._cable_mask, self._coupling_mask)]
            self._exact_layout = (*flat, np.ascontiguousarray(self.model.free_hinges, np.int64))
            self._positions3 = np.ascontiguousarray(np.concatenate([self._position + i * self._nnz for i in range(3)]),
                                                    np.int64)
            self._exact_segments = None
        segments = self._exact_segments
        if segments is None or segments[0] is not native:
            segments = self._exact_segments = (native, *self._segments_of(native))
        return segments[1], segments[2]

    def _segments_of(self, native: NativeModel) -> tuple:
        """The segments of :meth:`exact_matrix_values`' one native scatter (``latdyn_exact_matrix_values``,
        csrc/sensitivity_step.c) for ``native``'s buffers: the blocks in the order of reindex's pattern, M, C, K in
        turn, as evaluation_in and _flat give them — each (its buffer or none: zeros, a buffer added to it or
        none, its entries' flat indices) — as arrays of counts and addresses, and the array of the joint bodies'
        inertia stiffness the call adds to K's body blocks (copied in per call); returned as the call's first
        arguments (the count of segments, then addresses) and that array."""
        b, m = native.buffers, self.model
        elements, bodies, loads, cables, couplings, free = self._exact_layout
        stiffness = np.zeros_like(b["body_stiffness"])
        none, hinges = None, len(free)
        layout = [   # (first, second, indices or a count of zeros)
            (b["mass"], none, elements), (b["body_mass"], none, bodies), (none, none, hinges),
            (none, none, len(loads) + len(cables)), (none, none, len(couplings)),
            (b["quadratic_D"], none, elements), (b["body_damping"], none, bodies), (b["hinge_d_rate"], none, free),
            (none, none, len(loads)), (b["cable_damping"], none, cables), (b["coupling_damping"], none, couplings),
            (b["tangent"], b["inertia_tangent"], elements),
            (b["body_stiffness"], stiffness if len(m.body_nodes) else none, bodies),
            (b["hinge_d_theta"], none, free), (b["load_blocks"], none, loads), (b["cable_stiffness"], none, cables),
            (b["coupling_stiffness"], none, couplings)]
        indices = [np.ascontiguousarray(at, np.int64) if first is not None else np.zeros(1, np.int64)
                   for first, _, at in layout]
        counts = np.array([len(at) if first is not None else at for (first, _, at) in layout], np.int64)
        table = (counts, np.array([_address(first) for first, _, _ in layout], np.uint64),
                 np.array([_address(second) for _, second, _ in layout], np.uint64),
                 np.array([i.ctypes.data for i in indices], np.uint64))
        self._exact_held = (indices, table)   # alive as long as the addresses passed
        return (len(counts), *(t.ctypes.data for t in table), self._positions3.ctypes.data), stiffness

    def exact_rows(self, state: State, coordinates, load_factor: float = 1.0, inertia: bool = True):
        """(M, C, K), each (len(coordinates), n_assembled) dense: the rows of :meth:`exact_matrices`' matrices
        on any ``coordinates`` (free or not: a latched or prescribed joint's, whose residual is its reaction),
        their columns the free coordinates; the blocks of one native evaluation scattered without the free
        rows' mask (the joint-force probes' sensitivities, latdyn/analyses/joint_force_sensitivities.py).
        With rigid links or guides: before their reduction, the columns the n_assembled coordinates (free, then
        the dependent nodes'), the joint bodies' inertia stiffness in K as :func:`evaluate_linked` adds it."""
        m = self.model
        coordinates = np.asarray(coordinates, np.int64).reshape(-1)
        n = m.n_assembled
        native = self.native(inertia)
        self.complete_links(state)
        native.evaluate(state, True, load_factor, inertia, inertia)
        b = native.buffers
        where = np.full(m.n_total + 1, -1, np.int64)
        where[coordinates] = np.arange(len(coordinates))
        out = np.zeros((3, len(coordinates), n))   # M, C, K on the assembled columns

        def scatter(which, blocks, rows, cols=None):
            cols = rows if cols is None else cols
            r = np.broadcast_to(rows[:, :, None], blocks.shape)
            c = np.broadcast_to(cols[:, None, :], blocks.shape)
            keep = (where[r] >= 0) & (c < n)
            np.add.at(out[which], (where[r[keep]], c[keep]), blocks[keep])

        elements = m.element_dofs
        scatter(2, b["tangent"] + b["inertia_tangent"] if inertia else b["tangent"], elements)
        bodies = m.node_dofs[m.body_nodes].reshape(-1, 6)
        body_stiffness = b["body_stiffness"]
        if inertia and len(m.body_nodes):
            body_stiffness = body_stiffness + self.joint_body_inertia_stiffness(state, load_factor)
        scatter(2, body_stiffness, bodies)
        if inertia:
            scatter(0, b["mass"], elements)
            scatter(1, b["quadratic_D"], elements)
            scatter(0, b["body_mass"], bodies)
            scatter(1, b["body_damping"], bodies)
        scatter(2, b["load_blocks"], m.node_dofs[self._load_nodes].reshape(-1, 6), self._load_columns())
        cables = self.cable_dofs()
        scatter(2, b["cable_stiffness"], cables)
        scatter(1, b["cable_damping"], cables)
        couplings = (self.control.coupling_rows[:, None], self.control.coupling_cols[:, None])
        scatter(2, b["coupling_stiffness"][:, None, None], *couplings)
        scatter(1, b["coupling_damping"][:, None, None], *couplings)
        hinges = m.free_hinges   # a free joint's law on its own coordinate's diagonal
        diagonal = m.hinge_dofs[hinges][:, None]
        scatter(2, b["hinge_d_theta"][hinges][:, None, None], diagonal)
        scatter(1, b["hinge_d_rate"][hinges][:, None, None], diagonal)
        return out[0], out[1], out[2]

    def pattern(self) -> tuple[np.ndarray, np.ndarray]:
        """(indptr, indices) of the matrices :meth:`assemble` makes for the current numbering."""
        return self._indptr, self._indices

    def joint_body_inertia_stiffness(self, state: State, load_factor: float = 1.0) -> np.ndarray:
        """(bodies, 6, 6): each joint body's inertia stiffness at ``state`` (the generated
        ``joint_body_inertia_stiffness``: its inertia forces' and weight's derivative by its node's
        configuration, under gravity times ``load_factor``), which the time step's matrix leaves out."""
        model = self.model
        nodes = model.body_nodes
        section, gravity = self.body_stiffness_inputs(load_factor)
        native = self.current_native()
        kernel = self._body_stiffness_kernel() if native is not None else None
        if kernel is not None:   # one native call: the same kernel on the same inputs, gathered in C
            blocks = np.empty((len(nodes), 6, 6))
            scratch = self.__dict__.get("_body_scratch")
            if scratch is None or len(scratch) < 18 * len(nodes):
                scratch = self._body_scratch = np.empty(max(18 * len(nodes), 1))
            native.library.latdyn_joint_body_inertia_stiffness(
                native.model_ref, ctypes.byref(native.configuration(state)), kernel, section.ctypes.data,
                gravity.ctypes.data, scratch.ctypes.data, blocks.ctypes.data)
            return blocks
        frames = np.ascontiguousarray(state.T[nodes].reshape(-1, 9))
        motion = np.ascontiguousarray(np.concatenate([state.w[nodes], state.a[nodes], state.alpha[nodes]], axis=1))
        blocks = np.asarray(self.kernels.joint_body_inertia_stiffness(frames, motion, section, gravity)[0])
        return blocks.reshape(len(nodes), 6, 6)

    def body_stiffness_inputs(self, load_factor: float = 1.0) -> tuple:
        """The joint bodies' (mass, com, inertia) rows (bodies, 13) and λ g rows (bodies, 3) that
        :meth:`joint_body_inertia_stiffness` hands its kernel, made once a run."""
        model = self.model
        key = (model.body_mass, model.body_com, model.body_inertia, float(load_factor), tuple(self.gravity))
        held = self.__dict__.get("_body_inputs")   # the bodies' (mass, com, inertia) rows and gravity: made once a run
        if held is None or any(a is not b for a, b in zip(held[0][:3], key[:3])) or held[0][3:] != key[3:]:
            section = np.ascontiguousarray(np.concatenate([model.body_mass[:, None], model.body_com,
                                                           model.body_inertia.reshape(-1, 9)], axis=1))
            held = (key, section, np.repeat(load_factor * self.gravity[None], len(model.body_nodes), axis=0))
            self._body_inputs = held
        return held[1], held[2]

    def _body_stiffness_kernel(self) -> int | None:
        """The address of the C kernel ``joint_body_inertia_stiffness`` (found once), None where the kernels have no
        C libraries (the NumPy backend): :meth:`joint_body_inertia_stiffness` then calls it from Python."""
        if "_body_stiffness_address" not in self.__dict__:
            self._body_stiffness_address = self.kernels.address("joint_body_inertia_stiffness")
        return self._body_stiffness_address

    def evaluate_assembled(self, state: State, matrices: bool, load_factor: float, inertia: bool,
                           inertia_tangent: bool = False) -> Evaluation:
        """The equations of motion on the first ``n_assembled`` coordinates (free, then dependent):
        one native evaluation (``latdyn_evaluate``, csrc/evaluate.c), its blocks copied out."""
        native = self.native(inertia_tangent)
        total, power = native.evaluate(state, matrices, load_factor, inertia, inertia_tangent)
        return self.evaluation_in(native, total, power, matrices, inertia, inertia_tangent)

    def evaluation_in(self, native: NativeModel, total: np.ndarray, power: float, matrices: bool, inertia: bool,
                      inertia_tangent: bool) -> Evaluation:
        """The :class:`Evaluation` that ``native``'s Work buffers hold (its blocks copied out), with
        ``total`` (n_total + 1: residual, then reactions) and the power as the evaluation left them."""
        m = self.model
        n = m.n_assembled
        result = Evaluation(residual=total[:n], reaction=total[n:m.n_total], external_power=power,
                            hinge_work_torque=native.buffers["hinge_work_torque"].copy(),
                            hinge_damper_torque=native.buffers["hinge_damper_torque"].copy(),
                            cable_work=native.buffers["cable_work"].copy(), assembler=self)
        if matrices:
            b = native.buffers
            stiffness = b["tangent"] + b["inertia_tangent"] if inertia_tangent and inertia else b["tangent"].copy()
            zero_elements, zero_bodies = np.zeros_like(stiffness), np.zeros_like(b["body_mass"])
            free = m.free_hinges
            # the cable elements' blocks ride with the loads' (K and C: none is a mass)
            load_blocks = np.concatenate([b["load_blocks"][self._load_mask], b["cable_stiffness"][self._cable_mask]])
            cable_damping = np.concatenate([np.zeros(int(self._load_mask.sum())),
                                            b["cable_damping"][self._cable_mask]])
            zero_loads = np.zeros_like(load_blocks)
            couplings = self._coupling_mask
            result.blocks = {
                "stiffness": (stiffness, b["body_stiffness"].copy(), b["hinge_d_theta"][free], load_blocks,
                              b["coupling_stiffness"][couplings]),
                "mass": (b["mass"].copy() if inertia else zero_elements,
                         b["body_mass"].copy() if inertia else zero_bodies, np.zeros(len(free)), zero_loads,
                         np.zeros(int(couplings.sum()))),
                "damping": (b["quadratic_D"].copy() if inertia else zero_elements,
                            b["body_damping"].copy() if inertia else zero_bodies, b["hinge_d_rate"][free],
                            cable_damping, b["coupling_damping"][couplings]),
            }
        return result

    def energies(self, state: State) -> dict[str, float]:
        """Kinetic, strain and gravity potential energy of the whole model (``latdyn_energies``, the
        potential of hinge springs with a stiffness law included: csrc/evaluate.c law_spring_potential)."""
        self.complete_links(state)
        kinetic, strain, potential = self.native().energies(state)
        return {"kinetic": kinetic, "strain": strain, "potential": potential}

    def momentum(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """Linear momentum and angular momentum about the global origin (``latdyn_momentum``,
        csrc/rows.c, which the rows recorded in the loop of steps call too).

        For an element, P·c = q̇ᵀ M q̇_c with q̇_c the rigid translation c, and
        H·c = q̇ᵀ M q̇_c with q̇_c the rigid rotation c about the origin
        (B q̇_c = c × X), so the mass-matrix kernel gives both exactly. A joint body: m v_c and
        r × m v_c + J ω about its centre of mass r = x + T c, with J = T I Tᵀ.
        """
        self.complete_links(state)
        out = self.native().momentum(state)
        return out[:3], out[3:]


def _address(array: np.ndarray | None) -> int:
    """The address of ``array``'s data, 0 (NULL) for None or an empty array."""
    return 0 if array is None or array.size == 0 else array.ctypes.data
