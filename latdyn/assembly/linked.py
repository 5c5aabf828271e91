"""The equations of motion of a model with rigid links, on its minimum coordinates.

The blocks are assembled on the independent *and* the dependent nodes' coordinates, then
reduced by the projection P = [I; J] of :mod:`latdyn.model.links` (its module docstring has
the equations): r_min = Pᵀ r_all, M_min = Pᵀ M P, C_min = Pᵀ (C P + M_·dep ∂c/∂v),
K_min = Pᵀ K P + ∂(Pᵀ)/∂q · r_all, and with the inertia tangent (the exact K: ``inertia_tangent``,
the elements' inertia tangent and the joint bodies' inertia stiffness) also
Pᵀ (C_·dep ∂(J v)/∂q + M_·dep ∂(J a + c)/∂q): the dependent nodes' rates move with the coordinates at
fixed independent rates (csrc/links.c composes the generated edge factors ``*_rates_D_q`` along the
tree, ``dependent_rates_tangent``). The time step's Newton matrix, like the events' impulse weights
(M + dt²K), leaves these inertial terms out unless the run asks for the inertia tangent.

The reduction is written once, in C: the forward step's (csrc/links.c ``assemble_linked_into``,
``reduce_total``), which this module calls for every analysis driven from Python (statics and continuation,
modes and linearisation, buckling, impulses at latches, events' weights: ``latdyn_linked_matrices`` and
``latdyn_linked_reduce_total``, csrc/linked_matrices.c). M, C and K come as the values of the iteration
matrix's pattern (:func:`latdyn.assembly.held_matrix.matrix_pattern`), gathered from a storage of its layout
(dense, band or sparse) other than the step's own. What stays here reads the C buffers: P, J and ∂c/∂v
(maps of vectors for the sensitivities) and the dependent rates' ∂/∂q.
"""
from __future__ import annotations

import ctypes

import numpy as np

from latdyn.assembly.evaluation import Evaluation, SeparateMatrices
from latdyn.numerics.linalg import DENSE_LIMIT


def _is_dense(dense, n):
    return n <= DENSE_LIMIT if dense is None else dense


class LinkedEvaluation(SeparateMatrices):
    """An :class:`latdyn.assembly.assembler.Evaluation` on the minimum coordinates of a model with rigid
    links: the blocks are assembled on the independent and dependent coordinates and reduced
    by the projection P (module docstring) in C; ``blocks`` are those before the reduction."""

    def __init__(self, residual, reaction, external_power, blocks, assembler, hinge_work_torque=None,
                 hinge_damper_torque=None, cable_work=None):
        self.residual, self.reaction, self.external_power = residual, reaction, external_power
        self.hinge_work_torque = np.zeros(0) if hinge_work_torque is None else hinge_work_torque
        self.hinge_damper_torque = np.zeros(0) if hinge_damper_torque is None else hinge_damper_torque
        self.cable_work = np.zeros((0, 4)) if cable_work is None else cable_work
        self.blocks, self.assembler = blocks, assembler
        self.projection = self.velocity_derivative = self.dependent_rows = self.assembled_residual = None
        #: ∂(v, w)/∂q and ∂(a, alpha)/∂q of the dependent rows at fixed independent rates (6 n_dep × n), or None
        self.rates_tangent = None
        #: M, C, K and K without the geometric term on the minimum coordinates (latdyn_linked_matrices), each the
        #: values of :attr:`pattern` (rows, cols, CSR indptr)
        self.parts = self.pattern = None

    def combined_before_reduction(self, cm: float, cc: float, ck: float, dense: bool | None = None):
        """cm M + cc C + ck K on the assembled coordinates (free and dependent), before the reduction (the M_all,
        C_all, K_all of the module docstring; K exact where the evaluation took the inertia tangent): the blocks'
        own scatter, which the sensitivities through rigid links compose with :attr:`projection` and
        :attr:`assembled_residual` (the held angles' weight term, latdyn/analyses/transient_sensitivities.py; the
        links' weight derivative, latdyn/analyses/weight_derivative.py); tests/test_sensitivities_joint_forces.py
        holds ``Assembler.exact_rows`` to it. ``dense`` as :meth:`combined`'s."""
        raw = Evaluation(residual=None, reaction=None, blocks=self.blocks, assembler=self.assembler)
        return raw.combined(cm, cc, ck, dense=dense)

    def combined(self, cm: float, cc: float, ck: float, dense: bool | None = None, geometric_term: bool = True):
        """cm M + cc C + ck K on the minimum coordinates; ``geometric_term`` False: K without
        ∂(Pᵀ)/∂q · r_all, the part of the forces at the dependent nodes (a load term: the material
        stiffness that :meth:`latdyn.model.model.Model.check_held` asks for, which a pretensioned
        cable's pull through a link would make indefinite)."""
        M, C, K, material = self.parts
        values = np.zeros_like(M)
        for coefficient, part in ((cm, M), (cc, C), (ck, K if geometric_term else material)):
            if coefficient != 0.0:
                values += coefficient * part
        return self._matrix(values, dense)

    @property
    def geometric(self):
        """∂(Pᵀ)/∂q · r_all on the free coordinates: K less K without it (dense below DENSE_LIMIT, else CSR)."""
        return self._matrix(self.parts[2] - self.parts[3], None)

    def _matrix(self, values, dense):
        rows, cols, indptr = self.pattern
        n = len(indptr) - 1
        if _is_dense(dense, n):
            out = np.zeros((n, n))
            out[rows, cols] = values
            return out
        import scipy.sparse as sps  # on use: a sparse matrix asked for

        return sps.csr_matrix((values, cols, indptr), shape=(n, n))


