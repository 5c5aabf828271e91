"""Read and validate a scene file (the contract is ``shared/SCENE.md``).

``load_scene(source)`` takes a path to a YAML or JSON file, a mapping, or a
:class:`Scene` (returned as is), checks *everything* and returns normalised,
picklable dataclasses. The first problem found raises
:class:`latdyn.errors.SceneError` naming the file (or ``<dict>``), the key path
(``beams.arm.section``, ``loads[0].force[2]``) and what was expected, so that
``latdyn run``/``latdyn check`` can exit with status 2 before anything is solved.

Conventions of the normalised scene:

- all vectors are float64 arrays of shape ``(3,)``, inertia ``(3, 3)``;
- every key mapping keeps the order of the file;
- any constant scalar may be a number or a string expression without ``t``
  (``lock_at: "pi/2"``); time-dependent scalars (forces, moments, torques,
  prescribed angles and translations) become :class:`~latdyn.scene.expressions.TimeFunction`;
- a beam's ``y_axis`` is unit and normal to its x axis (start -> end).

Extensions to SCENE.md (keys may be added, never renamed):

- ``from: [x, y, z]`` (a free start node) as well as ``to: [x, y, z]``;
- ``output.probes`` may also be a list of probes each with a ``name``;
- a point probe's ``component`` defaults to ``norm``;
- ``solve``: ``adaptive``, ``error_tol``, ``dt_min``, ``max_iterations``,
  ``formulation`` (code-generation variant, one of :data:`FORMULATIONS`);
- expression names ``asin acos atan atan2 sinh cosh tanh``;
- hinge ``stiffness``/``damping``/``torque`` also as a table in t.

Parameters (SCENE.md, "Parameters and sensitivities"): ``parameters: {NAME: number}`` is read
first and the rest of the scene inside :func:`~latdyn.scene.parameters.parameter_scope`, so that
every number and expression may name them (:mod:`latdyn.scene.parameters`; whole numbers such as
``elements`` take a constant expression too); ``Scene.parameters`` records what uses which.
``solve.sensitivities: [NAME, …]`` is checked here (parameters, each once); what can be
differentiated exactly is decided in :mod:`latdyn.analyses.sensitivities` (docs/parameters.md).

Rigid links (``rigid: true``, SCENE.md): the beam is one rigid body (mass ρA·L at mid-length, the
slender rod's inertia), hinged or clamped at its ends like any beam; ``elements`` is ignored (the
link counts as one element for point names: ``LINK.node[0]`` = start, ``LINK.node[1]`` = end) and
it has no element probes. A body at its ``to`` end becomes a *dependent node* (its configuration
follows from the link's; :mod:`latdyn.model.links`). What minimum coordinates cannot express is refused
by :meth:`latdyn.model.model.Model.from_scene` with a SceneError naming ``beams.NAME.rigid``: a closed
loop of rigid links (but a slider-crank's rigid rod closing onto a slider on a fixed guide, computed
by closure edges: docs/guides.md), a ``to`` body that is fixed or prescribed, or one reached by two links.

Hinge additions (SCENE.md): ``rest_angle``, ``limits: [lo, hi]`` (lo <= 0 <= hi, the angle being
0 at t = 0; not with a prescribed ``angle``; a ``lock_at`` must lie within them),
``restitution`` (only with limits), and laws in ``theta``, ``theta_dot``, ``t``
(:class:`~latdyn.scene.expressions.HingeLaw`); a constant law is kept as a number, a torque of t
alone as a :class:`~latdyn.scene.expressions.TimeFunction`. ``contact: {stiffness, exponent, damping}``
(only with limits, not with restitution) makes the stops compliant (:class:`StopContact`), and
``friction: {coulomb, static, stribeck_rate, viscous, stick_rate}`` (not on a prescribed angle) adds
friction (:class:`JointFriction`); docs/contact.md.

Limits, so that a scene is refused rather than hang or exhaust memory:

- at most :data:`MAX_ELEMENTS` beam elements in the whole scene;
- whole numbers (``steps``, ``count``, ``max_iterations``) at most :data:`MAX_COUNT`;
- expressions as bounded in :mod:`latdyn.scene.expressions` (length, nesting, size of
  the derivatives);
- geometry whose lengths and directions are finite in float64;
- names of printable characters, and text that is valid Unicode.
"""
from __future__ import annotations

import copy
import json
import keyword
import math
import os
import re
from dataclasses import field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from latdyn.digest import sha256
from latdyn.errors import SceneError, show_value
from latdyn.records import record
from latdyn.scene.controllers import Controller, controller_names, read_controllers
from latdyn.scene.inputs import ControllerOutputs, Inputs, Signals
from latdyn.scene.expressions import (
    ALLOWED_NAMES,
    HingeLaw,
    TimeFunction,
    parse_hinge_law,
    parse_time_function,
    reading_inputs,
)
from latdyn.scene.parameters import Parameters, parameter_scope, read_parameters

__all__ = [
    "Section", "Hinge", "BeamEnd", "Beam", "Cable", "Body", "PointRef", "Load", "Probe", "Solve",
    "Output", "Control", "InitialVelocity", "Scene", "load_scene", "describe",
    "ANALYSES", "METHODS", "STATIC_METHODS", "FORMULATIONS", "MAX_ELEMENTS", "MAX_COUNT",
]

ANALYSES = ("transient", "static", "modes", "buckling")
#: ``solve.about`` of a modal analysis (latdyn/analyses/linearise.py); a mapping ``{t: T}`` is the fourth form
ABOUT = ("initial", "static", "steady")
METHODS = ("generalized-alpha", "hht-alpha", "newmark", "explicit")
#: ``solve.method`` of a static analysis (latdyn/analyses/continuation.py): load control on the grid
#: λ = k/steps (default), arc-length continuation (Crisfield 1981), displacement control of a point.
STATIC_METHODS = ("load-control", "arc-length", "displacement-control")
#: Beam-element variants a scene may ask for (``solve.formulation``); each names the generated
#: kernel variant ``generated/beam_<name>`` (codegen/formulation.py FORMULATIONS):
#: ``default`` exact local rotations (log map of T_cᵀT_e) with geometric stiffening;
#: ``cr4402`` the paper's small-rotation measures (sines, Eqs. 14–16) with stiffening;
#: ``no_stiffening`` the cr4402 measures without the ½(v′²+w′²) term of Eq. 35.
FORMULATIONS = ("default", "cr4402", "no_stiffening")
#: Most beam elements in a scene (the sum over its beams).
MAX_ELEMENTS = 10_000
#: Largest whole number a scene may give (load steps, modes, iterations).
MAX_COUNT = 10**9

POINT_QUANTITIES = ("position", "displacement", "velocity")
POINT_COMPONENTS = ("x", "y", "z", "norm")
HINGE_QUANTITIES = ("angle", "rate")
ENERGY_KINDS = ("kinetic", "strain", "potential", "external_work", "dissipated", "total")
MOMENTUM_KINDS = ("linear", "angular")
AXIS_COMPONENTS = ("x", "y", "z")
ELEMENT_QUANTITIES = ("axial_force", "torque", "moment_y", "moment_z")
PROBE_KINDS = ("point", "hinge", "guide", "energy", "momentum", "element", "controller", "cable")
#: ``{hinge: ..., quantity: torque}``: the generalized force the joint applies on its coordinate
HINGE_PROBE_QUANTITIES = HINGE_QUANTITIES + ("torque",)
GUIDE_QUANTITIES = ("position", "rate", "force")
CABLE_QUANTITIES = ("tension", "length")

_TOP_KEYS = ("title", "parameters", "gravity", "initial_velocity", "inputs", "sections", "bodies", "beams", "cables",
             "loads", "controllers", "solve", "output")
_SECTION_KEYS = ("EA", "EIy", "EIz", "GJ", "rhoA", "rhoIy", "rhoIz", "GAy", "GAz")
_BODY_KEYS = ("at", "mass", "com", "inertia", "fixed", "motion", "guide")
_GUIDE_KEYS = ("on", "axis", "stiffness", "damping", "force", "rest", "limits", "restitution", "lock_at", "position",
               "contact", "friction")
_BEAM_KEYS = ("from", "to", "section", "elements", "y_axis", "start", "end", "rigid")
_HINGE_KEYS = ("axis", "stiffness", "damping", "torque", "angle", "lock_at", "rest_angle", "limits", "restitution",
               "contact", "friction")
_LOAD_KEYS = ("at", "force", "moment", "frame")
_CABLE_KEYS = ("from", "to", "EA", "rhoA", "damping", "elements", "rest_length")
_SOLVE_KEYS = ("analysis", "t_end", "dt", "method", "rho_inf", "tol", "steps", "count",
               "adaptive", "error_tol", "dt_min", "max_iterations", "formulation", "engine", "newton", "planar",
               "control", "max_steps", "about", "linear_model", "mode_shapes", "flutter", "sensitivities",
               "sensitivity_method")
_CONTROL_KEYS = ("point", "direction", "to")
#: ``solve.engine``: ``auto`` or ``compiled``, the same: the implicit step's Newton iteration runs in C
#: (latdyn/step/compiled.py), its one implementation (the Python step it once chose is gone, issue 17);
#: ``solve.newton``: full or modified
#: Newton, or ``exact``: full Newton whose matrix holds the elements' inertia tangent from the start
#: (inertia_tangent in latdyn/assembly/csrc/evaluate.c; otherwise taken from the first Newton failure on).
#: The default stays ``full``, by measurement (benchmarks/newton_default.py, docs/performance.md
#: "Newton default"): modified takes 0.33–1.2× the solver time (median 0.68) on the shipped
#: scenes, but its last iterate is only within the tolerance (full Newton's is far inside it), and
#: on small-amplitude dynamics that error accumulates: tests/test_hinges.py's small oscillation
#: comes out with a period 4.9 % off (full: within 1e-3).
ENGINES = ("auto", "compiled")
#: ``solve.planar``: ``auto`` solves a scene that stays in a coordinate plane with in-plane
#: coordinates only (latdyn/model/planar.py), ``off`` always in 3D.
PLANAR = ("auto", "off")
NEWTON = ("full", "modified", "exact")
_PROBE_KEYS = {
    "point": ("point", "quantity", "frame", "component"),
    "hinge": ("hinge", "quantity"),
    "guide": ("guide", "quantity"),
    "energy": ("energy",),
    "momentum": ("momentum", "component"),
    "element": ("element", "quantity"),
    "controller": ("controller", "state"),
    "cable": ("cable", "quantity"),
}
_RESERVED_COLUMNS = ("t", "load_factor")
#: Words of the expression language (latdyn.scene.expressions), which cannot name an input or a controller.
RESERVED_WORDS = tuple(sorted(set(ALLOWED_NAMES) | {"theta", "theta_dot", "s", "s_dot", "Lt", "Le", "Gt", "Ge",
                                                    "Eq", "Ne", "And", "Integer", "Float", "Rational", "Symbol"}
                              | set(keyword.kwlist)))


class _Travel(NamedTuple):
    """How the loader speaks of a joint's coordinate in its refusals (:meth:`_Reader.stops_and_latch`)."""

    joint: str  # "hinge"
    prescribed: str  # the key (and attribute) that prescribes the coordinate: "angle"
    free: str  # "angle"
    coordinate: str  # "the hinge angle"
    symbol: str  # what the stops bound: "the hinge angle"
    held: str  # what a joint held from the start is instead


_HINGE_TRAVEL = _Travel("hinge", "angle", "angle", "the hinge angle", "the hinge angle",
                        "a joint held from the start is a clamped end")
_GUIDE_TRAVEL = _Travel("guide", "position", "slide", "the slide", "the slide s",
                        "a body held from the start is a rigid link or a fixed body")


# =========================================================================== dataclasses
@record
class Section:
    """Beam cross-section: stiffnesses (EA, EIy, EIz, GJ), inertia per length, shear stiffnesses.

    ``GAy``, ``GAz``: shear stiffness along local y (paired with EIz) and z (with EIy); ``None``
    (absent) is shear-rigid, Euler–Bernoulli.  The kernels take their compliances
    (:attr:`shear_compliances`).
    """
    name: str
    EA: float
    EIy: float
    EIz: float
    GJ: float
    rhoA: float
    rhoIy: float = 0.0
    rhoIz: float = 0.0
    GAy: float | None = None
    GAz: float | None = None

    @property
    def shear_compliances(self) -> tuple[float, float]:
        """(1/GAy, 1/GAz), 0 where shear-rigid: the last two columns of the kernels' section block."""
        return tuple(0.0 if ga is None else 1.0 / ga for ga in (self.GAy, self.GAz))


