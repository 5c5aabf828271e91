"""Coordinates without inertia: the null space of the mass matrix, joint by joint.

An Euler–Bernoulli beam without rotary inertia (``rhoIy = rhoIz = 0``) stores
kinetic energy only in the motion of its centreline, so the spin of each nodal
frame about the beam's tangent carries none; a massless joint body that one
hinged beam carries has no inertia about the hinge axis, and so on.  These
directions are rarely coordinate axes: in a scene rotated as a whole they are
mixtures of r_x, r_y, r_z (and hinge angles), so a test on the diagonal of M
is frame-dependent and wrong.

The null space is nonetheless *local*.  M is a sum of positive semi-definite
element and body blocks, so Mz = 0 exactly when every element and body sees no
kinetic energy from z.  An element's velocity field vanishes only when the
velocity of each end's grid point and the bending rate of each end frame
vanish (its Hermite shape functions are independent), and each of these
conditions involves one node and at most one hinge.  Hence, with a *joint
group* = a free node's 6 coordinates and the free hinges that sit on it (or a
lone free hinge on a fixed or prescribed body),

    null(M) = ⊕_groups null(M_gg),

and a batched eigen-decomposition of the small diagonal blocks M_gg finds it
exactly, at any model size, invariant under rigid motions of the scene.

To compare kilograms with kilogram-square-metres, each block is scaled by the
mean diagonal of its translational part, of its rotational part and of each
hinge (traces are invariant under rotation); the eigenvalues of the scaled
block are then O(1), and a direction whose eigenvalue falls below
``MASSLESS_TOL`` is a direction without inertia.

The basis ``Q = [Q_m, Q_c]`` (columns D^{-1/2}u of the scaled eigenvectors) is
block-diagonal and nonsingular, M Q_c = 0, and Q_mᵀ M Q_m is positive definite
wherever the massive directions have inertia: transient starts, explicit
steps and modal analysis condense the Q_c directions statically (exact for
them: they carry no inertia force).

*Light* directions, for the explicit step.  The twist of a beam node is
without inertia only while the beam is straight: CR-4402 interpolates the
lateral deflections with φ_y = t_c1·t_e(3), φ_z = −t_c1·t_e(2) (Eqs. 14–15),
components of the chord in the *nodal* frame, which turn with the twist of the
node, so once an element bends by φ its centreline moves when the node twists,
at a speed ~ L φ θ̇_x.  The twist then carries a kinetic energy ~ ρA L³ φ² θ̇_x²:
a scaled eigenvalue λ ~ φ² (0.056 φ² at an interior node of the L-frame of
tests/test_inertia.py), from round-off at rest to up to 8e-6 in that tumbling
L-frame and in the hinged chain, with joint Rayleigh frequencies
ω = (uᵀK̃u / λ)^½ of 1e5 … 7e7 rad/s.  Implicit methods
carry that inertia as it is; an explicit step cannot (its stability limit is
2/ω).  :func:`split_inertia` with ``stiffness`` and ``step`` therefore also
counts as without inertia every direction whose λ is below ``LIGHT_TOL`` and
whose joint Rayleigh frequency reaches ``LIGHT_OMEGA_H / step``: the explicit
step condenses it statically, dropping an inertia force of relative size λ.
(The Rayleigh quotient of a joint direction is a lower bound of ω_max, so a
direction it flags could not be integrated explicitly at that step anyway.)
"""
from __future__ import annotations

import numpy as np

from latdyn.numerics.csr import CSR
from latdyn.numerics.linalg import issparse
from latdyn.records import record

#: Relative eigenvalue of a scaled joint block below which a direction has no inertia.
MASSLESS_TOL = 1e-9
#: Relative eigenvalue below which a direction counts as *light* (module docstring): the
#: explicit step may condense it, dropping an inertia force of at most this relative size.
LIGHT_TOL = 1e-3
#: A light direction whose joint Rayleigh frequency ω satisfies ω h ≥ LIGHT_OMEGA_H is condensed
#: by the explicit step (half the central-difference limit ω h = 2: the joint quotient is a lower
#: bound of the direction's frequency in the assembled model).
LIGHT_OMEGA_H = 1.0