def evaluate_linked(links, assembler, state, matrices: bool, load_factor: float, inertia: bool,
                    inertia_tangent: bool = False, rates_term: bool | None = None):
    """The equations of motion on the minimum coordinates (module docstring); ``inertia_tangent``: K with
    the elements' inertia tangent and the joint bodies' inertia stiffness (the exact ∂r/∂q with the
    dependent rates' term; ``rates_term`` that term alone, default with ``inertia_tangent``: without
    inertia its velocity part, the velocity-dependent forces at the dependent nodes, a cable's damper).
    The native model that evaluates (with the inertia tangent's buffers where
    asked: building it replaces the one before) is the one whose links :func:`reduce_linked` reads, so
    it is built, and the storage of its iteration matrix held, before the links are completed."""
    full, body_stiffness = evaluate_before_reduction(assembler, state, matrices, load_factor, inertia, inertia_tangent)
    rates_term = inertia_tangent if rates_term is None else rates_term
    return reduce_linked(links, assembler, state, full, matrices, inertia, rates_term=rates_term,
                         inertia_tangent=inertia_tangent, body_stiffness=body_stiffness)


def evaluate_before_reduction(assembler, state, matrices: bool, load_factor: float, inertia: bool,
                              inertia_tangent: bool = False):
    """(the evaluation on the assembled coordinates, free and dependent, at ``state``, the joint bodies' inertia
    stiffness in its K or None): what :func:`evaluate_linked` reduces, its dependent nodes completed first; with
    ``matrices``, ``inertia`` and ``inertia_tangent`` K is the exact ∂r_all/∂q at fixed rates of every node (the
    elements' inertia tangent and the joint bodies' inertia stiffness, (bodies, 6, 6), added to their blocks). Alone
    where the reduction is not needed (a shift of the dependent nodes on a part that turns:
    latdyn/analyses/geometry_sensitivities.py ``ReferenceGeometry._add_shifts``)."""
    native = assembler.native(inertia_tangent)
    if matrices:  # the storage the reduction writes in: held before the links are completed (holding lays them out anew)
        linked_pattern(assembler, native)
    assembler.complete_links(state)
    full = assembler.evaluate_assembled(state, matrices, load_factor, inertia, inertia_tangent)
    body_stiffness = None
    if matrices and inertia and inertia_tangent and len(assembler.model.body_nodes):
        # the joint bodies' inertia stiffness with the elements' inertia tangent: K on the assembled
        # coordinates exact before the reduction
        body_stiffness = assembler.joint_body_inertia_stiffness(state, load_factor)
        stiffness = list(full.blocks["stiffness"])
        stiffness[1] = stiffness[1] + body_stiffness
        full.blocks = {**full.blocks, "stiffness": tuple(stiffness)}
    return full, body_stiffness


