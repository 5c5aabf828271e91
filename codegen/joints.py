"""Joint bodies, point loads and hinged beam ends, derived like the element (unit ``joints`` of ``generated/``).

CR-4402 models a joint as a rigid body whose reference point carries the translational
coordinates d and whose frame T turns with spatial virtual rotations π, δT = skew(δπ) T
(Eqs. 2, 59); its equations of motion are the Newton–Euler equations about that point. A
point load acts at a grid point of a node, at r_g = T r from its reference point (Eq. 2),
fixed in space (``frame: global``) or turning with a body (``frame: BODY``, a follower
load). Both are written here once; their derivatives by π are taken under the same
configuration update T ← exp(skew Δπ) T as the element's (to first order,
T ← (I + skew Δπ) T), so the stiffness blocks are the exact Newton matrix of the Lie-group
integrators.

Joint body (one per body node), with r_c = T c the centre of mass from the reference point,
J = T I_b Tᵀ the inertia about the centre of mass, ω the spatial angular velocity, a and α
the acceleration of the reference point and the angular acceleration:

    f   = m a + m α × r_c + m ω × (ω × r_c)                                     (Newton)
    τ   = m r_c × a + (J − m S S) α + r_c × m ω × (ω × r_c) + ω × J ω,  S = skew(r_c)  (Euler)
    body_force = [f; τ] − [W; r_c × W],   W = m g (g already scaled by the load factor)

    body_mass = ∂[f; τ]/∂[a; α],  body_gyroscopic = ∂[f; τ]/∂ω,
    body_gravity_stiffness = ∂(−[W; r_c × W])/∂π,
    body_inertia_stiffness = ∂[f; τ]/∂π at fixed a, α, ω (the inertia tangent of the body).

Rigid link's inertia (``beams.NAME.rigid``, latdyn/model/model.py ``_rigid_link``): the link is one joint body
on its link node L at its start grid point A, a uniform slender rod from A to B whose material points sit at
r = L ξ x̂ + y ŷ + z ẑ from A (ξ ∈ [0, 1], (y, z) on the section; the element's r_c = [L ξ, y, z], Eq. 47),
integrated with the element's section moments (codegen/formulation.py ``integrate_over_element``: ∫ρ dA = ρA,
∫ρ y² dA = ρI_z, ∫ρ z² dA = ρI_y, the odd and mixed ones 0):

    m = ∫ρ dV,   c = ∫ρ r dV / m,   I_A = ∫ρ (|r|² 1 − r rᵀ) dV,   I_c = I_A − m (|c|² 1 − c cᵀ)   (parallel axes)

in the link's axes E = [x̂, ŷ, x̂ × ŷ], x̂ = (B − A)/|B − A|, then turned into global axes at t = 0 (the link
node's axes), c ← E c, I ← E I_c Eᵀ, the joint-body block (m, c, I) of ``joint_body``. ŷ follows the loader's
rule (latdyn/scene/loader.py ``beam``): ŷ ∝ h + s e_z × (B − A) less its part along x̂, s = 1 and h = 0 without a
``y_axis`` (global Z × x̂, off the vertical), s = 0 and h the ``y_axis`` given (or e_y for a vertical link), so
the block's exact derivatives by the end points (``rigid_link_inertia_D_ends``: a geometry parameter that moves
the link's length or direction) and by the section values (``rigid_link_inertia_D_section``, linear in them)
include the frame's turn.

Point load, on the node it acts at (force F and moment Mo, given in global axes or in the
axes R of its frame body and already scaled by the load factor): the residual takes the
generalized force −[F; r_g × F + Mo] (it is on the right of the equations of motion), with
F = R f and Mo = R mo; its power on the node's velocities is F·(v + ω × r_g) + Mo·ω.
``load_stiffness_node`` is its derivative by the node's π, ``load_stiffness_frame`` by the
frame body's π (zero for a global load, where R = I is passed).

Hinge (the coordinate θ of a joint): f = k s + c θ̇ − λ τ with s = θ − θ_r and k, c, τ the scene's
laws in θ, θ̇ and t, given at the hinge's state with their first derivatives (compiled per scene by
codegen/laws.py, or constants); the kernel returns f, ∂f/∂θ, ∂f/∂θ̇ and the powers.

Hinged beam end (the element's geometry, Eq. 17): the nodal frame of a beam end joined to node j
by a hinge of unit axis a (node axes) at angle θ is T_e = T_j exp(θ skew a) E0, with E0 the
element axes at t = 0 in node axes (a clamped end: a = 0, the same formula); its grid point sits
at T_j r from the reference point (Eq. 2) and its hinge axis is T_j a (Eq. 9).

Rigid link edge (latdyn/model/links.py): a dependent node c follows its parent p through a hinge of
unit axis a (parent node axes; s = ±1 the sign of the angle on the edge, s = 0 on a clamped edge),
hinge point o and arm b (parent node axes at θ = 0):

    T_c = T_p R(a, sθ),   x_c = x_p + T_p (o + R b)                              (edge)

and, with g = T_p a, o_g = x_p + T_p o, the joint twist ξ = (o_g × g, g) and the parent's twist at the
origin V_p = (v_p − ω_p × x_p, ω_p), the child's twist and its rate

    V_c = V_p + s θ̇ ξ,   V̇_c = V̇_p + s (θ̈ ξ + θ̇ V_p ×̂ ξ),   (v, ω) ×̂ (v', ω') = (ω × v' + v × ω', ω × ω'),

returned as node rates (v_c = v_O + ω_c × x_c, a_c = v̇_O + ω̇_c × x_c + ω_c × v_c). The map J of the
dependent coordinates is composed edge by edge from ``child_transfer`` (∂(v_c, ω_c)/∂(v_p, ω_p), equal
to ∂(a_c, ω̇_c)/∂(a_p, ω̇_p)) and ``child_joint`` (∂(v_c, ω_c)/∂θ̇ = ∂(a_c, ω̇_c)/∂θ̈); the
velocity-quadratic part of the accelerations from ``child_convective`` (∂(a_c, ω̇_c)/∂(v_p, ω_p, θ̇)).
A wrench (f, m) at a point y of a dependent node (its residual rows) enters the minimum coordinates as
Jᵀ(f, m): s g·((y − o_g) × f + m) on each hinge of its path (``hinge_wrench``) and (f, m + (y − x_r) × f)
on its root r (``root_wrench``); their derivatives by the configuration at fixed (f, m) are the
geometric stiffness ∂(Pᵀ)/∂q · r of the reduction.

Prismatic edge (a sliding joint, ``bodies.NAME.guide``): the child keeps its parent's frame and slides
by s along the axis a fixed in the parent (s its coordinate, σ = ±1 its sign on the edge):

    T_c = T_p,   x_c = x_p + T_p (o + σ s a + b)                                 (prismatic edge)

with the joint twist ξ = (g, 0), g = T_p a, in the same rates (V_p ×̂ ξ = (ω_p × g, 0)): the Coriolis
term 2ω × ṡg and the centrifugal one of a slide on a turning body arise from them
(``prismatic_link_edge``, the same inputs and outputs as ``rigid_link_edge``). A wrench (f, m) at y
enters the slide as σ g·f (``slide_wrench``), whose derivative by the configuration at fixed (f, m) is
σ (g × f)·δπ_p, the edge parent's turn alone.

Closure edges (a slider-crank whose rigid rod closes the loop: latdyn/model/links.py, "Closure"): the
slider and the rod are functions of the pin's position p alone. With the guide line o + s a (global,
fixed), the loop's plane normal n (the hinge axes; n ⟂ a), b = n × a, d = p − o, the rod length l and
σ = ±1 the side of the pin the slider is on along a,

    s(p) = a·d + σ r,   r = √(l² − |d|² + (a·d)²)                              (the slider on its line)
    α(p) = atan2(−b·d, σ r) − β₀                                                 (the rod's turn about n)

the slider's node x_c = o + s a keeps its frame (``slider_closure_edge``), the rod's node x_c = p turns
as T_c = R(n, α) (``rod_closure_edge``; both node frames are the global axes at t = 0). Their rates
are those of functions of p: v_c = ∇x_c v_p, a_c = ∇x_c a_p + (v_p·∇)² x_c, in the outputs of
``rigid_link_edge`` (``child_joint`` zero: no coordinate of their own). A wrench (f, m) on such a node
enters the pin's translation as g = (∂x_c/∂p)ᵀ f + ∇α (n·m) (``slider_closure_wrench``,
``rod_closure_wrench``), whose derivative by p at fixed (f, m) is the closure's geometric stiffness.
r → 0 is a dead point (the rod normal to the guide), where the loop stops being a function of p.

Cable element (a tension-only axial member between the points p_i = x_i + T_i r_i of two nodes):
the taut law N = EA (ℓ − L0)/L0 + c ℓ̇ on the residual rows of both ends, its exact derivatives by
the end coordinates (same spatial update) and by their rates, the strain energy ½ EA (ℓ − L0)²/L0,
the generalized force ∂U/∂L0 of the rest length (a reel's work is ∫ ∂U/∂L0 dL0) and the dampers'
forces (their dissipation ∫ f dℓ), integrated over each step by the trapezoidal rule in L0 and ℓ, as
the hinges' torques are in θ (latdyn/timeloop/progress.py cable_work). Slack (ℓ ≤ L0, or N ≤ 0) is the
runtime's choice of zero (csrc/evaluate.c ``cables``; latdyn/model/cables.py).
"""
from __future__ import annotations

import sympy as sp

from . import formulation as fm
from .ir import Argument, KernelSpec, Output

DESCRIPTION = ("joint bodies (Newton-Euler about the reference point), point loads (global and follower), "
               "hinged beam ends, hinge laws, rigid link, prismatic and closure edges, cable elements and the SO(3) "
               "exponential and logarithm")

BODY_FRAME = Argument("frame", 9, "T: the body's frame (columns = body axes in global axes), row-major")
BODY_MOTION = Argument("motion", 9, "omega[3] a[3] alpha[3]: spatial angular velocity, acceleration of the "
                       "reference point, angular acceleration")
BODY_SECTION = Argument("body", 13, "m c[3] I[9]: mass, centre of mass from the reference point and inertia "
                        "about the centre of mass (row-major), in body axes")
GRAVITY = Argument("gravity", 3, "uniform gravity acceleration, global, times the load factor")
BODY_DIRECTION = Argument("direction", 6, "w[6]: a direction [d; π] on the body's node (the impulse weight's w)")

LOAD_NODE = Argument("node_frame", 9, "T: frame of the node the load acts at, row-major")
LOAD_OFFSET = Argument("offset", 3, "r: the point of the load from the node's reference point, in node axes")
LOAD_VALUES = Argument("values", 6, "f[3] mo[3]: force and moment in the axes of the load's frame, times the "
                       "load factor")
LOAD_FRAME = Argument("load_frame", 9, "R: frame of the body the load turns with (the identity for a global "
                      "load), row-major")
LOAD_VELOCITY = Argument("node_velocity", 6, "v[3] omega[3]: velocity of the node's reference point and its "
                         "spatial angular velocity")


def _vector(symbols) -> sp.Matrix:
    return sp.Matrix(list(symbols))


def _matrix(symbols) -> sp.Matrix:
    return sp.Matrix(3, 3, list(symbols))


def skew(w) -> sp.Matrix:
    return sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def _turned(T: sp.Matrix, delta: sp.Matrix) -> sp.Matrix:
    """T after a spatial virtual rotation δπ, to first order (all a derivative at δπ = 0 needs)."""
    return (sp.eye(3) + skew(delta)) * T


def _jacobian(expressions: sp.Matrix, variables: sp.Matrix, at: dict) -> sp.Matrix:
    return expressions.jacobian(variables).xreplace(at)


def _rows(matrix: sp.Matrix) -> list:
    return list(matrix)


def joint_body_terms(T, motion, body, gravity):
    """(inertia forces [f; τ], weight terms −[W; r_c × W]) of a joint body (module docstring)."""
    omega, a, alpha = _vector(motion[0:3]), _vector(motion[3:6]), _vector(motion[6:9])
    m, c, inertia = body[0], _vector(body[1:4]), _matrix(body[4:13])
    rc = T * c
    J = T * inertia * T.T
    S = skew(rc)
    centripetal = m * omega.cross(omega.cross(rc))
    f = m * a + m * alpha.cross(rc) + centripetal
    tau = m * rc.cross(a) + (J - m * S * S) * alpha + rc.cross(centripetal) + omega.cross(J * omega)
    W = m * _vector(gravity)
    return sp.Matrix.vstack(f, tau), -sp.Matrix.vstack(W, rc.cross(W))


