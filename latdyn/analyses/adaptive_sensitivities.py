"""Exact sensitivities of adaptive-step runs: the step control differentiated (docs/parameters.md,
"Adaptive steps"; latdyn/timeloop/control.py).

With ``solve.adaptive`` the computed solution depends on p through the size of every accepted step. The
step control (:class:`latdyn.timeloop.control.StepControl`) chooses each size from the step before:

- a trial the error estimate rejects is tried again with h' = max(h · max(0.2, 0.9 e^(−1/3)), dt_min),
  e = ê / (error_tol · length) the relative estimate of the rejected trial,

      ê = h² |β − 1/6| N,   N = max(max_g scale · sqrt(x_gᵀ M_gg x_g / m_g), ℓ max_i |x_i|),   x = a_{n+1} − a_n,

  (:meth:`latdyn.step.integrators.GeneralizedAlpha.error_estimate`, :func:`latdyn.numerics.inertia.joint_norms`:
  M at the trial's end, m_g a mean of translational diagonal entries of M; i over the hinges of rigid links,
  :func:`latdyn.numerics.inertia.largest_link_turn`, whose δN / N is δx_i / x_i where it is the larger);
- after an accepted step h' = min(dt, max(dt_min, h · min(2, 0.9 e^(−1/3)))), e the accepted step's own
  relative estimate, taken before the integrator accepts it (:meth:`StepControl.estimate_accepted`); after a
  latch or a stop e is taken as 0 (h' = 2h); after a step shortened onto a grid point h' is the size proposed
  before it was shortened, h' = h_proposed, δh' = δh_proposed (``Resize.by_proposed``);
- a trial Newton does not converge is tried again at the same size (the inertia tangent switched on) or
  cut in half; a trial that would pass the next grid point is shortened onto it (h = t_k − t_n).

Each rule is smooth in (h, e) save where it clips; :class:`latdyn.timeloop.control.Resize` holds its
derivative (∂h'/∂h, ∂h'/∂e; 0 where clipped at dt or dt_min, the factor's bound's where clipped there),
and δh' = ∂h'/∂h δh + ∂h'/∂e δe is carried to the next trial (``carried["dh_next"]``), which
:meth:`latdyn.analyses.transient_sensitivities.TransientSensitivities._step_size_derivative` takes as the
accepted step's δh (a trial shortened onto the grid: δh = −δt_n; onto an event: the event's). That δh
enters the step's derivative through its step-size column and the laws in t (δt_{n+1} = δt_n + δh), as
for events. A rejected trial enters the solution only through the next trial's size, so its derivative
is taken (one more solve with its exact matrix) only to differentiate its error estimate. An accepted step's
estimate is differentiated the same way from that step's own derivative (its δq, δa_{n+1} and δh, kept by
:func:`accepted_trial` before its events; no extra solve), where the control read it (∂h'/∂e ≠ 0):

    δe / e = 2 δh / h + δN / N,   δN / N = ½ (δE / E − δm / m),
    δE = 2 (M_gg x_g)ᵀ δx_g + x_gᵀ δM x_g,   δm = Σ_i c_i δM_ii,
    δM w = [K(v = 0, v̇ = w) − K(v = 0, v̇ = 0)] δq + ∂(M w)/∂p   along a column (δq, δp),

δx = δa_{n+1} − δa_n (x_g: x on the largest group's coordinates, zero elsewhere): the exact K's inertia tangent is ∂(M(q) v̇)/∂q (the generated ``beam_inertia_tangent`` and
``joint_body_inertia_stiffness``), ∂(M w)/∂p the inertia forces' parameter derivative at accelerations w
less at rest (linear in the accelerations), so nothing here is a difference. Its cost: per rejected trial one
step solve and (2 + the reference's entries) evaluations with matrices and of ∂r/∂p (one at rest, one per w);
per accepted step whose estimate sized the next one, the evaluations without the solve.

Not differentiated (refused, :func:`refusal`): prescribed motions (M moves in time through the prescribed
ends, ∂M/∂t is not computed), controllers with states or sampled ones, and a step size restored after a pause
of a :class:`latdyn.Simulation` (SolverError). A continuous controller whose output names t moves the residual
in t as a load in t does (ExplicitTime)."""
from __future__ import annotations

import numpy as np

from latdyn.analyses.geometry_sensitivities import GEOMETRY_KEY
from latdyn.analyses.parameter_keys import prescribed_motion
from latdyn.assembly.assembler import unpack_free
from latdyn.errors import SolverError
from latdyn.numerics.inertia import joint_blocks, largest_joint_norm, largest_link_turn

__all__ = ["refusal", "rejected", "accepted_trial", "resized", "error_derivative"]


