"""Continuous controllers wired into the equations of motion (SCENE.md ``controllers`` without ``rate``).

A continuous controller k reads sensors s (probes: hinge angles and rates, guide slides and rates,
global components of the position, displacement or velocity of a point, with or without an offset
from its node, components of a point's position, displacement or velocity in a body's axes, a cable's length
and tension, an element's section forces, a free joint's torque or force, the outputs of earlier continuous
controllers) and drives
actuators (a hinge torque, a guide force, a load component, each naming the controller alone or in
an expression τ = a y + b with a constant a = ∂τ/∂y, :func:`actuator_gain`). In the one evaluation
(``csrc/evaluate.c``, ``controllers``) its output y_k = clip(f_k(t, s)) is computed from the
configuration with the generated law (codegen/laws.py ``latdyn_controller_laws``: y and ∂y/∂s,
exact), the actuators apply it, and the coupling of each actuator's rows to each sensor's
coordinate enters K (a sensor of position) or C (a sensor of rate):

    ∂r_row/∂q_sensor = g_row · ∂y/∂s,

(a controller that reads earlier continuous ones: ∂y/∂s the total derivative through them, the
chain rule, on every coordinate sensor it reaches), g_row the actuator's generalized force per unit output (−1 on a hinge's coordinate: f = … − y; the
point-load kernel's force for a unit component on a load's node), times λ a for an expression (the
law applies λ τ, ramped like any load). A controller's output is
feedback, not a load: the load factor λ of a static path does not scale it (it acts at full
strength while loads and gravity are ramped). A non-collocated
controller thus couples the actuator's equation to the sensor's coordinates: the entries are in
the assembler's pattern (:meth:`latdyn.assembly.assembler.Assembler.reindex`), so the iteration
matrix's factorization, the linearisation (the closed loop) and the reduction onto the minimum
coordinates with rigid links take them. Saturated (output at a limit), ∂y/∂s = 0.

:func:`wiring` lays this out for one numbering of the coordinates; what it cannot wire (a sensor or
an actuator outside the list above, states in a chain of continuous controllers) is refused with
the key path. It lays out the sampled controllers' sensors too (:func:`_wire_sampled`), after the
continuous ones' in the same arrays, for the compiled sample (csrc/sampling.c,
latdyn.timeloop.sampling): the same probe kinds, any controller's output or state, and a probe
without a C sensor handed in from Python; a held output enters no matrix.
"""
from __future__ import annotations

import math
from dataclasses import field

import numpy as np

from latdyn.errors import SceneError
from latdyn.records import record

#: sensor kinds (csrc/evaluate.c): hinge (or guide) angle, its rate, node position component, node velocity
#: component, the output of an earlier continuous controller (index: its position among them; no coordinate),
#: a global position component of a point offset from its node (the node's six coordinates), and of its
#: velocity (the node's six rates, then its three rotations)
#: a component of a point's position or displacement in a body's axes (the point's node's and the body's six)
#: a cable's length (its elements' end nodes)
ANGLE, RATE, POSITION, VELOCITY, CONTROLLER, OFFSET_POSITION, OFFSET_VELOCITY, BODY_FRAME, CABLE_LENGTH = range(9)
#: sensors of sampled controllers only (csrc/sampling.c): a probe whose value the time loop hands in
#: (energy, momentum, a joint's reaction: latdyn.timeloop.sampling), and a
#: controller's state (index: its entry in the scene's controller_states); kind 4 of a sampled
#: controller is any controller's output (index: its entry in the scene's controller_outputs)
PROVIDED, CONTROLLER_STATE = 9, 10
#: a cable's tension: its first element's N (0 slack), by its end nodes' six coordinates (K), then their
#: six rates (C): the generated cable_tension (codegen/joints.py)
CABLE_TENSION = 11
#: a section force of an element, w0 S_k + w1 S_k+1 of the mid-element section forces S = [N, T, M_y', M_z']
#: (index 4 e + k, sensor_offset [w0, w1, 0]: a planar model's turned sections back in the beam's axes),
#: by the element's fourteen coordinates: the generated beam_section_forces_D_q (codegen/derivation.py)
SECTION_FORCE = 12
#: a component of a point's velocity relative to a body, in its axes (index 3 n + c, the point's offset, the
#: body's node): by the point's node's and the body's six coordinates (K), then their six rates (C)
BODY_VELOCITY = 13
#: a free joint's force (its law: spring, damper, applied torque or force, compliant stops; index the joint),
#: by its coordinate (K) and rate (C)
JOINT_FORCE = 14
#: the columns of each kind's gradient in csrc/evaluate.c's sensor_jacobian (kind 8: 12 an element)
_GRADIENT_COLUMNS = {OFFSET_POSITION: 6, OFFSET_VELOCITY: 9, BODY_FRAME: 12, CABLE_TENSION: 24, SECTION_FORCE: 14,
                     BODY_VELOCITY: 24, JOINT_FORCE: 2}