def _joint_body_kernels() -> list[KernelSpec]:
    T = _matrix(BODY_FRAME.symbols())
    motion, body, gravity = BODY_MOTION.symbols(), BODY_SECTION.symbols(), GRAVITY.symbols()
    delta = sp.Matrix(sp.symbols("delta_0:3"))
    zero = {d: 0 for d in delta}
    inertia, weight = joint_body_terms(T, motion, body, gravity)
    inertia_turned, weight_turned = joint_body_terms(_turned(T, delta), motion, body, gravity)
    acceleration = _vector(motion[3:9])
    omega = _vector(motion[0:3])
    outputs = [
        Output("body_force", (6,), _rows(inertia + weight), "[f; τ] − [W; r_c × W]: the body's row of the residual"),
        Output("body_mass", (6, 6), _rows(inertia.jacobian(acceleration)), "∂[f; τ]/∂[a; α]"),
        Output("body_gyroscopic", (6, 6), _rows(sp.Matrix.hstack(sp.zeros(6, 3), inertia.jacobian(omega))),
               "∂[f; τ]/∂[v; ω] (no v: the reference point's velocity does not enter)"),
        Output("body_gravity_stiffness", (6, 6),
               _rows(sp.Matrix.hstack(sp.zeros(6, 3), _jacobian(weight_turned, delta, zero))),
               "∂(−[W; r_c × W])/∂[d; π]"),
    ]
    tangent = [Output("body_inertia_stiffness", (6, 6),
                      _rows(sp.Matrix.hstack(sp.zeros(6, 3), _jacobian(inertia_turned, delta, zero))),
                      "∂[f; τ]/∂[d; π] at fixed a, α, ω: the inertia tangent of the body")]
    com = _vector(body[1:4])
    by_com = [Output("body_force_D_com", (6, 3), _rows((inertia + weight).jacobian(com)),
                     "∂([f; τ] − [W; r_c × W])/∂c: by the centre of mass c in the body's frame (a polynomial of "
                     "degree two in c: the parameter sensitivities' explicit part)")]
    inputs = [BODY_FRAME, BODY_MOTION, BODY_SECTION, GRAVITY]
    # the gravity stiffness along a direction w, G(T) w, and its derivative by the node's π at fixed w (the event's
    # impulse weight M + dt²K along δq, latdyn/analyses/weight_derivative.py): G(T) exact as the derivative at δ = 0
    # of the first-order turn, so G(T') w with T' = (I + skew δ₂) T is exact to first order in δ₂
    direction = _vector(BODY_DIRECTION.symbols())
    second = sp.Matrix(sp.symbols("epsilon_0:3"))

    def stiffness_along(frame):
        _, turned_weight = joint_body_terms(_turned(frame, delta), motion, body, gravity)
        return _jacobian(turned_weight, delta, zero) * direction[3:6, :]

    along = stiffness_along(T)
    by_turn = _jacobian(stiffness_along(_turned(T, second)), second, {e: 0 for e in second})
    weight = [Output("body_gravity_stiffness_along", (6,), _rows(along), "∂(−[W; r_c × W])/∂π · w_π"),
              Output("body_gravity_stiffness_along_D_q", (6, 6), _rows(sp.Matrix.hstack(sp.zeros(6, 3), by_turn)),
                     "∂(∂(−[W; r_c × W])/∂π · w_π)/∂[d; π] at fixed w")]
    return [KernelSpec(name="joint_body_gravity_stiffness_D_q", doc="A joint body's gravity stiffness along a "
                       "direction and its exact derivative by the node's configuration (an event's impulse weight "
                       "with sensitivities)", inputs=[BODY_FRAME, BODY_DIRECTION, BODY_SECTION, GRAVITY],
                       outputs=weight, variant="joints", equations="Eqs. 2, 59 (joint bodies as rigid bodies)"),
            KernelSpec(name="joint_body", doc="Newton-Euler equations of a joint body about its reference point, "
                       "their mass, gyroscopic and gravity-stiffness blocks", inputs=inputs, outputs=outputs,
                       variant="joints", equations="Eqs. 2, 59 (joint bodies as rigid bodies)"),
            KernelSpec(name="joint_body_inertia_stiffness", doc="The inertia tangent of a joint body (not part of "
                       "the time step's matrix, which leaves out inertia derivatives by q)", inputs=inputs,
                       outputs=tangent, variant="joints", equations="Eqs. 2, 59 (joint bodies as rigid bodies)"),
            KernelSpec(name="joint_body_D_com", doc="The derivative of a joint body's Newton-Euler row by its centre of "
                       "mass (the sensitivities by a parameter that places it: forces, kinetic energy, momenta)",
                       inputs=inputs, outputs=by_com, variant="joints",
                       equations="Eqs. 2, 59 (joint bodies as rigid bodies)")]


LINK_ENDS = Argument("ends", 6, "A[3] B[3]: a rigid link's start and end grid points, global, at t = 0")
LINK_Y_RULE = Argument("y_rule", 4, "h[3] s: the rule of the link's y axis, ŷ ∝ h + s e_z × (B − A) less its "
                       "part along x̂ (the loader's: h = 0, s = 1 without a y_axis off the vertical; h the y_axis "
                       "given, or e_y for a vertical link, and s = 0)")
LINK_SECTION = Argument("section", 3, "rhoA rhoIy rhoIz: the mass and the rotary inertias per length of the link's "
                        "section")


def rigid_link_inertia(ends, rule, section) -> sp.Matrix:
    """The joint-body block [m; c; I] (13: m, c[3], I[9] row-major) of a rigid link, a uniform slender rod from A
    to B, c from A and I about c in global axes (module docstring, "Rigid link's inertia")."""
    A, B = _vector(ends[0:3]), _vector(ends[3:6])
    vector = B - A
    length = sp.sqrt(vector.dot(vector))
    x_axis = vector / length
    hint = _vector(rule[0:3]) + rule[3] * sp.Matrix([0, 0, 1]).cross(vector)
    raw = hint - hint.dot(x_axis) * x_axis
    y_axis = raw / sp.sqrt(raw.dot(raw))
    E = sp.Matrix.hstack(x_axis, y_axis, x_axis.cross(y_axis))
    # the rod in its own axes: a material point at r = [L ξ, y, z] from A (the element's r_c, Eq. 47)
    L = sp.Symbol("L", positive=True)
    values = dict(zip(("rhoA", "rhoIy", "rhoIz"), section))
    r = sp.Matrix([L * fm.xi, fm.ys, fm.zs])
    mass = fm.integrate_over_element(sp.Integer(1), values, L)
    centre = r.applyfunc(lambda component: fm.integrate_over_element(component, values, L)) / mass
    about_start = (r.dot(r) * sp.eye(3) - r * r.T).applyfunc(lambda e: fm.integrate_over_element(e, values, L))
    about_centre = (about_start - mass * (centre.dot(centre) * sp.eye(3) - centre * centre.T)).applyfunc(sp.expand)
    at = {L: length}
    turned = E * about_centre.xreplace(at) * E.T
    return sp.Matrix([mass.xreplace(at), *(E * centre.xreplace(at)), *turned])


def _rigid_link_inertia_kernels() -> list[KernelSpec]:
    ends, rule, section = LINK_ENDS.symbols(), LINK_Y_RULE.symbols(), LINK_SECTION.symbols()
    block = rigid_link_inertia(ends, rule, section)
    inputs = [LINK_ENDS, LINK_Y_RULE, LINK_SECTION]
    equations = "Eq. 47 (r_c), the section's moments of Eqs. 44–57, integrated over a rigid rod"
    return [KernelSpec(name="rigid_link_inertia", doc="A rigid link's joint-body block (m, c, I): a uniform slender "
                       "rod's mass, centre from its start point and inertia about the centre, global axes at t = 0",
                       inputs=inputs, outputs=[Output("link_body", (13,), _rows(block), "m c[3] I[9]: the joint "
                                                      "body's block of the link (``joint_body``'s ``body``)")],
                       variant="joints", equations=equations),
            KernelSpec(name="rigid_link_inertia_D_ends", doc="The derivative of a rigid link's joint-body block by "
                       "its end points, the y axis's rule held (a geometry parameter moving the link's length or "
                       "direction)", inputs=inputs,
                       outputs=[Output("link_body_D_ends", (13, 6), _rows(block.jacobian(_vector(ends))),
                                       "∂[m; c; I]/∂[A; B]")],
                       variant="joints", equations=equations),
            KernelSpec(name="rigid_link_inertia_D_section", doc="The derivative of a rigid link's joint-body block by "
                       "its section values (linear in them: a parameter in a rigid link's rhoA, rhoIy, rhoIz)",
                       inputs=inputs,
                       outputs=[Output("link_body_D_section", (13, 3), _rows(block.jacobian(_vector(section))),
                                       "∂[m; c; I]/∂[ρA, ρIy, ρIz]")],
                       variant="joints", equations=equations)]


def point_load_terms(T, r, values, R, velocity):
    """(generalized force on the node's residual, power) of a point load (module docstring)."""
    rg = T * _vector(r)
    F, Mo = R * _vector(values[0:3]), R * _vector(values[3:6])
    v, omega = _vector(velocity[0:3]), _vector(velocity[3:6])
    force = -sp.Matrix.vstack(F, rg.cross(F) + Mo)
    power = F.dot(v + omega.cross(rg)) + Mo.dot(omega)
    return force, power


def _point_load_kernel() -> KernelSpec:
    T, R = _matrix(LOAD_NODE.symbols()), _matrix(LOAD_FRAME.symbols())
    r, values, velocity = LOAD_OFFSET.symbols(), LOAD_VALUES.symbols(), LOAD_VELOCITY.symbols()
    delta = sp.Matrix(sp.symbols("delta_0:3"))
    zero = {d: 0 for d in delta}
    force, power = point_load_terms(T, r, values, R, velocity)
    by_node, _ = point_load_terms(_turned(T, delta), r, values, R, velocity)
    by_frame, _ = point_load_terms(T, r, values, _turned(R, delta), velocity)
    outputs = [
        Output("load_force", (6,), _rows(force), "−[F; r_g × F + Mo]: the load's part of the node's residual rows"),
        Output("load_power", (), [power], "F·(v + ω × r_g) + Mo·ω"),
        Output("load_stiffness_node", (6, 3), _rows(_jacobian(by_node, delta, zero)),
               "∂load_force/∂π of the node"),
        Output("load_stiffness_frame", (6, 3), _rows(_jacobian(by_frame, delta, zero)),
               "∂load_force/∂π of the load's frame body (follower loads)"),
    ]
    return KernelSpec(name="point_load", doc="A point load on its node: generalized force, power, and its exact "
                      "tangent, also for loads that turn with a body",
                      inputs=[LOAD_NODE, LOAD_OFFSET, LOAD_VALUES, LOAD_FRAME, LOAD_VELOCITY], outputs=outputs,
                      variant="joints", equations="Eq. 2 (the point), follower loads turning with a body")


LOAD_DIRECTION = Argument("load_direction", 6, "w[6]: a direction on the load's block columns, the node's π then the "
                          "frame body's π (an event's impulse weight w; 0 on the frame's for a global load)")


def _point_load_stiffness_D_q_kernel() -> KernelSpec:
    """A point load's stiffness along a direction, K_l w = (∂f/∂π_node) w_node + (∂f/∂π_frame) w_frame (the block of
    :func:`_point_load_kernel`), and its exact derivative by the node's and the frame body's turns at fixed w, values
    and offset (an event's impulse weight M + dt²K along δq, latdyn/analyses/weight_derivative.py). K_l w is the
    derivative of the force along the turns τ w at τ = 0, differentiated once more by the turns ε it starts from."""
    T, R = _matrix(LOAD_NODE.symbols()), _matrix(LOAD_FRAME.symbols())
    r, values = LOAD_OFFSET.symbols(), LOAD_VALUES.symbols()
    direction = _vector(LOAD_DIRECTION.symbols())
    tau, second = sp.Symbol("tau"), sp.Matrix(sp.symbols("epsilon_0:3"))
    at_second = {e: 0 for e in second}

    def stiffness_along(node, frame):
        turned = point_load_terms(_turned(node, tau * direction[0:3, :]), r, values,
                                  _turned(frame, tau * direction[3:6, :]), [0] * 6)[0]
        return sp.diff(turned, tau).xreplace({tau: 0})

    along = stiffness_along(T, R)
    by_node = _jacobian(stiffness_along(_turned(T, second), R), second, at_second)
    by_frame = _jacobian(stiffness_along(T, _turned(R, second)), second, at_second)
    outputs = [Output("load_stiffness_along", (6,), _rows(along), "(∂load_force/∂π_node) w_node + "
                      "(∂load_force/∂π_frame) w_frame"),
               Output("load_stiffness_along_D_q", (6, 6), _rows(sp.Matrix.hstack(by_node, by_frame)),
                      "∂(load_stiffness_along)/∂[π_node, π_frame] at fixed w: the load block's columns")]
    return KernelSpec(name="point_load_stiffness_D_q", doc="A point load's stiffness along a direction and its exact "
                      "derivative by the node's and the load frame's turns (an event's impulse weight with "
                      "sensitivities)", inputs=[LOAD_NODE, LOAD_OFFSET, LOAD_VALUES, LOAD_FRAME, LOAD_DIRECTION],
                      outputs=outputs, variant="joints",
                      equations="Eq. 2 (the point), follower loads turning with a body")


LOAD_OFFSET_MOVE = Argument("offset_move", 3, "δr: a variation of the load's point from the node's reference point, in "
                            "node axes (a geometry parameter moving a beam end's offset)")


def _point_load_offset_kernel() -> KernelSpec:
    """∂(load_force)/∂r along δr: the point load is linear in its offset r, so this is its exact change when a
    geometry parameter moves the point (latdyn/analyses/geometry_sensitivities.py, the loads' arms)."""
    T, R = _matrix(LOAD_NODE.symbols()), _matrix(LOAD_FRAME.symbols())
    r, move = _vector(LOAD_OFFSET.symbols()), _vector(LOAD_OFFSET_MOVE.symbols())
    force, _ = point_load_terms(T, list(r), LOAD_VALUES.symbols(), R, [0] * 6)
    moved = force.jacobian(r) * move
    outputs = [Output("load_force_D_offset", (6,), _rows(moved), "∂(−[F; r_g × F + Mo])/∂r along δr: −[0; (T δr) × F]")]
    return KernelSpec(name="point_load_D_offset", doc="A point load's generalized force moved with its point: its "
                      "derivative along a variation of the offset (linear in it, so exact)",
                      inputs=[LOAD_NODE, LOAD_OFFSET_MOVE, LOAD_VALUES, LOAD_FRAME], outputs=outputs,
                      variant="joints", equations="Eq. 2 (the point) varied")


END_NODE = Argument("node_frame", 9, "T_j: frame of the node (joint body) the beam end is joined to, row-major")
END_DATA = Argument("end", 16, "a[3] r[3] E0[9] theta: the hinge axis (unit; zero for a clamped end), the grid point "
                    "and the element axes at t = 0 (row-major), all in node axes, and the hinge angle")


def hinged_end(T, end):
    """(nodal frame T_e, offset T_j r, axis T_j a) of a beam end at a joint (Eq. 17, Eqs. 2, 9)."""
    a, r, E0, theta = _vector(end[0:3]), _vector(end[3:6]), _matrix(end[6:15]), end[15]
    K = skew(a)
    hinge = sp.eye(3) + sp.sin(theta) * K + (1 - sp.cos(theta)) * K * K  # exp(θ skew a), |a| = 1 or a = 0
    return T * hinge * E0, T * r, T * a


