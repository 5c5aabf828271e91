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
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.evaluation import Evaluation, SeparateMatrices
from latdyn.numerics.linalg import DENSE_LIMIT


def _is_dense(dense, n):
    return n <= DENSE_LIMIT if dense is None else dense


class LinkedEvaluation(SeparateMatrices):
    """An :class:`latdyn.assembly.assembler.Evaluation` on the minimum coordinates of a model with rigid
    links: the blocks are assembled on the independent and dependent coordinates and reduced
    by the projection P (module docstring)."""

    def __init__(self, residual, reaction, external_power, blocks, assembler, hinge_work_torque=None,
                 hinge_damper_torque=None, cable_work=None):
        self.residual, self.reaction, self.external_power = residual, reaction, external_power
        self.hinge_work_torque = np.zeros(0) if hinge_work_torque is None else hinge_work_torque
        self.hinge_damper_torque = np.zeros(0) if hinge_damper_torque is None else hinge_damper_torque
        self.cable_work = np.zeros((0, 4)) if cable_work is None else cable_work
        self.blocks, self.assembler = blocks, assembler
        self.projection = self.geometric = self.velocity_derivative = self.dependent_rows = None
        #: ∂(v, w)/∂q and ∂(a, alpha)/∂q of the dependent rows at fixed independent rates (6 n_dep × n), or None
        self.rates_tangent = None
        self._mass_all = self._damping_all = None

    def _assembled(self, cm, cc, ck, dense):
        raw = Evaluation(residual=None, reaction=None, blocks=self.blocks, assembler=self.assembler)
        return raw.combined(cm, cc, ck, dense=dense)

    def combined(self, cm: float, cc: float, ck: float, dense: bool | None = None, geometric_term: bool = True):
        """cm M + cc C + ck K on the minimum coordinates; ``geometric_term`` False: K without
        ∂(Pᵀ)/∂q · r_all, the part of the forces at the dependent nodes (a load term: the material
        stiffness that :meth:`latdyn.model.model.Model.check_held` asks for, which a pretensioned
        cable's pull through a link would make indefinite)."""
        P, geometric, velocity_derivative = self.projection, self.geometric, self.velocity_derivative
        n_asm, n = P.shape
        small = n_asm <= DENSE_LIMIT  # small models: dense products (sparse overhead dominates), arrays
        out = P.T @ self._assembled(cm, cc, ck, small) @ P
        if cc != 0.0 and len(self.dependent_rows):
            if self._mass_all is None:
                self._mass_all = self._assembled(1.0, 0.0, 0.0, small)
            coupling = self._mass_all[:, self.dependent_rows] @ velocity_derivative  # M_·dep ∂c/∂v
            out = out + cc * (P.T @ coupling)
        if ck != 0.0 and geometric_term:
            out = out + ck * geometric
        if ck != 0.0 and self.rates_tangent is not None:  # the dependent rates move with q at fixed rates
            if self._mass_all is None:
                self._mass_all = self._assembled(1.0, 0.0, 0.0, small)
            if self._damping_all is None:
                self._damping_all = self._assembled(0.0, 1.0, 0.0, small)
            by_velocity, by_acceleration = self.rates_tangent
            rows = self.dependent_rows
            out = out + ck * (P.T @ (self._damping_all[:, rows] @ by_velocity + self._mass_all[:, rows] @ by_acceleration))
        if _is_dense(dense, n):
            return out if small else out.toarray()
        import scipy.sparse as sps  # on use: a sparse matrix asked for

        return sps.csr_matrix(out)


def evaluate_linked(links, assembler, state, matrices: bool, load_factor: float, inertia: bool,
                    inertia_tangent: bool = False, rates_term: bool | None = None):
    """The equations of motion on the minimum coordinates (module docstring); ``inertia_tangent``: K with
    the elements' inertia tangent and the joint bodies' inertia stiffness (the exact ∂r/∂q with the
    dependent rates' term; ``rates_term`` that term alone, default with ``inertia_tangent``: without
    inertia its velocity part, the velocity-dependent forces at the dependent nodes, a cable's damper).
    The native model that evaluates (with the inertia tangent's buffers where
    asked: building it replaces the one before) is the one whose links :func:`reduce_linked` reads, so
    it is built before the links are completed."""
    assembler.native(inertia_tangent)
    assembler.complete_links(state)
    full = assembler.evaluate_assembled(state, matrices, load_factor, inertia, inertia_tangent)
    if matrices and inertia and inertia_tangent and len(assembler.model.body_nodes):
        # the joint bodies' inertia stiffness with the elements' inertia tangent: K on the assembled
        # coordinates exact before the reduction
        stiffness = list(full.blocks["stiffness"])
        stiffness[1] = stiffness[1] + assembler.joint_body_inertia_stiffness(state, load_factor)
        full.blocks = {**full.blocks, "stiffness": tuple(stiffness)}
    rates_term = inertia_tangent if rates_term is None else rates_term
    return reduce_linked(links, assembler, state, full, matrices, inertia, rates_term=rates_term)