_NO_OFFSET = np.zeros(3)
_AXIS = {"x": 0, "y": 1, "z": 2}


@record
class Wiring:
    """The continuous controllers of a model for one numbering (arrays as csrc/evaluate.c reads them)."""

    controllers: list = field(default_factory=list)  # latdyn.scene.controllers.Controller, k = 0, 1, …
    slots: list = field(default_factory=list)  # each one's index in the scene's ControllerOutputs
    limits: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    sensor_start: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int64))
    sensor_kind: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    sensor_index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    sensor_origin: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sensor_offset: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # kinds 5-7: r in node axes
    sensor_frame_node: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # kind 7: the body's node
    sensor_column_start: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int64))  # their gradients' columns
    hinge_controller: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    load_controller: np.ndarray = field(default_factory=lambda: np.zeros((0, 6), np.int64))
    actuator_kind: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # 0 hinge, 1 load
    actuator_index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    actuator_component: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    actuator_controller: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: ∂τ/∂y of an actuator inside an expression τ = a y + b (the law itself applies it, ramped with the
    #: load factor like any load); 0 for the controller's name alone (its output applied, not ramped)
    actuator_gain: np.ndarray = field(default_factory=lambda: np.zeros(0))
    coupling_actuator: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    coupling_slot: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    coupling_sensor: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    coupling_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    coupling_cols: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: each entry's column among its sensor's coordinates (a kind-5 sensor's node's six; else 0)
    coupling_column: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: the controllers' states (controller k: state_start[k] … state_start[k+1]−1), each one's index in
    #: the scene's controller_states (``states``, whose values are S at the last accepted state) and
    #: ``state_rates`` (dS/dt there, what the trapezoidal rule starts each step from)
    state_start: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int64))
    state_slot: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    states: object = None
    state_rates: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: the continuous controllers' sensors are the first ``n_sensors`` entries of the sensor arrays;
    #: the sampled controllers' follow (sampled controller k: sampled_sensor_start[k] … [k+1]−1)
    n_sensors: int = 0
    sampled: list = field(default_factory=list)  # the sampled controllers, in file order
    sampled_sensor_start: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int64))
    sampled_slot: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    sampled_limits: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    sampled_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sampled_state_start: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int64))
    sampled_state_slot: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: (sensor index, probe name) of the sensors of kind PROVIDED, whose values the caller hands in
    provided: list = field(default_factory=list)

    def sampled_sensor_names(self, k: int) -> tuple:
        """The probes sampled controller k reads, in the order of its sensors (its law's arguments)."""
        return tuple(n for n in self.sampled[k].reads if n in self._probe_names)

    @property
    def law_values(self) -> int:
        """The most values a controller law gives: (1 + p)(1 + m + p), m sensors and p states."""
        return max([1] + [(1 + p) * (1 + m + p) for m, p in self._sizes()])

    @property
    def law_arguments(self) -> int:
        return max([1] + [m + p for m, p in self._sizes()])

    @property
    def solve_size(self) -> int:
        """The scratch of a controller's local solve: p² + p·max(m, 1)."""
        return max([1] + [p * p + p * max(m, 1) for m, p in self._sizes()])

    def _sizes(self):
        return [(int(self.sensor_start[k + 1] - self.sensor_start[k]), int(self.state_start[k + 1] - self.state_start[k]))
                for k in range(self.n)] if len(self.state_start) == self.n + 1 else \
            [(int(self.sensor_start[k + 1] - self.sensor_start[k]), 0) for k in range(self.n)]

    @property
    def n(self) -> int:
        return len(self.controllers)

    def sensor_names(self, k: int) -> tuple:
        """The probes and earlier continuous controllers controller k reads, in the order of its sensors."""
        c = self.controllers[k]
        earlier = {d.name for d in self.controllers[:k]}
        return tuple(n for n in c.reads if n in earlier or n in self._probe_names)

    _probe_names: tuple = ()