def _hinged_end_kernel() -> KernelSpec:
    frame, offset, axis = hinged_end(_matrix(END_NODE.symbols()), END_DATA.symbols())
    outputs = [Output("end_frame", (3, 3), list(frame), "T_e = T_j exp(θ skew a) E0, Eq. 17"),
               Output("end_offset", (3,), list(offset), "T_j r: the grid point from the reference point, Eq. 2"),
               Output("end_axis", (3,), list(axis), "T_j a: the hinge axis, global, Eq. 9")]
    return KernelSpec(name="hinged_end", doc="The nodal frame, grid-point offset and hinge axis of a beam end at a "
                      "joint turned by its hinge angle: the element's geometry block, end by end",
                      inputs=[END_NODE, END_DATA], outputs=outputs, variant="joints",
                      equations="Eqs. 2, 9, 17")


END_FRAME = Argument("end_frame", 9, "T_e: the element's nodal frame at the end, from its geometry block, row-major")
END_FRAME0 = Argument("frame0", 9, "E0: the element axes at t = 0 in node axes, row-major")
END_HINGE = Argument("axis_angle", 4, "a[3] theta: the end's hinge axis (unit, node axes; zero for a clamped "
                     "end) and its angle")
REFERENCE_HELD = Argument("held", 9, "phi[3] dr[3] da[3]: a variation of the end's reference data in node axes (the "
                          "frame's turn, the grid point's move, the hinge axis's move; "
                          "latdyn/analyses/geometry_sensitivities.py)")


def reference_variation_at_state(T_e, E0, T, hinge, held):
    """(ψ, δo, δh) of a beam end's reference variation at a state, from its parts in node axes (φ, δr_g, δa):
    the frame turned, spatial at the end, ψ = T_e E0ᵀ φ (= T_j R(a, θ) φ), plus T_j J(θa) θ δa where the hinge
    axis moves (T_e = T_j exp(θ skew a) E0, J the left Jacobian of exp, :func:`so3_dexp`); the grid point's move
    δo = T_j δr_g; the hinge axis's δh = T_j δa (codegen/derivation.py ``reference_first_variation``);
    (vector of 9, intermediates)."""
    a, theta = _vector(hinge[0:3]), hinge[3]
    phi, dr, da = _vector(held[0:3]), _vector(held[3:6]), _vector(held[6:9])
    J, intermediates = so3_dexp(theta * a)
    psi = (T_e * E0.T) * phi + T * (theta * (J * da))
    return list(psi) + list(T * dr) + list(T * da), intermediates


def _reference_variation_kernel() -> KernelSpec:
    variation, intermediates = reference_variation_at_state(
        _matrix(END_FRAME.symbols()), _matrix(END_FRAME0.symbols()), _matrix(END_NODE.symbols()),
        END_HINGE.symbols(), REFERENCE_HELD.symbols())
    outputs = [Output("variation", (9,), variation, "psi[3] do[3] dh[3]: the reference block's parts of the end "
                      "(codegen/conventions.py REFERENCE), spatial")]
    return KernelSpec(name="reference_variation_at_state", doc="A beam end's variation of its reference data at a "
                      "state from its parts in node axes: the geometry parameters' input of the "
                      "*_D_reference kernels (latdyn/analyses/geometry_sensitivities.py)",
                      inputs=[END_FRAME, END_FRAME0, END_NODE, END_HINGE, REFERENCE_HELD], outputs=outputs,
                      variant="joints", equations="Eqs. 2, 9, 17 varied (the reference configuration's derivative)",
                      intermediates=intermediates)


HINGE_STATE = Argument("hinge", 4, "theta theta_dot rest_angle load_factor: the hinge angle, its rate, the "
                       "spring's rest angle, and the factor that scales the applied torque")
HINGE_LAWS = Argument("laws", 9, "k dk/dtheta dk/dtheta_dot c dc/dtheta dc/dtheta_dot tau dtau/dtheta "
                      "dtau/dtheta_dot: stiffness, damping and applied torque and their derivatives at the "
                      "hinge's (theta, theta_dot, t): the compiled laws of the scene, or constants")
JOINT_CONTACT = Argument("contact", 11, "lower upper stiffness exponent damping coulomb static stribeck_inverse "
                         "stribeck_smooth viscous stick_rate: a compliant stop's limits and Hunt-Crossley law "
                         "(stiffness 0, damping 0: none) and the friction law (1/stribeck_rate, or 0 with "
                         "stribeck_smooth 0 when stribeck_rate is 0; all forces 0: none, stick_rate then 1)")

#: |x| below this is the kink itself: the step x/(|x| + KINK) is exactly 0 or 1 in floating point for
#: |x| > 1e-284, ½ at x = 0 (a branch-free Heaviside for the derivatives of the kinks)
KINK = sp.Float("1e-300")


class _Step(sp.Function):
    """The Heaviside step of a kink (its own derivative 0 away from the kink)."""

    def fdiff(self, argindex=1):
        return sp.S.Zero


class _PositivePower(sp.Function):
    """⟨x⟩ⁿ, ⟨x⟩ = max(x, 0): differentiated as n ⟨x⟩ⁿ⁻¹ step(x), never through x⁻¹ (which is
    0/0 outside contact), and printed branch-free by :class:`_BranchFree`."""

    def fdiff(self, argindex=1):
        x, n = self.args
        if argindex == 2:   # by the exponent: ⟨x⟩ⁿ ln⟨x⟩ (0 for x ≤ 0)
            return _PositivePowerLog(x, n)
        if argindex != 1:
            raise sp.ArgumentIndexError(self, argindex)
        return n * _PositivePower(x, n - 1) * _Step(x)


class _PositivePowerLog(sp.Function):
    """⟨x⟩ⁿ ln⟨x⟩, the derivative of ⟨x⟩ⁿ by n: 0 for x ≤ 0 (the limit), printed branch-free by
    :class:`_BranchFree` as ⟨x⟩ⁿ ln(⟨x⟩ + KINK) (ln x itself for x > 1e-284, a finite ln at 0 times
    ⟨x⟩ⁿ = 0 exactly). Not differentiated further."""


def _positive(x):
    return _PositivePower(x, 1)


def _absolute(x):
    return 2 * _PositivePower(x, 1) - x


def _clipped(x):
    """x clipped to [−1, 1]: ⟨x + 1⟩ − ⟨x − 1⟩ − 1."""
    return _positive(x + 1) - _positive(x - 1) - 1


def _engaged(x):
    """The friction's engagement at rate ratio x = v/v₀: y(2 − |y|), y = x clipped to [−1, 1]; C¹
    (its slope 2 at 0 falls to 0 at |x| = 1, where it meets ±1): Newton's matrix is continuous
    across the end of the stick band (a linear ramp's has a corner there; with the regularised law
    alone holding a sticking joint, on the oscillator of docs/contact.md released from 1.05, both
    cut the step at every reversal: 12 and 10 rejected steps over five)."""
    y = _clipped(x)
    return y * (2 - _absolute(y))


class _BranchFree:
    """The kinks in what the printers write: ⟨x⟩ = (g + |g|)/2 (a power of it when n ≠ 1) and
    step(x) = (1 + g/(|g| + KINK))/2, with g = x a named intermediate of the kernel, which no
    simplification distributes, so that ⟨x⟩ is exactly 0 for x ≤ 0 (distributed, −a/2 + b/2 + |b − a|/2
    rounds to ±1e-17, and a negative base of a fractional power is NaN)."""

    def __init__(self):
        self.named: dict = {}

    def _name(self, x):
        if x.is_Symbol:
            return x
        if x not in self.named:
            self.named[x] = sp.Symbol(f"kink_{len(self.named)}", real=True)
        return self.named[x]

    def __call__(self, expr):
        def power(x, n):
            g = self._name(x)
            positive = (g + sp.Abs(g)) / 2
            return positive if n == 1 else positive ** n

        def step(x):
            g = self._name(x)
            return (1 + g / (sp.Abs(g) + KINK)) / 2

        def power_log(x, n):
            g = self._name(x)
            positive = (g + sp.Abs(g)) / 2
            return positive ** n * sp.log(positive + KINK)

        kinks = (_PositivePower, _Step, _PositivePowerLog)
        printed = {_PositivePower: power, _Step: step, _PositivePowerLog: power_log}
        # innermost first: an argument that holds a kink is named after its own kinks are
        for _ in range(8):
            if not expr.has(*kinks):
                return expr
            expr = expr.replace(lambda e: isinstance(e, kinks) and not e.args[0].has(*kinks),
                                lambda e: printed[type(e)](*e.args))
        raise ValueError("kinks nested too deep")

    @property
    def intermediates(self) -> list:
        return [(symbol, value) for value, symbol in self.named.items()]


def joint_contact(theta, rate, contact):
    """(force on the joint's coordinate, contact potential, its dissipative part) of a compliant stop and
    of friction in a joint (SCENE.md "Contact and friction at joints"), for a coordinate θ (an angle or
    a slide) and its rate v = θ̇.

    Stop (Hunt–Crossley), penetrations δ_u = θ − hi and δ_l = lo − θ:
        F_u = ⟨δ_u⟩ⁿ ⟨k + c θ̇⟩,  F_l = ⟨δ_l⟩ⁿ ⟨k − c θ̇⟩,   ⟨x⟩ = max(x, 0)
    i.e. k δⁿ + c δⁿ δ̇ while δ > 0, clipped at 0 (never pulling); the row of the residual takes
    F_u − F_l; the potential is k (⟨δ_u⟩ⁿ⁺¹ + ⟨δ_l⟩ⁿ⁺¹)/(n + 1); the rest of the force,
    (F_u − k⟨δ_u⟩ⁿ) − (F_l − k⟨δ_l⟩ⁿ) (its damping and clip), is dissipative: its power times θ̇ ≥ 0.

    Friction while the joint slips, regularised: f = L(v) g(v/v₀) + c_v v, with the engagement
    g(x) = y(2 − |y|), y = x clipped to [−1, 1] (C¹: ±1 from |v| = v₀ on) and the level
        L(v) = F_c + (F_s − F_c) exp(−(v/v_s)²)                 (v_s > 0, Stribeck)
        L(v) = F_c                                              (v_s = 0: F_s is only the breakaway
                                                                 level of a stuck joint, an event)
    Sticking is an event (latdyn/timeloop/events.py stick_and_slip); below it, a joint that must carry
    a force F < L(v₀) would turn at |v| = v₀ (1 − √(1 − F/L)) < v₀: the stick tolerance
    of SCENE.md. It is dissipative too (f v ≥ 0). The dissipative part returned is the stop's
    damping and clip plus the friction: the time loop integrates its work over each step's Δθ as the
    declared dissipation (latdyn.timeloop.progress.hinge_work)."""
    lower, upper, k, n, c, coulomb, static, inverse, smooth, viscous, stick = contact
    upper_power, lower_power = _PositivePower(theta - upper, n), _PositivePower(lower - theta, n)
    upper_force = upper_power * _positive(k + c * rate)
    lower_force = lower_power * _positive(k - c * rate)
    potential = k * (_PositivePower(theta - upper, n + 1) + _PositivePower(lower - theta, n + 1)) / (n + 1)
    stop_dissipative = (upper_force - k * upper_power) - (lower_force - k * lower_power)
    level = coulomb + (static - coulomb) * smooth * sp.exp(-(rate * inverse) ** 2)
    friction = level * _engaged(rate / stick) + viscous * rate
    return upper_force - lower_force + friction, potential, stop_dissipative + friction


def hinge_force(state, laws, contact=None, branch_free=None):
    """(∂f/∂θ, ∂f/∂θ̇, f at the state, spring torque k s, contact potential, the dissipative part of
    the contact and friction force) of a hinge, f = k(θ, θ̇, t) s + c(θ, θ̇, t) θ̇ − λ τ(θ, θ̇, t) + f_contact(θ, θ̇), s = θ − θ_r
    (f_contact: :func:`joint_contact`; omitted without ``contact``). Each law enters as its
    first-order expansion about the hinge's (θ, θ̇), which is all its exact first derivatives need;
    ``branch_free`` (a :class:`_BranchFree`) names the kinks' arguments (the kernel's intermediates)."""
    theta, rate, rest, factor = state
    branch_free = branch_free or _BranchFree()
    d_theta, d_rate = sp.symbols("dtheta drate")
    k, c, tau = ((laws[3 * j] + laws[3 * j + 1] * d_theta + laws[3 * j + 2] * d_rate) for j in range(3))
    s = theta + d_theta - rest
    f = k * s + c * (rate + d_rate) - factor * tau
    potential = dissipative = sp.S.Zero
    if contact is not None:
        stop, potential, dissipative = joint_contact(theta + d_theta, rate + d_rate, contact)
        f = f + stop
    zero = {d_theta: 0, d_rate: 0}

    def at_state(expr):
        return branch_free(expr.xreplace(zero))

    return at_state(sp.diff(f, d_theta)), at_state(sp.diff(f, d_rate)), at_state(f), (k * s).xreplace(zero), \
        at_state(potential), at_state(dissipative)