def reduce_linked(links, assembler, state, full, matrices: bool, inertia: bool,
                  rates_term: bool = False) -> LinkedEvaluation:
    """``full``, the evaluation on the independent and dependent coordinates at ``state`` (its
    dependent nodes completed by the caller, J and ∂c/∂v of this state in the native links' buffers), reduced onto the minimum coordinates (module docstring). J and ∂c/∂v
    are those of the compiled step (the generated edge kernels composed along the tree in C,
    :meth:`latdyn.assembly.native_model.NativeModel.complete_links`), the geometric stiffness the
    generated wrench kernels' (:func:`geometric_stiffness`); with ``rates_term`` K also holds the
    dependent rates' q-dependence, Pᵀ(C_·dep ∂(J v)/∂q + M_·dep ∂(J a + c)/∂q) (module docstring; without
    inertia M is zero), which, like the inertia tangent, the time step's Newton matrix holds only with it."""
    model = assembler.model
    n, n_asm, n_total = model.n_dofs, model.n_assembled, model.n_total
    native = assembler.native().links
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
    r_dep = full.residual[dep_rows]  # tree order, like the rows of J
    free_cols = columns < n
    residual = full.residual[:n].copy()
    residual[columns[free_cols]] += J[:, free_cols].T @ r_dep
    reaction = np.zeros(n_total - n)
    reaction[n_asm - n:] = full.reaction
    constrained = columns >= n_asm
    reaction[columns[constrained] - n] += J[:, constrained].T @ r_dep
    out = LinkedEvaluation(residual=residual, reaction=reaction, external_power=full.external_power,
                           blocks=full.blocks, assembler=assembler,
                           hinge_work_torque=full.hinge_work_torque, hinge_damper_torque=full.hinge_damper_torque,
                           cable_work=full.cable_work)
    if matrices:
        small = n_asm <= DENSE_LIMIT
        Jf = J[:, free_cols]
        if small:  # dense products (and no SciPy import) for small models
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
        out.geometric = geometric_stiffness(links, assembler, state, native, r_dep, small)
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