def _gradient_width(kind: int, columns) -> int:
    """How many gradient columns a sensor of ``kind`` carries (a cable's length: one per coordinate of its
    ends, ``columns``)."""
    return _GRADIENT_COLUMNS.get(kind, len(columns) if kind == CABLE_LENGTH else 0)

def _refuse(scene, key, what):
    raise SceneError(scene.file, key, what)


def _sensor(scene, model, controller, probe):
    """(kind, index, origin, the coordinates it depends on, offset, the node of the body whose axes it is
    in or -1) of the probe a continuous controller reads."""
    key = f"controllers.{controller.name}.output"
    if probe.kind in ("hinge", "guide") and probe.quantity in ("angle", "position", "rate"):
        # a guide's slide s and its rate ṡ are its coordinate as a hinge's θ and θ̇ are
        j = model.hinge_index(probe.beam, probe.end) if probe.kind == "hinge" else model.hinge_index(probe.body, "guide")
        return (RATE if probe.quantity == "rate" else ANGLE), j, 0.0, [int(model.hinge_dofs[j])], _NO_OFFSET, -1
    if probe.kind == "cable" and probe.quantity == "length":
        cables = model.cables
        elements = np.flatnonzero(cables.cable == cables.names.index(probe.beam))
        columns = [int(d) for e in elements for end in (0, 1) for d in model.node_dofs[cables.nodes[e, end]]]
        assert np.all(np.diff(elements) == 1)  # a cable's elements are numbered one after the other
        return CABLE_LENGTH, int(elements[0]), 0.0, columns, _NO_OFFSET, -1
    if probe.kind == "cable" and probe.quantity == "tension":
        return _tension_sensor(model, probe)
    if probe.kind == "element":
        return _section_sensor(model, probe)
    if probe.kind in ("hinge", "guide") and probe.quantity in ("torque", "force"):
        return _joint_force_sensor(scene, model, controller, probe)
    if probe.kind == "point" and probe.frame != "global" and probe.component in _AXIS and probe.quantity == "velocity":
        node, r = model.point(probe.point)
        ends = [int(d) for d in model.node_dofs[node]] + [int(d) for d in model.node_dofs[model.body_node[probe.frame]]]
        return BODY_VELOCITY, 3 * node + _AXIS[probe.component], 0.0, ends + ends, np.asarray(r, float), \
            model.body_node[probe.frame]
    if probe.kind == "point" and probe.frame != "global" and probe.component in _AXIS \
            and probe.quantity in ("position", "displacement"):
        node, r = model.point(probe.point)
        body, c = model.body_node[probe.frame], _AXIS[probe.component]
        # at t = 0 the node axes are the global ones: the point's place in the body's axes is p0 − x_b0
        start = model.nodes[node].position + np.asarray(r, float) - model.nodes[body].position
        origin = float(start[c]) if probe.quantity == "displacement" else 0.0
        columns = [int(d) for d in model.node_dofs[node]] + [int(d) for d in model.node_dofs[body]]
        return BODY_FRAME, 3 * node + c, origin, columns, np.asarray(r, float), body
    if probe.kind == "point" and probe.frame == "global" and probe.component in _AXIS:
        node, r = model.point(probe.point)
        c = _AXIS[probe.component]
        if np.any(np.asarray(r) != 0.0):
            if probe.quantity == "velocity":  # by the node's six rates, then its three rotations
                columns = [int(d) for d in model.node_dofs[node]] + [int(d) for d in model.node_dofs[node, 3:]]
                return OFFSET_VELOCITY, 3 * node + c, 0.0, columns, np.asarray(r, float), -1
            # at t = 0 the node axes are the global ones (Assembler.initial_state): the point is at x0 + r
            origin = float(model.nodes[node].position[c] + r[c]) if probe.quantity == "displacement" else 0.0
            return OFFSET_POSITION, 3 * node + c, origin, [int(d) for d in model.node_dofs[node]], np.asarray(r, float), -1
        origin = float(model.nodes[node].position[c]) if probe.quantity == "displacement" else 0.0
        kind = VELOCITY if probe.quantity == "velocity" else POSITION
        return kind, 3 * node + c, origin, [int(model.node_dofs[node, c])], _NO_OFFSET, -1
    _refuse(scene, key, f"a continuous controller reads hinge angles and rates, guide positions and rates, the "
                        f"global x, y or z component of a point's position, displacement or velocity and the x, y or z "
                        f"component of its position, displacement or velocity in a body's axes, a cable's length or "
                        f"tension, "
                        f"an element's section force and a free joint's torque or force; the probe "
                        f"{probe.name!r} ({probe.kind} {probe.quantity}"
                        f"{'' if probe.kind != 'point' else f', frame {probe.frame}'}) is not one "
                        "(expected one of those, or a sampled controller: rate: HZ)")