def _hinge_force_kernel() -> KernelSpec:
    state, laws, contact = HINGE_STATE.symbols(), HINGE_LAWS.symbols(), JOINT_CONTACT.symbols()
    branch_free = _BranchFree()
    stiffness, damping, force, spring, potential, dissipative = hinge_force(state, laws, contact, branch_free)
    rate, factor, tau, damper = state[1], state[3], laws[6], laws[3]
    outputs = [Output("hinge_force", (), [force], "f = k s + c θ̇ − λ τ + f_contact, s = θ − θ_r: the hinge's row "
                      "of the residual (f_contact: a compliant stop's and friction's force)"),
               Output("hinge_stiffness", (), [stiffness], "∂f/∂θ = k + s ∂k/∂θ + θ̇ ∂c/∂θ − λ ∂τ/∂θ + ∂f_contact/∂θ"),
               Output("hinge_damping", (), [damping], "∂f/∂θ̇ = s ∂k/∂θ̇ + c + θ̇ ∂c/∂θ̇ − λ ∂τ/∂θ̇ + ∂f_contact/∂θ̇"),
               Output("spring_torque", (), [spring], "k s: the spring's torque; its work is external when the "
                      "spring is not conservative (a law in θ̇ or t)"),
               Output("applied_torque", (), [factor * tau], "λ τ: the applied torque"),
               Output("damper_torque", (), [damper * rate + dissipative], "c θ̇ + the dissipative part of a "
                      "compliant stop's force (its damping and clip, F − k δⁿ) and the friction: the torque whose "
                      "work is the declared dissipation (latdyn.timeloop.progress)"),
               Output("contact_energy", (), [potential], "k (⟨δ_u⟩ⁿ⁺¹ + ⟨δ_l⟩ⁿ⁺¹)/(n + 1): the potential of a "
                      "compliant stop's spring (strain energy)")]
    return KernelSpec(name="hinge_force", doc="A hinge's generalized force from its spring, damper and applied torque "
                      "laws, a compliant stop (Hunt-Crossley) and friction, its exact derivatives by the angle and "
                      "its rate, the torques whose work the energy balance integrates over each step's Δθ (external "
                      "work, the joint's dissipation) and the stop's potential",
                      inputs=[HINGE_STATE, HINGE_LAWS, JOINT_CONTACT], outputs=outputs, variant="joints",
                      equations="hinge springs, dampers and torques (Eqs. 4, 9: the hinge coordinate); "
                                "Hunt-Crossley contact, Coulomb-Stribeck-viscous friction",
                      intermediates=branch_free.intermediates)


HINGE_LAW_CURVATURES = Argument("curvatures", 3, "d2k/dtheta2 d2c/dtheta2 d2tau/dtheta2: the second derivatives by the "
                                "angle of the stiffness, damping and applied torque laws at the hinge's (theta, "
                                "theta_dot, t) (SymPy's, compiled as the laws are; 0 for constants and laws of t)")


def hinge_stiffness_by_angle(state, laws, curvatures, contact, branch_free=None):
    """∂K/∂θ of a hinge's K = ∂f/∂θ (:func:`hinge_force`'s f, its stop included) at fixed θ̇ and t: f with each
    law expanded to second order in the angle, k + ∂k/∂θ dθ + ∂²k/∂θ² dθ²/2 (and c, τ alike), differentiated twice
    by dθ at 0. A stop's ⟨δ⟩ⁿ⁻² (n(n − 1)⟨δ⟩ⁿ⁻² step(δ)²) is written ⟨δ⟩ⁿ⁻¹/(⟨δ⟩ + KINK): δⁿ⁻² in contact, exactly 0
    out of it for every n ≥ 1 (0⁻ᵃ would be inf there)."""
    theta, rate, rest, factor = state
    branch_free = branch_free or _BranchFree()
    d_theta = sp.Symbol("dtheta")
    k, c, tau = ((laws[3 * j] + laws[3 * j + 1] * d_theta + curvatures[j] * d_theta ** 2 / 2) for j in range(3))
    f = k * (theta + d_theta - rest) + c * rate - factor * tau
    stop, _, _ = joint_contact(theta + d_theta, rate, contact)
    curvature = sp.diff(f + stop, d_theta, 2).xreplace({d_theta: 0})
    exponent = contact[3]
    curvature = curvature.replace(
        lambda e: isinstance(e, _PositivePower) and sp.simplify(e.args[1] - (exponent - 2)) == 0,
        lambda e: _PositivePower(e.args[0], exponent - 1) / (_positive(e.args[0]) + KINK))
    return branch_free(curvature)


def _hinge_stiffness_by_angle_kernel() -> KernelSpec:
    state, laws, contact = HINGE_STATE.symbols(), HINGE_LAWS.symbols(), JOINT_CONTACT.symbols()
    curvatures = HINGE_LAW_CURVATURES.symbols()
    branch_free = _BranchFree()
    by_angle = hinge_stiffness_by_angle(state, laws, curvatures, contact, branch_free)
    outputs = [Output("hinge_stiffness_by_angle", (), [by_angle], "∂K/∂θ, K = ∂f/∂θ: 2 ∂k/∂θ + s ∂²k/∂θ² + θ̇ ∂²c/∂θ² "
                      "− λ ∂²τ/∂θ² + ∂²f_contact/∂θ²: a hinge's part of an event's impulse weight derivative "
                      "∂(W w)/∂q (latdyn/analyses/weight_derivative.py)")]
    return KernelSpec(name="hinge_stiffness_by_angle", doc="The derivative by the angle of a hinge's stiffness "
                      "∂f/∂θ (hinge_force's), from its laws' second derivatives and its compliant stop",
                      inputs=[HINGE_STATE, HINGE_LAWS, HINGE_LAW_CURVATURES, JOINT_CONTACT], outputs=outputs,
                      variant="joints", equations="hinge springs, dampers and torques (Eqs. 4, 9) differentiated "
                      "twice by the angle; Hunt-Crossley contact", intermediates=branch_free.intermediates)


HINGE_LAW_MIXED = Argument("mixed", 3, "d2k/dtheta_dtheta_dot d2c/dtheta_dtheta_dot d2tau/dtheta_dtheta_dot: the mixed "
                           "second derivatives by the angle and its rate of the stiffness, damping and applied torque "
                           "laws at the hinge's (theta, theta_dot, t) (SymPy's; 0 for constants and laws of t)")


def hinge_stiffness_by_rate(state, laws, mixed, contact, branch_free=None):
    """∂K/∂θ̇ of a hinge's K = ∂f/∂θ (:func:`hinge_force`'s f, its stop with its damping included) at fixed θ and t,
    the mixed second derivative ∂²f/∂θ∂θ̇: f with each law expanded to second order in (θ, θ̇),
    k + ∂k/∂θ dθ + ∂k/∂θ̇ dθ̇ + ∂²k/∂θ∂θ̇ dθ dθ̇ (and c, τ alike; the pure second-order terms do not enter the mixed
    derivative), differentiated by dθ and dθ̇ at 0. A compliant stop's part is n ⟨δ⟩ⁿ⁻¹ step(δ) c step(k ± c θ̇) in
    contact (its Hunt–Crossley damping), exactly 0 out of it; friction reads the rate alone (0)."""
    theta, rate, rest, factor = state
    branch_free = branch_free or _BranchFree()
    d_theta, d_rate = sp.symbols("dtheta drate")
    k, c, tau = ((laws[3 * j] + laws[3 * j + 1] * d_theta + laws[3 * j + 2] * d_rate + mixed[j] * d_theta * d_rate)
                 for j in range(3))
    f = k * (theta + d_theta - rest) + c * (rate + d_rate) - factor * tau
    stop, _, _ = joint_contact(theta + d_theta, rate + d_rate, contact)
    return branch_free(sp.diff(f + stop, d_theta, d_rate).xreplace({d_theta: 0, d_rate: 0}))


def _hinge_stiffness_by_rate_kernel() -> KernelSpec:
    state, laws, contact = HINGE_STATE.symbols(), HINGE_LAWS.symbols(), JOINT_CONTACT.symbols()
    mixed = HINGE_LAW_MIXED.symbols()
    branch_free = _BranchFree()
    by_rate = hinge_stiffness_by_rate(state, laws, mixed, contact, branch_free)
    outputs = [Output("hinge_stiffness_by_rate", (), [by_rate], "∂K/∂θ̇ = ∂²f/∂θ∂θ̇, K = ∂f/∂θ: ∂k/∂θ̇ + s ∂²k/∂θ∂θ̇ "
                      "+ ∂c/∂θ + θ̇ ∂²c/∂θ∂θ̇ − λ ∂²τ/∂θ∂θ̇ + ∂²f_contact/∂θ∂θ̇: a hinge's part of an event's impulse "
                      "weight derivative along the rates ∂(W w)/∂v (latdyn/analyses/weight_derivative.py)")]
    return KernelSpec(name="hinge_stiffness_by_rate", doc="The derivative by the angle's rate of a hinge's stiffness "
                      "∂f/∂θ (hinge_force's), from its laws' mixed second derivatives and its compliant stop's damping",
                      inputs=[HINGE_STATE, HINGE_LAWS, HINGE_LAW_MIXED, JOINT_CONTACT], outputs=outputs,
                      variant="joints", equations="hinge springs, dampers and torques (Eqs. 4, 9) differentiated by "
                      "the angle and its rate; Hunt-Crossley contact", intermediates=branch_free.intermediates)


def _stop_law_kernel(name: str, by_angle: bool, description: str, doc: str) -> KernelSpec:
    """∂/∂(k, n, c) of a compliant stop's force (:func:`joint_contact`) at a joint's (θ, θ̇), or with ``by_angle`` of
    its ∂/∂θ at fixed θ̇, differentiated from the same expression as the force the residual holds."""
    state, contact = HINGE_STATE.symbols(), JOINT_CONTACT.symbols()
    branch_free = _BranchFree()
    force, _, _ = joint_contact(state[0], state[1], contact)
    differentiated = sp.diff(force, state[0]) if by_angle else force
    law = [contact[2], contact[3], contact[4]]   # stiffness exponent damping
    outputs = [Output(name, (3,), [branch_free(sp.diff(differentiated, symbol)) for symbol in law], description)]
    return KernelSpec(name=name, doc=doc, inputs=[HINGE_STATE, JOINT_CONTACT], outputs=outputs, variant="joints",
                      equations="Hunt-Crossley contact", intermediates=branch_free.intermediates)


def _contact_law_derivative_kernel() -> KernelSpec:
    """∂f/∂(k, n, c) of a compliant stop's force (:func:`joint_contact`) at a joint's (θ, θ̇): the
    right-hand sides of sensitivities by the stop's stiffness, exponent and damping
    (latdyn/analyses/transient_sensitivities.py), differentiated from the same expression as the
    force the residual holds."""
    return _stop_law_kernel("contact_force_D_law", False,
                            "∂f_contact/∂(k, n, c): the compliant stops' force F_u − F_l by their stiffness, exponent "
                            "and damping (the friction depends on none of them)",
                            "The derivatives of a joint's compliant-stop force (Hunt-Crossley) by its law's stiffness, "
                            "exponent and damping")


def _contact_stiffness_law_derivative_kernel() -> KernelSpec:
    """∂(∂f_contact/∂θ)/∂(k, n, c) of a compliant stop's force (:func:`joint_contact`) at a joint's (θ, θ̇), fixed θ̇:
    how a parameter of the stop's stiffness, exponent or damping moves the joint's K = ∂f/∂θ (``hinge_force``'s
    ``hinge_stiffness``), a parameter's part of an event's impulse weight derivative (∂K/∂p) w
    (latdyn/analyses/parameter_stiffness.py). F_u = ⟨δ_u⟩ⁿ ⟨k + c θ̇⟩ is not linear in n, nor in (k, c) across the
    clip, so no value fed to ``hinge_force`` in the law's place gives it. The friction's force depends on θ̇ alone: its
    part of K is 0, and so is its derivative."""
    return _stop_law_kernel("contact_stiffness_D_law", True,
                            "∂(∂f_contact/∂θ)/∂(k, n, c): the compliant stops' part of the joint's stiffness by their "
                            "law's stiffness, exponent and damping",
                            "The derivatives of a joint's compliant-stop stiffness ∂f_contact/∂θ (Hunt-Crossley) by "
                            "its law's stiffness, exponent and damping")


def _friction_law_derivative_kernel() -> KernelSpec:
    """∂f/∂(F_c, F_s, 1/v_s, c_v, v₀) of a joint's friction force (:func:`joint_contact`) at its (θ, θ̇) while
    it slips: the right-hand sides of sensitivities by the friction's coulomb, static, stribeck_rate (through
    1/v_s: ∂f/∂v_s = −(1/v_s)² ∂f/∂(1/v_s)), viscous and stick_rate values
    (latdyn/analyses/sensitivities.py), differentiated from the same expression as the force the residual holds."""
    state, contact = HINGE_STATE.symbols(), JOINT_CONTACT.symbols()
    branch_free = _BranchFree()
    force, _, _ = joint_contact(state[0], state[1], contact)
    law = [contact[5], contact[6], contact[7], contact[9], contact[10]]   # coulomb static inverse viscous stick
    outputs = [Output("friction_force_D_law", (5,), [branch_free(sp.diff(force, symbol)) for symbol in law],
                      "∂f_friction/∂(F_c, F_s, 1/v_s, c_v, v₀): the slipping friction's force L(v) g(v/v₀) + c_v v by "
                      "its law's values (the compliant stop's force depends on none of them)")]
    return KernelSpec(name="friction_force_D_law", doc="The derivatives of a joint's slipping friction force "
                      "(Coulomb-Stribeck-viscous, regularised below the stick rate) by its law's values",
                      inputs=[HINGE_STATE, JOINT_CONTACT], outputs=outputs, variant="joints",
                      equations="Coulomb-Stribeck-viscous friction", intermediates=branch_free.intermediates)


CABLE_GEOMETRY = Argument("cable_geometry", 12, "x1[3] x2[3] o1[3] o2[3]: the reference points of the nodes at the "
                          "element's ends and the offsets T_i r_i of its end points from them, global")
CABLE_VELOCITY = Argument("cable_velocity", 12, "v1[3] w1[3] v2[3] w2[3]: velocities of the reference points and "
                          "spatial angular velocities of the end nodes")
CABLE_SECTION = Argument("cable_section", 4, "L0 L0_dot EA c: the element's share of the rest length and its rate "
                         "(a reel), the axial stiffness and the axial damping coefficient")