def refusal(scene) -> str | None:
    """Why the sensitivities of ``scene``'s adaptive run are not computed, or None (module docstring)."""
    if not scene.solve.adaptive:
        return None
    placing = next((used for name in scene.solve.sensitivities for used in scene.parameters.depending_on(name)
                    if GEOMETRY_KEY.match(used)), None)
    if placing is not None:
        return (f"with adaptive step control, a parameter used at {placing} places the structure and so moves the "
                "error estimate's length scale (twice the largest distance of a node from the centroid at t = 0), "
                "which the step sizes' derivative does not follow yet; expected a fixed step (adaptive: false) "
                "(docs/parameters.md, \"Adaptive steps\")")
    if prescribed_motion(scene):
        return ("with adaptive step control and a prescribed motion (a body's translation or rotation, a hinge's "
                "angle) the error estimate's mass matrix moves in time through the prescribed ends, which the step "
                "sizes' derivative does not follow yet; expected a fixed step (adaptive: false) or no prescribed "
                "motion (docs/parameters.md, \"Adaptive steps\")")
    for c in (getattr(scene, "controllers", None) or {}).values():
        if c.states or c.sampled:
            what = "has states" if c.states else "is sampled"
            return (f"with adaptive step control, controller {c.name!r} {what}, which the step sizes' derivative does "
                    "not follow yet (its states' step and its samples' restarts); expected a fixed step (adaptive: "
                    "false) or continuous controllers without states (docs/parameters.md, \"Adaptive steps\")")
    return None


def _trial_size_derivative(owner, carried: dict, lands: bool) -> np.ndarray:
    """δh (k,) of a trial step: shortened onto the next grid point, −δt_n; else the size the control chose."""
    if lands:
        return -np.asarray(carried["dt"])
    return np.asarray(carried.get("dh_next", np.zeros(len(owner.names))))


def halved(owner, carried: dict) -> dict:
    """``carried`` with ``dh_next`` of a trial that takes half the way left to the next grid point
    (:meth:`latdyn.timeloop.control.StepControl.next_step`: h = (t_k − t_n)/2, δh = −δt_n/2), the size the
    control chose instead of the one it proposed."""
    if owner.model.n_dofs == 0 or len(owner.names) == 0:
        return carried
    return {**carried, "dh_next": -0.5 * np.asarray(carried["dt"])}


def rejected(owner, carried: dict, progress, attempt, integrator, control) -> dict:
    """``carried`` with ``dh_next``, the derivative of the size the control chose after rejecting the
    converged trial ``attempt`` from ``progress.state`` (module docstring)."""
    k = len(owner.names)
    if owner.model.n_dofs == 0 or k == 0:
        return carried
    dh = _trial_size_derivative(owner, carried, attempt.lands)
    resize = control.resize
    d_error = np.zeros(k)
    if resize.by_error != 0.0:
        columns, _ = owner.step_columns(carried, progress.state, attempt.new, attempt.h,
                                    progress.algorithmic_acceleration, integrator.a_candidate)
        total = {key: value[:, :k] + np.outer(value[:, k], dh) for key, value in columns.items()}
        d_error = error_derivative(owner, attempt.new, integrator.a_candidate - progress.algorithmic_acceleration,
                                   total["dq"], total["da"] - carried["da"], dh, attempt.h, resize.error, integrator)
    return _next_size(carried, resize, dh, d_error)


def _next_size(carried: dict, resize, dh: np.ndarray, d_error: np.ndarray) -> dict:
    """``carried`` with ``dh_next`` = ∂h'/∂h δh + ∂h'/∂e δe + ∂h'/∂h_proposed δh_proposed (``resize``: the control's
    :class:`latdyn.timeloop.control.Resize`; δh_proposed the carried ``dh_next``, the trial's size before it landed)."""
    proposed = np.asarray(carried.get("dh_next", np.zeros(len(dh))))
    return {**carried, "dh_next": resize.by_step * dh + resize.by_error * d_error + resize.by_proposed * proposed}


def accepted_trial(new, x: np.ndarray, total: dict, before: dict, dh: np.ndarray, h: float) -> dict:
    """What the accepted step's error estimate is differentiated from once the control has read it
    (:func:`resized`), kept in the carried sensitivities by the step's derivative before its events: the step's
    end ``new`` (a copy), x = a_{n+1} − a_n, its δq and δx = δa_{n+1} − δa_n (``total``'s and ``before``'s δa),
    its size ``h`` and δh."""
    return {"state": new.copy(), "x": x, "dq": total["dq"], "dx": total["da"] - before["da"], "dh": dh, "h": h}