def _tension_sensor(model, probe):
    """A cable's tension as :func:`_sensor` gives it: its first element (the probe's,
    latdyn.results.probes.cable_value), by the two end nodes' coordinates and then their rates."""
    cables = model.cables
    element = int(cables.first[cables.names.index(probe.beam)])
    ends = [int(d) for end in (0, 1) for d in model.node_dofs[cables.nodes[element, end]]]
    return CABLE_TENSION, element, 0.0, ends + ends, _NO_OFFSET, -1


def _section_sensor(model, probe):
    """An element's section force as :func:`_sensor` gives it (latdyn.results.probes.section_forces: the
    kernel's [N, T, M_y', M_z'], a planar model's turned moments back in the beam's axes by β,
    M_y = cos β M_y' − sin β M_z', M_z = sin β M_y' + cos β M_z'), by the element's fourteen coordinates."""
    from latdyn.scene.loader import ELEMENT_QUANTITIES as SECTION_QUANTITIES   # the probe's order

    e = int(model.beam_elements[probe.beam][probe.element])
    quantity = SECTION_QUANTITIES.index(probe.quantity)
    beta = float(model.section_turns[e])
    first, weights = min(quantity, 2), {0: (1.0, 0.0), 1: (1.0, 0.0), 2: (math.cos(beta), -math.sin(beta)),
                                        3: (math.sin(beta), math.cos(beta))}[quantity]
    columns = [int(d) for d in model.element_dofs[e]]
    return SECTION_FORCE, 4 * e + first, 0.0, columns, np.array([*weights, 0.0]), -1


def _joint_force_sensor(scene, model, controller, probe):
    """A joint's force as :func:`_sensor` gives it, where it is the joint's own law of its coordinate and rate
    (latdyn.results.probes.ProbeSet.joint_forces: a free joint applies its law); refused where the probe is
    a reaction (a prescribed joint, one that latches, rests on a rigid stop or sticks by friction), where
    the law names a continuous controller (its output would read itself) and on a static path (the load
    factor ramps the applied torque)."""
    j = model.hinge_index(probe.beam, probe.end) if probe.kind == "hinge" else model.hinge_index(probe.body, "guide")
    h = model.hinges[j]
    continuous = {c.name for c in scene.controllers.values() if not c.sampled}
    why = ("it is prescribed" if h.angle is not None else
           "it latches (lock_at)" if h.lock_at is not None else
           "it has rigid stops (limits without contact), on which it comes to rest" if h.limits is not None
           and h.contact is None else
           "it has friction, by which it sticks" if h.friction is not None else
           f"its {'force' if h.kind == 'guide' else 'torque'} names the continuous controller "
           f"{sorted(continuous & set(h.torque.input_names))[0]!r}"
           if h.torque is not None and continuous & set(getattr(h.torque, "input_names", ())) else
           "a static path ramps its applied torque with the load factor" if scene.solve.analysis == "static" else None)
    if why is not None:
        _refuse(scene, f"controllers.{controller.name}.output",
                f"a continuous controller reads a joint's torque or force where it is the joint's own law (a "
                f"spring, a damper, an applied torque or force, compliant stops) outside a static path; the probe "
                f"{probe.name!r} ({probe.kind} {probe.quantity}) is not, {why}: there it is a reaction, whose "
                "exact derivative is not built (expected a sampled controller: rate: HZ)")
    return JOINT_FORCE, j, 0.0, [int(model.hinge_dofs[j])] * 2, _NO_OFFSET, -1


