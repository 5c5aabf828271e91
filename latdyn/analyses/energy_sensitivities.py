"""Sensitivities of the energy and momentum probes (SCENE.md, "Parameters and sensitivities";
docs/parameters.md, "Energies and momenta").

A recorded energy or momentum is a function of the row's state and the parameters; its derivative
by a parameter p is taken along the carried sensitivities of the state (δq in the coordinates of the
configuration update, δq̇ = (δv, δω, δθ̇) the rates' components) plus its explicit derivative, every
term from the generated kernels the recorded value itself is made of (latdyn_energies, csrc/evaluate.c;
latdyn_momentum, csrc/rows.c), never from differences:

- strain energy of the elements U = Σ beam_strain_energy: ∂U/∂q^e = F^e, the internal force
  ``beam_internal_force`` (Eq. 43 makes F^e = Bᵀ ∂U/∂Ψ the exact gradient of the kernel's U:
  tests/test_sensitivities_energies.py checks it), and ∂U/∂p from the generated ``beam_energies_D_section``
  (∂[U, T, V] by the section values, exact in every formulation and for shear-flexible sections);
  of a hinge's spring with a constant stiffness k, ½ k s² (s = θ − θ_r): δ = τ_s (δθ − δθ_r) + ½ (∂k/∂p) s²
  with τ_s = k s the ``hinge_force`` kernel's spring torque; of a conservative law k(θ), ∫_{θ_r}^{θ} k(x)(x − θ_r) dx:
  δ = τ_s δθ + ∫ (∂k/∂p)(x)(x − θ_r) dx − ∫ k(x) dx δθ_r on latdyn_energies' own quadrature (a law in θ̇ or t
  is not strain energy: its torque −k s does external work, below); of a compliant stop (a hinge's or a guide's on its
slide), the kernel's contact
  energy k(⟨δ_u⟩ⁿ⁺¹ + ⟨δ_l⟩ⁿ⁺¹)/(n + 1): ∂/∂θ its contact force at θ̇ = 0, ∂/∂p linear in the stop's stiffness;
- kinetic energy T = ½ q̇ᵀ M(q) q̇ of an element (``beam_kinetic_energy``): ∂T/∂q̇ = M q̇
  (``beam_mass_matrix``), ∂T/∂q δq = ½ q̇ᵀ [∂(M a)/∂q]_{a = q̇} δq (``beam_inertia_tangent`` at zero
  velocity and the acceleration a = q̇), ∂T/∂p from ``beam_energies_D_section``; of a joint body ½ uᵀ M_b u, u = (v, ω) of its reference point, alike from ``joint_body``
  (its mass block M_b = ∂[f; τ]/∂[a; α]) and ``joint_body_inertia_stiffness`` at (ω, a, α) = (0, v, ω);
  linear in (m, I) at a fixed centre of mass c, and by c the generated ``joint_body_D_com`` (∂f/∂c of the
  momentum f = M_b u, along ∂c/∂p);
- gravity potential V: of an element ``beam_gravity``'s potential, ∂V/∂q^e = −G^e (its gravity force),
  ∂V/∂p from ``beam_energies_D_section``; of a joint body −W·(x + T c), ∂V/∂[x; π] = the ``joint_body``
  gravity row Q = −[W; T c × W], ∂V/∂m = Q(∂m)·(x + T c), ∂V/∂c = Q·T ∂c;
- momentum: the generalized momentum f = M q̇ of an element (of a joint body M_b u) gives
  P = Σ f_translation and H = Σ (x × f_translation + f_rotation) over its ends (about the global origin,
  as latdyn_momentum); δf = M δq̇ + [∂(M a)/∂q]_{a = q̇} δq + (∂M/∂p) q̇ (the last from
  ``beam_inertia_force_D_section`` at zero velocity and a = q̇), δH adds δx × f_translation;
- total = kinetic + strain + potential;
- dissipated energy D of a transient run, Σ ½ (f_n + f_{n+1}) Δθ of the dampers' torques f = c θ̇, carried alike
  (:func:`_dissipated_step`);
- external work W of a transient run, integrated by the loop as Σ ½ h (P_n + P_{n+1}) of the point
  loads' power P = −Q·u (Q the ``point_load`` kernel's generalized force, u the node's rates) and
  Σ ½ (τ_n + τ_{n+1}) Δθ of the hinges' applied torques (less k s of a spring that is a law in θ̇ or t), and
  Σ ½ (r_n + r_{n+1}) Δq_d of the reactions that impose the prescribed motions (:func:`_drive_reactions`): its
  sensitivity is carried through the steps with the same quadrature (:func:`external_work_step`), δP = −(∂Q/∂π δπ + ∂Q/∂p)·u − Q·δu, δτ =
  ∂τ/∂θ δθ + ∂τ/∂θ̇ δθ̇ + ∂τ/∂p, and through an event as the loop takes it (:func:`external_work_after_event`);
  so it is exact for the computed solution up to the Newton tolerance (the loop takes each step's power from its
  last Newton evaluation, within that tolerance of the converged state). Both sums' terms and steps are
  csrc/work_accounts.c's, called here with the laws' values at the state and by the sensitivities' loop of steps in C
  with them tabulated (latdyn/analyses/sensitivities_in_loop.py ``_account_refusal``): one formula for both paths. Static paths record no external work
  (0): its derivative is 0.

Each energy and momentum of a row is held as its forms (:class:`_StateForms`): the gradient rows c_q, c_v on
all coordinates and the explicit derivative, the scatter of the kernels' element and body blocks (δx × f
as −skew(f) δx), so that the forward method contracts them with δq, δq̇ (:func:`probe_derivatives`) and the
discrete adjoint seeds its rows with them (:func:`probe_forms`).

What is refused (:func:`refusal`, exit 2 naming ``solve.sensitivities``; under ``sensitivity_method:
adjoint`` naming that key): the external work and the dissipated energy with cables and any energy or momentum beside a
reel (:func:`_cable_refusal`; a row's energies and momenta with cables are differentiated, :meth:`_StateForms._cables`,
and by a rigid link's ρA, ρIy, ρIz, :meth:`_StateForms._link_blocks`), energy and momentum probes with geometry
parameters — with guides they are
computed as without (the external work of a prescribed motion too: its drive's reaction is the reduced residual's row
of the prescribed coordinate, :func:`_drive_reactions`): a guided body is a dependent node of the links' reduction, its δq = J δq and
its rates' δv_dep = J δv + ∂(J v)/∂q δq (latdyn/analyses/link_sensitivities.py ``dependent_rates``, the generated
``prismatic_link_edge_rates_D_q``; a load on it csrc/work_accounts.c ``dependent_node_motion``), a guide's force and
its parameters' uses a hinge's applied torque on its slide; the
strain energy (and the total) by a compliant stop's exponent; the dissipated energy through events; the external work of a
transient run with events (a hinge's or a guide's) where a load, a torque, a guide's force, a spring or a prescribed
motion depends on t, with
controllers; both sums over the steps under the discrete adjoint.
"""
from __future__ import annotations

import ctypes

import re

import numpy as np

from latdyn.analyses.geometry_sensitivities import GEOMETRY_KEY
from latdyn.assembly.assembler import pack
from latdyn.assembly.native_model import NO_CONTACT, joint_contact_rows
from latdyn.errors import SceneError

__all__ = ["STATE_ENERGIES", "is_energy_or_momentum", "refusal", "probe_derivatives", "probe_forms", "external_work_step",
           "external_work_after_event"]

#: a hinge's or a guide's compliant stops' stiffness (the potential is linear in it) and exponent (refused)
_STOP_STIFFNESS = re.compile(r"^beams\.(?P<beam>.+)\.(?P<end>start|end)\.hinge\.contact\.stiffness$"
                             r"|^bodies\.(?P<body>[^.]+)\.guide\.contact\.stiffness$")
_STOP_EXPONENT = re.compile(r"^beams\.(?P<beam>.+)\.(?P<end>start|end)\.hinge\.contact\.exponent$"
                            r"|^bodies\.(?P<body>[^.]+)\.guide\.contact\.exponent$")