def linked_pattern(assembler, native):
    """The iteration matrix's pattern (rows, cols, CSR indptr), each entry's offset in its storage and a storage of
    that size other than the step's (``latdyn.assembly.held_matrix.hold_matrix``, which this holds where the step has not
    yet), made once per native model."""
    held = getattr(native, "linked_pattern", None)
    if held is not None:
        return held
    from latdyn.assembly.held_matrix import hold_matrix, matrix_pattern   # on use: the compiled step's storage

    factorization = hold_matrix(assembler, native)
    rows, cols = matrix_pattern(assembler)
    n = assembler.model.n_dofs
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]).astype(np.int64)
    offsets = np.ascontiguousarray(factorization.position(rows, cols), np.int64)
    native.linked_pattern = held = ((rows, cols, indptr), offsets, np.zeros(max(factorization.values.size, 1)))
    return held


def reduce_linked(links, assembler, state, full, matrices: bool, inertia: bool,
                  rates_term: bool = False, inertia_tangent: bool = False,
                  body_stiffness: np.ndarray | None = None) -> LinkedEvaluation:
    """``full``, the evaluation on the independent and dependent coordinates at ``state`` that the native model's
    Work holds (``Assembler.evaluate_assembled`` just before, with ``inertia_tangent`` as given here; its
    dependent nodes completed by the caller, J and ∂c/∂v of this state in the native links' buffers), reduced
    onto the minimum coordinates (module docstring) by the forward step's reduction in C: the residual and
    reactions (``latdyn_linked_reduce_total``), M, C and K (``latdyn_linked_matrices``; with ``rates_term`` K also
    holds the dependent rates' q-dependence, Pᵀ(C_·dep ∂(J v)/∂q + M_·dep ∂(J a + c)/∂q), which, like the inertia
    tangent, the time step's Newton matrix holds only with it; ``body_stiffness`` (bodies, 6, 6) the joint
    bodies' inertia stiffness added to their K). J and ∂c/∂v are those of the compiled step (the generated edge
    kernels composed along the tree in C, :meth:`latdyn.assembly.native_model.NativeModel.complete_links`)."""
    model = assembler.model
    n, n_asm, n_total = model.n_dofs, model.n_assembled, model.n_total
    native_model = assembler.native()
    if matrices and getattr(native_model, "linked_pattern", None) is None:
        linked_pattern(assembler, native_model)   # lays the links out anew: J and ∂c/∂v of this state again
        native_model.complete_links(state)
    native = native_model.links
    columns = links.columns(model)
    where = {int(c): k for k, c in enumerate(columns)}
    n_dep = len(links.dependent)
    J, convective = np.zeros((6 * n_dep, len(columns))), np.zeros((6 * n_dep, len(columns)))
    for k, c in enumerate(links.dependent):
        s = native.slot_of_node[int(c)]
        at = [where[int(col)] for col in native.columns[s, :native.count[s]]]
        J[6 * k:6 * k + 6, at] = native.jacobian[s, :, :len(at)]
        convective[6 * k:6 * k + 6, at] = native.convective[s, :, :len(at)]
    dep_rows = model.node_dofs[links.dependent].ravel()  # n ≤ index < n_asm, in order
    assert np.all((dep_rows >= n) & (dep_rows < n_asm))
    total = np.zeros(n_total + 1)
    total[:n_asm], total[n_asm:n_total] = full.residual, full.reaction
    native_model.library.latdyn_linked_reduce_total(native_model.model_ref, total.ctypes.data)
    out = LinkedEvaluation(residual=total[:n].copy(), reaction=total[n:n_total].copy(),
                           external_power=full.external_power, blocks=full.blocks, assembler=assembler,
                           hinge_work_torque=full.hinge_work_torque, hinge_damper_torque=full.hinge_damper_torque,
                           cable_work=full.cable_work)
    # r_all, the residual on the assembled coordinates before the reduction: its dependent rows make the geometric
    # term (an event weight's derivative, latdyn/analyses/weight_derivative.py ``linked_geometric_derivative``)
    out.assembled_residual = np.array(full.residual)
    if matrices:
        small = n_asm <= DENSE_LIMIT
        free_cols = columns < n
        out.pattern, offsets, storage = linked_pattern(assembler, native_model)
        body = (np.ascontiguousarray(body_stiffness, float) if body_stiffness is not None and len(body_stiffness)
                else None)
        material = bool(np.any(full.residual[dep_rows]))   # else K without the geometric term is K
        parts = np.empty((3 + material, len(offsets)))
        native_model.library.latdyn_linked_matrices(
            native_model.model_ref, native_model.work_ref, ctypes.byref(native_model.configuration(state)),
            int(inertia), int(inertia_tangent and inertia), int(rates_term), int(material),
            None if body is None else body.ctypes.data, offsets.ctypes.data, len(offsets), storage.ctypes.data,
            parts.ctypes.data)
        out.parts = (*parts[:3], parts[3] if material else parts[2])
        Jf = J[:, free_cols]
        if small:  # dense arrays (and no SciPy import) for small models
            P = np.zeros((n_asm, n))
            P[np.arange(n), np.arange(n)] = 1.0
            P[np.ix_(dep_rows, columns[free_cols])] = Jf
            velocity_derivative = np.zeros((6 * n_dep, n))
            if inertia:
                velocity_derivative[:, columns[free_cols]] = convective[:, free_cols]
        else:
            import scipy.sparse as sps  # on use: large models with rigid links

            rows = np.concatenate([np.arange(n), dep_rows[np.repeat(np.arange(6 * n_dep), Jf.shape[1])]])
            cols = np.concatenate([np.arange(n), np.tile(columns[free_cols], 6 * n_dep)])
            P = sps.csr_matrix((np.concatenate([np.ones(n), Jf.ravel()]), (rows, cols)), shape=(n_asm, n))
            Cf = convective[:, free_cols] if inertia else np.zeros_like(Jf)
            velocity_derivative = sps.csr_matrix(
                (Cf.ravel(), (np.repeat(np.arange(6 * n_dep), Jf.shape[1]), np.tile(columns[free_cols], 6 * n_dep))),
                shape=(6 * n_dep, n))
        out.projection = P
        if rates_term:
            out.rates_tangent = _rates_tangent(assembler, state, native, links, columns, free_cols, small)
        out.velocity_derivative = velocity_derivative
        out.dependent_rows = dep_rows
        #: J on every column of the dependent nodes' slots (constrained ones too), and those columns: a held
        #: joint's reaction row (latdyn/analyses/joint_force_sensitivities.py)
        out.jacobian, out.jacobian_columns = J, columns
    return out