def state_rates(scene) -> np.ndarray:
    """dS/dt of every controller state at the last accepted state (entries of continuous controllers'
    states; the array beside ``scene.controller_states.values``, one per scene, kept across numberings)."""
    states = scene.controller_states
    if getattr(states, "rates", None) is None or len(states.rates) != len(states.values):
        states.rates = np.zeros(len(states.values))
    return states.rates


def refuse_states_without_step(scene, method: str) -> None:
    """The states of continuous controllers are integrated by the implicit step (the trapezoidal rule
    condensed into its Newton iteration): the explicit method (``solve.method: explicit``) is refused."""
    for c in getattr(scene, "controllers", {}).values():
        if not c.sampled and c.states and method == "explicit":
            _refuse(scene, f"controllers.{c.name}.states",
                    "the states of a continuous controller are integrated with the implicit step; expected an "
                    "implicit solve.method (generalized-alpha, hht-alpha or newmark), or a sampled controller "
                    "(rate: HZ)")


def _named_alone(law, name: str) -> bool:
    return law is not None and isinstance(law.source, str) and law.source.strip() == name


def _law_expression(law):
    """The SymPy expression of a hinge torque (:class:`HingeLaw`) or a load component (:class:`TimeFunction`)."""
    from latdyn.scene.expressions import HingeLaw

    if isinstance(law, HingeLaw):
        expressions = law.expressions
        return expressions[1][0] if expressions is not None else None
    return law.expr


def actuator_gain(law, name: str) -> float | None:
    """The constant ∂τ/∂y of a hinge torque or load component τ that names the continuous controller
    ``name`` (its output y): 1 for the name alone, the SymPy derivative of an expression affine in y
    (``"2*ctl + 0.1 - 0.5*theta_dot"``: 2); None when τ does not name it or ∂τ/∂y is not a constant."""
    if law is None or name not in getattr(law, "input_names", ()):
        return None
    if _named_alone(law, name):
        return 1.0
    expression = _law_expression(law)
    if expression is None:
        return None
    import sympy as sp

    y = next((s for s in expression.free_symbols if s.name == name), None)
    derivative = sp.diff(expression, y) if y is not None else sp.S.Zero
    return float(derivative) if not derivative.free_symbols else None


