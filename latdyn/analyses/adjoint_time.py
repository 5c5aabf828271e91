"""The discrete adjoint's pieces of an event's time beside laws in t (issue 34; docs/parameters.md, "The discrete
adjoint", "Events"): the transposes of the forward method's terms that carry δt where a load, a hinge's or guide's
law, a prescribed motion, a reel or a controller's output depends on t
(latdyn/analyses/transient_sensitivities.py, "Laws in time", :class:`ExplicitTime`).

The forward method moves a step's end t_{n+1} = t_n + h with δt_{n+1} = δt_n + δh and adds ∂r/∂t δt_{n+1} to the
step's right-hand side: ∂r/∂t δt_n in the parameters' columns and ∂r/∂t in the step size's column
(``_add_time_columns``); at an event it takes the impulse and the restart at t_e + δt_e (``time_shift``): ∂r/∂t δt_e
in the restart's ∂r/∂p, and in the weight's (∂K/∂p) w and ∂M/∂p w their parts moving with δt_e. Each is linear in
δt, so its transpose adds to t̄, the adjoint of δt that the reverse pass carries beside the bars
(latdyn/analyses/adjoint_sensitivities.py ``_reverse_columns``):

- a step (:func:`step_transposed`): z = S⁻¹(−(E + ∂r/∂t δt_n + …)), so t̄_n −= (∂r/∂t)ᵀ w with w = S⁻ᵀz̄ — the
  forward's ``_add_time_columns`` transposed; the step size's column carries ∂r/∂t (:func:`rate_at`, added by
  ``_step_size_column`` as the forward method adds it);
- the restart (:func:`restart_transposed`): δv̇ = −B⁻¹(E + ∂r/∂t δt_e + …) with the inertia forces, so t̄ += (∂r/∂t)ᵀ ū
  (ū = −B⁻ᵀs̄, the restart's own);
- a row whose time moves (an output row at an event, before a step lands on the grid): the forward method's row adds
  each probe's explicit time dependence times δt (a prescribed point's or angle's motion, a joint force's law in t or
  its reaction's ∂r_d/∂t: ``TransientSensitivities.record``); :func:`row_coefficients` reads that coefficient, and
  the adjoint takes such a row where it is 0, seeds t̄ there with it for a controller's output naming t (its ∂f/∂t,
  ``controller_probe_sensitivities._continuous_output``), and refuses it otherwise (no check has reached one);
- the weight's derivative (:func:`weight_transposed`): the forward's δ(W w) holds scale·(∂K/∂t w) δt_e and, with the
  mass, (∂r/∂t at the accelerations w less at rest) δt_e; the first is the static residual's ∂(∂r/∂t)/∂q w alone
  (:func:`shift_stiffness_along`: the forward method's ``_stiffness_derivative`` path for the time shift, generated
  where the laws' rates in t are, else its difference along w, with rigid links or guides ``_geometric_derivative``'s
  terms in δt_e), one evaluation, the same for every parameter; the second ExplicitTime's ∂r/∂t itself.

None of these differentiates anything new: each is the forward method's map at the event or step, read as the
coefficient of δt, transposed onto the adjoint's columns.
"""
from __future__ import annotations

import numpy as np

__all__ = ["moves_in_time", "rate_at", "restart_transposed", "row_coefficients", "shift_stiffness_along",
           "step_transposed", "weight_transposed"]


def moves_in_time(owner) -> bool:
    """Whether ``owner`` (an AdjointSensitivities) has explicit time dependence that an event's time moves
    (the forward method's :class:`ExplicitTime`; None where nothing depends on t or no event can move a step)."""
    return owner.explicit_time is not None


def rate_at(owner, state, prescribed: np.ndarray | None = None) -> np.ndarray:
    """∂r/∂t (n,) of the equations of motion at ``state`` on the free coordinates, as the forward method's step adds
    it (``ExplicitTime.__call__``, with the prescribed motions' part: ``prescribed`` where the caller evaluated it,
    with the controllers' states condensed as in the step)."""
    return np.asarray(owner.explicit_time(state, prescribed=prescribed), float)


def step_transposed(owner, state, w: np.ndarray, rate: np.ndarray | None = None) -> np.ndarray:
    """(m,): the step's part of t̄_n, −(∂r/∂t)ᵀ w at the step's end ``state`` (``w`` (n, m) the step's S⁻ᵀz̄; ``rate``
    ∂r/∂t where the caller evaluated it, :func:`rate_at`)."""
    return -((rate_at(owner, state) if rate is None else rate) @ w)


def restart_transposed(owner, after, u_bar: np.ndarray) -> np.ndarray:
    """(m,): the restart's part of t̄ at the event, (∂r/∂t)ᵀ ū with the inertia forces at the state after it
    (``u_bar`` (n, m) the restart's −B⁻ᵀs̄)."""
    return np.asarray(owner.explicit_time(after, inertia=True), float) @ u_bar