@record
class Hinge:
    """A revolute joint between a beam end and its body (SCENE.md HINGE, "Hinge additions").

    ``stiffness`` and ``damping`` are numbers, or :class:`~latdyn.scene.expressions.HingeLaw` when
    they vary (with ``theta``, ``theta_dot`` or ``t``); ``torque`` is a
    :class:`~latdyn.scene.expressions.TimeFunction` unless it depends on ``theta``/``theta_dot``
    (then a HingeLaw). The generalized hinge force is, with θ_r = ``rest_angle``,
    f = k(θ, θ̇, t)(θ − θ_r) + c(θ, θ̇, t) θ̇ − τ(θ, θ̇, t).
    """
    axis: np.ndarray                        # (3,) unit, global at t = 0
    stiffness: float | HingeLaw = 0.0
    damping: float | HingeLaw = 0.0
    torque: TimeFunction | HingeLaw | None = None   # applied about the axis
    angle: TimeFunction | None = None       # prescribed hinge angle (no coordinate)
    lock_at: float | None = None            # latches when the angle reaches this value
    rest_angle: float = 0.0                 # neutral angle of the spring
    limits: tuple[float, float] | None = None   # hard stops [lo, hi] on the angle
    restitution: float = 0.0                # of an impact on a stop, in [0, 1]
    contact: StopContact | None = None      # the stops made compliant (Hunt–Crossley)
    friction: JointFriction | None = None
    #: the axis as given, before it is made unit (a geometry parameter's derivative:
    #: latdyn/analyses/geometry_sensitivities.py)
    axis_given: np.ndarray | None = None


@record(frozen=True)
class StopContact:
    """A compliant stop (SCENE.md "Contact and friction at joints"): past a limit by δ > 0 the joint
    takes the Hunt–Crossley force k δⁿ + c δⁿ δ̇, never pulling (clipped at 0); restitution does not
    apply (refused with it). The law is codegen/joints.py ``joint_contact``."""
    stiffness: float
    exponent: float = 1.0
    damping: float = 0.0


@record(frozen=True)
class JointFriction:
    """Friction in a joint: Coulomb ``coulomb``, static level ``static`` with its Stribeck decay
    exp(−(rate/stribeck_rate)²) (stribeck_rate 0: ``static`` is the breakaway level of a stuck
    joint only), viscous ``viscous``·rate, regularised below ``stick_rate`` while the joint slips
    (codegen/joints.py ``joint_contact``); a joint sticks by an event while its reaction is within
    ``static`` (latdyn/timeloop/events.py ``stick_and_slip``; docs/contact.md)."""
    coulomb: float
    static: float
    stribeck_rate: float = 0.0
    viscous: float = 0.0
    stick_rate: float = 1e-3


@record
class Guide:
    """A prismatic (sliding) joint of a body (SCENE.md ``bodies.NAME.guide``): the body slides along
    ``axis``, fixed in body ``on`` (None: the ground), and keeps ``on``'s orientation.

    Its coordinate is the slide s (from the body's position at t = 0, along the axis), its rate
    s_dot; the laws are those of a hinge with s for θ (:class:`Hinge`): the generalized force on s
    is f = k(s, ṡ, t)(s − s_r) + c(s, ṡ, t) ṡ − F(s, ṡ, t), s_r = ``rest``. The laws are stored with
    the hinge's variable names (``theta``, ``theta_dot``), so that a guide's law is evaluated by the
    same code as a hinge's (:func:`guide_law_text`)."""
    axis: np.ndarray                        # (3,) unit, global at t = 0
    on: str | None = None                   # the body the axis is fixed in; None: the ground
    stiffness: float | HingeLaw = 0.0
    damping: float | HingeLaw = 0.0
    force: TimeFunction | HingeLaw | None = None   # applied along the axis
    position: TimeFunction | None = None    # prescribed slide (no coordinate)
    lock_at: float | None = None            # latches when the slide reaches this value
    rest: float = 0.0                       # neutral slide of the spring
    limits: tuple[float, float] | None = None   # hard stops [lo, hi] on the slide
    restitution: float = 0.0                # of an impact on a stop, in [0, 1]
    contact: StopContact | None = None      # the stops compliant (Hunt–Crossley), docs/contact.md
    friction: JointFriction | None = None   # Coulomb, Stribeck and viscous friction on the slide


def guide_law_text(value, file, key):
    """A guide's law as the hinge-law text it equals: ``s`` → ``theta``, ``s_dot`` → ``theta_dot``
    (whole words; a number or a table is returned as it is). ``theta``/``theta_dot`` in a guide's
    law are refused: its variables are s and s_dot."""
    if not isinstance(value, str):
        return value
    if re.search(r"\btheta(_dot)?\b", value):
        raise SceneError(file, key, f"a guide's law is in s, s_dot and t (not theta, theta_dot), got {value!r}")
    return re.sub(r"\bs_dot\b", "theta_dot", re.sub(r"\bs\b(?!_)", "theta", value))


def in_guide_words(error: SceneError) -> SceneError:
    """A refusal of a guide's law (parsed as the hinge law it equals, :func:`guide_law_text`) said in
    the guide's words: the user's ``s``, ``s_dot`` where the hinge law's ``theta``, ``theta_dot`` stand,
    so that the message quotes the text as it was typed and names the variables a guide's law takes."""
    said = error.expected.replace("theta (hinge angle), theta_dot (its rate)", "s (the slide), s_dot (its rate)")
    said = re.sub(r"\btheta_dot\b", "s_dot", re.sub(r"\btheta\b(?!_)", "s", said))
    return SceneError(error.file, error.key, said)


@record
class BeamEnd:
    """One end of a beam: the grid point and how it is joined."""
    body: str | None        # None for a free end (a new massless node)
    offset: np.ndarray      # (3,) grid point offset in body axes (zeros for a body reference / free end)
    point: np.ndarray       # (3,) global position of the grid point at t = 0
    joint: str              # "clamped" | "hinge" | "free"
    hinge: Hinge | None = None


@record
class Beam:
    """A flexible beam meshed into ``elements`` equal elements."""
    name: str
    start: BeamEnd
    end: BeamEnd
    section: Section
    elements: int
    y_axis: np.ndarray      # (3,) unit, normal to x = start -> end
    rigid: bool = False     # one rigid link (elements is then 1 and no elements are meshed)
    #: the ``y_axis`` as given (before it is made unit and its x part taken off), None where global z × x is
    #: taken: the frame's derivative by a geometry parameter (latdyn/analyses/geometry_sensitivities.py) follows it
    y_given: np.ndarray | None = None

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.end.point - self.start.point))

    @property
    def x_axis(self) -> np.ndarray:
        d = self.end.point - self.start.point
        return d / np.linalg.norm(d)


@record
class Cable:
    """A tension-only member (``cables.NAME``, latdyn/model/cables.py): ``elements`` equal elements
    between two ends (``body`` None: a free end node at ``point``), axial stiffness EA, mass per
    unstretched length rhoA, axial damping c; its rest length a function of time (the initial distance
    of its ends when the scene gives none)."""
    name: str
    start: BeamEnd
    end: BeamEnd
    EA: float
    rhoA: float
    damping: float
    elements: int
    rest_length: TimeFunction

    @property
    def length(self) -> float:
        """The distance of its ends at t = 0."""
        return float(np.linalg.norm(self.end.point - self.start.point))


@record
class Body:
    """A rigid joint body; frame parallel to the global axes at t = 0."""
    name: str
    at: np.ndarray          # (3,) reference point at t = 0
    mass: float
    com: np.ndarray         # (3,) centre of mass relative to `at`
    inertia: np.ndarray     # (3, 3) about the centre of mass, t = 0 axes
    fixed: bool = False
    translation: list[TimeFunction] | None = None   # displacement of `at`
    rotation_axis: np.ndarray | None = None          # (3,) unit, through `at`
    rotation_angle: TimeFunction | None = None
    guide: "Guide | None" = None  # a sliding joint: the body's one coordinate is its slide

    @property
    def prescribed(self) -> bool:
        """True when a motion law (translation and/or rotation) is given."""
        return self.translation is not None or self.rotation_angle is not None


@record
class PointRef:
    """``BODY`` | ``BEAM.start`` (node 0) | ``BEAM.end`` (node = elements) | ``BEAM.node[i]``."""
    text: str
    body: str | None = None
    beam: str | None = None
    node: int | None = None


@record
class Load:
    """Force and/or moment applied at a point; components in ``frame`` ("global" or a body)."""
    at: PointRef
    force: list[TimeFunction] | None
    moment: list[TimeFunction] | None
    frame: str = "global"


@record
class Probe:
    """One recorded column of probes.csv.

    ``kind`` and the fields it uses:

    - ``point``: point, quantity (position|displacement|velocity), frame, component (x|y|z|norm);
    - ``hinge``: beam, end ("start"|"end"), quantity (angle|rate|torque);
    - ``guide``: body (the guided body), quantity (position|rate|force);
    - ``energy``: quantity (kinetic|strain|potential|external_work|dissipated|total);
    - ``momentum``: quantity (linear|angular), component (x|y|z);
    - ``element``: beam, element (0-based index), quantity (axial_force|torque|moment_y|moment_z);
    - ``cable``: beam (the cable's name), quantity (tension|length).
    """
    name: str
    kind: str
    point: PointRef | None = None
    quantity: str | None = None
    frame: str = "global"
    component: str | None = None
    beam: str | None = None
    end: str | None = None
    element: int | None = None
    body: str | None = None  # a guide probe's guided body
    #: ``controller``: its output, or with ``state`` that state (latdyn.scene.controllers)
    controller: str | None = None
    state: str | None = None


@record
class Solve:
    """The scene's ``solve`` section as read (SCENE.md, "solve"): the analysis and its settings."""

    analysis: str = "transient"
    t_end: float | None = None
    dt: float | None = None
    method: str = "generalized-alpha"
    rho_inf: float = 0.8
    tol: float | None = None
    steps: int = 10
    count: int = 6
    adaptive: bool = False
    error_tol: float = 1e-4
    dt_min: float | None = None
    max_iterations: int = 25
    formulation: str = "default"
    engine: str = "auto"
    newton: str = "full"
    planar: str = "auto"
    #: the state a modal analysis linearises about: "initial", "static", "steady" or a time T (float)
    about: str | float = "initial"
    #: ``{"inputs": [...], "outputs": [...]}``: write OUT/linear_model.npz (latdyn/analyses/linearise.py)
    linear_model: dict | None = None
    #: a modal run also writes its mode shapes as ParaView animations (OUT/paraview/modes)
    mode_shapes: bool = False
    #: static ``method: displacement-control``: the controlled point and its displacement
    control: "Control | None" = None
    #: static ``method: arc-length``: most path steps (default 20 × steps)
    max_steps: int | None = None
    #: buckling: search the flutter load along the path (None: where the loads are follower loads,
    #: latdyn/analyses/stability.py)
    flutter: bool | None = None
    #: names of parameters whose derivatives of the probes are asked for (latdyn/scene/parameters.py)
    sensitivities: list[str] = field(default_factory=list)
    #: how they are computed: "forward" (every row) or "adjoint" (end, max, min; docs/parameters.md)
    sensitivity_method: str = "forward"


@record
class Control:
    """Displacement control (static): the displacement of ``point`` along the unit vector
    ``direction`` goes from 0 to ``to`` in ``steps`` equal increments; the load factor follows."""
    point: PointRef
    direction: np.ndarray
    to: float
    #: the direction as written (x, y, z or a vector), for messages
    text: str = ""


@record
class Output:
    """The scene's ``output`` section as read (SCENE.md, "output"): rows, ParaView frames, probes."""

    every: float | None = None
    #: time between ParaView frames; None: the package's choice (latdyn.results.paraview.default_every); 0: none
    paraview_every: float | None = None
    probes: list[Probe] = field(default_factory=list)


@record
class InitialVelocity:
    """Rigid motion of the whole structure at t = 0: velocity ``linear`` at ``about``; ``given``:
    the scene says it (without, the parts that prescribed bodies hold start with them:
    docs/initial_state.md)."""
    linear: np.ndarray
    angular: np.ndarray
    about: np.ndarray
    given: bool = False

    def velocity_at(self, point) -> np.ndarray:
        """Velocity of a material point at ``point`` (3,) at t = 0."""
        return self.linear + np.cross(self.angular, np.asarray(point, float) - self.about)