def cable_terms(geometry, velocity, section):
    """The taut law of a cable element between the points p_i = x_i + o_i (module docstring of
    latdyn/model/cables.py): length ℓ = |p2 − p1|, rate ℓ̇ = e·(ṗ2 − ṗ1) with ṗ_i = v_i + ω_i × o_i,
    elastic tension N_el = EA (ℓ − L0)/L0, tension N = N_el + c ℓ̇; the generalized force on the
    residual rows [d1, π1, d2, π2] is −[F1; o1 × F1; F2; o2 × F2] with F1 = N e = −F2 (the cable
    pulls its ends together). Returns (force, length, rate, elastic tension, tension)."""
    x1, x2, o1, o2 = (_vector(geometry[3 * k:3 * k + 3]) for k in range(4))
    v1, w1, v2, w2 = (_vector(velocity[3 * k:3 * k + 3]) for k in range(4))
    L0, _, EA, c = section
    u = (x2 + o2) - (x1 + o1)
    length = sp.sqrt(u.dot(u))
    e = u / length
    rate = e.dot((v2 + w2.cross(o2)) - (v1 + w1.cross(o1)))
    elastic = EA * (length - L0) / L0
    tension = elastic + c * rate
    F1 = tension * e
    force = -sp.Matrix.vstack(F1, o1.cross(F1), -F1, o2.cross(-F1))
    return force, length, rate, elastic, tension


def _cable_force_kernel() -> KernelSpec:
    geometry, velocity, section = CABLE_GEOMETRY.symbols(), CABLE_VELOCITY.symbols(), CABLE_SECTION.symbols()
    force, length, rate, elastic, tension = cable_terms(geometry, velocity, section)
    # the configuration update of both ends: x_i += δd_i, o_i ← (I + skew δπ_i) o_i (spatial, to first order)
    delta = sp.Matrix(sp.symbols("delta_0:12"))
    zero = {d: 0 for d in delta}
    moved = _cable_moved(geometry, delta)
    force_moved = cable_terms(moved, velocity, section)[0]
    L0, L0_dot, EA, c = section
    stretch = length - L0
    outputs = [
        Output("cable_force", (12,), _rows(force), "−[F1; o1 × F1; F2; o2 × F2], F1 = N e = −F2: the taut element's "
               "rows of the residual on [d1, π1, d2, π2]"),
        Output("cable_stiffness", (12, 12), _rows(_jacobian(force_moved, delta, zero)),
               "∂cable_force/∂[d1, π1, d2, π2] at fixed velocities (spatial update)"),
        Output("cable_damping", (12, 12), _rows(force.jacobian(_vector(velocity))),
               "∂cable_force/∂[v1, ω1, v2, ω2]"),
        Output("cable_state", (5,), [length, rate, stretch, elastic, tension],
               "ℓ, ℓ̇, ℓ − L0, N_el = EA (ℓ − L0)/L0, N = N_el + c ℓ̇"),
        Output("cable_strain_energy", (), [EA * stretch ** 2 / (2 * L0)], "½ EA (ℓ − L0)²/L0"),
        Output("reel_force", (), [sp.diff(EA * stretch ** 2 / (2 * L0), L0)],
               "∂U/∂L0: the generalized force of the rest length; a reel that changes it by ΔL0 over a step "
               "does ½(f_n + f_{n+1}) ΔL0 of external work"),
        Output("cable_damper_force", (), [c * rate],
               "c ℓ̇: the taut damper's force; over a step its dissipation is ½(f_n + f_{n+1}) Δℓ"),
        Output("clipped_damper_force", (), [-elastic],
               "−N_el: the dissipative force while the damper cancels the elastic tension (N clipped at 0), "
               "dissipating ½(f_n + f_{n+1}) Δℓ over a step"),
    ]
    return KernelSpec(name="cable_force", doc="A taut cable element between two points of nodes: its generalized "
                      "force, exact derivatives by the end coordinates and rates, length, tension, strain energy, "
                      "the rest length's generalized force (a reel) and the dampers' forces", inputs=[CABLE_GEOMETRY, CABLE_VELOCITY, CABLE_SECTION],
                      outputs=outputs, variant="joints", equations="Eq. 2 (the end points); cables, issue 32")


CABLE_DIRECTION = Argument("cable_direction", 12, "w[12]: a direction on [d1, π1, d2, π2] (an event's impulse "
                           "weight w)")


def _cable_moved(geometry, delta):
    """The cable's geometry after the configuration update of both ends by ``delta`` [d1, π1, d2, π2]: x_i += δd_i,
    o_i ← (I + skew δπ_i) o_i (spatial, to first order: all a derivative at δ = 0 needs)."""
    moved = list(geometry)
    for k in range(2):
        d, pi = delta[6 * k:6 * k + 3, 0], delta[6 * k + 3:6 * k + 6, 0]
        moved[3 * k:3 * k + 3] = list(_vector(geometry[3 * k:3 * k + 3]) + d)
        o = _vector(geometry[6 + 3 * k:9 + 3 * k])
        moved[6 + 3 * k:9 + 3 * k] = list(o + pi.cross(o))
    return moved


def cable_stiffness_along(geometry, velocity, section, direction):
    """K w of a taut cable element (K = ``cable_stiffness`` of :func:`_cable_force_kernel`, the damper's c ℓ̇ included,
    at fixed rates): the derivative of :func:`cable_terms`' force along the configuration update τ w at τ = 0."""
    tau = sp.Symbol("tau")
    return sp.diff(cable_terms(_cable_moved(geometry, tau * direction), velocity, section)[0], tau).xreplace({tau: 0})


def _cable_stiffness_D_q_kernel() -> KernelSpec:
    """A taut cable element's stiffness along a direction, K w (K = ``cable_stiffness`` of :func:`_cable_force_kernel`,
    the damper's c ℓ̇ included, at fixed rates), and its exact derivative by the end coordinates at fixed w and rates
    (an event's impulse weight M + dt²K along δq, latdyn/analyses/weight_derivative.py). K w is the derivative of the
    force along the configuration update τ w at τ = 0, differentiated once more by the update ε of the ends it starts
    from. The taut law alone: a slack element's K is the runtime's zero (csrc/evaluate.c ``cables``), its derivative
    too."""
    geometry, velocity, section = CABLE_GEOMETRY.symbols(), CABLE_VELOCITY.symbols(), CABLE_SECTION.symbols()
    direction = _vector(CABLE_DIRECTION.symbols())
    second = sp.Matrix(sp.symbols("epsilon_0:12"))
    along = cable_stiffness_along(list(geometry), velocity, section, direction)
    by_q = _jacobian(cable_stiffness_along(_cable_moved(list(geometry), second), velocity, section, direction), second,
                     {e: 0 for e in second})
    outputs = [Output("cable_stiffness_along", (12,), _rows(along), "(∂cable_force/∂[d1, π1, d2, π2]) w"),
               Output("cable_stiffness_along_D_q", (12, 12), _rows(by_q),
                      "∂(cable_stiffness_along)/∂[d1, π1, d2, π2] at fixed w and rates (spatial update)")]
    return KernelSpec(name="cable_stiffness_D_q", doc="A taut cable element's stiffness along a direction and its "
                      "exact derivative by the end coordinates (an event's impulse weight with sensitivities)",
                      inputs=[CABLE_GEOMETRY, CABLE_VELOCITY, CABLE_SECTION, CABLE_DIRECTION], outputs=outputs,
                      variant="joints", equations="Eq. 2 (the end points); cables, issue 32")


def _cable_rest_length_kernel() -> KernelSpec:
    """∂/∂L0 of the taut law of :func:`cable_terms` at fixed ends, rates, EA and c: what a rest length parameter
    or a reel (L0 in t) moves (latdyn/analyses/cable_sensitivities.py; in the loop of steps,
    csrc/cable_forces.c). N = EA (ℓ/L0 − 1) + c ℓ̇, so ∂N/∂L0 = −EA ℓ/L0² and the force moves along e."""
    geometry, velocity, section = CABLE_GEOMETRY.symbols(), CABLE_VELOCITY.symbols(), CABLE_SECTION.symbols()
    force, length, rate, elastic, tension = cable_terms(geometry, velocity, section)
    L0 = section[0]
    state = sp.Matrix([length, rate, length - L0, elastic, tension])
    outputs = [
        Output("cable_force_D_rest_length", (12,), _rows(sp.diff(force, L0)),
               "∂cable_force/∂L0 at fixed ends and rates"),
        Output("cable_state_D_rest_length", (5,), list(sp.diff(state, L0)),
               "∂[ℓ, ℓ̇, ℓ − L0, N_el, N]/∂L0 at fixed ends and rates"),
    ]
    return KernelSpec(name="cable_force_D_rest_length", doc="The derivatives of a taut cable element's force and "
                      "state by its rest length share L0 (a rest length parameter, a reel)",
                      inputs=[CABLE_GEOMETRY, CABLE_VELOCITY, CABLE_SECTION], outputs=outputs, variant="joints",
                      equations="Eq. 2 (the end points); cables, issue 32; their sensitivities, issue 34")


def _cable_stiffness_D_rest_length_kernel() -> KernelSpec:
    """∂(K w)/∂L0 of a taut cable element at fixed ends, rates, EA, c and w (K w of :func:`cable_stiffness_along`): a
    rest length parameter's part of an event's impulse weight derivative, (∂K/∂p) w
    (latdyn/analyses/parameter_stiffness.py). K is not linear in L0 (N_el = EA (ℓ/L0 − 1)), so no value fed to
    ``cable_stiffness_D_q`` in L0's place gives it."""
    geometry, velocity, section = CABLE_GEOMETRY.symbols(), CABLE_VELOCITY.symbols(), CABLE_SECTION.symbols()
    direction = _vector(CABLE_DIRECTION.symbols())
    along = cable_stiffness_along(list(geometry), velocity, section, direction)
    outputs = [Output("cable_stiffness_along_D_rest_length", (12,), _rows(sp.diff(along, section[0])),
                      "∂((∂cable_force/∂[d1, π1, d2, π2]) w)/∂L0 at fixed ends, rates and w")]
    return KernelSpec(name="cable_stiffness_D_rest_length", doc="The derivative of a taut cable element's stiffness "
                      "along a direction by its rest length share L0 (an event's impulse weight with a rest length "
                      "parameter)", inputs=[CABLE_GEOMETRY, CABLE_VELOCITY, CABLE_SECTION, CABLE_DIRECTION],
                      outputs=outputs, variant="joints",
                      equations="Eq. 2 (the end points); cables, issue 32; their sensitivities, issue 34")


def _cable_tension_kernel() -> KernelSpec:
    """The tension of a taut cable element as a controller's sensor reads it (SCENE.md ``controllers``: a
    ``{cable: NAME, quantity: tension}`` probe; csrc/evaluate.c ``sensor_value``): N_el and N of
    :func:`cable_terms`, the law the residual holds, with N's exact derivatives by the end coordinates
    (the spatial update of :func:`_cable_force_kernel`, at fixed velocities: K's entries of the coupling)
    and by the end rates (the damper: C's entries)."""
    geometry, velocity, section = CABLE_GEOMETRY.symbols(), CABLE_VELOCITY.symbols(), CABLE_SECTION.symbols()
    _, _, _, elastic, tension = cable_terms(geometry, velocity, section)
    delta = sp.Matrix(sp.symbols("delta_0:12"))
    zero = {d: 0 for d in delta}
    moved = _cable_moved(geometry, delta)
    tension_moved = sp.Matrix([cable_terms(moved, velocity, section)[4]])
    outputs = [
        Output("cable_tension", (2,), [elastic, tension], "N_el = EA (ℓ − L0)/L0, N = N_el + c ℓ̇ (taut)"),
        Output("cable_tension_D_q", (12,), _rows(_jacobian(tension_moved, delta, zero)),
               "∂N/∂[d1, π1, d2, π2] at fixed velocities (spatial update)"),
        Output("cable_tension_D_rate", (12,), _rows(sp.Matrix([tension]).jacobian(_vector(velocity))),
               "∂N/∂[v1, ω1, v2, ω2]: the damper's"),
    ]
    return KernelSpec(name="cable_tension", doc="The tension of a taut cable element and its exact derivatives by "
                      "the end coordinates and rates (a controller's sensor)",
                      inputs=[CABLE_GEOMETRY, CABLE_VELOCITY, CABLE_SECTION], outputs=outputs, variant="joints",
                      equations="Eq. 2 (the end points); cables, issue 32")


def _cable_tension_D_q_D_q_kernel() -> KernelSpec:
    """The second derivative of a taut cable element's tension N (:func:`_cable_tension_kernel`, the damper's c ℓ̇
    included, at fixed rates) by the end coordinates: ∂(∂N/∂q_c)/∂q_i, the gradient ``cable_tension_D_q`` (column c,
    the spatial update δ at τ = 0) differentiated once more by the update ε of the ends it starts from (column i), as
    ``cable_stiffness_D_q`` is built: a tension sensor's move along δq in an event's impulse weight derivative
    (latdyn/analyses/weight_derivative.py ``_sensor_kinematics``, kind 11)."""
    geometry, velocity, section = CABLE_GEOMETRY.symbols(), CABLE_VELOCITY.symbols(), CABLE_SECTION.symbols()
    delta = sp.Matrix(sp.symbols("delta_0:12"))
    second = sp.Matrix(sp.symbols("epsilon_0:12"))

    def gradient(start):
        moved = sp.Matrix([cable_terms(_cable_moved(start, delta), velocity, section)[4]])
        return _jacobian(moved, delta, {d: 0 for d in delta})

    by_q = _jacobian(gradient(_cable_moved(list(geometry), second)).T, second, {e: 0 for e in second})
    outputs = [Output("cable_tension_D_q", (12,), _rows(gradient(list(geometry))),
                      "∂N/∂[d1, π1, d2, π2] at fixed velocities (spatial update)"),
               Output("cable_tension_D_q_D_q", (12, 12), _rows(by_q),
                      "∂(∂N/∂q_c)/∂q_i at fixed velocities (spatial update): row c the gradient's column, column i "
                      "the move")]
    return KernelSpec(name="cable_tension_D_q_D_q", doc="The gradient of a taut cable element's tension by the end "
                      "coordinates and its exact derivative by them (a tension sensor in an event's impulse weight "
                      "with sensitivities)", inputs=[CABLE_GEOMETRY, CABLE_VELOCITY, CABLE_SECTION], outputs=outputs,
                      variant="joints", equations="Eq. 2 (the end points); cables, issue 32")