def weight_transposed(owner, state, w: np.ndarray, u_bar: np.ndarray, scale: float, mass: bool) -> np.ndarray:
    """(m,): (the coefficient of δt_e in the forward method's δ(W w) at ``state``)ᵀ ū, W = M + scale·K (``mass``) or
    scale·K (module docstring). Zeros where w is 0 (the forward method adds no parameter part then)."""
    if not np.any(w):
        return np.zeros(u_bar.shape[1])
    out = scale * (shift_stiffness_along(owner, state, w) @ u_bar)
    if mass:
        at_rest, accelerated = owner._at_rest_and_accelerated(state, w)   # noqa: SLF001
        moved = (np.asarray(owner.explicit_time(accelerated, inertia=True), float)
                 - np.asarray(owner.explicit_time(at_rest, inertia=True), float))
        out = out + moved @ u_bar
    return out


def shift_stiffness_along(owner, state, w: np.ndarray) -> np.ndarray:
    """(n,): the coefficient of the event's time shift δt_e in the forward method's (∂K/∂p) w at ``state``
    (``TransientSensitivities._stiffness_derivative``, with rigid links or guides ``_geometric_derivative`` too), the
    static residual's ∂(∂r/∂t)/∂q w alone, by the forward method's own decision and path
    (latdyn/analyses/parameter_stiffness.py ``time_shift_generated``, ``time_shift_along``: the laws' rates in t and
    the prescribed motions' part, with rigid links or guides along P w through the reduction), with rigid links or
    guides the reduction's geometric term of the static ∂r_all/∂t beside it (the forward method's
    ``_linked_stiffness_along`` takes it with the other columns of the static ∂r_all/∂p); where it is not generated
    the central difference of ∂r/∂t along w that the forward method's difference of the static ∂r/∂p holds (its
    step, :data:`WEIGHT_STEP` ℓ/|w|_∞); with rigid links or guides the reduction's geometric term of the inertia
    forces' ∂r_all/∂t and P's move with the prescribed coordinates beside either. One evaluation of the terms in t;
    before, the whole (∂K/∂p) w at two shifts and its first parameter's column (a parameter whose uses are
    differenced and one whose are generated took the other path)."""
    from latdyn.analyses.parameter_stiffness import time_shift_along
    from latdyn.analyses.transient_sensitivities import WEIGHT_STEP
    from latdyn.analyses.weight_derivative import geometric_product

    model, assembler = owner.model, owner.assembler
    linked = model.links is not None
    out = time_shift_along(owner, state, w)
    if out is None:   # the difference holds P's move along w
        eta = WEIGHT_STEP * (owner.length or 1.0) / float(np.max(np.abs(w)))
        ahead, behind = assembler.advance(state, eta * w), assembler.advance(state, -eta * w)
        out = (np.asarray(owner.explicit_time(ahead, inertia=False), float)
               - np.asarray(owner.explicit_time(behind, inertia=False), float)) / (2 * eta)
    elif linked:   # the geometric term of the static ∂r_all/∂t, as the forward method's
        static = np.asarray(owner.explicit_time(state, inertia=False, on_all=True), float)[:model.n_assembled]
        assembler.complete_links(state)   # J of the state in the links' buffers
        out = out + geometric_product(assembler, state, static, w)
    if linked:   # _geometric_derivative's terms in δt_e
        k = len(owner.names)
        held, owner.time_shift = owner.time_shift, np.ones(k)
        try:
            out = out + owner._geometric_rate_in_time(state, w)[:, 0]   # noqa: SLF001
        finally:
            owner.time_shift = held
        n_asm = model.n_assembled
        inertial = (np.asarray(owner.explicit_time(state, inertia=True, on_all=True), float)
                    - np.asarray(owner.explicit_time(state, inertia=False, on_all=True), float))[:n_asm]
        if np.any(inertial):
            assembler.complete_links(state)   # J of the state in the links' buffers
            out = out + geometric_product(assembler, state, inertial, w)
    return out


def row_coefficients(owner, state) -> np.ndarray:
    """(probes,): each probe's coefficient of δt in the forward method's row at ``state`` (its explicit time
    dependence: ``TransientSensitivities.record`` with δq = δv = δv̇ = 0 and the controllers' δS, δy 0, at δt = 1 less
    at δt = 0, the first parameter's column; every column takes the same coefficient times its δt; a controller's
    output naming t its ∂f/∂t, with the scene's arrays holding the row's accepted states)."""
    from latdyn.analyses.transient_sensitivities import TransientSensitivities

    n, k = owner.model.n_dofs, len(owner.names)
    rows = []
    held = {}   # the controllers' carried δS and held δy, zero (a controller probe's row reads them)
    terms = owner.controllers
    if terms is not None and terms.states is not None:
        held["controller_dS"] = np.zeros((len(terms.states.slots), k))
    if terms is not None and terms.sampled is not None:
        held["sampled_dy"] = np.zeros((len(terms.sampled.controllers), k))
        held["sampled_dS"] = np.zeros((int(sum(len(c.states) for c in terms.sampled.controllers)), k))
    for moved in (np.ones(k), np.zeros(k)):
        still = {"dq": np.zeros((n, k)), "dv": np.zeros((n, k)), "dvdot": np.zeros((n, k)), "dt": moved, "rows": [],
                 **held}
        rows.append(np.asarray(TransientSensitivities.record(owner, still, state)["rows"][0][1:], float))
    return (rows[0] - rows[1]).reshape(len(owner.probes), k)[:, 0]