def wiring(model, assembler) -> Wiring:
    """The continuous controllers of ``model`` wired for its current numbering (module docstring)."""
    scene = model.scene
    continuous = [c for c in getattr(scene, "controllers", {}).values() if not c.sampled]
    out = Wiring(_probe_names=tuple(p.name for p in scene.output.probes))
    H, L = len(model.hinges), len(assembler.loads)
    out.hinge_controller = np.full(H, -1, np.int64)
    out.load_controller = np.full((L, 6), -1, np.int64)
    if not continuous:
        return _wire_sampled(scene, model, out)
    probes = {p.name: p for p in scene.output.probes}
    index = {c.name: k for k, c in enumerate(continuous)}
    kinds, indices, origins, dofs, offsets, frames, start = [], [], [], [], [], [], [0]
    for c in continuous:
        key = f"controllers.{c.name}"
        for name in c.reads:
            recorded = probes.get(name)  # a probe {controller: NAME} of an earlier continuous one reads it
            if recorded is not None and recorded.kind == "controller" and recorded.state is None \
                    and recorded.controller in index:
                name = recorded.controller
            if name in index:  # an earlier continuous controller (the loader refuses a later one)
                if c.states or continuous[index[name]].states:
                    _refuse(scene, f"{key}.output", f"a continuous controller with states that reads another "
                                                    f"continuous one, or reads one with states ({name!r}), is not "
                                                    "run by this version of the package; expected controllers "
                                                    "without states in such a chain, or the other's expression "
                                                    "written into this output")
                kinds.append(CONTROLLER)
                indices.append(index[name])
                origins.append(0.0)
                dofs.append([])
                offsets.append(_NO_OFFSET)
                frames.append(-1)
            elif name in probes:
                kind, i, origin, columns, offset, frame = _sensor(scene, model, c, probes[name])
                frames.append(frame)
                kinds.append(kind)
                indices.append(i)
                origins.append(origin)
                dofs.append(columns)
                offsets.append(offset)
        start.append(len(kinds))
    out.controllers = continuous
    states = scene.controller_states
    out.states = states
    out.state_start = np.cumsum([0] + [len(c.states) for c in continuous]).astype(np.int64)
    out.state_slot = np.array([states.index(f"{c.name}.{s}") for c in continuous for s in c.states], np.int64)
    out.state_rates = state_rates(scene)
    out.slots = [scene.controller_outputs.index(c.name) for c in continuous]
    out.limits = np.array([c.limits if c.limits is not None else (-np.inf, np.inf) for c in continuous], float)
    out.sensor_start = np.array(start, np.int64)
    out.sensor_kind, out.sensor_index = np.array(kinds, np.int64), np.array(indices, np.int64)
    out.sensor_origin = np.array(origins, float)
    out.sensor_offset = np.array(offsets, float).reshape(-1, 3)
    out.sensor_frame_node = np.array(frames, np.int64)
    out.sensor_column_start = np.cumsum([0] + [_gradient_width(kind, columns)
                                               for kind, columns in zip(kinds, dofs)]).astype(np.int64)

    def driven(law, key):
        """(the continuous controller a law names, ∂τ/∂y, whether alone), or (-1, 0, False); refused when
        τ names more than one or is not affine in y with a constant coefficient."""
        names = [n for n in getattr(law, "input_names", ()) if n in index]
        if not names:
            return -1, 0.0, False
        gain = actuator_gain(law, names[0]) if len(names) == 1 else None
        if gain is None:
            _refuse(scene, key, f"a continuous controller ({names[0]!r}) drives a hinge torque, a guide force or a "
                                "load component that names one continuous controller y, alone or in an expression "
                                "a*y + b with a constant a (b may depend on t, theta, theta_dot, inputs); expected "
                                "such an expression (write the rest into the controller's output), or a sampled "
                                "controller")
        return index[names[0]], gain, _named_alone(law, names[0])

    def not_driven(law, key):
        names = [n for n in getattr(law, "input_names", ()) if n in index]
        if names:
            _refuse(scene, key, f"a continuous controller ({names[0]!r}) drives a hinge torque, a guide force or a "
                                "load component; expected it nowhere else (a sampled controller may be named anywhere)")

    for name, body in scene.bodies.items():
        for law in [*(body.translation or ()), body.rotation_angle]:
            not_driven(law, f"bodies.{name}.motion")
    for name, cable in (getattr(scene, "cables", None) or {}).items():
        # a rest length is a law of time that the evaluation reads as a held value: a continuous output
        # there was the value at the step's start, constant over the step and without its work
        not_driven(cable.rest_length, f"cables.{name}.rest_length")
    actuators, gains = [], []  # (kind, index, component, controller), ∂τ/∂y (0: the name alone)
    for j, h in enumerate(model.hinges):
        path = f"bodies.{h.beam}.guide" if h.kind == "guide" else f"beams.{h.beam}.{h.end}.hinge"
        for what in ("stiffness", "damping", "angle"):
            not_driven(getattr(h, what, None), f"{path}.{'position' if what == 'angle' and h.kind == 'guide' else what}")
        k, gain, alone = driven(h.torque, f"{path}.{'force' if h.kind == 'guide' else 'torque'}")
        if k >= 0:
            if alone:
                out.hinge_controller[j] = k
            actuators.append((0, j, 0, k))
            gains.append(0.0 if alone else gain)
    for l, load in enumerate(assembler.loads):
        for offset, components in ((0, load.force), (3, load.moment)):
            for p, law in enumerate(components or ()):
                k, gain, alone = driven(law, f"loads[{l}]")
                if k >= 0:
                    if alone:
                        out.load_controller[l, offset + p] = k
                    actuators.append((1, l, offset + p, k))
                    gains.append(0.0 if alone else gain)
    if actuators:
        out.actuator_kind, out.actuator_index, out.actuator_component, out.actuator_controller = (
            np.array(column, np.int64) for column in zip(*actuators))
        out.actuator_gain = np.array(gains, float)
    # the coordinate sensors each controller reaches: its own and, through the outputs it reads, those
    # of the earlier controllers (the chain rule's columns; csrc/evaluate.c controller_total)
    reached = []
    for k in range(len(continuous)):
        own = [m for m in range(start[k], start[k + 1]) if kinds[m] != CONTROLLER]
        through = [m for i in range(start[k], start[k + 1]) if kinds[i] == CONTROLLER for m in reached[indices[i]]]
        reached.append(sorted(set(own + through)))
    entries = []  # (actuator, slot, sensor, row, col)
    for a, (kind, i, p, k) in enumerate(actuators):
        rows = [int(model.hinge_dofs[i])] if kind == 0 else \
            [int(d) for d in model.node_dofs[assembler._load_nodes[i]]]
        for slot, row in enumerate(rows):
            for m in reached[k]:
                for column, dof in enumerate(dofs[m]):
                    entries.append((a, slot, m, row, dof, column))
    if entries:
        (out.coupling_actuator, out.coupling_slot, out.coupling_sensor, out.coupling_rows,
         out.coupling_cols, out.coupling_column) = (np.array(column, np.int64) for column in zip(*entries))
    return _wire_sampled(scene, model, out)