#: the recorded energies this module differentiates
_ENERGIES = ("kinetic", "strain", "potential", "external_work", "dissipated", "total")
#: the energies of a row's state alone (no account carried through the steps: the sensitivity loop takes them,
#: latdyn/analyses/sensitivities_in_loop.py)
STATE_ENERGIES = ("kinetic", "strain", "potential", "total")
#: the energies summed over the steps, and the carried key of their sensitivities
_ACCOUNTS = {"external_work": "external_work_sensitivity", "dissipated": "dissipated_sensitivity"}
#: the energies each probe sums (SCENE.md: total = kinetic + strain + potential)
_PARTS = {"kinetic": ("kinetic",), "strain": ("strain",), "potential": ("potential",),
          "total": ("kinetic", "strain", "potential")}


def is_energy_or_momentum(probe) -> bool:
    """Whether ``probe`` is an energy or a momentum probe (this module's)."""
    return probe.kind in ("energy", "momentum")


def refusal(scene, probe) -> SceneError | None:
    """The SceneError that refuses the sensitivities of the energy or momentum ``probe`` of ``scene``, or
    None where they are exact here (module docstring: naming ``solve.sensitivity_method`` under the
    adjoint, else ``solve.sensitivities``)."""
    quantity = probe.quantity
    what = f"probe {probe.name!r} ({probe.kind} {quantity})"
    if scene.solve.sensitivity_method == "adjoint" and quantity in ("external_work", "dissipated"):
        return SceneError(scene.file, "solve.sensitivity_method",
                          f"{what}: the discrete adjoint is seeded by a row's energies and momenta, not by the "
                          f"{'external work' if quantity == 'external_work' else 'dissipated energy'} (a sum over the "
                          "steps) yet; expected sensitivity_method: forward "
                          "(the default) here (docs/parameters.md, \"Energies and momenta\")")
    why = _why_not(scene, probe)
    if why is None:
        return None
    return SceneError(scene.file, "solve.sensitivities",
                      f"{what}: {why}; expected sensitivities only where they are exact (docs/parameters.md, "
                      "\"Energies and momenta\")")


def _why_not(scene, probe) -> str | None:
    """Why the energy or momentum ``probe``'s sensitivities are not exact here, or None."""
    quantity = probe.quantity
    if probe.kind == "energy" and quantity not in _ENERGIES:
        return f"the {quantity} energy is not differentiated (kinetic, strain, potential, external_work, dissipated, total are)"
    why = _cable_refusal(scene, probe)
    if why is not None:
        return why
    guided = [name for name, body in scene.bodies.items() if getattr(body, "guide", None) is not None]
    for name in _solve_names(scene):
        used = next((u for u in scene.parameters.depending_on(name) if GEOMETRY_KEY.match(u)), None)
        if used is not None:
            return (f"parameter {name!r} places the structure ({used}): energy and momentum sensitivities by "
                    "geometry parameters are not computed yet")
    if probe.kind == "energy" and quantity in ("strain", "total"):
        for name in _solve_names(scene):
            used = next((u for u in scene.parameters.depending_on(name) if _STOP_EXPONENT.match(u)), None)
            if used is not None:
                return (f"parameter {name!r} is the exponent of compliant stops ({used}): the stops' potential's "
                        "derivative by it is not computed yet (by their stiffness it is)")
    if probe.kind == "energy" and quantity == "dissipated" and scene.solve.analysis == "transient":
        for beam, which, hinge in scene.hinges:
            if hinge.friction is not None:   # its torque is not among _damper_torques' (a guide's: refused above)
                return (f"the dissipated energy of friction ({beam}.{which}.friction: the work of its torque) is not "
                        "differentiated yet")
            if hinge.lock_at is not None or hinge.limits is not None:
                return (f"the dissipated energy through the events of {beam}.{which} (lock_at, limits: a latch's or "
                        "an impact's loss, a compliant stop's damping) is not differentiated yet")
        for name in guided:   # a guide's damper c(s, ṡ, t) ṡ on its slide: a hinge's on its angle (_damper_torques)
            guide = scene.bodies[name].guide
            if guide.friction is not None:
                return (f"the dissipated energy of friction (bodies.{name}.guide.friction: the work of its force) is "
                        "not differentiated yet")
            if guide.lock_at is not None or guide.limits is not None:
                return (f"the dissipated energy through the events of bodies.{name}.guide (lock_at, limits: a latch's "
                        "or an impact's loss, a compliant stop's damping) is not differentiated yet")
    if probe.kind == "energy" and quantity == "external_work" and scene.solve.analysis == "transient":
        timed = _work_in_time(scene)
        if scene.solve.adaptive and timed is not None:
            return (f"the external work of an adaptive run with {timed}, which depends on t (the steps' ends move in "
                    "time with the parameters, and the power with them), is not differentiated yet")
        joints = [(f"{beam}.{which}", hinge) for beam, which, hinge in scene.hinges] + [
            (f"bodies.{name}.guide", scene.bodies[name].guide) for name in guided]   # a guide's events: a hinge's
        for joint, hinge in joints:
            if (hinge.lock_at is not None or hinge.limits is not None) and timed is not None:
                return (f"the external work through the events of {joint} (lock_at, limits) with {timed}, "
                        "which depends on t (the event's time moves the power there), is not differentiated yet")
        if getattr(scene, "controllers", None):
            return "the external work with controllers is not differentiated yet"
    return None


def _cable_refusal(scene, probe) -> str | None:
    """Why the energy or momentum ``probe`` is not differentiated beside ``scene``'s cables, or None: a row's energies
    and momenta are (:meth:`_StateForms._cables`: the elements' strain energy, their lumped masses' kinetic and
    potential energy and momenta as joint bodies' rows, by rhoA and the rest length too); the work accounts (external
    work, dissipated energy: a reel's work, a damped element's dissipation, summed over the steps) and a reel's strain
    energy (its rest length moves with t, and with an event's time) are not."""
    if not scene.cables:
        return None
    if probe.kind == "energy" and probe.quantity in _ACCOUNTS:
        return (f"the {probe.quantity.replace('_', ' ')} with cables (a reel's work, a damped element's dissipation) "
                "is not differentiated yet (a row's kinetic, strain, potential and total energy and its momenta are)")
    reel = next((name for name, cable in scene.cables.items() if not getattr(cable.rest_length, "is_constant", True)),
                None)
    if reel is not None:
        return (f"energy and momentum sensitivities with a cable whose rest length depends on t (cables.{reel}."
                "rest_length: its strain energy moves with t) are not computed yet; expected a constant rest length")
    return None


def _work_in_time(scene) -> str | None:
    """What of ``scene``'s external work depends on t explicitly — a load component, a hinge's torque or a
    spring that is not conservative, named — or None."""
    def timed(law):   # a HingeLaw names its variables; a TimeFunction is constant or not
        if law is None or isinstance(law, (int, float)):
            return False
        depends = getattr(law, "depends_on", None)
        return "t" in depends if depends is not None else not getattr(law, "is_constant", True)

    for i, load in enumerate(scene.loads):
        if any(timed(c) for c in (load.force or []) + (load.moment or [])):
            return f"loads[{i}]"
    for beam, which, hinge in scene.hinges:
        if timed(hinge.torque) or timed(hinge.stiffness):
            return f"the torque or spring of {beam}.{which}"
        if hinge.angle is not None:
            return f"the prescribed angle of {beam}.{which}"
    for name, body in scene.bodies.items():   # a guide's force or spring on its slide: a hinge's torque or spring
        guide = getattr(body, "guide", None)
        if guide is not None and (timed(guide.force) or timed(guide.stiffness)):
            return f"the force or spring of bodies.{name}.guide"
    moving = next((name for name, body in scene.bodies.items() if body.prescribed), None)
    return None if moving is None else f"the prescribed motion of bodies.{moving}"


def _solve_names(scene) -> list:
    """The parameters named by ``solve.sensitivities``."""
    return list(scene.solve.sensitivities or ())