def _cable_tension_D_q_D_section_kernel() -> KernelSpec:
    """The gradient of a taut cable element's tension N (:func:`_cable_tension_kernel`, the damper's c ℓ̇ included,
    at fixed rates) by the end coordinates and its exact derivative by the element's rest length share L0, EA and c:
    ∂²N/∂σ∂q, the move along w of a tension sensor's ∂N/∂p for a parameter in the cable's EA, damping or rest
    length (latdyn/analyses/parameter_stiffness.py ``_tension_along``) — generated, so no fact of the law (N linear
    in (EA, c), N_el = EA (ℓ/L0 − 1)) is used by hand there."""
    geometry, velocity, section = CABLE_GEOMETRY.symbols(), CABLE_VELOCITY.symbols(), CABLE_SECTION.symbols()
    delta = sp.Matrix(sp.symbols("delta_0:12"))
    moved = sp.Matrix([cable_terms(_cable_moved(list(geometry), delta), velocity, section)[4]])
    gradient = _jacobian(moved, delta, {d: 0 for d in delta})
    L0, _, EA, c = section
    by_section = gradient.T.jacobian(sp.Matrix([L0, EA, c]))
    outputs = [Output("cable_tension_D_q", (12,), _rows(gradient),
                      "∂N/∂[d1, π1, d2, π2] at fixed velocities (spatial update)"),
               Output("cable_tension_D_q_D_section", (12, 3), _rows(by_section),
                      "∂(∂N/∂q_c)/∂[L0, EA, c] at fixed ends and velocities: row c the gradient's column")]
    return KernelSpec(name="cable_tension_D_q_D_section", doc="The gradient of a taut cable element's tension by the "
                      "end coordinates and its exact derivative by the rest length share, EA and the damping "
                      "(a tension sensor in an event's impulse weight with a parameter of the cable)",
                      inputs=[CABLE_GEOMETRY, CABLE_VELOCITY, CABLE_SECTION], outputs=outputs, variant="joints",
                      equations="Eq. 2 (the end points); cables, issue 32; their sensitivities, issue 34")


RELATIVE_GEOMETRY = Argument("relative_geometry", 27, "x_n[3] x_b[3] T_n[9] r[3] T_b[9]: the reference points of the "
                             "point's node and of the body, the node's frame, the point from the node's reference "
                             "point in node axes, and the body's frame (frames row-major)")
RELATIVE_VELOCITY = Argument("relative_velocity", 12, "v_n[3] ω_n[3] v_b[3] ω_b[3]: the velocities of the two nodes' "
                             "reference points and their spatial angular velocities")


def point_velocity_in_body(geometry, velocity):
    """The velocity of the point p = x_n + T_n r of a node relative to a body, in the body's axes (SCENE.md
    ``controllers``: a ``{point: …, quantity: velocity, frame: BODY}`` probe; csrc/evaluate.c ``sensor_value``, kind
    13):

        s = T_bᵀ V,   V = ṗ − v_b − ω_b × u,   ṗ = v_n + ω_n × o,   o = T_n r,   u = x_n + o − x_b,

    component c the body's axis b_c = T_b e_c dotted with V (Eq. 2: the point at T_n r from its node)."""
    x_n, x_b = _vector(geometry[0:3]), _vector(geometry[3:6])
    T_n, r, T_b = _matrix(geometry[6:15]), _vector(geometry[15:18]), _matrix(geometry[18:27])
    v_n, w_n, v_b, w_b = (_vector(velocity[3 * k:3 * k + 3]) for k in range(4))
    o = T_n * r
    u = x_n + o - x_b
    return T_b.T * (v_n + w_n.cross(o) - v_b - w_b.cross(u))


def _relative_moved(geometry, delta):
    """The geometry of :func:`point_velocity_in_body` after the configuration update of both nodes by ``delta``
    [d_n, π_n, d_b, π_b]: x += δd, T ← (I + skew δπ) T (spatial, to first order: all a derivative at δ = 0 needs)."""
    moved = list(geometry)
    moved[0:3] = list(_vector(geometry[0:3]) + delta[0:3, 0])
    moved[3:6] = list(_vector(geometry[3:6]) + delta[6:9, 0])
    moved[6:15] = list(_turned(_matrix(geometry[6:15]), delta[3:6, 0]))
    moved[18:27] = list(_turned(_matrix(geometry[18:27]), delta[9:12, 0]))
    return moved


def _point_velocity_in_body_kernel() -> KernelSpec:
    """A point's velocity relative to a body in its axes (:func:`point_velocity_in_body`) with its exact derivatives
    by the two nodes' coordinates [d_n, π_n, d_b, π_b] (the spatial update, at fixed rates: a controller's coupling
    entries of K) and by their rates [v_n, ω_n, v_b, ω_b] (C's): the sensor of csrc/evaluate.c, kind 13."""
    geometry, velocity = RELATIVE_GEOMETRY.symbols(), RELATIVE_VELOCITY.symbols()
    delta = sp.Matrix(sp.symbols("delta_0:12"))
    value = point_velocity_in_body(geometry, velocity)
    moved = point_velocity_in_body(_relative_moved(geometry, delta), velocity)
    outputs = [Output("velocity_in_body", (3,), _rows(value), "T_bᵀ (v_n + ω_n × o − v_b − ω_b × (x_n + o − x_b))"),
               Output("velocity_in_body_D_q", (3, 12), _rows(_jacobian(moved, delta, {d: 0 for d in delta})),
                      "∂s/∂[d_n, π_n, d_b, π_b] at fixed rates (spatial update)"),
               Output("velocity_in_body_D_rate", (3, 12), _rows(value.jacobian(_vector(velocity))),
                      "∂s/∂[v_n, ω_n, v_b, ω_b]")]
    return KernelSpec(name="point_velocity_in_body", doc="A point's velocity relative to a body, in the body's axes, "
                      "and its exact derivatives by the two nodes' coordinates and rates (a controller's sensor)",
                      inputs=[RELATIVE_GEOMETRY, RELATIVE_VELOCITY], outputs=outputs, variant="joints",
                      equations="Eq. 2 (the point), relative to a body's frame")


def _point_velocity_in_body_D_q_D_q_kernel() -> KernelSpec:
    """The second derivative of :func:`point_velocity_in_body` by the two nodes' coordinates at fixed rates:
    ∂(∂s/∂q_c)/∂q_i, the gradient ``velocity_in_body_D_q`` (column c, the update δ at 0) differentiated once more by
    the update ε it starts from (column i), as ``cable_tension_D_q_D_q`` is built: the sensor's move along δq in an
    event's impulse weight derivative (latdyn/analyses/weight_derivative.py ``_sensor_kinematics``, kind 13)."""
    geometry, velocity = RELATIVE_GEOMETRY.symbols(), RELATIVE_VELOCITY.symbols()
    delta, second = sp.Matrix(sp.symbols("delta_0:12")), sp.Matrix(sp.symbols("epsilon_0:12"))

    def gradient(start):
        return _jacobian(point_velocity_in_body(_relative_moved(start, delta), velocity), delta, {d: 0 for d in delta})

    moved = gradient(_relative_moved(list(geometry), second))
    by_q = [entry for c in range(3) for entry in _jacobian(moved[c, :].T, second, {e: 0 for e in second})]
    outputs = [Output("velocity_in_body_D_q", (3, 12), _rows(gradient(list(geometry))),
                      "∂s/∂[d_n, π_n, d_b, π_b] at fixed rates (spatial update)"),
               Output("velocity_in_body_D_q_D_q", (3, 12, 12), by_q,
                      "∂(∂s_k/∂q_c)/∂q_i at fixed rates (spatial update): component k, row c the gradient's column, "
                      "column i the move")]
    return KernelSpec(name="point_velocity_in_body_D_q_D_q", doc="The gradient of a point's velocity relative to a "
                      "body by the two nodes' coordinates and its exact derivative by them (the sensor in an event's "
                      "impulse weight with sensitivities)", inputs=[RELATIVE_GEOMETRY, RELATIVE_VELOCITY],
                      outputs=outputs, variant="joints", equations="Eq. 2 (the point), relative to a body's frame")


ROTATION_VECTOR = Argument("rotation_vector", 3, "w: a rotation vector (axis times angle), global")

#: Below θ² = SO3_SWITCH the exponential's scalars are their Taylor polynomials in θ² (through θ⁸:
#: the next term is below 3e-18 there); above, the closed forms, never evaluated at θ² < SO3_SWITCH.
SO3_SWITCH = sp.Rational(1, 100)


def so3_scales(x, forms):
    """Scalar functions of x = θ², branch-free and finite at 0, one per (closed form F(θ, θ²), series
    coefficient c_k) of ``forms``: F(x̂) + P(x̌) − P(x_s) with x̂ = max(x, x_s), x̌ = min(x, x_s), P the Taylor
    polynomial Σ_{k<5} c_k (−x)^k. Above x_s that is F(x) (the two P terms are one and the same number);
    below, P(x) plus the truncation constant F(x_s) − P(x_s) (< 3e-18 for the maps here). Unlike the
    element's log map, whose argument stays below 2, a rotation vector grows without bound (a prescribed
    spin), so the polynomial is never evaluated beyond x_s, and x̌ is formed so that it *is* x_s there: with
    d = x − x_s as a value of its own (an intermediate, which no simplification distributes),
    x̌ = x_s − (|d| − d)/2 and x̂ = x_s + (d + |d|)/2. Returns (the scalars, intermediates)."""
    t = sp.Dummy("t", nonnegative=True)
    d, excess, shortfall = sp.symbols("so3_d so3_excess so3_shortfall")
    intermediates = [(d, x - SO3_SWITCH), (excess, (d + sp.Abs(d)) / 2), (shortfall, (sp.Abs(d) - d) / 2)]
    above, below = SO3_SWITCH + excess, SO3_SWITCH - shortfall
    root = sp.sqrt(above)
    scales = []
    for closed, coefficient in forms:
        P = sum((-t) ** k * coefficient(k) for k in range(5))
        scales.append(closed(root, above) + sp.horner(P, wrt=t).subs(t, below) - P.subs(t, SO3_SWITCH))
    return scales, intermediates


def so3_exp_scales(x):
    """a = sin θ/θ and b = (1 − cos θ)/θ² = 2 sin²(θ/2)/θ² as functions of x = θ² (:func:`so3_scales`).
    Returns (a, b, intermediates)."""
    (a, b), intermediates = so3_scales(x, [(lambda r, r2: sp.sin(r) / r, lambda k: 1 / sp.factorial(2 * k + 1)),
                                           (lambda r, r2: 2 * sp.sin(r / 2) ** 2 / r2, lambda k: 1 / sp.factorial(2 * k + 2))])
    return a, b, intermediates


def so3_exp(w):
    """exp(skew w) = I + a W + b W² (Rodrigues), W = skew w; (matrix, intermediates)."""
    W = skew(w)
    a, b, intermediates = so3_exp_scales(w.dot(w))
    return sp.eye(3) + a * W + b * W * W, intermediates


def _so3_exp_kernel() -> KernelSpec:
    R, intermediates = so3_exp(_vector(ROTATION_VECTOR.symbols()))
    return KernelSpec(name="so3_exp", doc="The exponential map of SO(3) (Rodrigues), branch-free and exact to "
                      "round-off at small angles: the configuration update T <- exp(skew dpi) T, prescribed "
                      "rotations", inputs=[ROTATION_VECTOR],
                      outputs=[Output("rotation", (3, 3), list(R), "exp(skew w), row-major")], variant="joints",
                      equations="the configuration update on SO(3) (Eq. 59's virtual rotations)",
                      intermediates=intermediates)


def so3_dexp(w):
    """The tangent operator of the exponential map in the spatial (left) form, exp(skew(w + δw)) =
    exp(skew(J δw)) exp(skew w) to first order: J = I + b W + c W², W = skew w, b = (1 − cos θ)/θ²,
    c = (θ − sin θ)/θ³ (:func:`so3_scales`: the series below the switch, where θ − sin θ cancels);
    (matrix, intermediates)."""
    W = skew(w)
    (b, c), intermediates = so3_scales(
        w.dot(w), [(lambda r, r2: 2 * sp.sin(r / 2) ** 2 / r2, lambda k: 1 / sp.factorial(2 * k + 2)),
                   (lambda r, r2: (r - sp.sin(r)) / (r2 * r), lambda k: 1 / sp.factorial(2 * k + 3))])
    return sp.eye(3) + b * W + c * W * W, intermediates


def _so3_dexp_kernel() -> KernelSpec:
    J, intermediates = so3_dexp(_vector(ROTATION_VECTOR.symbols()))
    return KernelSpec(name="so3_dexp", doc="The tangent operator of SO(3)'s exponential (spatial form), branch-free "
                      "and exact to round-off at small angles: how a step's rotation increment carries the "
                      "sensitivities of the rotations (latdyn/analyses/transient_sensitivities.py)",
                      inputs=[ROTATION_VECTOR],
                      outputs=[Output("tangent", (3, 3), list(J), "dexp(w), row-major")], variant="joints",
                      equations="the variation of the configuration update on SO(3) (Eq. 59's virtual rotations)",
                      intermediates=intermediates)


ROTATION_BEFORE = Argument("before", 9, "T_n: a rotation at a step's start (columns = body axes in global axes), "
                           "row-major")
ROTATION_AFTER = Argument("after", 9, "T_{n+1}: the rotation at the step's end, row-major")