def joint_groups(model) -> np.ndarray:
    """Free coordinates grouped by joint: (n_groups, width) indices, padded with -1.

    A free node's six coordinates come first, then the free hinges on that node;
    a free hinge on a fixed or prescribed node forms a group of its own.
    """
    n = model.n_dofs
    groups: list[list[int]] = []
    group_of_node: dict[int, int] = {}
    for node in model.free_nodes:
        group_of_node[int(node)] = len(groups)
        groups.append([int(d) for d in model.node_dofs[node] if d < n])  # a planar node has 3
    links = getattr(model, "links", None)
    for k in model.free_hinges:
        dof = int(model.hinge_dofs[k])
        if dof >= n:
            continue
        node = model.hinges[k].node
        if links is not None:
            # a hinge on a rigid-link tree moves its dependent nodes: one group with the tree's root
            node = links.root.get(node, node)
            if node not in group_of_node and node in links.root.values():
                group_of_node[node] = len(groups)
                groups.append([])
        if node in group_of_node:
            groups[group_of_node[node]].append(dof)
        else:
            groups.append([dof])
    width = max((len(g) for g in groups), default=1)
    out = np.full((len(groups), width), -1, dtype=np.int64)
    for i, g in enumerate(groups):
        out[i, :len(g)] = g
    return out


def _block_kind(model, groups: np.ndarray) -> np.ndarray:
    """Unit of each slot: 0 translation, 1 rotation, 2 + slot for a hinge, -1 padding."""
    kind = np.full(groups.shape, -1, dtype=np.int64)
    # unit of every free coordinate: node translations 0, node rotations 1, hinges 2
    unit = np.full(model.n_total + 1, 2, dtype=np.int64)
    unit[model.node_dofs[:, 0:3]] = 0
    unit[model.node_dofs[:, 3:6]] = 1
    valid = groups >= 0
    kind[valid] = unit[groups[valid]]
    hinge_slot = valid & (kind == 2)
    kind[hinge_slot] = 2 + np.nonzero(hinge_slot)[1]
    return kind


def diagonal_blocks(matrix, groups: np.ndarray) -> np.ndarray:
    """The dense diagonal blocks matrix[g, g] of every group (padding rows/cols zero)."""
    valid = groups >= 0
    safe = np.where(valid, groups, 0)
    rows = np.broadcast_to(safe[:, :, None], safe.shape + safe.shape[1:])
    cols = np.broadcast_to(safe[:, None, :], safe.shape + safe.shape[1:])
    if isinstance(matrix, CSR):
        values = matrix.at(rows, cols).reshape(rows.shape)
    elif issparse(matrix):
        values = np.asarray(matrix.tocsr()[rows.ravel(), cols.ravel()]).reshape(rows.shape)
    else:
        values = np.asarray(matrix)[rows, cols]
    mask = valid[:, :, None] & valid[:, None, :]
    return np.where(mask, values, 0.0)


@record
class JointBlocks:
    """The diagonal blocks M_gg of the mass matrix, joint by joint, with their unit scales."""

    groups: np.ndarray  # (n_groups, width) coordinate indices, -1 = padding
    blocks: np.ndarray  # (n_groups, width, width) M_gg, symmetric, zero on padding
    scale: np.ndarray  # (n_groups, width) mean diagonal of the slot's unit in its group (1 where 0)
    translation_mass: np.ndarray  # (n_groups,) mean translational diagonal (0 for a lone hinge)


def joint_blocks(model, mass, groups: np.ndarray | None = None) -> JointBlocks:
    """Extract M_gg for every joint group and the per-unit scales of the module docstring."""
    if groups is None:
        groups = joint_groups(model)
    blocks = diagonal_blocks(mass, groups)
    blocks = 0.5 * (blocks + np.swapaxes(blocks, 1, 2))
    kind = _block_kind(model, groups)
    diag = np.diagonal(blocks, axis1=1, axis2=2)
    scale = np.ones(groups.shape)
    translation_mass = np.zeros(len(groups))
    # the units present, ascending (a plain np.unique would import numpy.ma: docs/performance.md)
    for unit in np.flatnonzero(np.bincount(kind[kind >= 0].ravel())):
        in_unit = kind == unit
        count = in_unit.sum(axis=1)
        mean = (diag * in_unit).sum(axis=1) / np.maximum(count, 1)
        if unit == 0:
            translation_mass = mean
        scale = np.where(in_unit, mean[:, None], scale)
    return JointBlocks(groups, blocks, np.where(scale > 0, scale, 1.0), translation_mass)


@record
class InertiaSplit:
    """The free coordinates split into directions with and without inertia.

    ``basis`` is Q (n × n, block-diagonal by joint), its columns ordered
    massive first; the first ``n_massive`` carry inertia, M Q_c = 0 (up to the
    light directions, ``n_light`` of the Q_c columns, when a step was given).
    """

    basis: object  # dense ndarray or CSR, (n, n)
    n_massive: int
    n_light: int = 0

    @property
    def n_massless(self) -> int:
        return self.basis.shape[1] - self.n_massive

    @property
    def massive(self):
        return self.basis[:, :self.n_massive]

    @property
    def massless(self):
        return self.basis[:, self.n_massive:]