def resized(owner, carried: dict, control, lands: bool | None, integrator=None) -> dict:
    """``carried`` with ``dh_next`` after an accepted step (``lands`` None: its δh is ``carried["dh_step"]``, its
    error estimate differentiated from ``carried["accepted_trial"]``) or a trial Newton did not converge
    (``lands``: whether it was shortened onto the grid), on adaptive runs and on fixed steps (their sizes after
    a cut: ``control.resize`` without ∂h'/∂e, :meth:`latdyn.timeloop.control.StepControl.after_accepted`)."""
    k = len(owner.names)
    trial = carried.get("accepted_trial")
    if trial is not None:
        carried = {**carried, "accepted_trial": None}
    if owner.model.n_dofs == 0 or k == 0:
        return carried
    resize = control.resize
    if resize is None:
        raise SolverError("the sensitivities meet a step size that does not follow from the step before it as "
                          "latdyn/analyses/adaptive_sensitivities.py differentiates it (a pause of "
                          "latdyn.Simulation between grid points); expected latdyn run")
    dh = np.asarray(carried.get("dh_step", np.zeros(k)) if lands is None
                    else _trial_size_derivative(owner, carried, lands))
    d_error = np.zeros(k)
    if lands is None and resize.by_error != 0.0:   # the accepted step's own estimate sized the next one
        if trial is None:
            raise SolverError("the sensitivities of an adaptive run meet a step sized by an estimate they did not "
                              "follow (no accepted trial kept); expected a fixed step")
        d_error = error_derivative(owner, trial["state"], trial["x"], trial["dq"], trial["dx"], trial["dh"],
                                   trial["h"], resize.error, integrator)
    return _next_size(carried, resize, dh, d_error)


def error_derivative(owner, trial, x: np.ndarray, dq: np.ndarray, dx: np.ndarray, dh: np.ndarray, h: float,
                     error: float, integrator) -> np.ndarray:
    """δe (k,) of the relative error estimate ``error`` of the trial step of size ``h`` that ended at ``trial``
    (module docstring): ``x`` = a_{n+1} − a_n, ``dq``, ``dx`` (n, k) the trial's δq and δx, ``dh`` (k,) its
    size's derivative."""
    model = owner.model
    mass = owner.assembler.evaluate(trial, matrices=True).combined(1.0, 0.0, 0.0)
    largest = largest_joint_norm(model, joint_blocks(model, mass, integrator.groups()), x, integrator.length_scale)
    turn, i = largest_link_turn(integrator.link_hinges(), x, integrator.length_scale)
    if turn > largest.norm:   # a rigid link's hinge counted as a rotation, N = ℓ |x_i|: δN / N = δx_i / x_i
        return error * (2.0 * dh / h + dx[i] / x[i])
    if largest.energy <= 0.0 or largest.reference <= 0.0:
        return np.zeros(len(owner.names))
    n = model.n_dofs
    restricted = np.zeros(n)
    restricted[largest.dofs] = x[largest.dofs]
    units = list(largest.weights)
    vectors = [restricted] + [np.eye(1, n, i).ravel() for i in units]
    moved = _mass_derivatives(owner, trial, vectors, dq)
    block_x = np.asarray(mass @ restricted).ravel()[largest.dofs]   # M_gg x_g: the group's rows only
    d_energy = 2.0 * block_x @ dx[largest.dofs] + restricted @ moved[0]
    d_reference = sum(largest.weights[i] * moved[1 + j][i] for j, i in enumerate(units))
    d_norm = 0.5 * (d_energy / largest.energy - d_reference / largest.reference)
    return error * (2.0 * dh / h + d_norm)


def _mass_derivatives(owner, state, vectors: list, dq: np.ndarray) -> list:
    """δ(M w) (n, k) at ``state`` along each column's (δq, δp), exactly, for each w of ``vectors`` (module
    docstring): the state at rest evaluated once, then once with the accelerations w for each."""
    model, assembler = owner.model, owner.assembler
    at_rest = state.copy()
    for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
        getattr(at_rest, name)[...] = 0.0
    assembler.complete_links(at_rest)
    resting_K = assembler.exact_matrices(at_rest)[2]
    resting_p = owner.residual_derivatives(at_rest, 1.0, inertia=True)
    out = []
    for w in vectors:
        accelerated = at_rest.copy()
        unpack_free(model, w, accelerated.a, accelerated.alpha, accelerated.theta_ddot)
        assembler.complete_links(accelerated)
        tangent = assembler.exact_matrices(accelerated)[2] - resting_K
        out.append(np.asarray(tangent @ dq).reshape(dq.shape)
                   + owner.residual_derivatives(accelerated, 1.0, inertia=True) - resting_p)
    return out