# ---------------------------------------------------------------------- at a row
def probe_derivatives(owner, probe, state, dx, dpi, dtheta, rates, body_key) -> list:
    """The derivatives of the energy or momentum ``probe`` at ``state`` by every parameter of ``owner``
    (a :class:`latdyn.analyses.sensitivities.ParameterDerivatives`), along (δx, δπ, δθ) of its
    ``_by_parameter`` and the rates' (δv, δω, δθ̇) of ``_rates_by_parameter`` (``rates``; None on a static
    path, whose states are at rest): c_q·δq + c_v·δq̇ + ∂/∂p (:func:`probe_forms`); ``body_key`` the pattern of
    a body's parameter keys. The external work and the dissipated energy of a transient run are carried
    (:func:`external_work_step`): here only their values at the row, in ``owner.carried_accounts`` (0 on a static
    path, which records neither)."""
    k = len(owner.names)
    if probe.kind == "energy" and probe.quantity in _ACCOUNTS:   # sums over the steps, carried
        carried = getattr(owner, "carried_accounts", None) or {}
        return [float(v) for v in carried.get(_ACCOUNTS[probe.quantity], np.zeros(k))]
    forms = _StateForms.of(owner, body_key)
    by_q, by_rates, explicit = forms(state)
    row = _QUANTITIES.index(_quantity(probe)) if probe.kind == "momentum" else None
    rows = [row] if row is not None else [_QUANTITIES.index(part) for part in _PARTS[probe.quantity]]
    moved = explicit[rows].sum(axis=0) + by_q[rows].sum(axis=0) @ forms.on_all(dx, dpi, dtheta)
    if rates is not None:
        moved = moved + by_rates[rows].sum(axis=0) @ forms.on_all(*rates)
    return [float(v) for v in moved]


def probe_forms(owner, probe, state, body_key) -> tuple:
    """(c_q, c_v (n,) on the free coordinates, explicit (k,)): the energy or momentum ``probe``'s derivative at
    ``state`` is c_qᵀδq + c_vᵀδv + explicit — what the discrete adjoint seeds at its row
    (latdyn/analyses/adjoint_sensitivities.py ``output_forms``; the external work, a sum over the steps, is
    refused there: :func:`refusal`)."""
    forms = _StateForms.of(owner, body_key)
    by_q, by_rates, explicit = forms(state)
    rows = ([_QUANTITIES.index(_quantity(probe))] if probe.kind == "momentum"
            else [_QUANTITIES.index(part) for part in _PARTS[probe.quantity]])
    n = owner.model.n_dofs
    c_q, c_v = by_q[rows].sum(axis=0), by_rates[rows].sum(axis=0)
    if owner.model.links is None:
        return c_q[:n], c_v[:n], explicit[rows].sum(axis=0)
    # with rigid links or guides the forms on all coordinates through the forward method's own maps of the free
    # coordinates' columns (:func:`probe_derivatives` along ``_by_parameter`` and ``_rates_by_parameter``): a dependent
    # node moves by P δq, its rates by P δv + ∂(J v)/∂q δq — on the n unit columns, transposed onto the forms
    eye, zero = np.eye(n), np.zeros((n, n))
    moved = forms.on_all(*owner._by_parameter(eye, state))                     # noqa: SLF001
    turned = forms.on_all(*owner._rates_by_parameter(zero, eye, state))       # noqa: SLF001
    rated = forms.on_all(*owner._rates_by_parameter(eye, zero, state))        # noqa: SLF001
    return c_q @ moved + c_v @ turned, c_v @ rated, explicit[rows].sum(axis=0)


#: the rows of :class:`_StateForms`: the three energies and the momenta's components
_QUANTITIES = ("kinetic", "strain", "potential", "linear_x", "linear_y", "linear_z",
               "angular_x", "angular_y", "angular_z")


def _quantity(probe) -> str:
    """A momentum probe's row of :data:`_QUANTITIES`."""
    return f"{probe.quantity}_{probe.component}"