def so3_log_increment(before, after):
    """The spatial rotation vector φ = log(T_{n+1} T_nᵀ) of the turn that takes ``before`` to ``after`` (|φ| < π),
    through the element's log map (formulation.log_rotation: φ = f(x) vee(R − Rᵀ)/2, x = 1 − cos|φ| = (3 − tr R)/2,
    f = |φ|/sin|φ| the branch-free formulation.log_scale, its Taylor polynomial below x = 0.1, so exact to
    round-off near the identity; at |φ| = π the axis is undefined and vee(R − Rᵀ) = 0); (vector, intermediates)."""
    turn = after * before.T   # R = T_{n+1} T_nᵀ
    R = sp.Matrix(3, 3, sp.symbols("so3_R_0:9"))
    x, f = sp.symbols("so3_log_x so3_log_f")
    intermediates = [(R[k], turn[k]) for k in range(9)]
    intermediates += [(x, fm.to_sympy(fm.log_arguments(R)[0])), (f, fm.log_scale(x))]
    phi = [fm.to_sympy(component) for component in fm.log_rotation(R, lambda _: f)]
    return sp.Matrix(phi), intermediates


def _so3_log_increment_kernel() -> KernelSpec:
    phi, intermediates = so3_log_increment(_matrix(ROTATION_BEFORE.symbols()), _matrix(ROTATION_AFTER.symbols()))
    return KernelSpec(name="so3_log_increment", doc="The logarithm of SO(3) of a step's turn, log(T_{n+1} T_n^T), "
                      "branch-free and exact to round-off near the identity (the element's log map): the rotation "
                      "increment a prescribed body's reactions do work over (latdyn/timeloop/progress.py drive_work)",
                      inputs=[ROTATION_BEFORE, ROTATION_AFTER],
                      outputs=[Output("increment", (3,), list(phi), "phi = log(after before^T), spatial")],
                      variant="joints", equations="the rotation vector of a step's turn (the log map of the "
                      "element's deformation measure)", intermediates=intermediates)


LINK_PARENT = Argument("parent", 24, "x[3] T[9] v[3] w[3] a[3] alpha[3]: the parent node's position, frame "
                       "(row-major), velocity, spatial angular velocity, acceleration and angular acceleration")
LINK_EDGE = Argument("edge", 13, "a[3] o[3] b[3] s theta theta_dot theta_ddot: hinge axis (unit), hinge point and "
                     "the child's reference point from it, in the parent's node axes at theta = 0; the sign of the "
                     "angle on the edge (0 on a clamped edge); the hinge angle, rate and acceleration")


def rotation_about(axis, angle):
    """R(a, φ) = exp(φ skew a) = I + sin φ K + (1 − cos φ) K², K = skew a, |a| = 1 (or a = 0)."""
    K = skew(axis)
    return sp.eye(3) + sp.sin(angle) * K + (1 - sp.cos(angle)) * K * K


def link_edge(parent, edge, prismatic: bool = False):
    """(x_c, T_c, v_c, ω_c, a_c, ω̇_c) of a rigid link edge's child (module docstring, "Rigid link edge"),
    or of a prismatic edge's (``prismatic``: "Prismatic edge", θ the slide)."""
    x, T = _vector(parent[0:3]), _matrix(parent[3:12])
    v, w, acc, alpha = (_vector(parent[k:k + 3]) for k in (12, 15, 18, 21))
    a, o, b, s = _vector(edge[0:3]), _vector(edge[3:6]), _vector(edge[6:9]), edge[9]
    theta, rate, accel = edge[10], s * edge[11], s * edge[12]
    origin, origin_rate = v - w.cross(x), acc - alpha.cross(x) - w.cross(v)  # V_p and V̇_p at the origin
    g = T * a
    if prismatic:  # ξ = (g, 0): V_c = V_p + s ṡ ξ, V̇_c = V̇_p + s(s̈ ξ + ṡ (ω_p × g, 0))
        frame, position = T, x + T * (o + s * theta * a + b)
        origin_rate_c = origin_rate + accel * g + rate * w.cross(g)
        alpha_c, origin_c, w_c = alpha, origin + rate * g, w
    else:
        R = rotation_about(a, s * theta)
        frame, position = T * R, x + T * (o + R * b)
        hinge_point = x + T * o
        xi_v = hinge_point.cross(g)
        # V̇_c = V̇_p + s(θ̈ ξ + θ̇ V_p ×̂ ξ), V_c = V_p + s θ̇ ξ
        origin_rate_c = origin_rate + accel * xi_v + rate * (w.cross(xi_v) + origin.cross(g))
        alpha_c = alpha + accel * g + rate * w.cross(g)
        origin_c, w_c = origin + rate * xi_v, w + rate * g
    v_c = origin_c + w_c.cross(position)
    a_c = origin_rate_c + alpha_c.cross(position) + w_c.cross(v_c)
    return position, frame, v_c, w_c, a_c, alpha_c


def _link_edge_kernel(prismatic: bool = False) -> KernelSpec:
    parent, edge = LINK_PARENT.symbols(), LINK_EDGE.symbols()
    position, frame, v_c, w_c, a_c, alpha_c = link_edge(parent, edge, prismatic)
    velocity, acceleration = sp.Matrix.vstack(v_c, w_c), sp.Matrix.vstack(a_c, alpha_c)
    parent_velocity = _vector(parent[12:18])
    outputs = [
        Output("child_position", (3,), list(position), "x_c = x_p + T_p (o + R b)"),
        Output("child_frame", (3, 3), list(frame), "T_c = T_p R(a, s theta)"),
        Output("child_rates", (12,), _rows(sp.Matrix.vstack(velocity, acceleration)),
               "v_c w_c a_c alpha_c: the child's velocity, angular velocity, acceleration, angular acceleration"),
        Output("child_transfer", (6, 6), _rows(velocity.jacobian(parent_velocity)),
               "∂(v_c, w_c)/∂(v_p, w_p) (= ∂(a_c, alpha_c)/∂(a_p, alpha_p))"),
        Output("child_joint", (6,), _rows(velocity.diff(edge[11])),
               "∂(v_c, w_c)/∂theta_dot (= ∂(a_c, alpha_c)/∂theta_ddot): the column of the edge's hinge in J"),
        Output("child_convective", (6, 7),
               _rows(acceleration.jacobian(sp.Matrix.vstack(parent_velocity, sp.Matrix([edge[11]])))),
               "∂(a_c, alpha_c)/∂(v_p, w_p, theta_dot) at fixed accelerations: the velocity-quadratic terms"),
    ]
    if prismatic:
        outputs[0] = Output("child_position", (3,), list(position), "x_c = x_p + T_p (o + s theta a + b)")
        outputs[1] = Output("child_frame", (3, 3), list(frame), "T_c = T_p")
        return KernelSpec(name="prismatic_link_edge", doc="A guided body (a dependent node on a prismatic edge) "
                          "from its parent through the slide (edge's theta: the slide s): frame, position, rates, "
                          "and the edge's factors of J and of the velocity-quadratic accelerations (the same "
                          "inputs and outputs as rigid_link_edge)", inputs=[LINK_PARENT, LINK_EDGE],
                          outputs=outputs, variant="joints",
                          equations="Eq. 2 (a point of the parent), the slide along an axis fixed in it")
    return KernelSpec(name="rigid_link_edge", doc="A rigid link's dependent node from its parent through the edge's "
                      "hinge: frame, position, rates, and the edge's factors of J and of the velocity-quadratic "
                      "accelerations", inputs=[LINK_PARENT, LINK_EDGE], outputs=outputs, variant="joints",
                      equations="Eqs. 2, 4, 17 (a rigid link's motion through its hinges)")


def _rates_D_q(rates: sp.Matrix, parent, theta) -> sp.Matrix:
    """∂(v_c, w_c, a_c, alpha_c)/∂(δx_p, δπ_p, δθ) (12 × 7) at fixed parent rates and hinge rates: the
    child's rates moved with the parent's configuration (δπ_p a spatial turn of T_p) and the edge's
    coordinate θ (None: a closure edge, no coordinate; its column zero)."""
    delta = sp.Matrix(sp.symbols("delta_0:7"))
    zero = {d: 0 for d in delta}
    moved = {**{parent[k]: parent[k] + delta[k] for k in range(3)},
             **dict(zip(parent[3:12], _turned(_matrix(parent[3:12]), delta[3:6, :])))}
    if theta is not None:
        moved[theta] = theta + delta[6]
    return _jacobian(rates.xreplace(moved), delta, zero)


def _rates_D_q_kernel(kind: str) -> KernelSpec:
    """``{kind}_rates_D_q``: the q-dependence of a dependent node's rates at fixed independent rates, the
    edge's factor of it (csrc/links.c composes it along the tree into ∂(rates)/∂q of every slot, whose
    products with the damping and mass blocks at the dependent coordinates are a part of the reduced K)."""
    parent = LINK_PARENT.symbols()
    if kind in ("rigid_link_edge", "prismatic_link_edge"):
        edge = LINK_EDGE.symbols()
        _, _, v_c, w_c, a_c, alpha_c = link_edge(parent, edge, prismatic=kind == "prismatic_link_edge")
        theta = edge[10]
        inputs = [LINK_PARENT, LINK_EDGE]
    else:
        edge = CLOSURE_EDGE.symbols()
        _, _, v_c, w_c, a_c, alpha_c = closure_edge(parent, edge, rod=kind == "rod_closure_edge")
        theta = None
        inputs = [LINK_PARENT, CLOSURE_EDGE]
    rates = sp.Matrix.vstack(v_c, w_c, a_c, alpha_c)
    outputs = [Output("child_rates_D_q", (12, 7), _rows(_rates_D_q(rates, parent, theta)),
                      "∂(v_c, w_c, a_c, alpha_c)/∂(δx_p, δπ_p, δθ) at fixed parent rates and θ̇, θ̈ (δπ_p spatial; "
                      "the δθ column zero on a closure edge)")]
    return KernelSpec(name=f"{kind}_rates_D_q", doc=f"The rates of {kind}'s child moved with the parent's "
                      "configuration and the edge's coordinate at fixed rates: the edge's factor of the dependent "
                      "rates' q-dependence in the reduced stiffness", inputs=inputs, outputs=outputs,
                      variant="joints", equations="the reduction onto minimum coordinates: K_min holds "
                      "Pᵀ(C ∂(J v)/∂q + M ∂(J a + c)/∂q) at the dependent coordinates")


WRENCH_PARENT = Argument("parent", 12, "x[3] T[9]: the position and frame (row-major) of the node the hinge's "
                         "edge leaves from")
WRENCH_EDGE = Argument("edge", 7, "a[3] o[3] s: the hinge axis and point in that node's axes, the sign of the "
                       "angle on the edge")
WRENCH_POINT = Argument("wrench", 9, "y[3] f[3] m[3]: the point the wrench acts at (a dependent node's reference "
                        "point), its force and moment")


def hinge_wrench(parent, edge, wrench):
    """s g·((y − o_g) × f + m): the generalized force on a hinge of a wrench (f, m) at y (module docstring)."""
    x, T = _vector(parent[0:3]), _matrix(parent[3:12])
    a, o, s = _vector(edge[0:3]), _vector(edge[3:6]), edge[6]
    y, f, m = _vector(wrench[0:3]), _vector(wrench[3:6]), _vector(wrench[6:9])
    g, hinge_point = T * a, x + T * o
    return s * g.dot((y - hinge_point).cross(f) + m)


def _hinge_wrench_kernel() -> KernelSpec:
    parent, edge, wrench = WRENCH_PARENT.symbols(), WRENCH_EDGE.symbols(), WRENCH_POINT.symbols()
    delta = sp.Matrix(sp.symbols("delta_0:9"))  # δx_p, δπ_p, δy
    zero = {d: 0 for d in delta}
    moved_parent = list(_vector(parent[0:3]) + delta[0:3, :]) + list(_turned(_matrix(parent[3:12]), delta[3:6, :]))
    moved_wrench = list(_vector(wrench[0:3]) + delta[6:9, :]) + list(wrench[3:9])
    value = hinge_wrench(parent, edge, wrench)
    moved = sp.Matrix([hinge_wrench(moved_parent, edge, moved_wrench)])
    outputs = [Output("hinge_wrench", (), [value], "s g·((y − o_g) × f + m): the wrench's generalized force on "
                      "the hinge"),
               Output("hinge_wrench_D_q", (9,), _rows(_jacobian(moved, delta, zero)),
                      "its derivative by (δx_p, δπ_p, δy) at fixed f, m: a row of the geometric stiffness")]
    return KernelSpec(name="hinge_wrench", doc="The generalized force on a hinge of a rigid link of a wrench at a "
                      "point it moves, and its derivative by the configuration", inputs=[WRENCH_PARENT, WRENCH_EDGE,
                      WRENCH_POINT], outputs=outputs, variant="joints",
                      equations="Eqs. 4, 9 (the hinge coordinate); the reduction onto minimum coordinates")


def slide_wrench(parent, edge, wrench):
    """s g·f: the generalized force on a slide of a wrench (f, m) at y (module docstring, "Prismatic edge")."""
    T = _matrix(parent[3:12])
    a, s, f = _vector(edge[0:3]), edge[6], _vector(wrench[3:6])
    return s * (T * a).dot(f)


def _slide_wrench_kernel() -> KernelSpec:
    parent, edge, wrench = WRENCH_PARENT.symbols(), WRENCH_EDGE.symbols(), WRENCH_POINT.symbols()
    delta = sp.Matrix(sp.symbols("delta_0:9"))  # δx_p, δπ_p, δy
    zero = {d: 0 for d in delta}
    moved_parent = list(_vector(parent[0:3]) + delta[0:3, :]) + list(_turned(_matrix(parent[3:12]), delta[3:6, :]))
    moved_wrench = list(_vector(wrench[0:3]) + delta[6:9, :]) + list(wrench[3:9])
    value = slide_wrench(parent, edge, wrench)
    moved = sp.Matrix([slide_wrench(moved_parent, edge, moved_wrench)])
    outputs = [Output("slide_wrench", (), [value], "s g·f: the wrench's generalized force on the slide"),
               Output("slide_wrench_D_q", (9,), _rows(_jacobian(moved, delta, zero)),
                      "its derivative by (δx_p, δπ_p, δy) at fixed f, m: s (g × f) on δπ_p, a row of the "
                      "geometric stiffness")]
    return KernelSpec(name="slide_wrench", doc="The generalized force on a slide (a guide's prismatic edge) of a "
                      "wrench at a point it moves, and its derivative by the configuration (the same inputs and "
                      "outputs as hinge_wrench; the edge's point is not read)", inputs=[WRENCH_PARENT, WRENCH_EDGE,
                      WRENCH_POINT], outputs=outputs, variant="joints",
                      equations="The slide coordinate; the reduction onto minimum coordinates")


