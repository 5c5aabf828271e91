"""The iteration matrix's storage in the native model, shared by the compiled time step (:mod:`latdyn.step.compiled`),
its static mode and the sensitivities' exact matrices on the minimum coordinates
(:meth:`latdyn.assembly.assembler.Assembler.linked_exact_layout`): the matrix's pattern (:func:`matrix_pattern`)
and the storage made once per native model (:func:`hold_matrix`)."""
from __future__ import annotations

import ctypes

import numpy as np

from latdyn.assembly.factorization import Factorization

__all__ = ["hold_matrix", "matrix_pattern"]


def matrix_pattern(assembler) -> tuple[np.ndarray, np.ndarray]:
    """(row, col) of every entry the iteration matrix can hold, row by row: the assembler's pattern
    on the free coordinates; with rigid links, that of Pᵀ A P, P = [I; J] with J's dependent rows
    full on the free coordinates the dependent nodes move with (:mod:`latdyn.assembly.linked`),
    and all of those among themselves (where the geometric and convective terms lie)."""
    m = assembler.model
    n, n_asm = m.n_dofs, m.n_assembled
    rows, cols = assembler._csr_rows, assembler._csr_cols
    if m.links is None:
        return rows, cols
    moved = m.links.columns(m)
    moved = moved[moved < n]
    free_row, free_col = rows < n, cols < n
    dependent_row, dependent_col = (rows >= n) & (rows < n_asm), (cols >= n) & (cols < n_asm)
    after = np.unique(cols[dependent_row & free_col])  # columns of a dependent node's rows
    before = np.unique(rows[free_row & dependent_col])  # rows of a dependent node's columns
    pairs = [(rows[free_row & free_col], cols[free_row & free_col]), (np.arange(n), np.arange(n)),
             (np.repeat(moved, len(moved)), np.tile(moved, len(moved))),
             (np.repeat(moved, len(after)), np.tile(after, len(moved))),
             (np.repeat(before, len(moved)), np.tile(moved, len(before)))]
    keys = np.unique(np.concatenate([r.astype(np.int64) * n + c for r, c in pairs]))
    return keys // n, keys % n


def hold_matrix(assembler, native) -> Factorization:
    """The iteration matrix's storage in the native model: a :class:`Factorization` of the matrix's
    pattern (dense, band or sparse, as :mod:`latdyn.numerics.linalg` chooses) whose values and pivots
    are Work's ``matrix`` and ``pivots``, with every block entry's position in it. Made once per
    native model (a numbering) and shared by the time step and the static mode (:class:`StaticNewton`),
    which factorize into the same storage: a static solve between two steps of modified Newton would
    replace the factors the step holds (no analysis does: the static paths, the states that modes and
    buckling are taken about, come before any time step)."""
    held = getattr(native, "held_factorization", None)
    if held is not None:
        return held
    a, m = assembler, assembler.model
    n = m.n_dofs
    factorization = Factorization(*matrix_pattern(a), n)
    position = factorization.position
    keep = [factorization]

    def ints(values):
        array = np.ascontiguousarray(values, dtype=np.int64)
        keep.append(array if array.size else np.zeros(1, np.int64))
        return keep[-1].ctypes.data

    def block_positions(dofs, column_dofs=None):
        column_dofs = dofs if column_dofs is None else column_dofs
        rows = np.broadcast_to(dofs[:, :, None], dofs.shape + (column_dofs.shape[1],))
        cols = np.broadcast_to(column_dofs[:, None, :], dofs.shape + (column_dofs.shape[1],))
        return position(rows, cols)

    hd = m.hinge_dofs
    model = native.model
    model.element_position = ints(block_positions(m.element_dofs))
    model.body_position = ints(block_positions(m.node_dofs[m.body_nodes].reshape(-1, 6)))
    model.hinge_position = ints(np.where(hd < n, position(hd, hd), -1))
    model.load_position = ints(block_positions(m.node_dofs[a._load_nodes].reshape(-1, 6), a._load_columns()))
    rows, cols = a.control.coupling_rows, a.control.coupling_cols
    model.coupling_position = ints(block_positions(rows[:, None], cols[:, None])[:, 0, 0] if len(rows)
                                   else np.zeros(0, np.int64))
    model.cable_position = ints(block_positions(a.cable_dofs()))
    model.factorization = ctypes.pointer(factorization.structure)
    native.set_buffer("matrix", factorization.values)
    native.set_buffer("rhs", np.zeros(n))
    native.set_buffer("pivots", factorization.pivots)
    if native.model.n_sampled:  # the restart after a sample factorizes M in a storage of its own (sampling.c)
        native.set_buffer("restart_matrix", np.zeros_like(factorization.values))
        native.set_buffer("restart_pivots", np.zeros_like(factorization.pivots))
    if m.links is not None:
        native.hold_links(a, factorization)
    native.matrix_storage = keep
    native.held_factorization = factorization
    return factorization