def _skew(x: np.ndarray) -> np.ndarray:
    """skew(x) (…, 3, 3), skew(x) y = x × y, of vectors x (…, 3)."""
    out = np.zeros(x.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -x[..., 2], x[..., 1], -x[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = x[..., 2], -x[..., 1], x[..., 0]
    return out


def _law_integral(law, rest: float, theta: float, moment: bool) -> float:
    """∫_{θ_r}^{θ} k(x) (x − θ_r)^moment dx of the hinge law ``law`` (its value at θ̇ = 0, t = 0) on the very
    quadrature latdyn_energies takes a law spring's potential with (csrc/evaluate.c
    ``latdyn_law_spring_integral``, the law called back from C), so that its derivatives by the law's
    parameters are those of the recorded value."""
    from latdyn.assembly.library import HINGE_LAW_VALUES, native_library

    def values(_, x, rate, t, out):
        try:   # an exception cannot cross the C frames: a law undefined at x (a real power of a negative
            # angle) is NaN there, as the compiled law the recorded energy takes gives NaN
            out[0], out[1], out[2] = law.value(x, 0.0, 0.0), 0.0, 0.0
        except (ArithmeticError, TypeError, ValueError):
            out[0] = out[1] = out[2] = float("nan")

    return float(native_library().latdyn_law_spring_integral(HINGE_LAW_VALUES(values), 0, rest, theta, int(moment)))


class _StateForms:
    """The energies' and momenta's derivative forms at a row (module docstring): for each of
    :data:`_QUANTITIES` its gradient by the coordinates c_q and by the rates c_v, on all coordinates
    (n_total + 1; a clamped end's dummy row and the constrained rows multiply zeros), and its explicit
    derivative by every parameter; the last row's kept, so that several probes of one row cost one evaluation."""

    @classmethod
    def of(cls, owner, body_key) -> "_StateForms":
        held = owner.__dict__.get("_energy_forms")
        if held is None:
            held = owner._energy_forms = cls(owner, body_key)
        return held

    def __init__(self, owner, body_key):
        self.owner, self.body_key = owner, body_key
        self.model, self.kernels = owner.model, owner.kernels
        self._last = None

    def on_all(self, linear, angular, joint) -> np.ndarray:
        """Node and hinge arrays (n_nodes, 3, k), (n_nodes, 3, k), (n_hinges, k) as columns on all coordinates
        (n_total + 1, k), the dummy row zero."""
        model = self.model
        full = np.zeros((model.n_total + 1, linear.shape[2]))
        full[model.node_dofs[:, 0:3]] = linear
        full[model.node_dofs[:, 3:6]] = angular
        if len(model.hinges):
            full[model.hinge_dofs] = joint
        full[model.n_total] = 0.0
        return full

    def __call__(self, state) -> tuple:
        """(c_q (9, n_total + 1), c_v (9, n_total + 1), explicit (9, k)) at ``state``."""
        model = self.model   # the forms are on the coordinates of the current numbering (a latch renumbers)
        key = (model.n_dofs, model.locked.tobytes(), state.t, state.x.tobytes(), state.T.tobytes(),
               state.theta.tobytes(), state.v.tobytes(), state.w.tobytes(), state.theta_dot.tobytes())
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        size = (len(_QUANTITIES), model.n_total + 1)
        forms = (np.zeros(size), np.zeros(size), np.zeros((len(_QUANTITIES), len(self.owner.names))))
        if len(model.element_dofs):
            self._elements(state, *forms)
        if len(model.body_nodes):
            self._bodies(state, *forms)
        if len(model.hinges):
            self._hinges(state, *forms)
        if model.cables is not None and len(model.cables):
            self._cables(state, forms[0], forms[2])
        self._last = (key, forms)
        return forms

    @staticmethod
    def _momenta(by_q, by_rates, dofs, f, moved_by_q, moved_by_rates, ends) -> None:
        """Add P and H's forms of items whose generalized momentum is f (m, w) with δf = (moved_by_rates)
        δq̇ + (moved_by_q) δq (m, w, w) into ``by_q``, ``by_rates`` on ``dofs`` (m, w): at each end
        (first slot, x (m, 3)) of ``ends``, P += f[first:first+3], H += x × f[first:first+3] + f[first+3:first+6],
        δH adds δx × f_translation = −skew(f_translation) δx."""
        for first, at in ends:
            turn = _skew(at)                                                               # (m, 3, 3)
            for c in range(3):
                lin, ang = 3 + c, 6 + c
                for target, moved in ((by_rates, moved_by_rates), (by_q, moved_by_q)):
                    np.add.at(target[lin], dofs, moved[:, first + c])
                    np.add.at(target[ang], dofs, np.einsum("mj,mjw->mw", turn[:, c], moved[:, first:first + 3])
                              + moved[:, first + 3 + c])
                np.add.at(by_q[ang], dofs[:, first:first + 3], -_skew(f[:, first:first + 3])[:, c])

    def _elements(self, state, by_q, by_rates, explicit) -> None:
        """The elements' forms (module docstring)."""
        model, kernels, owner = self.model, self.kernels, self.owner
        geometry, velocity, _ = owner.assembler.native().element_inputs(state)
        velocity = np.ascontiguousarray(velocity)
        sections = np.ascontiguousarray(model.element_sections)
        E, dofs = len(geometry), model.element_dofs
        gravity = np.ascontiguousarray(np.repeat(np.asarray(owner.assembler.gravity, float)[None], E, axis=0))
        # the generalized momentum f = M q̇ and its derivative by q at a = q̇: beam_inertia_tangent at zero velocity
        momentum, tangent = (np.asarray(a) for a in kernels.beam_inertia_tangent(
            geometry, np.zeros((E, 14)), velocity, sections, np.zeros((E, 3))))
        momentum, tangent = momentum.reshape(E, 14), tangent.reshape(E, 14, 14)
        mass = np.asarray(kernels.beam_mass_matrix(geometry, sections)[0]).reshape(E, 14, 14)
        np.add.at(by_q[1], dofs, np.asarray(kernels.beam_internal_force(geometry, sections)[0]).reshape(E, 14))
        np.add.at(by_q[2], dofs, -np.asarray(kernels.beam_gravity(geometry, sections, gravity)[0]).reshape(E, 14))
        np.add.at(by_rates[0], dofs, momentum)
        np.add.at(by_q[0], dofs, 0.5 * np.einsum("ei,eij->ej", velocity, tangent))
        self._momenta(by_q, by_rates, dofs, momentum, tangent, mass,
                      ((0, geometry[:, 0:3]), (7, geometry[:, 3:6])))
        blocks = owner._section_derivative_blocks(state)
        if blocks is None:
            return
        # the generated derivatives by the section values (each element's once), contracted with each use's
        # ∂(section block)/∂p: ∂[U, T, V]/∂s and ∂(M q̇)/∂s, the inertia force at zero velocity and a = q̇
        elements, column, rows = blocks
        on, use = np.unique(elements, return_inverse=True)
        at, rate, block = (np.ascontiguousarray(a[on]) for a in (geometry, velocity, sections))
        by_section = np.asarray(kernels.beam_energies_D_section(at, rate, block, gravity[on])[1]).reshape(-1, 3, 9)
        energies = np.einsum("eid,ed->ei", by_section[use], rows[:, 1:])
        np.add.at(explicit[1], column, energies[:, 0])
        np.add.at(explicit[0], column, energies[:, 1])
        np.add.at(explicit[2], column, energies[:, 2])
        by_section = np.asarray(kernels.beam_inertia_force_D_section(at, np.zeros_like(rate), rate, block,
                                                                     np.zeros((len(on), 3)))[1]).reshape(-1, 14, 9)
        moved = np.einsum("epd,ed->ep", by_section[use], rows[:, 1:])
        at = geometry[elements]
        for first, x in ((0, at[:, 0:3]), (7, at[:, 3:6])):
            lin = moved[:, first:first + 3]
            turned = np.cross(x, lin) + moved[:, first + 3:first + 6]
            for c in range(3):
                np.add.at(explicit[3 + c], column, lin[:, c])
                np.add.at(explicit[6 + c], column, turned[:, c])

    def _bodies(self, state, by_q, by_rates, explicit) -> None:
        """The joint bodies' forms (module docstring)."""
        model, kernels, owner = self.model, self.kernels, self.owner
        nodes = model.body_nodes
        B, dofs = len(nodes), model.node_dofs[nodes]
        frames = np.ascontiguousarray(state.T[nodes].reshape(B, 9))
        u = np.concatenate([state.v[nodes], state.w[nodes]], axis=1)                       # (B, 6)
        moving = np.ascontiguousarray(np.concatenate([np.zeros((B, 3)), u], axis=1))       # (ω, a, α) = (0, v, ω)
        block = np.ascontiguousarray(np.concatenate([model.body_mass[:, None], model.body_com,
                                                     model.body_inertia.reshape(B, 9)], axis=1))
        gravity = np.ascontiguousarray(np.repeat(np.asarray(owner.assembler.gravity, float)[None], B, axis=0))
        still, free_fall, held = np.zeros((B, 9)), np.zeros((B, 3)), {}

        def momentum_of(body_block):   # f = M_b u (B, 6), M_b the kernel's mass block
            return np.asarray(kernels.joint_body(frames, moving, np.ascontiguousarray(body_block), free_fall)[0]
                              ).reshape(B, 6)

        def by_com():                  # ∂f/∂c (B, 6, 3) of f = M_b u, computed once
            if "by_com" not in held:
                held["by_com"] = np.asarray(kernels.joint_body_D_com(frames, moving, block, free_fall)[0]
                                            ).reshape(B, 6, 3)
            return held["by_com"]

        def weight_of(body_block):     # Q = −[W; T c × W] (B, 6)
            return np.asarray(kernels.joint_body(frames, still, np.ascontiguousarray(body_block), gravity)[0]
                              ).reshape(B, 6)

        f = momentum_of(block)
        mass = np.asarray(kernels.joint_body(frames, moving, block, free_fall)[1]).reshape(B, 6, 6)
        stiffness = np.asarray(kernels.joint_body_inertia_stiffness(frames, moving, block, free_fall)[0]).reshape(B, 6, 6)
        weight = weight_of(block)
        np.add.at(by_rates[0], dofs, f)
        np.add.at(by_q[0], dofs, 0.5 * np.einsum("bi,bij->bj", u, stiffness))
        np.add.at(by_q[2], dofs, weight)
        self._momenta(by_q, by_rates, dofs, f, stiffness, mass, ((0, state.x[nodes]),))
        for key, laws in owner.derivatives.items():
            body = self.body_key.match(key)
            if not body:
                continue
            b = int(np.flatnonzero(nodes == model.body_node[body["body"]])[0])
            node = nodes[b]
            for column, law in laws.items():
                value = law.value(0.0, 0.0, state.t)
                changed = np.zeros_like(block)
                if body["mass"]:              # linear in m at a fixed c
                    changed[b, 0], changed[b, 1:4] = value, model.body_com[b]
                    moved = momentum_of(changed)[b]
                    explicit[2, column] += weight_of(changed)[b, 0:3] @ (state.x[node] + state.T[node] @ model.body_com[b])
                elif body["inertia"]:         # inertia[i] (the diagonal) or inertia[i][j] (symmetrised)
                    i, j = int(body["row"]), int(body["col"] if body["col"] is not None else body["row"])
                    step = np.zeros((3, 3))
                    step[i, j] += 0.5 * value
                    step[j, i] += 0.5 * value
                    changed[b, 1:4], changed[b, 4:13] = model.body_com[b], step.reshape(9)
                    moved = momentum_of(changed)[b]
                else:                         # by c: the generated ∂f/∂c along ∂c/∂p
                    along = np.zeros(3)
                    along[int(body["com"])] = value
                    moved = by_com()[b] @ along
                    explicit[2, column] += weight[b, 0:3] @ (state.T[node] @ along)
                explicit[0, column] += 0.5 * u[b] @ moved
                explicit[3:6, column] += moved[0:3]
                explicit[6:9, column] += np.cross(state.x[node], moved[0:3]) + moved[3:6]
        for b, node, column, changed in self._link_blocks(state, block):   # a rigid link's ρA, ρIy, ρIz
            moved = momentum_of(changed)[b]
            explicit[2, column] += weight_of(changed)[b, 0:3] @ (state.x[node] + state.T[node] @ model.body_com[b])
            explicit[0, column] += 0.5 * u[b] @ moved
            explicit[3:6, column] += moved[0:3]
            explicit[6:9, column] += np.cross(state.x[node], moved[0:3]) + moved[3:6]

    def _link_blocks(self, state, block: np.ndarray) -> list:
        """(body row, node, column, the joint bodies' block with that row's ∂(m, c, I)/∂p) of each use of a parameter
        by a rigid link's section ρA, ρIy or ρIz: its joint body's mass and inertia move, linear in them at the link's
        fixed centre of mass (latdyn/analyses/link_sensitivities.py ``link_section_block``, the generated
        ``rigid_link_inertia_D_section``, as ``add_link_section_forces`` takes ∂r/∂p), so its kinetic and potential
        energy and momenta move as a body's by its mass and inertia (:meth:`_bodies`)."""
        from latdyn.analyses.link_sensitivities import link_section_block, link_section_uses

        model = self.model
        if model.links is None:
            return []
        out = []
        for beam, b, node, value, laws in link_section_uses(self.owner):
            for column, law in laws.items():
                changed = np.zeros_like(block)
                changed[b] = link_section_block(self.kernels, beam, value, law.value(0.0, 0.0, state.t),
                                                model.body_com[b])[0]
                out.append((b, node, column, changed))
        return out

    def _hinges(self, state, by_q, by_rates, explicit) -> None:
        """The hinge springs' potential, as latdyn_energies counts it: ½ k s² of a constant k, and
        ∫_{θ_r}^{θ} k(x)(x − θ_r) dx of a conservative law k(θ) (a law in θ̇ or t is not in the strain energy:
        its work is external). ∂/∂θ = k s, the ``hinge_force`` kernel's spring torque; by the parameter, ½ (∂k/∂p) s²
        and −k s ∂θ_r/∂p, or of a law ∫ (∂k/∂p)(x)(x − θ_r) dx and −∫ k(x) dx ∂θ_r/∂p on the quadrature of
        latdyn_energies (:func:`_law_integral`)."""
        model, owner = self.model, self.owner
        H = len(model.hinges)
        rest = np.array([h.rest_angle for h in model.hinges], float)
        counted = np.array([h.conservative_spring for h in model.hinges], bool)
        stiffness = np.array([h.stiffness.value(float(state.theta[j]), 0.0, 0.0) if counted[j] else 0.0
                              for j, h in enumerate(model.hinges)], float)
        spring = self._spring_torques(state.theta, rest, stiffness)                         # k s
        np.add.at(by_q[1], model.hinge_dofs, spring)
        s = np.asarray(state.theta, float) - rest
        self._stops(state, by_q, explicit)
        for key, laws in owner.derivatives.items():
            _, hinge = owner._key_kinds(key)
            if not hinge or hinge["law"] not in ("stiffness", "rest_angle"):   # a guide's: its slide's spring
                continue
            j = model.hinge_index(hinge["beam"], hinge["end"])
            if not counted[j]:
                continue
            law_k, theta = model.hinges[j].stiffness, float(state.theta[j])
            for column, law in laws.items():
                if law_k.is_constant:
                    value = law.value(theta, 0.0, 0.0)
                    if hinge["law"] == "stiffness":   # ½ (∂k/∂p) s²: the spring torque of ∂k/∂p, times ½ s
                        by = np.zeros(H)
                        by[j] = value
                        explicit[1, column] += 0.5 * s[j] * self._spring_torques(state.theta, rest, by)[j]
                    else:                              # ∂(½ k s²)/∂θ_r = −k s
                        explicit[1, column] -= spring[j] * value
                elif hinge["law"] == "stiffness":      # ∫ (∂k/∂p)(x)(x − θ_r) dx
                    explicit[1, column] += _law_integral(law, rest[j], theta, moment=True)
                else:                                  # −∫ k(x) dx ∂θ_r/∂p (the integrand vanishes at x = θ_r)
                    explicit[1, column] -= law.value(theta, 0.0, 0.0) * _law_integral(law_k, rest[j], theta,
                                                                                       moment=False)

    def _stops(self, state, by_q, explicit) -> None:
        """The compliant stops' potential k (⟨δ_u⟩ⁿ⁺¹ + ⟨δ_l⟩ⁿ⁺¹)/(n + 1) (``hinge_force``'s contact energy):
        ∂/∂θ = k (⟨δ_u⟩ⁿ − ⟨δ_l⟩ⁿ), the kernel's contact force at θ̇ = 0 (its damping then vanishes); linear in
        the stops' stiffness k: ∂/∂p the kernel's contact energy with k replaced by ∂k/∂p (the exponent is
        refused, :func:`refusal`; the damping does not enter)."""
        model = self.model
        stops = [j for j, h in enumerate(model.hinges) if h.contact is not None]
        if not stops:
            return
        rows = np.ascontiguousarray(joint_contact_rows([model.hinges[j] for j in stops]))
        rows[:, 5:11] = NO_CONTACT[5:11]   # no friction (refused with sensitivities)
        at = np.column_stack([np.asarray(state.theta, float)[stops], np.zeros(len(stops)),
                              [model.hinges[j].rest_angle for j in stops], np.zeros(len(stops))])
        nothing = np.zeros((len(stops), 9))
        force = np.asarray(self.kernels.hinge_force(np.ascontiguousarray(at), nothing, rows)[0]).reshape(-1)
        np.add.at(by_q[1], model.hinge_dofs[stops], force)
        for key, laws in self.owner.derivatives.items():
            stop = _STOP_STIFFNESS.match(key)
            if not stop:
                continue
            joint = (stop["beam"], stop["end"]) if stop["beam"] is not None else (stop["body"], "guide")
            i = stops.index(model.hinge_index(*joint))
            for column, law in laws.items():
                changed = rows[i:i + 1].copy()
                changed[0, 2] = law.value(0.0, 0.0, state.t)
                explicit[1, column] += float(np.asarray(self.kernels.hinge_force(
                    np.ascontiguousarray(at[i:i + 1]), nothing[:1], changed)[6]).reshape(-1)[0])

    def _cables(self, state, by_q, explicit) -> None:
        """The cables' forms: the strain energy U = ½ EA (ℓ − L0)²/L0 of each element latdyn_energies counts (held
        taut, or stretched: csrc/evaluate.c ``cables``), ∂U/∂q = N_el ∂ℓ/∂q, the generated ``cable_force``'s residual rows
        at c = 0,
        ∂U/∂p = U/EA ∂EA/∂p + ∂U/∂L0 share ∂L/∂p (``cable_strain_energy``, ``reel_force`` of the same kernel); a cable's
        lumped point masses (½ ρA L(0)/elements at each end of each element, joint bodies' rows appended by
        latdyn/model/cables.py) are in :meth:`_bodies`' forms already, their masses' ∂m/∂p = ½ (∂ρA/∂p L(0) + ρA
        ∂L(0)/∂p)/elements here, as a body's mass (kinetic, potential, momenta: linear in m at a fixed centre of
        mass, the end's offset)."""
        from latdyn.analyses.parameter_keys import CABLE_KEY
        from latdyn.analyses.probe_derivatives import _cable_terms

        model, kernels, owner = self.model, self.kernels, self.owner
        terms = _cable_terms(owner)
        cables = model.cables
        taut = terms.taut(state)
        uses = [(CABLE_KEY.match(key), laws) for key, laws in owner.derivatives.items() if CABLE_KEY.match(key)]
        for e in range(len(cables)):
            geometry, velocity, section = terms.inputs(state, e, c=0.0)
            out = kernels.cable_force(*(np.ascontiguousarray(a[None]) for a in (geometry, velocity, section)))
            stretch = float(np.asarray(out[3]).reshape(5)[2])
            if not (taut[e] or stretch > 0.0):   # slack: latdyn_energies counts no strain energy
                continue
            a, b = (int(n) for n in cables.nodes[e])
            dofs = np.concatenate([model.node_dofs[a], model.node_dofs[b]])
            np.add.at(by_q[1], dofs, np.asarray(out[0]).reshape(12))   # the residual's rows: ∂U/∂q at c = 0
            energy, by_rest = float(np.asarray(out[4]).reshape(-1)[0]), float(np.asarray(out[5]).reshape(-1)[0])
            for match, laws in uses:
                if cables.names.index(match["cable"]) != int(cables.cable[e]):
                    continue
                for column, law in laws.items():
                    value = law.value(0.0, 0.0, state.t)
                    if match["value"] == "EA":
                        explicit[1, column] += energy / cables.EA[e] * value
                    elif match["value"] == "rest_length":
                        explicit[1, column] += by_rest * cables.share[e] * value
        self._cable_masses(state, explicit, uses)

    def _cable_masses(self, state, explicit, uses) -> None:
        """∂m/∂p of the cables' lumped point masses (:meth:`_cables`) into ``explicit``: each as a body's mass."""
        from latdyn.analyses.probe_derivatives import _cable_terms

        model, kernels = self.model, self.kernels
        rows = _cable_terms(self.owner).mass_rows
        masses = [(match, laws) for match, laws in uses if match["value"] in ("rhoA", "rest_length")]
        if not rows or not masses:
            return
        nodes = model.body_nodes
        scene_cables = list(self.owner.scene.cables.values())
        for match, laws in masses:
            k = model.cables.names.index(match["cable"])
            if k not in rows:
                continue
            cable = scene_cables[k]
            for column, law in laws.items():
                value = law.value(0.0, 0.0, 0.0)
                rate = (value * cable.rest_length.value(0.0) if match["value"] == "rhoA"
                        else cable.rhoA * value) / cable.elements
                for b in rows[k]:
                    node = nodes[b]
                    frame = np.ascontiguousarray(state.T[node].reshape(1, 9))
                    u = np.concatenate([state.v[node], state.w[node]])
                    changed = np.zeros((1, 13))
                    changed[0, 0], changed[0, 1:4] = 0.5 * rate, model.body_com[b]
                    moving = np.ascontiguousarray(np.concatenate([np.zeros(3), u])[None])
                    moved = np.asarray(kernels.joint_body(frame, moving, changed, np.zeros((1, 3)))[0]).reshape(6)
                    gravity = np.asarray(self.owner.assembler.gravity, float)[None]
                    weight = np.asarray(kernels.joint_body(frame, np.zeros((1, 9)), changed,
                                                           np.ascontiguousarray(gravity))[0]).reshape(6)
                    explicit[2, column] += weight[0:3] @ (state.x[node] + state.T[node] @ model.body_com[b])
                    explicit[0, column] += 0.5 * u @ moved
                    explicit[3:6, column] += moved[0:3]
                    explicit[6:9, column] += np.cross(state.x[node], moved[0:3]) + moved[3:6]

    def _spring_torques(self, theta, rest, stiffness) -> np.ndarray:
        """k s of every hinge (the generated ``hinge_force``'s spring torque, without contact)."""
        H = len(rest)
        at = np.column_stack([np.asarray(theta, float), np.zeros(H), rest, np.zeros(H)])
        laws = np.zeros((H, 9))
        laws[:, 0] = stiffness
        return np.asarray(self.kernels.hinge_force(np.ascontiguousarray(at), laws,
                                                   np.ascontiguousarray(np.tile(NO_CONTACT, (H, 1))))[3]).reshape(H)


# ---------------------------------------------------------------------- the external work, carried
def external_work_step(owner, before: dict, after: dict, old, new, h: float) -> dict:
    """``after`` (the carried sensitivities at the end of the accepted step ``old`` → ``new`` of size ``h``)
    with the external work's sensitivity carried on by the loop's own quadrature (module docstring):
    δW_{n+1} = δW_n + ½ h (δP_n + δP_{n+1}) + ½ δh (P_n + P_{n+1}) + Σ_j ½ (δτ_n + δτ_{n+1}) Δθ
    + ½ (τ_n + τ_{n+1}) (δθ_{n+1} − δθ_n) + Σ_d ½ (δr_n + δr_{n+1}) Δq_d, ``before`` the carried sensitivities at ``old``. Nothing without
    an external-work probe."""
    after = _dissipated_step(owner, before, after, old, new)
    if not any(p.kind == "energy" and p.quantity == "external_work" for p in owner.probes):
        return after
    k = len(owner.names)
    work = np.array(before.get("external_work_sensitivity", np.zeros(k)), float)
    held = before.get("external_work_terms")   # the last step's end: this step's start
    power_old, dpower_old, torque_old, dtorque_old, dtheta_old = held if held is not None else _power(owner, old, before)
    terms = _power(owner, new, after)
    power_new, dpower_new, torque_new, dtorque_new, dtheta_new = terms
    arrays = [np.ascontiguousarray(a, np.float64) for a in (
        after["dh"], dpower_old, dpower_new, old.theta, new.theta, torque_old, dtorque_old, dtheta_old, torque_new,
        dtorque_new, dtheta_new)]
    dh, dpower_old, dpower_new, *rest = (a.ctypes.data for a in arrays)
    _work_accounts().latdyn_external_work_increment(k, len(owner.model.hinges), float(h), dh, float(power_old),
                                                    dpower_old, float(power_new), dpower_new, *rest, work.ctypes.data)
    held = before.get("external_work_drive")
    rows_old, dreaction_old = held if held is not None else _drive_reactions(owner, old, before)
    drive = _drive_reactions(owner, new, after)
    increment = np.zeros(0)
    if len(drive[0]):   # ½ Σ_d Δq_d (δr_d,n + δr_d,n+1): csrc/drive_sensitivities.c, the loop's too
        increment, dreaction_new = (np.ascontiguousarray(a, np.float64) for a in (
            _drive_increments(owner.model, owner.assembler.kernels, old, new, drive[0]), drive[1]))
        dreaction_old = np.ascontiguousarray(dreaction_old, np.float64)
        _work_accounts().latdyn_drive_work_sensitivity(len(increment), k, increment.ctypes.data,
                                                       dreaction_old.ctypes.data, dreaction_new.ctypes.data,
                                                       work.ctypes.data)
    return {**after, "external_work_sensitivity": work, "external_work_terms": terms, "external_work_drive": drive,
            "external_work_drive_increment": increment}


def _dissipated_step(owner, before: dict, after: dict, old, new) -> dict:
    """``after`` with the dissipated energy's sensitivity carried on by the loop's quadrature
    (latdyn/timeloop/progress.py hinge_work): D_{n+1} = D_n + Σ_j ½ (f_n + f_{n+1}) Δθ of the dampers' torques
    f = c(θ, θ̇, t) θ̇ (``hinge_force``'s damper torque without compliant stops and friction, which are refused), so
    δD_{n+1} = δD_n + Σ_j ½ (δf_n + δf_{n+1}) Δθ + ½ (f_n + f_{n+1}) (δθ_{n+1} − δθ_n) with
    δf = θ̇ ∂c/∂θ δθ + (c + θ̇ ∂c/∂θ̇) δθ̇ + θ̇ ∂c/∂p: csrc/work_accounts.c ``latdyn_dissipated_step``, which the loop
    of steps calls too (latdyn/analyses/sensitivities_in_loop.py). Nothing without a dissipated-energy probe."""
    if not any(p.kind == "energy" and p.quantity == "dissipated" for p in owner.probes):
        return after
    k = len(owner.names)
    held = before.get("dissipated_terms")
    torque_old, dtorque_old, dtheta_old = held if held is not None else _damper_torques(owner, old, before)
    terms = _damper_torques(owner, new, after)
    torque_new, dtorque_new, dtheta_new = terms
    dissipated = np.array(before.get("dissipated_sensitivity", np.zeros(k)), float)
    arrays = [np.ascontiguousarray(a, np.float64) for a in (old.theta, new.theta, torque_old, dtorque_old, dtheta_old,
                                                             torque_new, dtorque_new, dtheta_new)]
    _work_accounts().latdyn_dissipated_step(len(owner.model.hinges), k, *(a.ctypes.data for a in arrays),
                                            dissipated.ctypes.data)
    return {**after, "dissipated_sensitivity": dissipated, "dissipated_terms": terms}


def _work_accounts():
    """The native library whose csrc/work_accounts.c carries the dissipated energy's sensitivity (both paths')."""
    from latdyn.assembly.library import native_library

    return native_library()


def damping_uses(owner) -> list:
    """(hinge, column, derivative law) of every damping parameter's use, in the order of ``owner.derivatives``."""
    model, uses = owner.model, []
    for key, laws in owner.derivatives.items():
        _, hinge = owner._key_kinds(key)   # noqa: SLF001
        if hinge and hinge["law"] == "damping":
            j = model.hinge_index(hinge["beam"], hinge["end"])
            uses += [(j, column, law) for column, law in laws.items()]
    return uses


def _damper_torques(owner, state, carried: dict) -> tuple:
    """(f (hinges,), δf (hinges, k), δθ (hinges, k)): the dampers' torques c θ̇ at ``state`` and their derivatives
    along ``carried``'s δq, δv (:func:`_dissipated_step`; csrc/work_accounts.c ``latdyn_damper_torques`` with the
    damping laws' (c, ∂c/∂θ, ∂c/∂θ̇) and the damping parameters' ∂c/∂p at the state)."""
    model, k = owner.model, len(owner.names)
    _, _, dtheta = owner._by_parameter(carried["dq"], state)
    _, _, dtheta_dot = owner._rates_by_parameter(carried["dv"], carried["dq"], state)
    H = len(model.hinges)
    laws = np.zeros((H, 3))
    values = _law_values(owner)
    for j, hinge in enumerate(model.hinges):
        laws[j] = values(hinge.damping, float(state.theta[j]), float(state.theta_dot[j]), state.t)
    uses = damping_uses(owner)
    hinge_of = np.array([j for j, _, _ in uses] or [0], np.int64)
    column = np.array([c for _, c, _ in uses] or [0], np.int64)
    value = np.array([values(law, float(state.theta[j]), float(state.theta_dot[j]), state.t)[0] for j, _, law in uses]
                     or [0.0], float)
    torque, dtorque = np.zeros(H), np.zeros((H, k))
    arrays = [np.ascontiguousarray(a, np.float64) for a in (state.theta_dot, laws, dtheta, dtheta_dot)]
    _work_accounts().latdyn_damper_torques(H, k, *(a.ctypes.data for a in arrays), len(uses), hinge_of.ctypes.data,
                                           column.ctypes.data, value.ctypes.data, torque.ctypes.data,
                                           dtorque.ctypes.data)
    return torque, dtorque, dtheta


def external_work_after_event(owner, before: dict, after: dict, new, end_after_events: bool) -> dict:
    """``after`` (the carried sensitivities restarted after the events that ended the last step at ``new``;
    ``before``: those of that step's end, before the jump) with the external work's terms taken after the jump,
    as the loop takes them (latdyn/timeloop/loop.py ``_accept``): the next step starts from the power and torques
    after the jump; where the loop evaluated the step's end again after the events (``end_after_events``, which
    it says: a latch, a stick, a release, their renumbering changing its reactions' count, and a rest on a stop),
    the step's own trapezoid took the power after the jump, ½ h (P_n + P⁺_{n+1}): its sensitivity moves by
    ½ h (δP⁺ − δP⁻) + ½ δh (P⁺ − P⁻). Nothing without an external-work probe. At a stick and a release
    too (without the correction the gimbal's work by F_c was 3.6e-3 of itself off Richardson differences from its second
    stick on, 1.2e-9 with it at Newton's tolerance 1e-12, tests/test_sensitivities_linked_sticks.py; on the braked
    panel of tests/test_sensitivities_sticks_beside.py, whose power hardly jumps at its sticks, 3.7e-8 either way).
    The re-evaluation gives the step's end its prescribed motions' reactions after the jump too (loop.py
    ``drive_work`` takes them from it), so the drive's term moves by ½ Σ_d Δq_d (δr⁺_d − δr⁻_d), Δq_d the step's
    (``external_work_drive_increment``; without it a prescribed hinge beside sticks was 4.9e-4 of the work's largest
    off, 4.0e-8 with it, tests/test_sensitivities_work_at_events.py)."""
    if "external_work_terms" not in before:
        return after
    terms = _power(owner, new, after)
    work = before["external_work_sensitivity"]
    drive = _drive_reactions(owner, new, after)
    if end_after_events:
        held = before["external_work_terms"]
        work = work + 0.5 * before["h"] * (terms[1] - held[1]) + 0.5 * np.asarray(before["dh"]) * (terms[0] - held[0])
        if len(drive[0]):   # the drive's reactions at the step's end after the jump too (loop.py drive_work):
            # ½ Σ_d Δq_d (δr⁺_d − δr⁻_d), the prescribed coordinates in the same order in both numberings
            work = work + 0.5 * before["external_work_drive_increment"] @ (drive[1] - before["external_work_drive"][1])
    return {**after, "external_work_sensitivity": work, "external_work_terms": terms, "external_work_drive": drive}


def _drive_reactions(owner, state, carried: dict) -> tuple:
    """(rows, δr_d (d, k)): the derivatives of the reactions that impose the prescribed motions on the prescribed
    coordinates d (a prescribed body's six, a prescribed hinge's or guide's one; rows in the numbering at ``state``),
    δr_d = ∂r_d/∂p + K_d δq + C_d δv + M_d δv̇ with K, C, M the exact rows on d of one evaluation (as
    :meth:`latdyn.assembly.assembler.Assembler.exact_rows` scatters them) and their free columns: csrc/drive_sensitivities.c
    ``latdyn_drive_reaction_rates``, which the loop of steps calls too. With rigid links or guides r_d is the reduced
    residual's row of d, with the dependent nodes' wrenches through J (its derivative:
    :func:`latdyn.analyses.joint_force_sensitivities.reaction_forms_through_links`; the loop refuses these runs). The drive's work over a step is
    ½(r_n + r_{n+1}) Δq_d (latdyn/timeloop/progress.py drive_work), Δq_d the prescribed law's, no parameter's: its
    derivative ½(δr_n + δr_{n+1}) Δq_d (:func:`external_work_step`)."""
    from latdyn.analyses.prescribed_rates import coupling_entries, load_block_columns

    model, assembler = owner.model, owner.assembler
    k = len(owner.names)
    rows = model.prescribed_coordinates()
    if len(rows) == 0:
        return rows, np.zeros((0, k))
    if model.links is not None:   # the reduced residual's rows of the prescribed coordinates, with the dependent ones'
        from latdyn.analyses.joint_force_sensitivities import reaction_forms_through_links   # through J

        forms = reaction_forms_through_links(owner, state, rows)
        return rows, np.array([c_q @ carried["dq"] + c_v @ carried["dv"] + c_vdot @ carried["dvdot"] + explicit
                               for c_q, c_v, c_vdot, explicit in forms]).reshape(len(rows), k)
    moved = np.ascontiguousarray(owner.residual_derivatives(state, 1.0, inertia=True, on_all=True)[rows], np.float64)
    native = assembler.native(True)
    assembler.complete_links(state)
    native.evaluate(state, True, 1.0, True, True)
    where = np.full(model.n_total + 1, -1, np.int64)
    where[rows] = np.arange(len(rows))
    body = (np.ascontiguousarray(assembler.joint_body_inertia_stiffness(state, 1.0), np.float64)
            if len(model.body_nodes) else None)
    columns, couplings = load_block_columns(assembler), coupling_entries(assembler)
    rates = [np.ascontiguousarray(carried[name], np.float64) for name in ("dq", "dv", "dvdot")]
    native.library.latdyn_drive_reaction_rates(native.model_ref, native.work_ref, where.ctypes.data, k,
                                               None if body is None else body.ctypes.data, columns.ctypes.data,
                                               None if couplings is None else couplings.ctypes.data,
                                               *(a.ctypes.data for a in rates), moved.ctypes.data)
    return rows, moved


def _drive_increments(model, kernels, old, new, rows: np.ndarray) -> np.ndarray:
    """Δq on ``rows`` over the step ``old`` → ``new``: Δx, the rotation vector of T_{n+1} T_nᵀ (the generated
    so3_log_increment of ``kernels``), Δθ (latdyn/timeloop/progress.py drive_work)."""
    from latdyn.numerics.so3 import rotation_increment

    return pack(model, new.x - old.x, rotation_increment(old.T, new.T, kernels),
                np.asarray(new.theta, float) - np.asarray(old.theta, float))[rows]


def _power(owner, state, carried: dict):
    """(P, δP (k,), τ (hinges,), δτ (hinges, k), δθ (hinges, k)) at ``state`` along ``carried``'s δq, δv:
    the point loads' power P = −Q·u and its derivative, the hinges' applied torques and theirs (csrc/work_accounts.c
    ``latdyn_load_power`` and ``latdyn_applied_torques`` on the kernels' outputs and the laws' values at the state,
    which the loop of steps calls too)."""
    model, kernels = owner.model, owner.kernels
    k = len(owner.names)
    native = _work_accounts()
    dx, dpi, dtheta = owner._by_parameter(carried["dq"], state)
    dv, dw, dtheta_dot = owner._rates_by_parameter(carried["dv"], carried["dq"], state)
    power, dpower = 0.0, np.zeros(k)
    loads = owner.scene.loads
    rows = lambda a: np.ascontiguousarray(a, np.float64)   # noqa: E731
    if len(loads):
        node, offset, frame = owner._load_points()
        L = len(loads)

        def value(law):
            return float(law.value(state.t)) if hasattr(law, "value") else float(law)

        values = np.array([[value(c) for c in (load.force or [0.0] * 3)] + [value(c) for c in (load.moment or [0.0] * 3)]
                           for load in loads], float)
        follower = frame >= 0
        frames = np.where(follower[:, None, None], state.T[np.maximum(frame, 0)], np.eye(3))
        u = rows(np.concatenate([state.v[node], state.w[node]], axis=1))                    # (L, 6)
        force, load_power, by_node, by_frame = (rows(a) for a in kernels.point_load(
            np.ascontiguousarray(state.T[node].reshape(L, 9)), np.ascontiguousarray(offset), values,
            np.ascontiguousarray(frames.reshape(L, 9)), u))
        du = rows(np.concatenate([dv[node], dw[node]], axis=1))                             # (L, 6, k)
        dpi_node, dpi_frame = rows(dpi[node]), rows(np.where(follower[:, None, None], dpi[np.maximum(frame, 0)], 0.0))
        if model.links is not None:   # a node or frame that follows the links: the C the loop of steps calls
            _dependent_loads(owner, state, carried, node, frame, du, dpi_node, dpi_frame)
        pairs, columns, place, laws = owner._load_layout()
        pair_force = np.zeros((1, 6))
        if len(pairs):   # ∂Q/∂p: the kernel with the values' derivatives (linear in them)
            moved = np.zeros((len(pairs), 6))
            moved[place] = np.array([owner._of_time(law, state.t) for law in laws])
            pair_force = rows(owner._load_forces(state, pairs, moved)[1])
        ints = lambda a: np.ascontiguousarray(a, np.int64).reshape(-1) if len(a) else np.zeros(1, np.int64)  # noqa: E731
        frame_of, pair_load, pair_column = ints(frame), ints(pairs), ints(columns)
        power = native.latdyn_load_power(L, k, force.ctypes.data, load_power.ctypes.data, u.ctypes.data,
                                         by_node.ctypes.data, by_frame.ctypes.data, frame_of.ctypes.data,
                                         dpi_node.ctypes.data, dpi_frame.ctypes.data, du.ctypes.data, len(pairs),
                                         pair_load.ctypes.data, pair_column.ctypes.data, pair_force.ctypes.data,
                                         dpower.ctypes.data)
    H = len(model.hinges)
    torque, dtorque = np.zeros(H), np.zeros((H, k))
    values = _law_values(owner)
    laws = applied_torque_laws(model, state, values)
    uses = [(j, column, kind, values(law, float(state.theta[j]), float(state.theta_dot[j]), state.t)[0])
            for j, column, kind, law in applied_torque_uses(owner)]
    ints = lambda values: np.array(values or [0], np.int64)   # noqa: E731
    use_hinge, use_column, use_kind = (ints([use[i] for use in uses]) for i in range(3))
    use_value = np.array([use[3] for use in uses] or [0.0], float)
    arrays = [rows(a) for a in (state.theta, laws, dtheta, dtheta_dot)]
    native.latdyn_applied_torques(H, k, *(a.ctypes.data for a in arrays), len(uses), use_hinge.ctypes.data,
                                  use_column.ctypes.data, use_kind.ctypes.data, use_value.ctypes.data,
                                  torque.ctypes.data, dtorque.ctypes.data)
    return power, dpower, torque, dtorque, dtheta


def _dependent_loads(owner, state, carried: dict, node, frame, du, dpi_node, dpi_frame) -> None:
    """δu and δπ (in ``du``, ``dpi_node``, ``dpi_frame``) of the loads whose node, or whose follower frame's node,
    follows rigid links or guides: δq_dep = J δq, δv_dep = J δv + ∂(J v)/∂q δq from the links' buffers at ``state``
    (csrc/work_accounts.c ``latdyn_dependent_node_motion``, the function the loop of steps calls in
    ``loads_power_at``)."""
    model, native = owner.model, owner.assembler.native(True)
    free, k = set(model.free_nodes.tolist()), du.shape[2]
    slots = native.links.slot_of_node
    dq, dv = (np.ascontiguousarray(carried[name], np.float64) for name in ("dq", "dv"))
    mq, mv = np.zeros((6, k)), np.zeros((6, k))
    configuration = native.configuration(state)
    for l, i in enumerate(node):
        for at, is_frame in ((int(i), False), (int(frame[l]), True)):
            if at < 0 or at in free:
                continue
            native.library.latdyn_dependent_node_motion(native.model_ref, ctypes.byref(configuration), slots[at], k,
                                                        dq.ctypes.data, dv.ctypes.data, mq.ctypes.data, mv.ctypes.data)
            if is_frame:
                dpi_frame[l] = mq[3:6]
            else:
                du[l], dpi_node[l] = mv, mq[3:6]


#: a parameter's use in a hinge's applied torque (csrc/work_accounts.c applied_torques): its kind's number
_TORQUE_USE = {"torque": 0, "stiffness": 1, "rest_angle": 2}


def applied_torque_laws(model, state, values=None) -> np.ndarray:
    """(hinges, 8): each hinge's (τ, ∂τ/∂θ, ∂τ/∂θ̇, 1 where its spring is not conservative (its work external) else 0,
    k, ∂k/∂θ, ∂k/∂θ̇ (0 for a conservative spring), θ_r) at ``state`` (csrc/work_accounts.c applied_torques);
    ``values(law, θ, θ̇, t)``: a law's (f, ∂f/∂θ, ∂f/∂θ̇) (:func:`_law_values`; None: the law's own)."""
    values = values or _own_values
    laws = np.zeros((len(model.hinges), 8))
    for j, hinge in enumerate(model.hinges):
        theta, rate, t = float(state.theta[j]), float(state.theta_dot[j]), state.t
        if hinge.torque is not None:
            laws[j, 0:3] = values(hinge.torque, theta, rate, t)
        if not hinge.conservative_spring:   # (a conservative spring does no external work: its k is not read)
            laws[j, 3] = 1.0
            laws[j, 4:7] = values(hinge.stiffness, theta, rate, t)
        laws[j, 7] = hinge.rest_angle
    return laws


def _own_values(law, theta: float, rate: float, t: float) -> tuple:
    """(f, ∂f/∂θ, ∂f/∂θ̇) of a hinge law at (θ, θ̇, t), the law object's own."""
    return law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)


def account_laws(owner):
    """The work accounts' laws of θ, θ̇ or an input, compiled (:class:`latdyn.analyses.derivative_laws.DerivativeLaws`,
    as the step's hinge laws and the parameters' derivative laws of the state are): the dampers' laws and the damping
    parameters' derivative laws for the dissipated energy; the applied torques, the stiffness of a spring that is not
    conservative and the torque's, stiffness's and rest angle's parameters' derivative laws for the external work. Their
    (f, ∂f/∂θ, ∂f/∂θ̇) is one C function that the per-step Python path (:func:`_law_values`) and the loop of steps
    (csrc/work_accounts.c ``work_accounts_step``, at each hinge's θ, θ̇, t) both call. None where the accounts name no
    such law, without C kernels, or where they do not compile (the laws' own values then; the loop refuses the run:
    latdyn/analyses/sensitivities_in_loop.py ``_account_refusal``). Once a run."""
    held = owner.__dict__.get("_account_laws")
    if held is not None:
        return held[0]
    from latdyn.analyses.derivative_laws import DerivativeLaws, of_the_state

    compiled = None
    quantities = {p.quantity for p in owner.probes if p.kind == "energy"} & {"dissipated", "external_work"}
    laws: list = []
    if "dissipated" in quantities:
        laws += [hinge.damping for hinge in owner.model.hinges] + [law for *_, law in damping_uses(owner)]
    if "external_work" in quantities:
        laws += ([hinge.torque for hinge in owner.model.hinges if hinge.torque is not None]
                 + [hinge.stiffness for hinge in owner.model.hinges if not hinge.conservative_spring]
                 + [law for *_, law in applied_torque_uses(owner)])
    laws = list({id(law): law for law in laws if of_the_state(law)}.values())
    if laws and getattr(owner.kernels, "backend", None) == "c":
        compiled = DerivativeLaws.of_laws(owner.scene, laws)
    owner.__dict__["_account_laws"] = (compiled,)
    return compiled


def _law_values(owner):
    """``values(law, θ, θ̇, t)``: a work account's law's (f, ∂f/∂θ, ∂f/∂θ̇), the compiled law's where it is one of
    :func:`account_laws` (the C the loop of steps calls), else the law object's."""
    compiled = account_laws(owner)
    return compiled.values if compiled is not None else _own_values


def applied_torque_uses(owner) -> list:
    """(hinge, column, kind (:data:`_TORQUE_USE`), derivative law) of every parameter's use in a hinge's applied
    torque, in the order of ``owner.derivatives`` (a conservative spring's stiffness and rest angle do no external
    work; a guide's force, stiffness and rest on its slide as a hinge's)."""
    model, uses = owner.model, []
    for key, laws in owner.derivatives.items():
        _, hinge = owner._key_kinds(key)   # noqa: SLF001
        if not hinge or hinge["law"] not in _TORQUE_USE:
            continue
        j = model.hinge_index(hinge["beam"], hinge["end"])
        if hinge["law"] != "torque" and model.hinges[j].conservative_spring:
            continue
        uses += [(j, column, _TORQUE_USE[hinge["law"]], law) for column, law in laws.items()]
    return uses