@record
class Scene:
    """A scene as :func:`load_scene` reads and validates it: every section, the file it came from and its hash."""

    title: str
    file: str
    source_hash: str        # sha256 of the canonical JSON of `raw`
    gravity: np.ndarray
    initial_velocity: InitialVelocity
    sections: dict[str, Section]
    bodies: dict[str, Body]
    beams: dict[str, Beam]
    loads: list[Load]
    solve: Solve
    output: Output
    raw: dict
    #: ``parameters``: their values and which key paths use them (latdyn/scene/parameters.py)
    parameters: Parameters = field(default_factory=Parameters)
    #: ``inputs``: named external signals (latdyn.scene.inputs); set from outside with ``inputs.set(NAME, value)``
    inputs: Inputs = field(default_factory=Inputs)
    #: ``controllers``: control laws in the loop (latdyn.scene.controllers), in file order
    controllers: dict[str, Controller] = field(default_factory=dict)
    #: each controller's current output, which the laws that name it read
    controller_outputs: ControllerOutputs = field(default_factory=ControllerOutputs)
    #: each controller state's current value, named ``CONTROLLER.STATE``
    controller_states: Signals = field(default_factory=Signals)
    #: ``cables``: tension-only members between points (latdyn/model/cables.py), in file order
    cables: dict[str, Cable] = field(default_factory=dict)

    @property
    def n_elements(self) -> int:
        return sum(b.elements for b in self.beams.values() if not b.rigid)

    @property
    def hinges(self) -> list[tuple[str, str, Hinge]]:
        """(beam, "start"|"end", hinge) for every hinged beam end, in file order."""
        out = []
        for beam in self.beams.values():
            for which in ("start", "end"):
                end = getattr(beam, which)
                if end.hinge is not None:
                    out.append((beam.name, which, end.hinge))
        return out


# =========================================================================== YAML reading
def _index_suffix(scanner, length: int) -> int:
    """Length of ``[digits]`` at ``length`` in the scanner's buffer, or 0."""
    k = length + 1
    if scanner.peek(k) in "+-":
        k += 1
    digits = 0
    while scanner.peek(k).isdigit():
        k += 1
        digits += 1
    return k + 1 - length if digits and scanner.peek(k) == "]" else 0


#: The words YAML 1.1 reads as booleans. Scenes are read with YAML 1.2's booleans (true,
#: false), so these arrive as the words written; keys that take a boolean accept them.
YAML_WORDS = {"yes": True, "on": True, "true": True, "no": False, "off": False, "false": False}


def _yaml_loader():
    """SafeLoader for scenes.

    Four differences from ``yaml.SafeLoader``: ``2.8e7`` is a float (YAML 1.2; YAML
    1.1 wants ``2.8e+7``), only true and false are booleans (YAML 1.2; ``off``, ``no``
    stay words), a value its tag cannot read is a YAML error with its
    line, and a point such as ``arm.node[3]`` or
    ``arm.element[0]`` stays one plain scalar inside flow mappings
    (``{element: arm.element[0], quantity: torque}``), where YAML would
    otherwise read ``[`` as the start of a sequence.
    """
    import yaml
    from yaml.constructor import ConstructorError
    from yaml.tokens import ScalarToken

    class Loader(yaml.SafeLoader):
        def construct_object(self, node, deep=False):
            # A value its tag cannot read (``!!int abc``, ``!!bool maybe``, an integer of more
            # than 4300 digits) raises a plain ValueError, KeyError, ... with no position:
            # make it a YAML error that names the line.
            try:
                return super().construct_object(node, deep)
            except (ValueError, TypeError, KeyError, AttributeError, OverflowError):
                what = show_value(node.value) if isinstance(node, yaml.ScalarNode) else "a value"
                tag = node.tag.replace("tag:yaml.org,2002:", "!!")
                raise ConstructorError(None, None, f"cannot read {what} as {tag}", node.start_mark) from None

        def scan_plain(self):
            # yaml.scanner.Scanner.scan_plain, with "NAME[123]" kept whole in flow context
            chunks = []
            start_mark = self.get_mark()
            end_mark = start_mark
            indent = self.indent + 1
            spaces = []
            blank = "\0 \t\r\n\x85\u2028\u2029"
            while True:
                length = 0
                if self.peek() == "#":
                    break
                while True:
                    ch = self.peek(length)
                    if self.flow_level and ch == "[" and length > 0:
                        extra = _index_suffix(self, length)
                        if extra:
                            length += extra
                            continue
                    if ch in blank \
                            or (ch == ":" and self.peek(length + 1) in blank + (",[]{}" if self.flow_level else "")) \
                            or (self.flow_level and ch in ",?[]{}"):
                        break
                    length += 1
                if length == 0:
                    break
                self.allow_simple_key = False
                chunks.extend(spaces)
                chunks.append(self.prefix(length))
                self.forward(length)
                end_mark = self.get_mark()
                spaces = self.scan_plain_spaces(indent, start_mark)
                if not spaces or self.peek() == "#" or (not self.flow_level and self.column < indent):
                    break
            return ScalarToken("".join(chunks), True, start_mark, end_mark)

        def resolve(self, kind, value, implicit):
            # Resolver.resolve, each distinct plain text matched against the resolvers' patterns once
            # a file (the lattice's 1 400 lines: 2 567 nodes, 346 texts): without path resolvers a
            # plain scalar's tag is a function of its text alone, so the tags are the same
            if kind is not yaml.ScalarNode or not implicit[0] or self.yaml_path_resolvers:
                return super().resolve(kind, value, implicit)
            tags = self.__dict__.setdefault("_tag_of_text", {})
            tag = tags.get(value)
            if tag is None:
                tag = tags[value] = super().resolve(kind, value, implicit)
            return tag

    # YAML 1.2 booleans: only true/false. YAML 1.1 (PyYAML's default) also reads the words
    # yes/no/on/off as booleans, so that ``planar: off`` or a body named ``no`` would arrive
    # as False; here they stay the words the user wrote (SCENE.md, "YAML words"), and the
    # keys that take a boolean accept them (_Validator.boolean).
    Loader.yaml_implicit_resolvers = {
        first: [(tag, regexp) for tag, regexp in resolvers if tag != "tag:yaml.org,2002:bool"]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
    Loader.add_implicit_resolver("tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"),
                                 list("tTfF"))
    Loader.add_implicit_resolver(
        "tag:yaml.org,2002:float",
        re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
        list("-+0123456789"),
    )
    return Loader


def _check_duplicate_keys(node, path: str, file: str, seen_nodes: set) -> None:
    import yaml

    if id(node) in seen_nodes:
        return
    seen_nodes.add(id(node))
    if isinstance(node, yaml.MappingNode):
        names: dict[str, int] = {}
        for key_node, value_node in node.value:
            name = key_node.value if isinstance(key_node, yaml.ScalarNode) else None
            sub = _join(path, name)
            if name is not None:
                if name in names:
                    raise SceneError(file, sub, f"duplicated key (first on line {names[name] + 1}, "
                                                f"again on line {key_node.start_mark.line + 1}); "
                                                "expected each name once")
                names[name] = key_node.start_mark.line
            _check_duplicate_keys(value_node, sub, file, seen_nodes)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _check_duplicate_keys(item, f"{path}[{i}]", file, seen_nodes)


class _JsonObject(dict):
    """A JSON object that remembers keys given more than once."""
    duplicates: list


def _json_pairs(pairs):
    obj = _JsonObject()
    obj.duplicates = []
    for k, v in pairs:
        if k in obj:
            obj.duplicates.append(k)
        obj[k] = v
    return obj


def _find_json_duplicate(value, path: str, file: str) -> None:
    if isinstance(value, _JsonObject):
        if value.duplicates:
            raise SceneError(file, _join(path, value.duplicates[0]), "duplicated key; expected each name once")
        for k, v in value.items():
            _find_json_duplicate(v, _join(path, k), file)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _find_json_duplicate(v, f"{path}[{i}]", file)


def _plain(value):
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _read_json(text: str, file: str) -> Any:
    try:
        data = json.loads(text, object_pairs_hook=_json_pairs)
    except json.JSONDecodeError as exc:
        raise SceneError(file, f"line {exc.lineno}, column {exc.colno}", f"invalid JSON: {exc.msg}") from None
    except ValueError:  # an integer of more than 4300 digits
        raise SceneError(file, "<file>", "invalid JSON: an integer too long to read; expected numbers "
                                         "of a sensible size") from None
    _find_json_duplicate(data, "", file)
    return _plain(data)


