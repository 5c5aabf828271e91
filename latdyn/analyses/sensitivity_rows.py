"""A block of sensitivity rows at once: the rows the loop of steps recorded on its way (csrc/rows.c), with the carried
δq at each (csrc/sensitivity_loop.c ``sensitivity_loop_row``), differentiated for every row in one pass of array
operations instead of :meth:`latdyn.analyses.transient_sensitivities.TransientSensitivities.record` row by row
(docs/performance.md, "Sensitivity rows in the loop and the adjoint without SciPy's sparse package (issue 34)").

The probes taken here are those whose derivative is a fixed gather of δq and the row's state: a point's position or
displacement component in the global frame, δ(x + T r) = δx + δπ × T r (:func:`point_moved`, which
:meth:`ParameterDerivatives._probe_derivatives` takes for one row: the same products, differences and sum), and a hinge's or guide's angle or
position, δθ plus the δθ of the joints friction holds. Any other probe (norms, rates and velocities, joint forces,
section forces, cables, a body's frame), guides' dependent nodes, geometry parameters and a row whose time moves with
p beside a prescribed motion: None, and the rows are recorded one by one as from Python. The rows are the row-by-row
ones to the bit (tests/test_sensitivities_in_loop_rows.py).
"""
from __future__ import annotations

import numpy as np

from latdyn.model.model import PRESCRIBED

__all__ = ["block_rows", "point_moved"]


def point_moved(dx: np.ndarray, dpi: np.ndarray, arm: np.ndarray) -> np.ndarray:
    """δ(x + T r) = δx + δπ × T r: how a point at ``arm`` T r from its node moves along the node's δx and δπ (…, 3, k),
    by every parameter; one row's (:meth:`ParameterDerivatives._probe_derivatives`: ``arm`` (3,)) or a block of rows'
    (:func:`block_rows`: ``arm`` (r, 1, 3), a leading axis of rows, broadcast along the k parameters)."""
    return dx + np.cross(dpi, arm, axisa=-2, axisc=-2)


def _in_block(probe) -> bool:
    """Whether ``probe``'s derivative is taken here (module docstring)."""
    if probe.kind in ("hinge", "guide"):
        return probe.quantity in ("angle", "position")
    return (probe.kind == "point" and probe.frame == "global" and probe.quantity in ("position", "displacement")
            and probe.component in ("x", "y", "z"))


def block_rows(owner, carried: dict, times: np.ndarray, turns: np.ndarray, dq: np.ndarray,
               moved_in_time: np.ndarray) -> list | None:
    """The sensitivity rows ([t, the probes' derivatives by every parameter, …] per row, as
    :meth:`TransientSensitivities.record` appends them) of rows at ``times`` (r,) whose nodes' rotations are ``turns``
    (r, nodes, 3, 3), from the carried ``dq`` (r, n, k) and δt ``moved_in_time`` (r, k) at each; ``carried``: the
    sensitivities carried into the loop (the joints friction holds). None where a probe or the run is not one taken
    here (module docstring)."""
    model = owner.model
    if owner.geometry is not None or model.links is not None or not all(map(_in_block, owner.probes)):
        return None
    if np.any(moved_in_time) and (any(node.kind == PRESCRIBED for node in model.nodes)
                                  or any(hinge.angle is not None for hinge in model.hinges)):
        return None   # TransientSensitivities._prescribed_in_time moves them
    rows, n, k = dq.shape
    full = np.concatenate([dq, np.zeros((rows, model.n_total + 1 - n, k))], axis=1)
    free_nodes, free_hinges = set(model.free_nodes.tolist()), set(model.free_hinges.tolist())
    held = owner._held(carried)   # noqa: SLF001 - the row's own reading
    out = np.empty((rows, 1 + len(owner.probes) * k))
    out[:, 0] = times
    for i, probe in enumerate(owner.probes):
        columns = slice(1 + i * k, 1 + (i + 1) * k)
        if probe.kind in ("hinge", "guide"):
            j = model.hinge_index(*((probe.beam, probe.end) if probe.kind == "hinge" else (probe.body, "guide")))
            angle = full[:, model.hinge_dofs[j]] if j in free_hinges else np.zeros((rows, k))
            out[:, columns] = angle + held[j]
            continue
        node, offset = model.point(probe.point)
        arm = turns[:, node] @ offset                                             # T r, (r, 3)
        if node in free_nodes:
            dx, dpi = full[:, model.node_dofs[node, 0:3]], full[:, model.node_dofs[node, 3:6]]   # (r, 3, k)
        else:
            dx = dpi = np.zeros((rows, 3, k))
        moved = point_moved(dx, dpi, arm[:, None, :])                            # δ(x + T r), (r, 3, k)
        out[:, columns] = moved[:, "xyz".index(probe.component)]
    return out.tolist()
