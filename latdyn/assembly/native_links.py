"""The rigid links of a model as the compiled step reads them (``Links`` of ``csrc/links.c``).

The compiled Newton iteration completes the dependent nodes after every configuration update and
reduces every evaluation onto the minimum coordinates in C (``csrc/links.c``, with the generated
kernels ``rigid_link_edge``, ``hinge_wrench`` and ``root_wrench`` of ``codegen/joints.py``,
``prismatic_link_edge`` and ``slide_wrench`` on the prismatic edges of guides, and the closure edges'
kernels on a slider-crank whose rigid rod closes the loop): no
Python runs inside an iteration. :func:`native_links` lays out what it needs for one numbering of
the coordinates and one storage of the iteration matrix: the edges of :mod:`latdyn.model.links` in
tree order, a *slot* per root and dependent node with its columns (the coordinates it moves with:
a root's six, a dependent node's parent's columns and then its edge's hinge), and the *expansion*
of every element, body, load, controller coupling and cable element block that touches a dependent coordinate (its coordinates mapped
through P = [I; J] onto the reduced coordinates), with the matrix position of every entry the
reduction writes. ``csrc/links.c``'s header says how the C code reads them.
"""
from __future__ import annotations

import ctypes

import numpy as np

from latdyn.assembly.library import LinksData


class _Expansions:
    """The expansions of linked blocks (``csrc/links.c``, "Blocks"), built one by one."""

    def __init__(self, n: int, width: int, slot_of_dof: dict):
        self.n, self.width, self.slot_of_dof = n, width, slot_of_dof
        self.size, self.reduced, self.start = [], [], []
        self.slot, self.component, self.map = [], [], []
        self.columns = []  # the reduced columns of each expansion (free coordinates)
        self._count = 0

    def touches(self, dofs) -> bool:
        return any(int(d) in self.slot_of_dof for d in dofs)

    def add(self, dofs, slot_columns) -> int:
        n, width = self.n, self.width
        reduced = set()
        for d in dofs:
            d = int(d)
            if d in self.slot_of_dof:
                reduced.update(int(c) for c in slot_columns[self.slot_of_dof[d][0]] if c < n)
            elif d < n:
                reduced.add(d)
        reduced = sorted(reduced)
        where = {c: k for k, c in enumerate(reduced)}
        for d in dofs:
            d = int(d)
            row = np.full(width, -1, np.int64)
            if d in self.slot_of_dof:
                slot, component = self.slot_of_dof[d]
                for j, c in enumerate(slot_columns[slot]):
                    row[j] = where.get(int(c), -1)
            else:
                slot, component = -1, 0
                row[0] = where.get(d, -1)
            self.slot.append(slot)
            self.component.append(component)
            self.map.append(row)
        self.size.append(len(dofs))
        self.reduced.append(len(reduced))
        self.start.append(self._count)
        self.columns.append(np.array(reduced, np.int64))
        self._count += len(dofs)
        return len(self.size) - 1


class NativeLinks:
    """The ``Links`` struct (:attr:`data`) with the arrays it points into, and what Python reads of it:
    per slot its node, columns (:attr:`columns`, :attr:`count`), and J and ∂c/∂v as the last
    ``latdyn_complete_links`` or Newton iteration left them (:attr:`jacobian`, :attr:`convective`,
    (n_slots, 6, width)), ∂(v, w, a, alpha)/∂q at fixed independent rates as the last reduced matrix
    of an evaluation with inertia left it (:attr:`rates_tangent`, (n_slots, 12, width));
    :attr:`slot_of_node` maps a node to its slot."""

    def __init__(self, data, keep, slot_node, columns, count, buffers):
        self.data, self.keep = data, keep
        self.slot_node, self.columns, self.count = np.asarray(slot_node), columns, count
        self.jacobian, self.convective = buffers["jacobian"], buffers["convective"]
        self.rates_tangent = buffers["rates_tangent"]
        self.slot_of_node = {int(node): s for s, node in enumerate(slot_node)}

    @property
    def address(self) -> int:
        return ctypes.addressof(self.data)