def _read_text(path: Path, file: str) -> Any:
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(file, "<file>", "no such file; expected a scene file (YAML or JSON)") from None
    except IsADirectoryError:
        raise SceneError(file, "<file>", "is a directory; expected a scene file (YAML or JSON)") from None
    except UnicodeDecodeError as exc:
        raise SceneError(file, "<file>", f"not UTF-8 text ({exc.reason}); expected a YAML or JSON file") from None
    except OSError as exc:
        raise SceneError(file, "<file>", f"cannot be read ({exc.strerror or exc})") from None
    if path.suffix.lower() == ".json":
        return _read_json(text, file)
    data = _read_yaml_in_c(text, file)
    if data is not _MISSING:
        return data
    loader = _yaml_loader()(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_duplicate_keys(node, "", file, set())
        return loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "<file>"
        what = " ".join(str(p) for p in (exc.context, exc.problem) if p)
        raise SceneError(file, where, f"invalid YAML/JSON: {what}") from None
    except yaml.YAMLError as exc:
        raise SceneError(file, "<file>", f"invalid YAML/JSON: {exc}") from None
    finally:
        loader.dispose()


#: Where libyaml (C) parses a scene: text it reads as the Python scanner of :func:`_yaml_loader` does (no
#: ``[`` right after a character of a plain scalar, which that scanner keeps whole in flow context:
#: ``{element: arm.element[0]}``), nested shallowly enough for its recursive composer (≤ 2 000
#: brackets, ≤ 4 MB: a few thousand levels at most; 50 000 crash it).
_C_YAML_LIMITS = {"brackets": 2_000, "characters": 4_000_000}
_INDEX_IN_FLOW = re.compile(r"[^\s\[{,]\[")


def _read_yaml_in_c(text: str, file: str) -> Any:
    """The data of a YAML scene parsed by libyaml, with the constructor and resolvers of
    :func:`_yaml_loader` (the same values; the same duplicate-key check): about 5× faster than the
    Python parser on a large scene (a 16-bay lattice of 1 400 lines: 60 ms). ``_MISSING`` where the
    Python parser must read it: no libyaml, text outside :data:`_C_YAML_LIMITS`, text with a tab, a
    carriage return or a byte-order mark after its start (which libyaml accepts or drops where the
    Python scanner refuses or keeps them: a scene must not load on one installation and not another),
    or any YAML error (whose message and line then come from the Python parser, as always)."""
    import yaml

    if not getattr(yaml, "__with_libyaml__", False) or len(text) > _C_YAML_LIMITS["characters"] \
            or text.count("[") + text.count("{") > _C_YAML_LIMITS["brackets"] or _INDEX_IN_FLOW.search(text) \
            or "\t" in text or "\r" in text or "\ufeff" in text[1:]:
        return _MISSING
    loader = _c_yaml_loader()(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        data = _plain_document(loader, node)
        if data is not _MISSING:
            return data
        _check_duplicate_keys(node, "", file, set())
        return loader.construct_document(node)
    except yaml.YAMLError:
        return _MISSING
    finally:
        loader.dispose()


def _c_yaml_loader():
    """The loader of :func:`_yaml_loader` with libyaml's parser (``yaml.cyaml.CParser``) for its scanner,
    parser and composer."""
    import yaml

    class Loader(yaml.cyaml.CParser, _yaml_loader()):
        def __init__(self, stream):
            yaml.cyaml.CParser.__init__(self, stream)
            yaml.constructor.SafeConstructor.__init__(self)
            yaml.resolver.Resolver.__init__(self)

    return Loader


_YAML = "tag:yaml.org,2002:"
#: The tags of :func:`_plain_document`'s nodes: a scalar's (str, int, float, bool, null), a mapping's, a sequence's.
_PLAIN_SCALAR_TAGS = frozenset(_YAML + name for name in ("str", "int", "float", "bool", "null"))
_MAP_TAG, _SEQ_TAG = _YAML + "map", _YAML + "seq"
#: The deepest nesting :func:`_plain_document` walks (its recursion: one frame a level); a scene nests a few
#: levels, and a deeper document is left to the duplicate-key walk and the constructor (and their depth error).
_PLAIN_DEPTH = 200
#: What the scalar constructors of :data:`_PLAIN_SCALAR_TAGS` raise for a text their tag cannot read: ValueError
#: (``!!int abc``, ``0b_``, an integer of more than 4 300 digits, ``!!float x``), KeyError (``!!bool maybe``).
_UNREADABLE_SCALAR = (ValueError, KeyError)


class _NotPlain(Exception):
    """A node outside :func:`_plain_document`'s subset (raised and caught there only)."""


def _plain_document(loader, node) -> Any:
    """The data of a composed YAML document of plain nodes only, in one walk that also checks each mapping's
    keys: what :func:`_check_duplicate_keys` and ``loader.construct_document`` give, made with the loader's own
    constructors of the scalars, each distinct text of a tag once (docs/performance.md, "Thirteenth pass").
    ``_MISSING`` for anything else, which those two then read as before, with their errors: a tag but str, int,
    float, bool, null, map and seq (``!!set``, ``!!binary``, a timestamp, a merge key ``<<`` …), a mapping or
    sequence met twice (an alias; a scalar's alias is the same text, read to the same value), a mapping's key
    that is not a scalar or is given twice, a scalar its constructor cannot read (:data:`_UNREADABLE_SCALAR`,
    from that call alone), nesting deeper than :data:`_PLAIN_DEPTH`. Each is decided where it is met; any other
    exception is a fault of the walk and propagates."""
    import yaml

    scalar_node, mapping_node, sequence_node = yaml.ScalarNode, yaml.MappingNode, yaml.SequenceNode
    constructors = loader.yaml_constructors
    read: dict = {}  # (tag, text) -> the value its constructor made (str, int, float, bool or None)
    seen: set = set()

    def scalar(node):
        tag = node.tag
        if tag not in _PLAIN_SCALAR_TAGS:
            raise _NotPlain
        found = read.get((tag, node.value), read)
        if found is read:
            construct = constructors[tag]
            try:
                found = construct(loader, node)
            except _UNREADABLE_SCALAR:
                raise _NotPlain from None
            read[tag, node.value] = found
        return found

    def value(node, depth):
        kind = type(node)
        if kind is scalar_node:
            return scalar(node)
        if id(node) in seen or depth == _PLAIN_DEPTH:
            raise _NotPlain
        seen.add(id(node))
        depth += 1
        if kind is mapping_node and node.tag == _MAP_TAG:
            mapping, names = {}, set()
            for key_node, value_node in node.value:
                if type(key_node) is not scalar_node or key_node.value in names:
                    raise _NotPlain
                names.add(key_node.value)
                key = scalar(key_node)
                mapping[key] = value(value_node, depth)
            return mapping
        if kind is sequence_node and node.tag == _SEQ_TAG:
            return [value(item, depth) for item in node.value]
        raise _NotPlain

    try:
        return value(node, 0)
    except _NotPlain:
        return _MISSING


def _too_deep(file: str) -> SceneError:
    return SceneError(file, "(top level)", "nested too deeply; expected a scene of mappings and lists "
                                           "a few levels deep")


def _read_file(path: Path, file: str) -> Any:
    """The data of a YAML or JSON scene file (deep nesting refused)."""
    try:
        return _read_text(path, file)
    except RecursionError:
        raise _too_deep(file) from None


# =========================================================================== helpers
_MISSING = object()


_NAME_FORBIDDEN = re.compile(r"[.\[\],\"']")


def _valid_name(name) -> bool:
    """A name of a part or probe: printable text without . [ ] , quotes or surrounding spaces."""
    return (isinstance(name, str) and bool(name.strip()) and name == name.strip() and name.isprintable()
            and not _NAME_FORBIDDEN.search(name))


def _join(path: str, key) -> str:
    """``path.key``; a key that would not show in the path is quoted (``bodies.''``, ``bodies.' hub'``)."""
    plain = isinstance(key, str) and key and key == key.strip() and key.isprintable()
    text = key if plain else "null" if key is None else show_value(key)
    return f"{path}.{text}" if path else text


def _listing(names) -> str:
    names = list(names)
    return ", ".join(names) if names else "none"


def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _direction(v: np.ndarray) -> np.ndarray:
    """``v / |v|`` for a non-zero finite vector, without overflow or underflow in ``|v|``."""
    v = v / np.abs(v).max()
    return v / np.linalg.norm(v)


class _Reader:
    """Validation state: the file name for messages and the parts read so far."""

    def __init__(self, file: str):
        self.file = file
        self.sections: dict[str, Section] = {}
        self.bodies: dict[str, Body] = {}
        self.beams: dict[str, Beam] = {}
        self.cables: dict[str, Cable] = {}
        self.n_elements = 0  # elements of the beams read so far
        self.controller_specs: dict | None = None  # the scene's controllers as written (probes name them)
        self.input_names: tuple = ()  # the scene's inputs (solve.linear_model.inputs may name them)

    # -- primitive checks -------------------------------------------------------
    def fail(self, key: str, expected: str, got: Any = _MISSING):
        raise SceneError(self.file, key, expected if got is _MISSING else f"{expected}, got {show_value(got)}")

    def mapping(self, value, key, allowed, required=(), what="a mapping") -> dict:
        label = key or "(top level)"
        if not isinstance(value, dict):
            self.fail(label, f"expected {what} with keys {_listing(allowed)}", value)
        for k in value:
            if not isinstance(k, str):
                self.fail(label, f"expected text keys ({_listing(allowed)})", k)
            if k not in allowed:
                import difflib  # on use: only a refused key needs it

                close = difflib.get_close_matches(k, allowed, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                self.fail(_join(key, k), f"unknown key{hint}; allowed keys here: {_listing(allowed)}")
        for r in required:
            if r not in value:
                self.fail(_join(key, r), f"missing required key {r!r}")
        return value

    def named_mapping(self, value, key, what) -> dict:
        """A mapping NAME -> spec (sections, bodies, beams); None counts as empty."""
        if value is None:
            return {}
        if not isinstance(value, dict):
            self.fail(key, f"expected a mapping of {what} names to their definitions", value)
        for name in value:
            self.check_name(name, key, what)
        return value

    def check_name(self, name, key, what):
        if not isinstance(name, str) or not name.strip():
            self.fail(key, f"expected {what} names as text", name)
        if not _valid_name(name):
            self.fail(_join(key, name), f"expected a {what} name of printable characters without . [ ] , "
                                        "quotes, line breaks or surrounding spaces", name)

    def number(self, value, key, *, positive=False, nonnegative=False, lo=None, hi=None) -> float:
        if isinstance(value, str):
            tf = parse_time_function(value, self.file, key)
            if not tf.is_constant:
                self.fail(key, "expected a constant (a number or an expression without t)", value)
            x = tf.value(0.0)
        elif _is_number(value):
            try:
                x = float(value)
            except OverflowError:  # an integer beyond the float range
                self.fail(key, "expected a finite number", value)
        else:
            self.fail(key, "expected a number", value)
        if not math.isfinite(x):
            self.fail(key, "expected a finite number", value)
        if positive and not x > 0:
            self.fail(key, "expected a positive number", value)
        if nonnegative and not x >= 0:
            self.fail(key, "expected a number >= 0", value)
        if lo is not None and hi is not None and not lo <= x <= hi:
            self.fail(key, f"expected a number in [{lo:g}, {hi:g}]", value)
        return x

    def integer(self, value, key, *, minimum=1, maximum=MAX_COUNT, why="") -> int:
        """A whole number in [minimum, maximum]; ``why`` explains the maximum in the message."""
        number = value
        if isinstance(number, str):   # a constant expression ("2*n" of parameters n)
            function = parse_time_function(number, self.file, key)
            if not function.is_constant:
                self.fail(key, f"expected a whole number >= {minimum}", value)
            number = function.value(0.0)
        if isinstance(number, float) and math.isfinite(number) and number.is_integer():
            number = int(number)
        if not isinstance(number, (int, np.integer)) or isinstance(number, (bool, np.bool_)):
            self.fail(key, f"expected a whole number >= {minimum}", value)
        if number < minimum:
            self.fail(key, f"expected a whole number >= {minimum}", value)
        if number > maximum:
            self.fail(key, f"expected a whole number <= {maximum}{why}", value)
        return int(number)

    def boolean(self, value, key) -> bool:
        if isinstance(value, str) and value.lower() in YAML_WORDS:  # fixed: yes (YAML 1.1 spelling)
            return YAML_WORDS[value.lower()]
        if not isinstance(value, bool):
            self.fail(key, "expected true or false", value)
        return value

    def choice(self, value, key, options, what="one of") -> str:
        if isinstance(value, bool):
            # a word that a YAML 1.1 reader (a study's overrides, a scene built in Python from
            # yaml.safe_load) turned into a boolean: the one option it can have been, if any
            words = [o for o in options if YAML_WORDS.get(str(o).lower()) is value]
            if len(words) == 1:
                return words[0]
            self.fail(key, f"expected {what} {_listing(options)} (a word that YAML reads as a boolean, "
                           "such as off or yes, must be quoted: \"off\")", value)
        if isinstance(value, str) and value not in options and value.lower() in YAML_WORDS \
                and value.lower() in options:
            return value.lower()  # planar: Off
        if not isinstance(value, str) or value not in options:
            self.fail(key, f"expected {what} {_listing(options)}", value)
        return value

    def vector(self, value, key, *, nonzero=False, what="[x, y, z]") -> np.ndarray:
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            self.fail(key, f"expected a vector {what} of 3 numbers", value)
        v = np.array([self.number(x, f"{key}[{i}]") for i, x in enumerate(value)], dtype=np.float64)
        if nonzero and not np.any(v):
            self.fail(key, f"expected a non-zero vector {what}", value)
        return v

    def unit(self, value, key) -> np.ndarray:
        return _direction(self.vector(value, key, nonzero=True, what="[ax, ay, az]"))

    def time_functions(self, value, key) -> list[TimeFunction]:
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            self.fail(key, "expected 3 components [fx, fy, fz], each a number, an expression in t "
                           "or a {table: ...}", value)
        return [parse_time_function(x, self.file, f"{key}[{i}]") for i, x in enumerate(value)]

    def ref(self, value, key, known: dict, what: str) -> str:
        if not isinstance(value, str) or value not in known:
            self.fail(key, f"expected the name of a {what} (known: {_listing(known)})", value)
        return value

    def frame(self, value, key) -> str:
        if value == "global":
            return value
        if not isinstance(value, str) or value not in self.bodies:
            self.fail(key, f"expected global or the name of a body (known: {_listing(self.bodies)})", value)
        return value

    # -- parts -------------------------------------------------------------------
    def section(self, name, spec, key) -> Section:
        self.mapping(spec, key, _SECTION_KEYS, required=("EA", "EIy", "EIz", "GJ", "rhoA"))
        stiff = {k: self.number(spec[k], _join(key, k), positive=True) for k in ("EA", "EIy", "EIz", "GJ")}
        inert = {k: self.number(spec[k], _join(key, k), nonnegative=True)
                 for k in ("rhoA", "rhoIy", "rhoIz") if k in spec}
        shear = {k: self.number(spec[k], _join(key, k), positive=True) for k in ("GAy", "GAz") if k in spec}
        return Section(name=name, **stiff, **inert, **shear)

    def inertia(self, value, key) -> np.ndarray:
        if isinstance(value, (list, tuple)) and len(value) == 3 and all(isinstance(r, (list, tuple)) for r in value):
            if any(len(r) != 3 for r in value):
                self.fail(key, "expected [Ixx, Iyy, Izz] or a 3x3 list", value)
            inertia = np.array([[self.number(x, f"{key}[{i}][{j}]") for j, x in enumerate(row)]
                                for i, row in enumerate(value)], dtype=np.float64)
            scaled = inertia / max(np.abs(inertia).max(), 1e-300)   # entries up to 1: no overflow below
            if np.abs(scaled - scaled.T).max() > 1e-9:
                self.fail(key, "expected a symmetric inertia matrix", value)
            if np.linalg.eigvalsh(0.5 * (scaled + scaled.T)).min() < -1e-12:
                self.fail(key, "expected a positive semi-definite inertia matrix", value)
            return 0.5 * inertia + 0.5 * inertia.T
        if isinstance(value, (list, tuple)) and len(value) == 3:
            diag = [self.number(x, f"{key}[{i}]", nonnegative=True) for i, x in enumerate(value)]
            return np.diag(np.array(diag, dtype=np.float64))
        self.fail(key, "expected [Ixx, Iyy, Izz] or a 3x3 list", value)

    def body(self, name, spec, key) -> Body:
        if name == "global":
            self.fail(key, "'global' is reserved for the global frame; expected another body name")
        self.mapping(spec, key, _BODY_KEYS, required=("at",))
        at = self.vector(spec["at"], _join(key, "at"))
        mass = self.number(spec.get("mass", 0.0), _join(key, "mass"), nonnegative=True)
        com = self.vector(spec["com"], _join(key, "com")) if "com" in spec else np.zeros(3)
        inertia = self.inertia(spec["inertia"], _join(key, "inertia")) if "inertia" in spec else np.zeros((3, 3))
        fixed = self.boolean(spec["fixed"], _join(key, "fixed")) if "fixed" in spec else False
        body = Body(name=name, at=at, mass=mass, com=com, inertia=inertia, fixed=fixed)
        if "motion" in spec:
            mkey = _join(key, "motion")
            if fixed:
                self.fail(mkey, "a fixed body takes no motion; expected either fixed: true or motion, not both")
            motion = spec["motion"]
            self.mapping(motion, mkey, ("translation", "rotation"))
            if not motion:
                self.fail(mkey, "expected translation and/or rotation")
            if "translation" in motion:
                body.translation = self.time_functions(motion["translation"], _join(mkey, "translation"))
            if "rotation" in motion:
                rkey = _join(mkey, "rotation")
                rot = self.mapping(motion["rotation"], rkey, ("axis", "angle"), required=("axis", "angle"))
                body.rotation_axis = self.unit(rot["axis"], _join(rkey, "axis"))
                body.rotation_angle = parse_time_function(rot["angle"], self.file, _join(rkey, "angle"))
        return body

    def hinge(self, spec, key) -> Hinge:
        self.mapping(spec, key, _HINGE_KEYS, required=("axis",))
        given = self.vector(spec["axis"], _join(key, "axis"), nonzero=True, what="[ax, ay, az]")
        h = Hinge(axis=_direction(given), axis_given=given)
        for name in ("stiffness", "damping"):
            if name in spec:
                setattr(h, name, self.hinge_coefficient(spec[name], _join(key, name)))
        if "torque" in spec:
            law = parse_hinge_law(spec["torque"], self.file, _join(key, "torque"))
            h.torque = law if {"theta", "theta_dot"} & set(law.depends_on) else \
                parse_time_function(spec["torque"], self.file, _join(key, "torque"))
        if "angle" in spec:
            h.angle = parse_time_function(spec["angle"], self.file, _join(key, "angle"))
        self.stops_and_latch(h, spec, key, _HINGE_TRAVEL)
        if "rest_angle" in spec:
            h.rest_angle = self.number(spec["rest_angle"], _join(key, "rest_angle"))
        if "contact" in spec:
            h.contact = self.stop_contact(spec, key, h.limits)
        if "friction" in spec:
            h.friction = self.joint_friction(spec["friction"], _join(key, "friction"), spec.get("angle"))
        return h

    def stops_and_latch(self, joint, spec, key, words: _Travel) -> None:
        """``lock_at``, ``limits`` and ``restitution`` of a hinge or a guide (SCENE.md): one reading for
        both joints, said in the joint's words (:class:`_Travel`); sets them on ``joint``."""
        prescribed = getattr(joint, words.prescribed) is not None
        if "lock_at" in spec:
            joint.lock_at = self.number(spec["lock_at"], _join(key, "lock_at"))
            if prescribed:  # it was accepted and never latched
                self.fail(_join(key, "lock_at"), f"a prescribed {words.joint} ({words.prescribed}) has no free "
                                                 f"{words.free} to latch; expected no lock_at with "
                                                 f"{words.prescribed}", spec["lock_at"])
            if joint.lock_at == 0.0:  # latched a step late, past it (measured: energy balance error 1)
                self.fail(_join(key, "lock_at"), f"{words.coordinate} is 0 at t = 0, so it would be latched from "
                                                 f"the start; expected a lock_at other than 0 ({words.held})",
                          spec["lock_at"])
        if "limits" in spec:
            lkey = _join(key, "limits")
            value = spec["limits"]
            if not isinstance(value, (list, tuple)) or len(value) != 2:
                self.fail(lkey, f"expected hard stops [lo, hi] on {words.symbol}", value)
            lo, hi = (self.number(x, f"{lkey}[{i}]") for i, x in enumerate(value))
            if not lo <= 0.0 <= hi or not lo < hi:
                self.fail(lkey, f"expected lo <= 0 <= hi and lo < hi ({words.coordinate} is 0 at t = 0)", value)
            if prescribed:
                self.fail(lkey, f"a prescribed {words.joint} ({words.prescribed}) has no free {words.free} to "
                                f"stop; expected no limits with {words.prescribed}", value)
            if joint.lock_at is not None and not lo <= joint.lock_at <= hi:
                self.fail(_join(key, "lock_at"), f"expected lock_at within the limits [{lo:g}, {hi:g}] "
                                                 "(it could never be reached)", spec["lock_at"])
            joint.limits = (lo, hi)
        if "restitution" in spec:
            rkey = _join(key, "restitution")
            if joint.limits is None:
                self.fail(rkey, "restitution applies to impacts on hard stops; expected limits: [lo, hi] with it")
            joint.restitution = self.number(spec["restitution"], rkey, lo=0.0, hi=1.0)

    def guide(self, name, spec, key) -> Guide:
        """``bodies.NAME.guide`` (SCENE.md): a sliding joint; read after every body, as ``on`` may
        name a body defined later in the file. The key ``on`` that a YAML 1.1 reader (``yaml.safe_load``,
        not latdyn's) turned into ``True`` is refused with a message to quote it (SCENE.md, "YAML words")."""
        if isinstance(spec, dict) and True in spec:
            self.fail(_join(key, "on"), "a YAML 1.1 reader took the key `on` for the boolean true; quote it "
                                        "('on': BODY), or read the file with latdyn.load_scene(path)")
        self.mapping(spec, key, _GUIDE_KEYS, required=("axis",))
        body = self.bodies[name]
        if body.fixed or body.prescribed:
            self.fail(key, f"body {name!r} is {'fixed' if body.fixed else 'prescribed (motion)'}; a body with a "
                           "guide takes no fixed or motion: its motion is its slide (prescribe it with "
                           "guide.position)")
        g = Guide(axis=self.unit(spec["axis"], _join(key, "axis")))
        if spec.get("on") is not None:
            g.on = self.ref(spec["on"], _join(key, "on"), self.bodies, "body")
            if g.on == name:
                self.fail(_join(key, "on"), "expected another body (or none: the ground), not the guided body itself",
                          spec["on"])

        def law(sub):
            return guide_law_text(spec[sub], self.file, _join(key, sub))

        laws = {sub: law(sub) for sub in ("stiffness", "damping", "force") if sub in spec}
        try:  # parsed as the hinge laws they equal; a refusal is said in the guide's words
            for sub in ("stiffness", "damping"):
                if sub in laws:
                    setattr(g, sub, self.hinge_coefficient(laws[sub], _join(key, sub)))
            if "force" in laws:
                fkey = _join(key, "force")
                hinge_law = parse_hinge_law(laws["force"], self.file, fkey)
                g.force = hinge_law if {"theta", "theta_dot"} & set(hinge_law.depends_on) else \
                    parse_time_function(spec["force"], self.file, fkey)
        except SceneError as error:
            raise in_guide_words(error) from None
        if "position" in spec:
            g.position = parse_time_function(spec["position"], self.file, _join(key, "position"))
        if "rest" in spec:
            g.rest = self.number(spec["rest"], _join(key, "rest"))
        self.stops_and_latch(g, spec, key, _GUIDE_TRAVEL)
        if "contact" in spec:
            g.contact = self.stop_contact(spec, key, g.limits)
        if "friction" in spec:
            g.friction = self.joint_friction(spec["friction"], _join(key, "friction"), spec.get("position"))
        return g

    def guide_loops(self) -> None:
        """Refuse guides that carry each other round a loop (a on b, b on a)."""
        for name, body in self.bodies.items():
            seen, walk = [name], body
            while walk.guide is not None and walk.guide.on is not None:
                if walk.guide.on in seen:
                    self.fail(f"bodies.{name}.guide.on", "guides that carry each other round a loop ("
                              + " -> ".join(seen + [walk.guide.on]) + "); expected a tree of guides", walk.guide.on)
                seen.append(walk.guide.on)
                walk = self.bodies[walk.guide.on]

    def stop_contact(self, spec, key, limits) -> StopContact:
        """A joint's ``contact`` (compliant stops): only with ``limits``, never with ``restitution``."""
        ckey = _join(key, "contact")
        value = self.mapping(spec["contact"], ckey, ("stiffness", "exponent", "damping"), required=("stiffness",))
        if limits is None:
            self.fail(ckey, "contact makes the stops compliant; expected limits: [lo, hi] with it")
        if "restitution" in spec:
            self.fail(_join(key, "restitution"), "a compliant stop (contact) has no restitution: its damping "
                                                 "sets the loss; expected contact or restitution, not both")
        stiffness = self.number(value["stiffness"], _join(ckey, "stiffness"), positive=True)
        exponent = self.number(value.get("exponent", 1.0), _join(ckey, "exponent"))
        if exponent < 1.0:
            self.fail(_join(ckey, "exponent"), "expected an exponent >= 1 (1: linear, 1.5: Hertz)", value["exponent"])
        damping = self.number(value.get("damping", 0.0), _join(ckey, "damping"), nonnegative=True)
        return StopContact(stiffness, exponent, damping)

    def joint_friction(self, value, key, prescribed) -> JointFriction:
        """A joint's ``friction``: forces >= 0, static >= coulomb, stick_rate > 0; not on a prescribed joint."""
        self.mapping(value, key, ("coulomb", "static", "stribeck_rate", "viscous", "stick_rate"),
                     required=("coulomb",))
        if prescribed is not None:
            self.fail(key, "a prescribed joint has no free coordinate to resist; expected no friction with it")
        coulomb = self.number(value["coulomb"], _join(key, "coulomb"), nonnegative=True)
        static = self.number(value.get("static", coulomb), _join(key, "static"), nonnegative=True)
        if static < coulomb:
            self.fail(_join(key, "static"), f"expected a static level >= coulomb ({coulomb:g})", value["static"])
        stribeck = self.number(value.get("stribeck_rate", 0.0), _join(key, "stribeck_rate"), nonnegative=True)
        viscous = self.number(value.get("viscous", 0.0), _join(key, "viscous"), nonnegative=True)
        stick = self.number(value.get("stick_rate", 1e-3), _join(key, "stick_rate"), positive=True)
        return JointFriction(coulomb, static, stribeck, viscous, stick)

    def hinge_coefficient(self, value, key) -> float | HingeLaw:
        """A hinge stiffness or damping: a number >= 0, or a law in theta, theta_dot and t."""
        if _is_number(value):
            return self.number(value, key, nonnegative=True)
        law = parse_hinge_law(value, self.file, key)
        if law.is_constant:
            return self.number(law.constant, key, nonnegative=True)
        return law

    def beam_end(self, spec, key, joint_spec, joint_key, joint_given) -> BeamEnd:
        forms = "a body name, {body: NAME, offset: [dx, dy, dz]} or a point [x, y, z]"
        if isinstance(spec, str):
            body = self.ref(spec, key, self.bodies, "body")
            end = BeamEnd(body=body, offset=np.zeros(3), point=self.bodies[body].at.copy(), joint="clamped")
        elif isinstance(spec, dict):
            self.mapping(spec, key, ("body", "offset"), required=("body",))
            body = self.ref(spec["body"], _join(key, "body"), self.bodies, "body")
            offset = self.vector(spec["offset"], _join(key, "offset")) if "offset" in spec else np.zeros(3)
            end = BeamEnd(body=body, offset=offset, point=self.bodies[body].at + offset, joint="clamped")
        elif isinstance(spec, (list, tuple)):
            point = self.vector(spec, key, what="[x, y, z]")
            if joint_given:
                self.fail(joint_key, "a free end (a point [x, y, z]) takes no joint; "
                                     "expected no start/end key for it", joint_spec)
            return BeamEnd(body=None, offset=np.zeros(3), point=point, joint="free")
        else:
            self.fail(key, f"expected {forms}", spec)
        if not joint_given or joint_spec == "clamped":
            return end
        if isinstance(joint_spec, dict) and set(joint_spec) == {"hinge"}:
            end.joint = "hinge"
            end.hinge = self.hinge(joint_spec["hinge"], _join(joint_key, "hinge"))
            return end
        if isinstance(joint_spec, dict):
            self.mapping(joint_spec, joint_key, ("hinge",), required=("hinge",))
        self.fail(joint_key, "expected clamped or {hinge: {axis: [ax, ay, az], ...}}", joint_spec)

    def beam(self, name, spec, key) -> Beam:
        self.mapping(spec, key, _BEAM_KEYS, required=("from", "to", "section"))
        rigid = "rigid" in spec and self.boolean(spec["rigid"], _join(key, "rigid"))
        section = self.sections[self.ref(spec["section"], _join(key, "section"), self.sections, "section")]
        before = self.n_elements  # a running total: summing over the beams read would be O(n²)
        if rigid:  # SCENE.md: elements is ignored; the link is one segment from start to end
            elements = 1
        else:
            elements = self.integer(spec.get("elements", 1), _join(key, "elements"),
                                    maximum=MAX_ELEMENTS - before,
                                    why=f" (at most {MAX_ELEMENTS} elements in a scene, {before} in the beams before)")
        with np.errstate(over="ignore", invalid="ignore"):  # coordinates beyond float64: refused below
            start = self.beam_end(spec["from"], _join(key, "from"), spec.get("start"), _join(key, "start"),
                                  "start" in spec)
            end = self.beam_end(spec["to"], _join(key, "to"), spec.get("end"), _join(key, "end"), "end" in spec)
            d = end.point - start.point
            length = math.sqrt(float(np.dot(d, d)))
        if not math.isfinite(length):
            self.fail(key, f"beam from {start.point.tolist()} to {end.point.tolist()} is too long to compute "
                           "in float64; expected coordinates below about 1e150")
        scale = max(map(abs, start.point.tolist() + end.point.tolist()))  # NumPy's max of |x|, exactly: finite here
        if length == 0.0 or length <= 1e-12 * scale:
            self.fail(key, f"zero-length beam: from and to are both at {start.point.tolist()}; "
                           "expected two distinct points")
        x = d / length
        if "y_axis" in spec:
            y_key = _join(key, "y_axis")
            y_given = self.vector(spec["y_axis"], y_key, nonzero=True)
            y = _direction(y_given)
            y = y - np.dot(y, x) * x                       # Gram-Schmidt
            if np.linalg.norm(y) < 1e-8:
                self.fail(y_key, f"expected a direction not parallel to the beam (x = {x.round(12).tolist()})",
                          spec["y_axis"])
        else:
            y_given = None
            y = np.array([-x[1], x[0], 0.0])               # global Z × x, written out (np.cross is slow)
            if math.hypot(x[0], x[1]) < 1e-9:
                y = np.array([0.0, 1.0, 0.0])
                y = y - np.dot(y, x) * x
        if not rigid:
            self.n_elements += elements
        return Beam(name=name, start=start, end=end, section=section, elements=elements,
                    y_axis=y / math.sqrt(float(np.dot(y, y))), rigid=rigid, y_given=y_given)

    # indices of up to 18 digits: int() refuses more than 4300, and any index that long is out of range
    _POINT = re.compile(r"^(?P<name>[^.\[\]]+)\.(?:(?P<end>start|end)|node\[(?P<node>[+-]?\d{1,18})\])$")
    _ELEMENT = re.compile(r"^(?P<name>[^.\[\]]+)\.element\[(?P<index>[+-]?\d{1,18})\]$")
    _HINGE_REF = re.compile(r"^(?P<name>[^.\[\]]+)\.(?P<end>start|end)$")

    def point(self, value, key) -> PointRef:
        forms = (f"expected a point: BODY (known: {_listing(self.bodies)}) or BEAM.start, BEAM.end, "
                 f"BEAM.node[i] (beams: {_listing(self.beams)})")
        if not isinstance(value, str):
            self.fail(key, forms, value)
        if value in self.bodies:
            return PointRef(text=value, body=value)
        m = self._POINT.match(value)
        if not m or (m["name"] not in self.beams and m["name"] not in self.cables):
            self.fail(key, forms + (f" or CABLE.start, CABLE.end, CABLE.node[i] (cables: {_listing(self.cables)})"
                                    if self.cables else ""), value)
        beam = self.beams.get(m["name"]) or self.cables[m["name"]]
        if m["end"]:
            return PointRef(text=value, beam=beam.name, node=0 if m["end"] == "start" else beam.elements)
        node = int(m["node"])
        if not 0 <= node <= beam.elements:
            self.fail(key, f"node index out of range: expected 0 ... {beam.elements} for beam "
                           f"{beam.name!r}", value)
        return PointRef(text=value, beam=beam.name, node=node)

    _INPUT = re.compile(r"^(?P<point>.+)\.(?P<kind>force|moment)\.(?P<component>[xyz])$")
    _LOAD_INDEX = re.compile(r"^loads\[(?P<index>\d{1,9})\]$")

    def inputs(self, value, key) -> Inputs:
        """``inputs: {NAME: number}``: names that are not words of the expression language."""
        if value is None:
            return Inputs()
        if not isinstance(value, dict):
            self.fail(key, "expected a mapping of input names to numbers {NAME: number, ...}", value)
        initial = {}
        for name, number in value.items():
            self.check_name(name, key, "input")
            if not re.fullmatch(r"[A-Za-z_][A-Za-z_0-9]*", name):
                self.fail(_join(key, name), "expected an input name that an expression can use: a letter or _ "
                                            "followed by letters, digits or _", name)
            if name in RESERVED_WORDS:
                self.fail(_join(key, name), "a word of the expression language cannot name an input; expected "
                                            f"a name other than {_listing(RESERVED_WORDS)}", name)
            if isinstance(number, str) or not _is_number(number):
                self.fail(_join(key, name), "expected a number (the input's value in latdyn run)", number)
            initial[name] = self.number(number, _join(key, name))
        return Inputs(initial)

    def linear_model_names(self, spec: dict, key: str, loads: list, probes: list) -> dict:
        """The inputs of ``solve.linear_model`` as (kind, reference) pairs: ``("hinge", (beam, end))``
        for ``BEAM.start|end`` (the torque about a free hinge's axis), ``("force"|"moment", (PointRef,
        axis))`` for ``POINT.force.x`` (a global component at a point), ``("load", i)`` for ``loads[i]``
        (that load, scaled by the input); outputs are probe names."""
        inputs = []
        forms = ("expected BEAM.start or BEAM.end (a hinge torque), POINT.force.x|y|z or "
                 "POINT.moment.x|y|z (a global force or moment at a point), loads[i], or the name of one of "
                 "the scene's inputs")
        for i, name in enumerate(spec["inputs"]):
            k = f"{key}.inputs[{i}]"
            if isinstance(name, str) and name in self.input_names:  # a scene input (latdyn.scene.inputs)
                inputs.append(("input", name))
                continue
            hinge, point, index = self._HINGE_REF.match(name), self._INPUT.match(name), self._LOAD_INDEX.match(name)
            if hinge and hinge["name"] in self.beams:
                end = getattr(self.beams[hinge["name"]], hinge["end"])
                if end.hinge is None or end.hinge.angle is not None:
                    self.fail(k, f"expected a hinge with a coordinate: {name} is not a free hinge", name)
                inputs.append(("hinge", (hinge["name"], hinge["end"])))
            elif point:
                inputs.append((point["kind"], (self.point(point["point"], k), "xyz".index(point["component"]))))
            elif index:
                if int(index["index"]) >= len(loads):
                    self.fail(k, f"expected loads[0] ... loads[{len(loads) - 1}] (the scene has {len(loads)} loads)",
                              name)
                inputs.append(("load", int(index["index"])))
            else:
                self.fail(k, forms, name)
        known = [p.name for p in probes]
        for i, name in enumerate(spec["outputs"]):
            if name not in known:
                self.fail(f"{key}.outputs[{i}]", f"expected the name of a probe (output.probes: {_listing(known)})",
                          name)
        return {"inputs": inputs, "input_names": list(spec["inputs"]), "outputs": list(spec["outputs"])}

    def cable(self, name, spec, key) -> Cable:
        """``cables.NAME`` (SCENE.md): ends as for beams (no joints), EA > 0, rhoA ≥ 0, damping ≥ 0,
        elements ≥ 1 (several only with rhoA > 0: massless inner nodes would hold nothing), rest_length
        a positive number or an expression in t."""
        if name in self.beams:
            self.fail(key, f"expected a cable name that is not a beam's ({name!r} is a beam)", name)
        self.mapping(spec, key, _CABLE_KEYS, required=("from", "to", "EA"))
        ends = [self.beam_end(spec[side], _join(key, side), None, "", False) for side in ("from", "to")]
        d = ends[1].point - ends[0].point
        length = float(np.linalg.norm(d))
        scale = max(np.abs(ends[0].point).max(), np.abs(ends[1].point).max(), 1.0)
        if not math.isfinite(length) or length <= 1e-12 * scale:
            self.fail(key, f"zero-length cable: from and to are both at {ends[0].point.tolist()}; "
                           "expected two distinct points")
        EA = self.number(spec["EA"], _join(key, "EA"), positive=True)
        rhoA = self.number(spec.get("rhoA", 0.0), _join(key, "rhoA"), nonnegative=True)
        damping = self.number(spec.get("damping", 0.0), _join(key, "damping"), nonnegative=True)
        elements = self.integer(spec.get("elements", 1), _join(key, "elements"), maximum=MAX_ELEMENTS)
        if elements > 1 and rhoA == 0.0:
            self.fail(_join(key, "elements"), "a massless cable is one element (its inner nodes would have "
                                              "nothing to hold them); expected 1, or rhoA > 0", elements)
        rest_key = _join(key, "rest_length")
        rest = parse_time_function(spec.get("rest_length", length), self.file, rest_key)
        if rest.is_constant:
            self.number(rest.value(0.0), rest_key, positive=True)
        elif not rest.value(0.0) > 0.0:
            self.fail(rest_key, f"expected a rest length > 0 at t = 0 (it is {rest.value(0.0):g})", spec["rest_length"])
        return Cable(name=name, start=ends[0], end=ends[1], EA=EA, rhoA=rhoA, damping=damping, elements=elements,
                     rest_length=rest)

    def load(self, spec, key) -> Load:
        self.mapping(spec, key, _LOAD_KEYS, required=("at",))
        if "force" not in spec and "moment" not in spec:
            self.fail(key, "expected force and/or moment")
        at = self.point(spec["at"], _join(key, "at"))
        force = self.time_functions(spec["force"], _join(key, "force")) if "force" in spec else None
        moment = self.time_functions(spec["moment"], _join(key, "moment")) if "moment" in spec else None
        frame = self.frame(spec.get("frame", "global"), _join(key, "frame"))
        return Load(at=at, force=force, moment=moment, frame=frame)

    def probe(self, name, spec, key) -> Probe:
        if not isinstance(spec, dict):
            self.fail(key, f"expected a probe: a mapping with one of {_listing(PROBE_KINDS)}", spec)
        kinds = [k for k in PROBE_KINDS if k in spec]
        if len(kinds) != 1:
            if not kinds:
                allowed = sorted({k for keys in _PROBE_KEYS.values() for k in keys})
                self.mapping(spec, key, allowed)
            self.fail(key, f"expected exactly one of {_listing(PROBE_KINDS)} in a probe, "
                           f"got {_listing(kinds) if kinds else 'none'}")
        kind = kinds[0]
        self.mapping(spec, key, _PROBE_KEYS[kind], required=_PROBE_KEYS[kind][:2] if kind not in ("energy", "controller")
                     else (kind,), what=f"a {kind} probe")
        k = lambda sub: _join(key, sub)  # noqa: E731
        if kind == "controller":
            return self.controller_probe(name, spec, key)
        if kind == "point":
            return Probe(name=name, kind=kind, point=self.point(spec["point"], k("point")),
                         quantity=self.choice(spec["quantity"], k("quantity"), POINT_QUANTITIES),
                         frame=self.frame(spec.get("frame", "global"), k("frame")),
                         component=self.choice(spec.get("component", "norm"), k("component"), POINT_COMPONENTS))
        if kind == "hinge":
            ref = spec["hinge"]
            m = self._HINGE_REF.match(ref) if isinstance(ref, str) else None
            if not m or m["name"] not in self.beams:
                self.fail(k("hinge"), f"expected BEAM.start or BEAM.end (beams: {_listing(self.beams)})", ref)
            beam = self.beams[m["name"]]
            end = getattr(beam, m["end"])
            if end.joint != "hinge":
                self.fail(k("hinge"), f"expected a hinged beam end, but {ref} is {end.joint}", ref)
            return Probe(name=name, kind=kind, beam=beam.name, end=m["end"],
                         quantity=self.choice(spec["quantity"], k("quantity"), HINGE_PROBE_QUANTITIES))
        if kind == "guide":
            ref = spec["guide"]
            guided = [n for n, b in self.bodies.items() if b.guide is not None]
            if not isinstance(ref, str) or ref not in guided:
                self.fail(k("guide"), f"expected the name of a body with a guide (guided bodies: {_listing(guided)})",
                          ref)
            return Probe(name=name, kind=kind, body=ref,
                         quantity=self.choice(spec["quantity"], k("quantity"), GUIDE_QUANTITIES))
        if kind == "energy":
            return Probe(name=name, kind=kind, quantity=self.choice(spec["energy"], k("energy"), ENERGY_KINDS))
        if kind == "cable":
            return Probe(name=name, kind=kind, beam=self.ref(spec["cable"], k("cable"), self.cables, "cable"),
                         quantity=self.choice(spec["quantity"], k("quantity"), CABLE_QUANTITIES))
        if kind == "momentum":
            return Probe(name=name, kind=kind, quantity=self.choice(spec["momentum"], k("momentum"), MOMENTUM_KINDS),
                         component=self.choice(spec["component"], k("component"), AXIS_COMPONENTS))
        ref = spec["element"]
        m = self._ELEMENT.match(ref) if isinstance(ref, str) else None
        if not m or m["name"] not in self.beams:
            self.fail(k("element"), f"expected BEAM.element[i] (beams: {_listing(self.beams)})", ref)
        beam = self.beams[m["name"]]
        if beam.rigid:
            self.fail(k("element"), f"beam {beam.name!r} is a rigid link (rigid: true) and has no elements or "
                                    "section forces; expected an element of a flexible beam", ref)
        index = int(m["index"])
        if not 0 <= index < beam.elements:
            self.fail(k("element"), f"element index out of range: expected 0 ... {beam.elements - 1} "
                                    f"for beam {beam.name!r}", ref)
        return Probe(name=name, kind=kind, beam=beam.name, element=index,
                     quantity=self.choice(spec["quantity"], k("quantity"), ELEMENT_QUANTITIES))

    def controller_probe(self, name, spec, key) -> Probe:
        """``{controller: NAME}`` (its output) or ``{controller: NAME, state: S}``."""
        specs = self.controller_specs or {}
        ref = spec["controller"]
        if not isinstance(ref, str) or ref not in specs:
            self.fail(_join(key, "controller"), f"expected the name of a controller (known: {_listing(specs)})", ref)
        state = spec.get("state")
        if state is not None:
            states = specs[ref].get("states") if isinstance(specs[ref], dict) else None
            states = states if isinstance(states, dict) else {}
            if not isinstance(state, str) or state not in states:
                self.fail(_join(key, "state"), f"expected a state of controller {ref!r} (its states: "
                                               f"{_listing(states) if states else 'none'})", state)
        return Probe(name=name, kind="controller", controller=ref, state=state)

    def probes(self, value, key) -> list[Probe]:
        if value is None:
            return []
        items: list[tuple[Any, Any, str]] = []
        if isinstance(value, dict):
            items = [(name, spec, _join(key, name)) for name, spec in value.items()]
        elif isinstance(value, list):
            for i, spec in enumerate(value):
                ikey = f"{key}[{i}]"
                if not isinstance(spec, dict) or "name" not in spec:
                    self.fail(ikey, "expected a probe with a name: {name: NAME, ...}", spec)
                spec = dict(spec)
                items.append((spec.pop("name"), spec, ikey))
        else:
            self.fail(key, "expected a mapping of probe names to probes", value)
        out, seen = [], set()
        for name, spec, pkey in items:
            if not _valid_name(name):
                self.fail(pkey, "expected a probe name of printable characters without . [ ] , quotes, "
                                "line breaks or surrounding spaces", name)
            if name in _RESERVED_COLUMNS:
                self.fail(pkey, f"expected a probe name other than {_listing(_RESERVED_COLUMNS)} "
                                "(first column of probes.csv)", name)
            if name in seen:
                self.fail(pkey, "duplicated probe name; expected each name once", name)
            seen.add(name)
            out.append(self.probe(name, spec, pkey))
        return out

    def solve(self, spec, key="solve") -> Solve:
        spec = {} if spec is None else spec
        self.mapping(spec, key, _SOLVE_KEYS)
        s = Solve()
        k = lambda sub: _join(key, sub)  # noqa: E731
        if "analysis" in spec:
            s.analysis = self.choice(spec["analysis"], k("analysis"), ANALYSES)
        if s.analysis == "static":
            s.method = "load-control"
            if "method" in spec:
                s.method = self.choice(spec["method"], k("method"), STATIC_METHODS,
                                       what="for a static analysis one of")
        elif "method" in spec:
            s.method = self.choice(spec["method"], k("method"), METHODS)
        for static_only in ("control", "max_steps"):
            if static_only in spec and s.analysis != "static":
                self.fail(k(static_only), "expected only in a static analysis (analysis: static)")
        if "control" in spec:
            if s.method != "displacement-control":
                self.fail(k("control"), "expected only with method: displacement-control")
            s.control = self.control(spec["control"], k("control"))
        elif s.method == "displacement-control":
            self.fail(k("control"), "missing required key 'control' (method: displacement-control needs "
                                    "control: {point: POINT, direction: x|y|z|[dx, dy, dz], to: DISPLACEMENT})")
        if "max_steps" in spec:
            if s.method != "arc-length":
                self.fail(k("max_steps"), "expected only with method: arc-length")
            s.max_steps = self.integer(spec["max_steps"], k("max_steps"))
        if s.analysis == "transient":
            for req in ("t_end", "dt"):
                if req not in spec:
                    self.fail(k(req), f"missing required key {req!r} (a transient analysis needs t_end and dt)")
        if "t_end" in spec:
            s.t_end = self.number(spec["t_end"], k("t_end"), positive=True)
        if "dt" in spec:
            s.dt = self.number(spec["dt"], k("dt"), positive=True)
            if s.t_end is not None and s.dt > s.t_end:
                self.fail(k("dt"), f"expected dt <= t_end = {s.t_end:g}", spec["dt"])
        if "rho_inf" in spec:
            s.rho_inf = self.number(spec["rho_inf"], k("rho_inf"), lo=0.0, hi=1.0)
        if "tol" in spec:
            s.tol = self.number(spec["tol"], k("tol"), positive=True)
        if "steps" in spec:
            s.steps = self.integer(spec["steps"], k("steps"))
        if "count" in spec:
            s.count = self.integer(spec["count"], k("count"))
        if "adaptive" in spec:
            s.adaptive = self.boolean(spec["adaptive"], k("adaptive"))
        if "error_tol" in spec:
            s.error_tol = self.number(spec["error_tol"], k("error_tol"), positive=True)
        if "dt_min" in spec:
            s.dt_min = self.number(spec["dt_min"], k("dt_min"), positive=True)
            if s.dt is not None and s.dt_min > s.dt:
                self.fail(k("dt_min"), f"expected dt_min <= dt = {s.dt:g}", spec["dt_min"])
            if s.t_end is not None and s.dt_min < 1e-12 * s.t_end:
                self.fail(k("dt_min"), f"expected dt_min >= 1e-12 * t_end = {1e-12 * s.t_end:g} (a shorter "
                                       "step is lost in the round-off of t)", spec["dt_min"])
        if "max_iterations" in spec:
            s.max_iterations = self.integer(spec["max_iterations"], k("max_iterations"))
        if "formulation" in spec:
            s.formulation = self.choice(spec["formulation"], k("formulation"), FORMULATIONS)
        if "engine" in spec:
            s.engine = self.choice(spec["engine"], k("engine"), ENGINES)
        if "newton" in spec:
            s.newton = self.choice(spec["newton"], k("newton"), NEWTON)
        if "planar" in spec:
            s.planar = self.choice(spec["planar"], k("planar"), PLANAR)
        if "about" in spec:
            s.about = self.about(spec["about"], k("about"))
        if "linear_model" in spec:
            s.linear_model = self.linear_model(spec["linear_model"], k("linear_model"))
        if "mode_shapes" in spec:
            s.mode_shapes = self.boolean(spec["mode_shapes"], k("mode_shapes"))
        if "flutter" in spec:
            if s.analysis != "buckling":
                self.fail(k("flutter"), "expected only in a buckling analysis (analysis: buckling)")
            s.flutter = self.boolean(spec["flutter"], k("flutter"))
        return s

    def control(self, spec, key) -> Control:
        self.mapping(spec, key, _CONTROL_KEYS, required=_CONTROL_KEYS)
        point = self.point(spec["point"], _join(key, "point"))
        direction = spec["direction"]
        if isinstance(direction, str) and direction in AXIS_COMPONENTS:
            unit = np.eye(3)[AXIS_COMPONENTS.index(direction)]
            text = direction
        elif isinstance(direction, str):
            self.fail(_join(key, "direction"), f"expected {_listing(AXIS_COMPONENTS)} or a vector [dx, dy, dz]",
                      direction)
        else:
            vector = self.vector(direction, _join(key, "direction"), nonzero=True)
            unit = vector / math.sqrt(float(np.dot(vector, vector)))
            text = "[" + ", ".join(f"{c:g}" for c in vector) + "]"
        to = self.number(spec["to"], _join(key, "to"))
        if to == 0.0:
            self.fail(_join(key, "to"), "expected a non-zero displacement", spec["to"])
        return Control(point=point, direction=unit, to=to, text=text)

    def about(self, value, key):
        """``solve.about``: initial | static | steady | {t: T} (SCENE.md, "Linearisation")."""
        if isinstance(value, dict):
            self.mapping(value, key, ("t",), required=("t",), what="a word or a mapping {t: T}")
            return self.number(value["t"], _join(key, "t"), positive=True)
        return self.choice(value, key, ABOUT, what="one of {t: T} or")

    def linear_model(self, value, key) -> dict:
        """``solve.linear_model: {inputs: [...], outputs: [...]}``: names, checked against the model
        when it is built (hinges, points and probes by name, latdyn/analyses/linearise.py)."""
        self.mapping(value, key, ("inputs", "outputs"))
        out = {}
        for part in ("inputs", "outputs"):
            names = value.get(part, [])
            if not isinstance(names, list) or not all(isinstance(n, str) and n.strip() for n in names):
                self.fail(_join(key, part), "expected a list of names", names)
            out[part] = list(names)
        return out


# =========================================================================== entry points
def _canonical_hash(raw: Any) -> str:
    text = json.dumps(raw, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)
    return sha256(text.encode("utf-8")).hexdigest()


def _plain_data(value: Any, memo: dict | None = None) -> Any:
    """A deep copy of a mapping given in Python, NumPy arrays and scalars made plain lists and numbers.

    Like :func:`copy.deepcopy`, a container met twice is copied once (``memo``: id -> (original,
    copy)), so shared parts stay shared and cycles stay cycles instead of recursing forever.
    """
    memo = {} if memo is None else memo
    if id(value) in memo:
        return memo[id(value)][1]
    if isinstance(value, dict):
        out: Any = {}
        memo[id(value)] = (value, out)       # the original is kept alive so that its id stays unique
        out.update((k, _plain_data(v, memo)) for k, v in value.items())
        return out
    if isinstance(value, (list, tuple)):
        out = []
        memo[id(value)] = (value, out)
        out.extend(_plain_data(v, memo) for v in value)
        return out
    if isinstance(value, np.ndarray):
        return _plain_data(value.tolist(), memo)
    if isinstance(value, np.generic):
        return value.item()
    return copy.deepcopy(value)


def load_scene(source: "str | os.PathLike | dict | Scene") -> Scene:
    """Read and validate a scene: a path to YAML/JSON, a mapping, or a :class:`Scene`.

    Raises :class:`~latdyn.errors.SceneError` (file, key path, what was expected)
    on the first problem; never returns a scene that was not fully checked.
    """
    if isinstance(source, Scene):
        return source
    if isinstance(source, dict):
        file = "<dict>"
        try:
            raw = _plain_data(source)
        except RecursionError:
            raise _too_deep(file) from None
    elif isinstance(source, (str, os.PathLike)):
        file = os.fspath(source)
        raw = _read_file(Path(file), file)
    else:
        raise SceneError("<scene>", "<source>",
                         f"expected a path to a scene file or a mapping, got {show_value(source)}")
    return _build(raw, file)


def _build(raw: Any, file: str) -> Scene:
    r = _Reader(file)
    if raw is None:
        r.fail("(top level)", f"expected a mapping of scene keys ({_listing(_TOP_KEYS)}), got an empty scene")
    r.mapping(raw, "", _TOP_KEYS, what="a scene: a mapping")
    names_taken = {n: "a probe" for n in _probe_names(raw.get("output"))}
    for section, what in (("inputs", "an input"), ("controllers", "a controller")):
        if isinstance(raw.get(section), dict):
            names_taken.update({n: what for n in raw[section] if isinstance(n, str)})
    params = read_parameters(raw.get("parameters"), file, names_taken)
    with parameter_scope(params):
        scene = _build_controlled_parts(r, raw, file)
    scene.parameters = params
    scene.solve.sensitivities = _sensitivities(r, raw.get("solve"), params)
    scene.solve.sensitivity_method = _sensitivity_method(r, raw.get("solve"))
    return scene


def _probe_names(output) -> list:
    """The probe names an ``output`` mapping gives, unchecked (for the clash with parameter names)."""
    probes = output.get("probes") if isinstance(output, dict) else None
    if isinstance(probes, dict):
        return list(probes)
    if isinstance(probes, list):
        return [p.get("name") for p in probes if isinstance(p, dict)]
    return []


def _sensitivities(r: _Reader, solve, params: Parameters) -> list[str]:
    """``solve.sensitivities: [NAME, …]``: names of parameters, each once (which the package can
    differentiate exactly is decided with the model: latdyn/analyses/sensitivities.py ``refusal``)."""
    if not isinstance(solve, dict) or "sensitivities" not in solve:
        return []
    key, value = "solve.sensitivities", solve["sensitivities"]
    if not isinstance(value, list) or not value:
        r.fail(key, "expected a list of parameter names [NAME, ...]", value)
    names = []
    for i, name in enumerate(value):
        if not isinstance(name, str) or name not in params.values:
            r.fail(f"{key}[{i}]", f"expected the name of a parameter (parameters: {_listing(params.values)})", name)
        if name in names:
            r.fail(f"{key}[{i}]", "duplicated parameter name; expected each name once", name)
        names.append(name)
    return names


def _sensitivity_method(r: _Reader, solve) -> str:
    """``solve.sensitivity_method``: ``forward`` (default) or ``adjoint``, the latter with
    ``solve.sensitivities`` (latdyn/analyses/adjoint_sensitivities.py decides where it applies)."""
    if not isinstance(solve, dict) or "sensitivity_method" not in solve:
        return "forward"
    key, value = "solve.sensitivity_method", solve["sensitivity_method"]
    if value not in ("forward", "adjoint"):
        r.fail(key, "expected forward or adjoint", value)
    if value == "adjoint" and not solve.get("sensitivities"):
        r.fail(key, "the adjoint computes solve.sensitivities; expected it with solve.sensitivities: [NAME, ...]",
               value)
    return value


def _build_controlled_parts(r: "_Reader", raw: dict, file: str) -> Scene:
    """The scene's parts read with its ``inputs`` and ``controllers`` named, then the controllers."""
    inputs = r.inputs(raw.get("inputs"), "inputs")
    names = controller_names(raw.get("controllers"), file, RESERVED_WORDS, {n: "an input" for n in inputs})
    outputs = ControllerOutputs({n: 0.0 for n in names})
    r.controller_specs = raw.get("controllers") or {}
    r.input_names = inputs.names
    with reading_inputs(inputs, outputs):  # every expression of the scene may name them
        scene = _build_parts(r, raw, file)
    scene.inputs, scene.controller_outputs = inputs, outputs
    for probe in scene.output.probes:
        if probe.name in inputs or probe.name in outputs:
            what = "an input" if probe.name in inputs else "a controller"
            r.fail(f"output.probes.{probe.name}", f"a probe named like {what}; probes, inputs and controllers share "
                                                  "one namespace: expected another name", probe.name)
    scene.controllers = read_controllers(raw.get("controllers"), file, names, scene.output.probes, inputs.names,
                                         RESERVED_WORDS)
    scene.controller_states = Signals({f"{c.name}.{s}": c.initial[s] for c in scene.controllers.values()
                                       for s in c.states})
    return scene



def _build_parts(r: _Reader, raw: dict, file: str) -> Scene:
    title = raw.get("title", "")
    if title is None:
        title = ""
    if isinstance(title, (dict, list, tuple)):
        r.fail("title", "expected free text", title)
    try:
        title = str(title)
        title.encode("utf-8")
    except ValueError:  # an integer of more than 4300 digits, a lone surrogate
        r.fail("title", "expected free text (valid Unicode)", title)

    gravity = r.vector(raw["gravity"], "gravity", what="[gx, gy, gz]") if raw.get("gravity") is not None \
        else np.zeros(3)

    iv = raw.get("initial_velocity")
    if iv is None:
        iv = {}
    r.mapping(iv, "initial_velocity", ("linear", "angular", "about"))
    initial_velocity = InitialVelocity(
        linear=r.vector(iv["linear"], "initial_velocity.linear") if "linear" in iv else np.zeros(3),
        angular=r.vector(iv["angular"], "initial_velocity.angular") if "angular" in iv else np.zeros(3),
        about=r.vector(iv["about"], "initial_velocity.about") if "about" in iv else np.zeros(3),
        given=raw.get("initial_velocity") is not None,
    )

    for name, spec in r.named_mapping(raw.get("sections"), "sections", "section").items():
        r.sections[name] = r.section(name, spec, f"sections.{name}")
    for name, spec in r.named_mapping(raw.get("bodies"), "bodies", "body").items():
        r.bodies[name] = r.body(name, spec, f"bodies.{name}")
    for name, spec in (raw.get("bodies") or {}).items():
        if isinstance(spec, dict) and "guide" in spec:
            r.bodies[name].guide = r.guide(name, spec["guide"], f"bodies.{name}.guide")
    r.guide_loops()
    for name, spec in r.named_mapping(raw.get("beams"), "beams", "beam").items():
        r.beams[name] = r.beam(name, spec, f"beams.{name}")
    for name, spec in r.named_mapping(raw.get("cables"), "cables", "cable").items():
        r.cables[name] = r.cable(name, spec, f"cables.{name}")
    if not r.bodies and not r.beams:
        r.fail("beams", "expected at least one body or beam in the scene")

    attached = {end.body for b in [*r.beams.values(), *r.cables.values()] for end in (b.start, b.end)
                if end.body is not None}
    # a body that carries a guided body, and a guided body (its slide may be held by its spring or by
    # what it carries), are left to the model's check of each coordinate (Model.check_held)
    attached |= {body.guide.on for body in r.bodies.values() if body.guide is not None}
    for name, body in r.bodies.items():
        if (body.mass == 0.0 and not np.any(body.inertia) and not body.fixed and not body.prescribed
                and name not in attached and body.guide is None):
            r.fail(f"bodies.{name}", f"a coordinate that nothing holds: body {name!r} has no mass, no inertia "
                                     "and no beam attached; expected mass/inertia, a beam, fixed: true or a motion")

    loads_spec = raw.get("loads")
    if loads_spec is None:
        loads_spec = []
    if not isinstance(loads_spec, list):
        r.fail("loads", "expected a list of loads [{at: POINT, force: [..], moment: [..], frame: ..}]", loads_spec)
    loads = [r.load(spec, f"loads[{i}]") for i, spec in enumerate(loads_spec)]

    solve = r.solve(raw.get("solve"))

    out_spec = raw.get("output")
    if out_spec is None:
        out_spec = {}
    r.mapping(out_spec, "output", ("every", "paraview_every", "probes"))
    every = r.number(out_spec["every"], "output.every", positive=True) if out_spec.get("every") is not None \
        else None
    paraview_every = None
    if out_spec.get("paraview_every") is not None:
        paraview_every = r.number(out_spec["paraview_every"], "output.paraview_every", nonnegative=True)
    probes = r.probes(out_spec.get("probes"), "output.probes")
    if solve.linear_model is not None:
        solve.linear_model = r.linear_model_names(solve.linear_model, "solve.linear_model", loads, probes)

    return Scene(
        title=title, file=file, source_hash=_canonical_hash(raw), gravity=gravity,
        initial_velocity=initial_velocity, sections=r.sections, bodies=r.bodies, beams=r.beams,
        loads=loads, solve=solve, output=Output(every=every, paraview_every=paraview_every, probes=probes), raw=raw,
        cables=r.cables,
    )


def describe(scene: Scene) -> str:
    """A short human summary of a validated scene (``latdyn check``)."""
    lines = [f"{scene.title or '(untitled)'}  [{scene.file}]"]
    kinds = []
    for b in scene.bodies.values():
        state = "fixed" if b.fixed else "prescribed" if b.prescribed else "guided" if b.guide is not None else "free"
        kinds.append(f"{b.name} ({state}{f', mass {b.mass:g}' if b.mass else ''})")
    lines.append(f"  bodies:   {len(scene.bodies)}" + (f": {', '.join(kinds)}" if kinds else ""))
    beams = [f"{b.name} ({'rigid link' if b.rigid else f'{b.elements} el'}, L = {b.length:g}, "
             f"{b.start.joint}-{b.end.joint})" for b in scene.beams.values()]
    lines.append(f"  beams:    {len(scene.beams)}" + (f": {', '.join(beams)}" if beams else ""))
    lines.append(f"  elements: {scene.n_elements}")
    if scene.cables:
        cables = [f"{c.name} ({c.elements} el, EA = {c.EA:g})" for c in scene.cables.values()]
        lines.append(f"  cables:   {len(cables)}: {', '.join(cables)}")
    hinges = [f"{beam}.{which}" + (" (prescribed)" if h.angle is not None else "")
              for beam, which, h in scene.hinges]
    lines.append(f"  hinges:   {len(hinges)}" + (f": {', '.join(hinges)}" if hinges else ""))
    guides = [f"{name} on {b.guide.on or 'the ground'}" + (" (prescribed)" if b.guide.position is not None else "")
              for name, b in scene.bodies.items() if b.guide is not None]
    if guides:
        lines.append(f"  guides:   {len(guides)}: {', '.join(guides)}")
    lines.append(f"  loads:    {len(scene.loads)}")
    names = [p.name for p in scene.output.probes]
    lines.append(f"  probes:   {len(names)}" + (f": {', '.join(names)}" if names else ""))
    if scene.parameters:
        lines.append(f"  parameters: {len(scene.parameters.values)}")
        lines.extend(f"    {line}" for line in scene.parameters.describe())
        if scene.solve.sensitivities:
            lines.append(f"    sensitivities by: {', '.join(scene.solve.sensitivities)}")
    s = scene.solve
    if s.analysis == "transient":
        what = f"transient, t_end = {s.t_end:g}, dt = {s.dt:g}, {s.method}"
        if s.method in ("generalized-alpha", "hht-alpha"):
            what += f" (rho_inf = {s.rho_inf:g})"
        if s.adaptive:
            what += ", adaptive"
    elif s.analysis == "static":
        what = {"load-control": f"static, {s.steps} load steps",
                "arc-length": f"static, arc-length continuation from {s.steps} load steps' first step",
                "displacement-control": f"static, displacement of {s.control.point.text if s.control else ''} "
                                        f"controlled in {s.steps} steps"}[s.method]
    elif s.analysis == "buckling":
        what = f"buckling (stability along the static path), {s.steps} load steps"
    else:
        what = f"modes, {s.count} lowest, about {s.about if isinstance(s.about, str) else f't = {s.about:g}'}"
    lines.append(f"  solve:    {what}")
    return "\n".join(lines)