def _wire_sampled(scene, model, out: Wiring) -> Wiring:
    """The sampled controllers' sensors appended to the continuous ones' (:class:`Wiring`): a probe the
    C sensors read (as a continuous controller's, :func:`_sensor`), a controller's output or state, or
    else (energy, momentum, forces: no C sensor) a value handed in by the time loop (``PROVIDED``)."""
    out.n_sensors = len(out.sensor_kind)
    sampled = [c for c in getattr(scene, "controllers", {}).values() if c.sampled]
    if not sampled:
        return out
    probes = {p.name: p for p in scene.output.probes}
    outputs, states = scene.controller_outputs, scene.controller_states
    kinds, indices, origins, offsets, frames, columns, start = [], [], [], [], [], [], [out.n_sensors]
    for c in sampled:
        for name in c.reads:
            probe = probes.get(name)
            if probe is None:  # an input or a controller named in the law: read from the bound arrays
                continue
            kind, index, origin, offset, frame, width = PROVIDED, 0, 0.0, _NO_OFFSET, -1, 0
            if probe.kind == "controller":
                kind, index = ((CONTROLLER, outputs.index(probe.controller)) if probe.state is None else
                               (CONTROLLER_STATE, states.index(f"{probe.controller}.{probe.state}")))
            else:
                try:
                    kind, index, origin, dofs, offset, frame = _sensor(scene, model, c, probe)
                    width = _gradient_width(kind, dofs)
                except SceneError:  # no C sensor: the time loop hands its value in
                    kind = PROVIDED
            if kind == PROVIDED:
                out.provided.append((out.n_sensors + len(kinds), name))
            kinds.append(kind)
            indices.append(index)
            origins.append(origin)
            offsets.append(offset)
            frames.append(frame)
            columns.append(width)
        start.append(out.n_sensors + len(kinds))
    out.sampled = sampled
    out.sensor_kind = np.concatenate([out.sensor_kind, np.array(kinds, np.int64)])
    out.sensor_index = np.concatenate([out.sensor_index, np.array(indices, np.int64)])
    out.sensor_origin = np.concatenate([out.sensor_origin, np.array(origins, float)])
    out.sensor_offset = np.concatenate([out.sensor_offset.reshape(-1, 3), np.array(offsets, float).reshape(-1, 3)])
    out.sensor_frame_node = np.concatenate([out.sensor_frame_node, np.array(frames, np.int64)])
    out.sensor_column_start = np.concatenate([out.sensor_column_start,
                                              out.sensor_column_start[-1] + np.cumsum(columns, dtype=np.int64)])
    out.sampled_sensor_start = np.array(start, np.int64)
    out.sampled_slot = np.array([outputs.index(c.name) for c in sampled], np.int64)
    out.sampled_limits = np.array([c.limits if c.limits is not None else (-np.inf, np.inf) for c in sampled], float)
    out.sampled_rate = np.array([c.rate for c in sampled], float)
    out.sampled_state_start = np.cumsum([0] + [len(c.states) for c in sampled]).astype(np.int64)
    out.sampled_state_slot = np.array([states.index(f"{c.name}.{s}") for c in sampled for s in c.states], np.int64)
    return out