def native_links(assembler, factorization, kernel_address) -> NativeLinks:
    """The ``Links`` struct of the assembler's model for ``factorization``'s storage, with the arrays it
    points into (kept alive with it). ``kernel_address(name)``: a generated kernel's address.
    ``factorization`` None: the kinematics alone (``latdyn_complete_links``), no block is reduced."""
    m = assembler.model
    links, n = m.links, m.n_dofs
    keep = []

    def ints(values):
        array = np.ascontiguousarray(values, dtype=np.int64).ravel()
        keep.append(array if array.size else np.zeros(1, np.int64))
        return keep[-1].ctypes.data

    def doubles(values):
        array = np.ascontiguousarray(values, dtype=np.float64).ravel()
        keep.append(array if array.size else np.zeros(1))
        return keep[-1].ctypes.data

    # slots: roots when first met as a parent, every dependent node as its edge's child
    slot_of_node, slot_node, slot_root, slot_edge, slot_columns = {}, [], [], [], []
    edge_parent_slot, edge_slot = [], []
    for k, e in enumerate(links.edges):
        if e.parent not in slot_of_node:  # a root: its six coordinates
            slot_of_node[e.parent] = len(slot_node)
            slot_node.append(e.parent)
            slot_root.append(len(slot_node) - 1)
            slot_edge.append(-1)
            slot_columns.append([int(d) for d in m.node_dofs[e.parent]])
        parent = slot_of_node[e.parent]
        slot_of_node[e.child] = len(slot_node)
        slot_node.append(e.child)
        slot_root.append(slot_root[parent])
        slot_edge.append(k)
        slot_columns.append(slot_columns[parent] + ([int(m.hinge_dofs[e.hinge])] if e.hinge >= 0 else []))
        edge_parent_slot.append(parent)
        edge_slot.append(slot_of_node[e.child])
    n_slots = len(slot_node)
    width = max(len(c) for c in slot_columns)
    count = np.array([len(c) for c in slot_columns], np.int64)
    columns = np.full((n_slots, width), -1, np.int64)
    for s, c in enumerate(slot_columns):
        columns[s, :len(c)] = c
    def position(rows, cols):
        shape = np.broadcast(rows, cols).shape
        return factorization.position(rows, cols) if factorization is not None else np.full(shape, -1, np.int64)

    pairs = np.full((n_slots, width, width), -1, np.int64)
    for s, c in enumerate(slot_columns):
        c = np.array(c, np.int64)
        pairs[s, :len(c), :len(c)] = position(c[:, None], c[None, :])
    jacobian = np.zeros((n_slots, 6, width))
    for s in range(n_slots):
        if slot_edge[s] < 0:
            jacobian[s, :, :6] = np.eye(6)
    edge_data = np.array([e.closure_data if e.closure else
                          np.concatenate([e.axis if e.hinge >= 0 else np.zeros(3), e.point, e.arm,
                                          [e.sign if e.hinge >= 0 else 0.0], np.zeros(3)]) for e in links.edges], float)

    # the blocks that touch a dependent coordinate, through their expansions
    slot_of_dof = {int(d): (slot_of_node[c], k) for c in links.dependent for k, d in enumerate(m.node_dofs[c])}
    x = _Expansions(n, width, slot_of_dof)
    block_rows, block_columns, block_position, positions = [], [], [], []
    offset = 0

    def block(row_dofs, column_dofs) -> int:
        nonlocal offset
        if factorization is None or not (x.touches(row_dofs) or x.touches(column_dofs)):
            return -1
        rows = x.add(row_dofs, slot_columns)
        cols = x.add(column_dofs, slot_columns) if column_dofs is not row_dofs else rows
        r, c = x.columns[rows], x.columns[cols]
        block_rows.append(rows)
        block_columns.append(cols)
        block_position.append(offset)
        positions.append(position(r[:, None], c[None, :]).ravel())
        offset += len(r) * len(c)
        return len(block_rows) - 1

    element_block = [block(dofs, dofs) for dofs in m.element_dofs]
    body_block = [block(d, d) for d in m.node_dofs[m.body_nodes]]
    load_block = [block(d, c) for d, c in zip(m.node_dofs[assembler._load_nodes], assembler._load_columns())]
    control = assembler.control  # continuous controllers: an actuator's row by a sensor's coordinate
    coupling_block = [block(np.array([r]), np.array([c])) for r, c in zip(control.coupling_rows, control.coupling_cols)]
    cable_block = [block(d, d) for d in assembler.cable_dofs()]  # cable elements: [d, π] of both ends
    biggest = max([(x.size[b_r] + x.size[b_c]) for b_r, b_c in zip(block_rows, block_columns)] + [1])
    most = max(x.reduced + [1])
    scratch = np.zeros(6 * biggest * most + most * most)
    buffers = {"jacobian": jacobian, "convective": np.zeros((n_slots, 6, width)), "wrench": np.zeros((n_slots, 6)),
               "scratch": scratch, "rates_tangent": np.zeros((n_slots, 12, width))}
    keep.append(buffers)
    data = LinksData(
        n_edges=len(links.edges), n_slots=n_slots, width=width, n_assembled=m.n_assembled,
        edge_parent=ints([e.parent for e in links.edges]), edge_child=ints([e.child for e in links.edges]),
        edge_hinge=ints([e.hinge for e in links.edges]), edge_kind=ints([e.kind for e in links.edges]),
        edge_parent_slot=ints(edge_parent_slot),
        edge_slot=ints(edge_slot), edge_data=doubles(edge_data),
        slot_node=ints(slot_node), slot_root=ints(slot_root), slot_edge=ints(slot_edge), slot_count=ints(count),
        slot_columns=ints(columns), slot_position=ints(pairs),
        element_block=ints(element_block), body_block=ints(body_block), load_block=ints(load_block),
        coupling_block=ints(coupling_block), cable_block=ints(cable_block),
        block_rows=ints(block_rows), block_columns=ints(block_columns), block_position=ints(block_position),
        positions=ints(np.concatenate(positions) if positions else []),
        expansion_size=ints(x.size), expansion_reduced=ints(x.reduced), expansion_start=ints(x.start),
        dof_slot=ints(x.slot), dof_component=ints(x.component), dof_map=ints(np.array(x.map).reshape(-1)),
        rigid_link_edge=kernel_address("rigid_link_edge"), hinge_wrench=kernel_address("hinge_wrench"),
        root_wrench=kernel_address("root_wrench"), prismatic_link_edge=kernel_address("prismatic_link_edge"),
        slide_wrench=kernel_address("slide_wrench"), slider_closure_edge=kernel_address("slider_closure_edge"),
        rod_closure_edge=kernel_address("rod_closure_edge"),
        slider_closure_wrench=kernel_address("slider_closure_wrench"),
        rod_closure_wrench=kernel_address("rod_closure_wrench"),
        rates_D_q=(ctypes.c_void_p * 4)(*(kernel_address(f"{kind}_rates_D_q") for kind in (
            "rigid_link_edge", "prismatic_link_edge", "slider_closure_edge", "rod_closure_edge"))),
        **{name: buffer.ctypes.data for name, buffer in buffers.items()})
    return NativeLinks(data, keep, slot_node, columns, count, buffers)