def split_inertia(model, mass, groups: np.ndarray | None = None, stiffness=None,
                  step: float | None = None) -> InertiaSplit:
    """Find null(M) joint by joint (module docstring) and return the basis [Q_m, Q_c].

    With ``stiffness`` (K on the free coordinates) and ``step`` h, Q_c also holds the
    light directions that an explicit step of size h cannot integrate (module
    docstring: λ ≤ ``LIGHT_TOL``·λ_top and ω h ≥ ``LIGHT_OMEGA_H``).  Without them the
    split is the exact null space and does not depend on K.  Q is dense when
    ``mass`` is, a :class:`latdyn.numerics.csr.CSR` when it is one, SciPy's CSR otherwise.
    """
    joint = joint_blocks(model, mass, groups)
    groups = joint.groups
    valid = groups >= 0
    root = 1.0 / np.sqrt(joint.scale)
    scaled = joint.blocks * root[:, :, None] * root[:, None, :]
    # padding slots get eigenvalue −1, so their eigenvectors are unit vectors on the padding
    # and never mix with a degenerate null space of the real block
    scaled = scaled - np.eye(groups.shape[1]) * (~valid)[:, None, :]
    eigenvalues, vectors = np.linalg.eigh(scaled)
    on_padding = eigenvalues < -0.5
    top = np.maximum(np.max(eigenvalues, axis=1, initial=0.0), 1e-300)[:, None]
    massless = (eigenvalues <= MASSLESS_TOL * top) & ~on_padding
    light = np.zeros_like(massless)
    if stiffness is not None and step is not None:
        # joint Rayleigh quotient of each eigenvector u of the scaled block: ω² = |uᵀ K̃ u| / λ,
        # K̃ = D^{-1/2} K_gg D^{-1/2} (only the symmetric part of K enters a quadratic form)
        K = diagonal_blocks(stiffness, groups) * root[:, :, None] * root[:, None, :]
        k_u = np.abs(np.einsum("gik,gij,gjk->gk", vectors, K, vectors))
        fast = k_u * step * step >= LIGHT_OMEGA_H ** 2 * np.maximum(eigenvalues, 0.0)
        light = (eigenvalues <= LIGHT_TOL * top) & fast & ~massless & ~on_padding
        massless = massless | light
    massive = ~on_padding & ~massless
    n_massive = int(massive.sum())
    column = np.full(eigenvalues.shape, -1, dtype=np.int64)
    column[massive] = np.arange(n_massive)
    column[massless] = n_massive + np.arange(int(massless.sum()))
    g, i, j = np.nonzero(valid[:, :, None] & (column[:, None, :] >= 0))
    values = (vectors * root[:, :, None])[g, i, j]  # columns D^{-1/2} u
    n = model.n_dofs
    rows, cols = groups[g, i], column[g, j]
    if isinstance(mass, CSR):  # the same entries in NumPy (latdyn.numerics.csr)
        Q = CSR.from_coo(values, rows, cols, (n, n))
    elif issparse(mass):
        import scipy.sparse as sps  # on use: the dense LU's models run without it

        Q = sps.csr_matrix((values, (rows, cols)), shape=(n, n))
    else:
        Q = np.zeros((n, n))
        np.add.at(Q, (rows, cols), values)
    return InertiaSplit(Q, n_massive, int(light.sum()))


def joint_norms(joint: JointBlocks, vector: np.ndarray, length: float) -> np.ndarray:
    """Per joint, the inertia-weighted size of a coordinate vector in length units.

    sqrt(x_gᵀ M_gg x_g / m_g): a translation counts as itself, a rotation by the
    lever arm of the inertia it moves.  m_g is the joint's translational mass; a
    joint without one (the hinge of a rigid link or of a beam on a fixed body, a
    body with rotary inertia only) takes the mean translational mass of the joints
    that have one, so that its rotations count by the same kind of lever arm as the
    others'; in a model where no joint has translational mass (a rigid pendulum on a
    fixed body), rotations count in radians times ``length`` (the scene's size, the
    length ``error_tol`` is relative to): ℓ·sqrt(x_gᵀ M_gg x_g / J_g), J_g the mean
    diagonal of the block.  Every direction with inertia is measured, directions
    without inertia count for nothing.  Invariant under rigid motions of the scene
    (traces and quadratic forms).
    """
    groups = joint.groups
    padded = np.append(vector, 0.0)
    x = padded[np.where(groups >= 0, groups, len(vector))]
    energy = np.clip(np.einsum("gi,gij,gj->g", x, joint.blocks, x), 0.0, None)
    reference, scale = reference_masses(joint, length)
    return np.where(reference > 0, scale * np.sqrt(energy / np.where(reference > 0, reference, 1.0)), 0.0)