def geometric_stiffness(links, assembler, state, native, r_dep, dense: bool):
    """∂(Pᵀ)/∂q · r_all on the free coordinates (n, n), r_all held fixed: for each dependent node c
    with residual wrench (f, m) at x_c, the derivative of its generalized force on its root
    (``root_wrench``: (f, m + (x_c − x_r) × f), by δx_r and δx_c) and on every hinge of its path
    (``hinge_wrench``: s g·((x_c − o_g) × f + m); on a guide's slide ``slide_wrench``: s g·f; by the edge
    parent's δx, δπ and δx_c), the generated
    kernels of codegen/joints.py, chained with J of the parent and of c (as csrc/links.c does); a closure
    edge's child first passes its wrench to its pin (:func:`_closure_wrenches`)."""
    model, kernels = assembler.model, assembler.kernels
    n = model.n_dofs
    rows, cols, values = [], [], []
    closure_block = _closure_wrenches(links, state, native, kernels, r_dep)
    r_dep = closure_block.pop("residual")
    pairs = []  # (dependent index, edge index) of every hinge and slide on every path
    for k, c in enumerate(links.dependent):
        if np.any(r_dep[6 * k:6 * k + 6]):
            pairs += [(k, e) for e in links.path(int(c)) if links.edges[e].hinge >= 0]
    nodes = [k for k, c in enumerate(links.dependent) if np.any(r_dep[6 * k:6 * k + 6])]

    def add(slot, row_columns, block):  # block (rows, count of the slot's columns)
        columns = native.columns[slot, :block.shape[1]]
        for row, values_row in zip(row_columns, block):
            keep = (columns < n) & (row < n)
            rows.append(np.full(int(keep.sum()), row))
            cols.append(columns[keep])
            values.append(values_row[keep])

    for slot, block in closure_block.items():
        add(slot, native.columns[slot, :block.shape[1]], block)
    if nodes:
        dependent = links.dependent[nodes]
        roots = [links.root[int(c)] for c in dependent]
        wrench = np.concatenate([state.x[roots], state.x[dependent], r_dep.reshape(-1, 6)[nodes]], axis=1)
        _, derivative = kernels.root_wrench(np.ascontiguousarray(wrench))
        for c, D in zip(dependent, derivative):
            s = native.slot_of_node[int(c)]
            Jc = native.jacobian[s, :, :native.count[s]]
            block = D[:, 3:] @ Jc[:3]
            block[:, :3] += D[:, :3]  # δx_r: the root's translations, its slot's first columns
            add(s, native.columns[s, :6], block)
    if pairs:
        edges = [links.edges[e] for _, e in pairs]
        parent = np.concatenate([state.x[[e.parent for e in edges]], state.T[[e.parent for e in edges]].reshape(-1, 9)],
                                axis=1)
        data = np.array([np.concatenate([e.axis, e.point, [e.sign]]) for e in edges])
        wrench = np.array([np.concatenate([state.x[links.dependent[k]], r_dep[6 * k:6 * k + 6]]) for k, _ in pairs])
        derivative = np.empty((len(pairs), 9))
        for prismatic, kernel in ((False, kernels.hinge_wrench), (True, kernels.slide_wrench)):
            kind = np.array([e.prismatic == prismatic for e in edges])
            if kind.any():
                derivative[kind] = kernel(parent[kind], data[kind], wrench[kind])[1]
        for (k, e), edge, D in zip(pairs, edges, derivative):
            s, p = native.slot_of_node[int(links.dependent[k])], native.slot_of_node[int(edge.parent)]
            Jc, Jp = native.jacobian[s, :, :native.count[s]], native.jacobian[p, :, :native.count[p]]
            row = D[6:] @ Jc[:3]
            row[:Jp.shape[1]] += D[:6] @ Jp
            add(s, [int(model.hinge_dofs[edge.hinge])], row[None])
    rows = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    cols = np.concatenate(cols) if cols else np.zeros(0, np.int64)
    values = np.concatenate(values) if values else np.zeros(0)
    if dense:
        out = np.zeros((n, n))
        np.add.at(out, (rows, cols), values)
        return out
    import scipy.sparse as sps  # on use: large models with rigid links

    return sps.csr_matrix((values, (rows, cols)), shape=(n, n))


def _closure_wrenches(links, state, native, kernels, r_dep) -> dict:
    """The closure edges' part of ∂(Pᵀ)/∂q · r_all (as csrc/links.c's): each closure child's wrench r moves its
    pin as g = transferᵀ r (``slider_closure_wrench``, ``rod_closure_wrench``), with J_pᵀ D J_p on the pin's
    columns, D = ∂g/∂p; g joins a dependent pin's wrench. Returns {pin slot: block} and, under "residual",
    r_dep with the closure children's wrenches passed on (zero) and the pins' grown."""
    r_dep = np.array(r_dep, float)
    out = {}
    index_of = {int(c): k for k, c in enumerate(links.dependent)}
    for k, c in enumerate(links.dependent):
        edge = links.edges[links.edge_of[int(c)]]
        r = r_dep[6 * k:6 * k + 6]
        if not edge.closure or not np.any(r):
            continue
        kernel = kernels.rod_closure_wrench if edge.closure == "rod" else kernels.slider_closure_wrench
        g, D = kernel(np.ascontiguousarray(state.x[[edge.parent]]), np.ascontiguousarray(edge.closure_data[None]),
                      np.ascontiguousarray(r[None]))
        slot = native.slot_of_node[int(edge.parent)]
        Jp = native.jacobian[slot, :3, :native.count[slot]]
        out[slot] = out.get(slot, 0.0) + Jp.T @ D.reshape(3, 3) @ Jp
        if int(edge.parent) in index_of:
            j = index_of[int(edge.parent)]
            r_dep[6 * j:6 * j + 3] += g.reshape(3)
        r_dep[6 * k:6 * k + 6] = 0.0
    out["residual"] = r_dep
    return out
