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
"""
from __future__ import annotations

import sympy as sp

from .ir import Argument, KernelSpec, Output

DESCRIPTION = ("joint bodies (Newton-Euler about the reference point), point loads (global and follower), "
               "hinged beam ends, hinge laws and the SO(3) exponential")

BODY_FRAME = Argument("frame", 9, "T: the body's frame (columns = body axes in global axes), row-major")
BODY_MOTION = Argument("motion", 9, "omega[3] a[3] alpha[3]: spatial angular velocity, acceleration of the "
                       "reference point, angular acceleration")
BODY_SECTION = Argument("body", 13, "m c[3] I[9]: mass, centre of mass from the reference point and inertia "
                        "about the centre of mass (row-major), in body axes")
GRAVITY = Argument("gravity", 3, "uniform gravity acceleration, global, times the load factor")

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
    inputs = [BODY_FRAME, BODY_MOTION, BODY_SECTION, GRAVITY]
    return [KernelSpec(name="joint_body", doc="Newton-Euler equations of a joint body about its reference point, "
                       "their mass, gyroscopic and gravity-stiffness blocks", inputs=inputs, outputs=outputs,
                       variant="joints", equations="Eqs. 2, 59 (joint bodies as rigid bodies)"),
            KernelSpec(name="joint_body_inertia_stiffness", doc="The inertia tangent of a joint body (not part of "
                       "the time step's matrix, which leaves out inertia derivatives by q)", inputs=inputs,
                       outputs=tangent, variant="joints", equations="Eqs. 2, 59 (joint bodies as rigid bodies)")]


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


HINGE_STATE = Argument("hinge", 4, "theta theta_dot rest_angle load_factor: the hinge angle, its rate, the "
                       "spring's rest angle, and the factor that scales the applied torque")
HINGE_LAWS = Argument("laws", 9, "k dk/dtheta dk/dtheta_dot c dc/dtheta dc/dtheta_dot tau dtau/dtheta "
                      "dtau/dtheta_dot: stiffness, damping and applied torque and their derivatives at the "
                      "hinge's (theta, theta_dot, t): the compiled laws of the scene, or constants")


def hinge_force(state, laws):
    """(f, spring torque k s) of a hinge, f = k(θ, θ̇, t) s + c(θ, θ̇, t) θ̇ − λ τ(θ, θ̇, t), s = θ − θ_r.
    Each law enters as its first-order expansion about the hinge's (θ, θ̇), which is all its exact
    first derivatives need."""
    theta, rate, rest, factor = state
    d_theta, d_rate = sp.symbols("dtheta drate")
    k, c, tau = ((laws[3 * j] + laws[3 * j + 1] * d_theta + laws[3 * j + 2] * d_rate) for j in range(3))
    s = theta + d_theta - rest
    f = k * s + c * (rate + d_rate) - factor * tau
    zero = {d_theta: 0, d_rate: 0}
    return f, sp.diff(f, d_theta).xreplace(zero), sp.diff(f, d_rate).xreplace(zero), f.xreplace(zero), \
        (k * s).xreplace(zero)


def _hinge_force_kernel() -> KernelSpec:
    state, laws = HINGE_STATE.symbols(), HINGE_LAWS.symbols()
    _, stiffness, damping, force, spring = hinge_force(state, laws)
    rate, factor, tau, damper = state[1], state[3], laws[6], laws[3]
    outputs = [Output("hinge_force", (), [force], "f = k s + c θ̇ − λ τ, s = θ − θ_r: the hinge's row of the residual"),
               Output("hinge_stiffness", (), [stiffness], "∂f/∂θ = k + s ∂k/∂θ + θ̇ ∂c/∂θ − λ ∂τ/∂θ"),
               Output("hinge_damping", (), [damping], "∂f/∂θ̇ = s ∂k/∂θ̇ + c + θ̇ ∂c/∂θ̇ − λ ∂τ/∂θ̇"),
               Output("spring_torque", (), [spring], "k s: the spring's torque; its work is external when the "
                      "spring is not conservative (a law in θ̇ or t)"),
               Output("applied_torque", (), [factor * tau], "λ τ: the applied torque"),
               Output("damper_torque", (), [damper * rate], "c θ̇: the damper's torque, whose work is the declared "
                      "dissipation (latdyn.timeloop.progress)")]
    return KernelSpec(name="hinge_force", doc="A hinge's generalized force from its spring, damper and applied torque "
                      "laws, its exact derivatives by the angle and its rate, and the torques whose work the "
                      "energy balance integrates over each step's Δθ (external work, the damper's dissipation)",
                      inputs=[HINGE_STATE, HINGE_LAWS], outputs=outputs, variant="joints",
                      equations="hinge springs, dampers and torques (Eqs. 4, 9: the hinge coordinate)")


ROTATION_VECTOR = Argument("rotation_vector", 3, "w: a rotation vector (axis times angle), global")

#: Below θ² = SO3_SWITCH the exponential's scalars are their Taylor polynomials in θ² (through θ⁸:
#: the next term is below 3e-18 there); above, the closed forms, never evaluated at θ² < SO3_SWITCH.
SO3_SWITCH = sp.Rational(1, 100)


def so3_exp_scales(x):
    """a = sin θ/θ and b = (1 − cos θ)/θ² = 2 sin²(θ/2)/θ² as functions of x = θ², branch-free and
    finite at 0: F(x̂) + P(x̌) − P(x_s) with x̂ = max(x, x_s), x̌ = min(x, x_s), F the closed form and P
    the Taylor polynomial. Above x_s that is F(x) (the two P terms are one and the same number);
    below, P(x) plus the truncation constant F(x_s) − P(x_s) < 3e-18. Unlike the element's log map,
    whose argument stays below 2, a rotation vector grows without bound (a prescribed spin), so the
    polynomial is never evaluated beyond x_s, and x̌ is formed so that it *is* x_s there: with
    d = x − x_s as a value of its own (an intermediate, which no simplification distributes),
    x̌ = x_s − (|d| − d)/2 and x̂ = x_s + (d + |d|)/2. Returns (a, b, intermediates)."""
    t = sp.Dummy("t", nonnegative=True)
    d, excess, shortfall = sp.symbols("so3_d so3_excess so3_shortfall")
    intermediates = [(d, x - SO3_SWITCH), (excess, (d + sp.Abs(d)) / 2), (shortfall, (sp.Abs(d) - d) / 2)]
    above, below = SO3_SWITCH + excess, SO3_SWITCH - shortfall
    root = sp.sqrt(above)
    closed = (sp.sin(root) / root, 2 * sp.sin(root / 2) ** 2 / above)
    series = (sum((-t) ** k / sp.factorial(2 * k + 1) for k in range(5)),
              sum((-t) ** k / sp.factorial(2 * k + 2) for k in range(5)))
    a, b = (F + sp.horner(P, wrt=t).subs(t, below) - P.subs(t, SO3_SWITCH) for F, P in zip(closed, series))
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


def build_kernels() -> list[KernelSpec]:
    """The kernels of the ``joints`` unit."""
    return [*_joint_body_kernels(), _point_load_kernel(), _hinged_end_kernel(), _hinge_force_kernel(),
            _so3_exp_kernel()]