def link_hinge_coordinates(model) -> np.ndarray:
    """The free coordinates of the hinges on the revolute edges of rigid links (latdyn.model.links), sorted.

    Their angles set where the links are, with or without mass, and their accelerations are those of rigid
    bodies (no elastic direction of little inertia for the algorithmic accelerations to ring in), so the
    adaptive step's error estimate counts each one's own change of acceleration as a rotation
    (:func:`largest_link_turn`), beside :func:`joint_norms`, which weighs a direction by the inertia it moves:
    at a gimbal lock the massless rings' flip moves almost nothing with inertia at that moment, yet sets the
    plane the motion goes on in (docs/energy.md, "Steps that do not resolve a hinge")."""
    links = getattr(model, "links", None)
    if links is None:
        return np.zeros(0, dtype=np.int64)
    dofs = {int(model.hinge_dofs[e.hinge]) for e in links.edges if e.hinge >= 0 and not e.prismatic}
    return np.array(sorted(d for d in dofs if d < model.n_dofs), dtype=np.int64)


def largest_link_turn(coordinates: np.ndarray, vector: np.ndarray, length: float) -> tuple[float, int]:
    """``length`` · max |x_i| over the link hinges' ``coordinates`` (:func:`link_hinge_coordinates`): a rotation
    in radians counted by the scene's length, the unit :func:`joint_norms` gives a joint without translational
    mass; with the coordinate where it is largest (−1: none)."""
    if len(coordinates) == 0:
        return 0.0, -1
    values = np.abs(vector[coordinates])
    i = int(np.argmax(values))
    return float(length) * float(values[i]), int(coordinates[i])


def reference_masses(joint: JointBlocks, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, the reference m_g that :func:`joint_norms` divides its energy by and the scale its norm is
    multiplied by (the rule of :func:`joint_norms`' docstring, written once): the joint's translational mass, or
    the mean of the joints that have one, scale 1; where no joint has translational mass, the mean diagonal of
    its block, scale ``length``."""
    mass = joint.translation_mass
    if np.any(mass > 0):
        return np.where(mass > 0, mass, np.mean(mass[mass > 0])), np.ones(len(mass))
    diagonal = np.diagonal(joint.blocks, axis1=1, axis2=2)
    inertia = diagonal.sum(axis=1) / np.maximum((joint.groups >= 0).sum(axis=1), 1)
    return inertia, np.full(len(mass), float(length))


@record
class LargestNorm:
    """The largest of :func:`joint_norms` as a function of M, for its derivative (the adaptive step's
    error estimate differentiated, latdyn/analyses/adaptive_sensitivities.py): the norm is
    ``scale`` · sqrt(E / m) with E = x_gᵀ M_gg x_g over the coordinates ``dofs`` of the largest group and
    the reference m = Σ_i ``weights``[i] M_ii (the group's mean translational diagonal, the mean of the
    groups that have one, or the group's mean diagonal, as :func:`joint_norms` takes it)."""

    dofs: np.ndarray  # the coordinates of the largest group
    norm: float
    energy: float  # E
    reference: float  # m
    weights: dict  # coordinate -> its weight in m
    scale: float  # 1, or the length where no joint has translational mass


def largest_joint_norm(model, joint: JointBlocks, vector: np.ndarray, length: float) -> LargestNorm:
    """The largest of :func:`joint_norms` (``joint`` from :func:`joint_blocks`) with the parts its
    derivative needs (:class:`LargestNorm`); the norm equals ``joint_norms(...).max()``."""
    norms = joint_norms(joint, vector, length)
    g = int(np.argmax(norms))
    groups, kind = joint.groups, _block_kind(model, joint.groups)
    dofs = groups[g][groups[g] >= 0]
    energy = float(np.clip(vector[dofs] @ joint.blocks[g][:len(dofs), :len(dofs)] @ vector[dofs], 0.0, None))
    mass = joint.translation_mass

    def translations(h):
        slots = (kind[h] == 0)
        return {int(i): 1.0 / slots.sum() for i in groups[h][slots]}

    # the derivative of reference_masses' rule by the diagonal of M: which diagonal entries m_g averages
    if np.any(mass > 0):
        if mass[g] > 0:
            weights = translations(g)
        else:
            massive = np.flatnonzero(mass > 0)
            weights = {}
            for h in massive:
                weights.update({i: c / len(massive) for i, c in translations(h).items()})
    else:
        weights = {int(i): 1.0 / len(dofs) for i in dofs}
    reference, scale = (float(value[g]) for value in reference_masses(joint, length))
    return LargestNorm(dofs, float(norms[g]), energy, reference, weights, scale)