def _rates_tangent(assembler, state, native, links, columns, free_cols, dense: bool):
    """(∂(v, w)/∂q, ∂(a, alpha)/∂q) of the dependent rows in tree order (6 n_dep × n each) at fixed
    independent rates, as the compiled step composes them (``latdyn_dependent_rates_tangent``)."""
    assembler.native().dependent_rates_tangent(state)
    where = {int(c): k for k, c in enumerate(columns)}
    n, n_dep = assembler.model.n_dofs, len(links.dependent)
    by_velocity, by_acceleration = np.zeros((6 * n_dep, len(columns))), np.zeros((6 * n_dep, len(columns)))
    for k, c in enumerate(links.dependent):
        s = native.slot_of_node[int(c)]
        at = [where[int(col)] for col in native.columns[s, :native.count[s]]]
        by_velocity[6 * k:6 * k + 6, at] = native.rates_tangent[s, :6, :len(at)]
        by_acceleration[6 * k:6 * k + 6, at] = native.rates_tangent[s, 6:, :len(at)]
    out = []
    for R in (by_velocity, by_acceleration):
        full = np.zeros((6 * n_dep, n))
        full[:, columns[free_cols]] = R[:, free_cols]
        if not dense:
            import scipy.sparse as sps  # on use: large models with rigid links

            full = sps.csr_matrix(full)
        out.append(full)
    return tuple(out)


def dependent_columns(assembler, state, coordinate: int) -> tuple:
    """(J_·c, ∂(J v)/∂q_c) (n_dep, 6) each: the dependent nodes' [δd, δπ] per unit of ``coordinate`` (a free one or
    a constrained one: a held joint's angle) and their rates' (δv, δω) at fixed independent rates, in tree order,
    as the compiled step composes them (the slots' J and ``latdyn_dependent_rates_tangent``, csrc/links.c) at
    ``state`` (its dependent nodes completed here); zero rows for a node that does not hang from it."""
    native_model = assembler.native()
    assembler.complete_links(state)
    native_model.dependent_rates_tangent(state)
    native, dependent = native_model.links, assembler.model.links.dependent
    jacobian, by_velocity = np.zeros((len(dependent), 6)), np.zeros((len(dependent), 6))
    for k, c in enumerate(dependent):
        s = native.slot_of_node[int(c)]
        at = np.flatnonzero(native.columns[s, :native.count[s]] == coordinate)
        if len(at):
            jacobian[k] = native.jacobian[s, :, at[0]]
            by_velocity[k] = native.rates_tangent[s, :6, at[0]]
    return jacobian, by_velocity