def _wrench_moved(parent, wrench, delta):
    """The parent's (x, T) and the wrench's point y moved by δ = (δx_p, δπ_p, δy) (δπ_p a spatial turn, to first
    order), the force and moment held: the configuration update that ``hinge_wrench_D_q`` differentiates by."""
    return (list(_vector(parent[0:3]) + delta[0:3, :]) + list(_turned(_matrix(parent[3:12]), delta[3:6, :])),
            list(_vector(wrench[0:3]) + delta[6:9, :]) + list(wrench[3:9]))


def _wrench_second_kernel(slide: bool) -> KernelSpec:
    """``hinge_wrench_D_q_D_q`` (``slide_wrench_D_q_D_q``): the derivative of hinge_wrench's (slide_wrench's) row of the
    geometric stiffness, D = ∂/∂δ F(parent ⊕ δ, y + δy) at δ = 0 (9), along a second move δ′ of the same
    configuration at fixed (f, m): ∂D_i/∂δ′_k (9 × 9), D taken at the parent moved by δ′ and differentiated at
    δ′ = 0 — the links' second derivatives in the reduction's geometric term (csrc/linked_weight_second.c)."""
    parent, edge, wrench = WRENCH_PARENT.symbols(), WRENCH_EDGE.symbols(), WRENCH_POINT.symbols()
    force = slide_wrench if slide else hinge_wrench
    delta, outer = sp.Matrix(sp.symbols("delta_0:9")), sp.Matrix(sp.symbols("epsilon_0:9"))
    moved_parent, moved_wrench = _wrench_moved(parent, wrench, delta)
    first = _jacobian(sp.Matrix([force(moved_parent, edge, moved_wrench)]), delta, {d: 0 for d in delta})
    outer_parent, outer_wrench = _wrench_moved(parent, wrench, outer)
    moved_first = first.T.xreplace({**dict(zip(parent, outer_parent)), **dict(zip(wrench[0:3], outer_wrench[0:3]))})
    second = _jacobian(moved_first, outer, {e: 0 for e in outer})
    name = "slide_wrench" if slide else "hinge_wrench"
    outputs = [Output(f"{name}_D_q_D_q", (9, 9), _rows(second),
                      f"∂({name}_D_q)_i/∂δ′_k, δ′ = (δx_p, δπ_p, δy) at fixed f, m: the row of the geometric "
                      "stiffness moved with the configuration")]
    return KernelSpec(name=f"{name}_D_q_D_q", doc=f"The derivative of {name}'s row of the geometric stiffness by the "
                      "configuration (the links' second derivatives: an event's impulse weight with sensitivities on "
                      "a model with rigid links or guides)", inputs=[WRENCH_PARENT, WRENCH_EDGE, WRENCH_POINT],
                      outputs=outputs, variant="joints",
                      equations="Eqs. 4, 9 (the hinge coordinate); the reduction onto minimum coordinates, "
                      "differentiated twice" if not slide else "The slide coordinate; the reduction onto minimum "
                      "coordinates, differentiated twice")


ROOT_WRENCH = Argument("wrench", 12, "x_r[3] y[3] f[3] m[3]: the root's reference point, the point the wrench acts "
                       "at, its force and moment")


def root_wrench(wrench):
    """(f, m + (y − x_r) × f): the generalized force on a root node of a wrench at y (module docstring)."""
    x, y, f, m = (_vector(wrench[k:k + 3]) for k in (0, 3, 6, 9))
    return sp.Matrix.vstack(f, m + (y - x).cross(f))


def _root_wrench_kernel() -> KernelSpec:
    wrench = ROOT_WRENCH.symbols()
    value = root_wrench(wrench)
    outputs = [Output("root_wrench", (6,), _rows(value), "(f, m + (y − x_r) × f) on the root's coordinates"),
               Output("root_wrench_D_q", (6, 6), _rows(value.jacobian(_vector(wrench[0:6]))),
                      "its derivative by (δx_r, δy) at fixed f, m: rows of the geometric stiffness")]
    return KernelSpec(name="root_wrench", doc="The generalized force on the root node of a rigid link tree of a "
                      "wrench at a point it moves, and its derivative by the configuration", inputs=[ROOT_WRENCH],
                      outputs=outputs, variant="joints", equations="Eq. 2 (the point); the reduction onto minimum "
                      "coordinates")


CLOSURE_EDGE = Argument("edge", 13, "o[3] a[3] n[3] l sigma beta0 (unused): the guide line's point and unit axis "
                        "(global), the loop's unit normal, the rod length, the slider's side of the pin along a, the "
                        "rod's initial angle atan2(b·u0, a·u0) (b = n × a)")
CLOSURE_PIN = Argument("pin", 3, "p[3]: the position of the pin (the closure edge's parent node)")
CLOSURE_WRENCH = Argument("wrench", 6, "f[3] m[3]: the residual rows of the closure edge's child")


def closure_slide_and_turn(p, edge):
    """(s, α) of the module docstring, "Closure edges": the slide of the slider along the guide and the rod's
    turn about n, as functions of the pin's position p."""
    o, a, n = _vector(edge[0:3]), _vector(edge[3:6]), _vector(edge[6:9])
    length, sigma, beta0 = edge[9], edge[10], edge[11]
    d = p - o
    along = a.dot(d)
    r = sp.sqrt(length ** 2 - d.dot(d) + along ** 2)
    return along + sigma * r, sp.atan2(-(n.cross(a)).dot(d), sigma * r) - beta0


def closure_edge(parent, edge, rod: bool):
    """(x_c, T_c, v_c, ω_c, a_c, ω̇_c) of a closure edge's child: the rod's node (``rod``) or the slider's."""
    p, v, acc = _vector(parent[0:3]), _vector(parent[12:15]), _vector(parent[18:21])
    o, a, n = _vector(edge[0:3]), _vector(edge[3:6]), _vector(edge[6:9])
    slide, turn = closure_slide_and_turn(p, edge)
    value = turn if rod else slide
    gradient = sp.Matrix([value]).jacobian(p)
    hessian = gradient.T.jacobian(p)
    rate = (gradient * v)[0]
    acceleration = (gradient * acc)[0] + (v.T * hessian * v)[0]
    zero = sp.zeros(3, 1)
    if rod:
        return p, rotation_about(n, turn), v, rate * n, acc, acceleration * n
    return o + slide * a, sp.eye(3), rate * a, zero, acceleration * a, zero


def _closure_edge_kernel(rod: bool) -> KernelSpec:
    parent, edge = LINK_PARENT.symbols(), CLOSURE_EDGE.symbols()
    position, frame, v_c, w_c, a_c, alpha_c = closure_edge(parent, edge, rod)
    velocity, acceleration = sp.Matrix.vstack(v_c, w_c), sp.Matrix.vstack(a_c, alpha_c)
    parent_velocity = _vector(parent[12:18])
    name = "rod_closure_edge" if rod else "slider_closure_edge"
    outputs = [
        Output("child_position", (3,), list(position), "x_c = p (the rod's node) or o + s(p) a (the slider's)"),
        Output("child_frame", (3, 3), list(frame), "T_c = R(n, alpha(p)) (the rod's) or the identity (the slider's)"),
        Output("child_rates", (12,), _rows(sp.Matrix.vstack(velocity, acceleration)),
               "v_c w_c a_c alpha_c: the child's velocity, angular velocity, acceleration, angular acceleration"),
        Output("child_transfer", (6, 6), _rows(velocity.jacobian(parent_velocity)),
               "∂(v_c, w_c)/∂(v_p, w_p) (= ∂(a_c, alpha_c)/∂(a_p, alpha_p))"),
        Output("child_joint", (6,), [0] * 6, "zero: a closure edge has no coordinate of its own"),
        Output("child_convective", (6, 7),
               _rows(acceleration.jacobian(sp.Matrix.vstack(parent_velocity, sp.Matrix([edge[12]])))),
               "∂(a_c, alpha_c)/∂(v_p, w_p, -) at fixed accelerations: the velocity-quadratic terms"),
    ]
    what = "rigid rod (its node at the pin, turning about n)" if rod else "slider (on its guide line)"
    return KernelSpec(name=name, doc=f"A slider-crank's {what} as a function of the pin's position: frame, position, "
                      "rates, and the edge's factors of J and of the velocity-quadratic accelerations (the same "
                      "outputs as rigid_link_edge)", inputs=[LINK_PARENT, CLOSURE_EDGE], outputs=outputs,
                      variant="joints", equations="The closure of a slider-crank's loop (rigid rod, guide on the ground)")


def closure_wrench(pin, edge, wrench, rod: bool):
    """g = (∂x_c/∂p)ᵀ f + ∇α (n·m) (the rod's) or ∇s (a·f) (the slider's): a wrench on the child on the pin."""
    p, f, m = _vector(pin), _vector(wrench[0:3]), _vector(wrench[3:6])
    a, n = _vector(edge[3:6]), _vector(edge[6:9])
    slide, turn = closure_slide_and_turn(p, edge)
    if rod:
        return f + sp.Matrix([turn]).jacobian(p).T * n.dot(m)
    return sp.Matrix([slide]).jacobian(p).T * a.dot(f)


def _closure_wrench_kernel(rod: bool) -> KernelSpec:
    pin, edge, wrench = CLOSURE_PIN.symbols(), CLOSURE_EDGE.symbols(), CLOSURE_WRENCH.symbols()
    value = closure_wrench(pin, edge, wrench, rod)
    name = "rod_closure_wrench" if rod else "slider_closure_wrench"
    outputs = [Output(name, (3,), _rows(value), "the wrench's generalized force on the pin's translation"),
               Output(f"{name}_D_q", (3, 3), _rows(value.jacobian(_vector(pin))),
                      "its derivative by the pin's position at fixed f, m: the closure's geometric stiffness")]
    return KernelSpec(name=name, doc="The generalized force on the pin's translation of a wrench on a slider-crank's "
                      + ("rod" if rod else "slider") + " node, and its derivative by the pin's position",
                      inputs=[CLOSURE_PIN, CLOSURE_EDGE, CLOSURE_WRENCH], outputs=outputs, variant="joints",
                      equations="The closure of a slider-crank's loop; the reduction onto minimum coordinates")


def _closure_wrench_second_kernel(rod: bool) -> KernelSpec:
    """``{slider,rod}_closure_wrench_D_q_D_q``: ∂D_ab/∂p_c (9 × 3, row a b) of the closure's geometric stiffness
    D = ∂g/∂p at fixed (f, m): its move with the pin's position (the links' second derivatives)."""
    pin, edge, wrench = CLOSURE_PIN.symbols(), CLOSURE_EDGE.symbols(), CLOSURE_WRENCH.symbols()
    first = closure_wrench(pin, edge, wrench, rod).jacobian(_vector(pin))
    name = "rod_closure_wrench" if rod else "slider_closure_wrench"
    outputs = [Output(f"{name}_D_q_D_q", (9, 3), _rows(sp.Matrix(list(first)).jacobian(_vector(pin))),
                      "∂(∂g_a/∂p_b)/∂p_c, row 3a + b: the closure's geometric stiffness moved with the pin")]
    return KernelSpec(name=f"{name}_D_q_D_q", doc="The derivative by the pin's position of the closure's geometric "
                      f"stiffness on a slider-crank's {'rod' if rod else 'slider'} node (the links' second "
                      "derivatives)", inputs=[CLOSURE_PIN, CLOSURE_EDGE, CLOSURE_WRENCH], outputs=outputs,
                      variant="joints", equations="The closure of a slider-crank's loop; the reduction onto minimum "
                      "coordinates, differentiated twice")


def build_kernels() -> list[KernelSpec]:
    """The kernels of the ``joints`` unit."""
    return [*_joint_body_kernels(), *_rigid_link_inertia_kernels(), _point_load_kernel(), _point_load_offset_kernel(),
            _point_load_stiffness_D_q_kernel(), _hinged_end_kernel(),
            _reference_variation_kernel(), _hinge_force_kernel(), _hinge_stiffness_by_angle_kernel(),
            _hinge_stiffness_by_rate_kernel(),
            _contact_law_derivative_kernel(), _contact_stiffness_law_derivative_kernel(),
            _friction_law_derivative_kernel(), _so3_exp_kernel(), _so3_dexp_kernel(),
            _so3_log_increment_kernel(), _link_edge_kernel(),
            _hinge_wrench_kernel(), _root_wrench_kernel(),
            _link_edge_kernel(prismatic=True), _slide_wrench_kernel(), _cable_force_kernel(),
            _cable_stiffness_D_q_kernel(), _cable_rest_length_kernel(), _cable_stiffness_D_rest_length_kernel(),
            _cable_tension_kernel(), _cable_tension_D_q_D_q_kernel(), _cable_tension_D_q_D_section_kernel(),
            _point_velocity_in_body_kernel(), _point_velocity_in_body_D_q_D_q_kernel(),
            _closure_edge_kernel(rod=False), _closure_edge_kernel(rod=True), _closure_wrench_kernel(rod=False),
            _closure_wrench_kernel(rod=True),
            *(_rates_D_q_kernel(kind) for kind in ("rigid_link_edge", "prismatic_link_edge", "slider_closure_edge",
                                                   "rod_closure_edge")),
            _wrench_second_kernel(slide=False), _wrench_second_kernel(slide=True),
            _closure_wrench_second_kernel(rod=False), _closure_wrench_second_kernel(rod=True)]
