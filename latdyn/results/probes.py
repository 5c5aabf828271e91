"""Probe values from a state (SCENE.md, ``output.probes``)."""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import Assembler, State
from latdyn.model.planar import section_moments_back

_COMPONENT = {"x": 0, "y": 1, "z": 2}

#: the columns of :func:`section_forces`, as spelled by ``{element: ..., quantity: ...}`` probes
SECTION_QUANTITIES = ("axial_force", "torque", "moment_y", "moment_z")


def cable_value(cables, state: np.ndarray, name: str, quantity: str) -> float:
    """A ``{cable: NAME, quantity: tension|length}`` probe from the cable elements' [ℓ, ℓ̇, ℓ − L0,
    N_el, N] (``state``, :meth:`latdyn.assembly.native_model.NativeModel.cable_state`): the tension N of
    its first element (0 while slack), or its length along the cable, Σ ℓ over its elements."""
    k = cables.names.index(name)
    elements = cables.cable == k
    if quantity == "tension":
        return float(state[cables.first[k], 4])
    return float(state[elements, 0].sum())


def section_forces(assembler: Assembler, state: State, geometry: np.ndarray | None = None) -> np.ndarray:
    """Mid-element section forces of every element, shape (n_elem, 4), columns
    :data:`SECTION_QUANTITIES`; ``geometry`` may be passed when already computed."""
    if geometry is None:
        geometry = assembler.element_geometry(state)
    _, sections = assembler.kernels.beam_strain_energy(geometry, assembler.model.element_sections)
    return section_moments_back(assembler.model, sections)  # a planar model turned some sections


class ProbeSet:
    """Evaluates the scene's probes; expensive groups (energies, momentum) once per call."""

    def __init__(self, assembler: Assembler, initial: State):
        self.assembler = assembler
        self.model = assembler.model
        self.probes = self.model.scene.output.probes
        self.names = [p.name for p in self.probes]
        self.initial = initial.copy()
        self.external_work = 0.0
        self.dissipated = 0.0  # declared dissipation so far (the time loop's, docs/energy.md)
        kinds = {p.kind for p in self.probes}
        self._need_energy = "energy" in kinds
        self._need_momentum = "momentum" in kinds
        self._need_sections = "element" in kinds
        self._need_cables = "cable" in kinds

    def _point(self, probe, state: State) -> np.ndarray:
        m = self.model
        node, r = m.point(probe.point)
        p = state.x[node] + state.T[node] @ r
        if probe.quantity == "velocity":
            value = state.v[node] + np.cross(state.w[node], state.T[node] @ r)
        else:
            value = p
        if probe.frame != "global":
            b = m.body_node[probe.frame]
            R, xb = state.T[b], state.x[b]
            if probe.quantity == "velocity":
                value = R.T @ (value - state.v[b] - np.cross(state.w[b], p - xb))
            else:
                value = R.T @ (p - xb)
                if probe.quantity == "displacement":
                    b0 = self.initial
                    p0 = b0.x[node] + b0.T[node] @ r
                    value = value - b0.T[b].T @ (p0 - b0.x[b])
        elif probe.quantity == "displacement":
            value = value - (self.initial.x[node] + self.initial.T[node] @ r)
        if probe.component == "norm" or probe.component is None:
            return float(np.linalg.norm(value))
        return float(value[_COMPONENT[probe.component]])

    def values(self, state: State, energies: dict | None = None) -> list[float]:
        """Probe values in file order; ``energies`` may be passed when already computed."""
        m = self.model
        if m.links is not None:
            m.links.complete(state)
        if energies is None and self._need_energy:
            energies = self.assembler.energies(state)
        momentum = self.assembler.momentum(state) if self._need_momentum else None
        sections = None
        if self._need_sections:
            sections = section_forces(self.assembler, state)
        cables = self.assembler.native().cable_state(state) if self._need_cables else None
        out = []
        for p in self.probes:
            if p.kind == "point":
                out.append(self._point(p, state))
            elif p.kind == "hinge":
                k = m.hinge_index(p.beam, p.end)
                out.append(float(state.theta[k] if p.quantity == "angle" else state.theta_dot[k]))
            elif p.kind == "energy":
                kind = p.quantity
                if kind == "external_work":
                    out.append(self.external_work)
                elif kind == "dissipated":
                    out.append(self.dissipated)
                elif kind == "total":
                    out.append(energies["kinetic"] + energies["strain"] + energies["potential"])
                else:
                    out.append(energies[kind])
            elif p.kind == "momentum":
                vec = momentum[0] if p.quantity == "linear" else momentum[1]
                out.append(float(vec[_COMPONENT[p.component]]))
            elif p.kind == "element":
                e = int(m.beam_elements[p.beam][p.element])
                column = SECTION_QUANTITIES.index(p.quantity)
                out.append(float(sections[e, column]))
            elif p.kind == "cable":
                out.append(cable_value(m.cables, cables, p.beam, p.quantity))
            else:  # pragma: no cover - the scene validator refuses other kinds
                raise ValueError(p.kind)
        return out
