"""What ``latdyn check`` reports beyond the model's size: the lowest non-rigid mode against dt
and the element rotations against what the formulation's rotation measure handles."""
from __future__ import annotations

import numpy as np

#: Fewer steps per period of the lowest non-rigid mode than this: ``latdyn check`` warns.
STEPS_PER_PERIOD = 10


#: Modes with ω² below this fraction of the largest are rigid-body or mechanism modes.
RIGID_MODE_RATIO = 1e-8


#: The same for the Lanczos path, against the largest diag K / diag M (which exceeds the largest
#: ω² by the spread of the mesh): measured on the 10⁴-element truss of examples/, the lowest
#: mode is 1.8e-12 of it (a soft mechanism of the hinge springs, a real mode).
LANCZOS_RIGID_RATIO = 1e-14


#: Largest |sin φ| of an element's local rotations the sine measures (Eqs. 14–16) handle
#: (at 0.5, φ = 30°, the sine is 4.5 % below the angle).
SINE_LIMIT = 0.5


#: Largest |φ| (rad) the exact log-map measure is trusted with inside one element.
LOG_LIMIT = 1.0


#: Largest model whose modes ``latdyn check`` finds with a dense eigensolver; larger ones use
#: shift-invert Lanczos (a few eigenvalues near zero).
DENSE_MODES_LIMIT = 1500


def lowest_frequencies(model, assembler, state) -> float | None:
    """The lowest non-rigid natural frequency (Hz) about ``state`` (at rest), or None.

    Up to :data:`DENSE_MODES_LIMIT` coordinates: every mode of the linearisation about ``state``
    in the inertial frame, the modal analysis ``about: initial`` of :mod:`latdyn.analyses.linearise`
    (the directions without inertia condensed, Guyan); a divergent mode (a real eigenvalue > 0, no
    oscillation) is not one the time step has to resolve. Beyond: shift-invert Lanczos on (K, M)
    at σ = −10⁻⁶ λ_ref (K − σM is regular where the model passed the held check; λ_ref the
    largest diag K / diag M), the 6 eigenvalues nearest zero to 1e-3. Modes with ω² below
    :data:`RIGID_MODE_RATIO` of the largest (dense) or :data:`LANCZOS_RIGID_RATIO` of λ_ref
    (Lanczos) are rigid. None when all are rigid or Lanczos does not converge.
    """
    from scipy.sparse.linalg import ArpackNoConvergence, eigsh

    if model.n_dofs <= DENSE_MODES_LIMIT:
        from latdyn.analyses.linearisation import Frame, linearise, modes

        found = modes(linearise(assembler, state, Frame.inertial()))
        omega2 = np.array([(2 * np.pi * mode.natural_frequency_hz) ** 2 for mode in found
                           if mode.frequency_hz > 0 or mode.eigenvalue.real <= 0])
        if not len(omega2):
            return None
        elastic = omega2[omega2 > RIGID_MODE_RATIO * omega2.max()]
    else:
        ev = assembler.evaluate(state, matrices=True)
        K, M = ev.stiffness, ev.mass
        K, M = (0.5 * (K + K.T)).tocsc(), (0.5 * (M + M.T)).tocsc()
        m, k = M.diagonal(), K.diagonal()
        reference = float(np.max(k[m > 0] / m[m > 0]))
        try:
            values = eigsh(K, k=min(6, model.n_dofs - 2), M=M, sigma=-1e-6 * reference, which="LM",
                           return_eigenvectors=False, tol=1e-3, maxiter=300)
        except (ArpackNoConvergence, RuntimeError):
            return None
        elastic = np.sort(values[values > LANCZOS_RIGID_RATIO * reference])
    return float(np.sqrt(elastic.min()) / (2 * np.pi)) if len(elastic) else None


def static_estimate(model, assembler, state):
    """The configuration of one Newton step from ``state`` under the loads at t = 0 (K u = −r),
    or None when K is singular or nothing loads the model."""
    from latdyn.assembly.factorization import solve_linear

    if not model.n_dofs:
        return None
    ev = assembler.evaluate(state, matrices=True, inertia=False)
    if not np.any(ev.residual):
        return None
    try:
        u = solve_linear(ev.stiffness, -ev.residual)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(u)) or np.abs(u).max() > 1e6 * max(1.0, float(np.abs(state.x).max())):
        return None
    return assembler.advance(state, u)


def dynamics_report(model, assembler, state) -> list[str]:
    """Lines on the lowest non-rigid mode (against ``solve.dt``) and on element rotations.

    The lowest non-rigid mode about the initial configuration: the eigenvalues of
    (K, M) at rest (:func:`lowest_frequencies`), where modes with ω² below
    :data:`RIGID_MODE_RATIO` of the largest are rigid-body (or mechanism) modes. A
    transient run warns when dt gives fewer than :data:`STEPS_PER_PERIOD` steps per period
    of that mode: the Lie-group generalized-α then damps it and lengthens its period (by
    more than about 3 % below 10 steps at ρ∞ = 0.8).

    Rotations: the rotation measure of the formulation (sines of the local rotations,
    Eqs. 14–16, for ``cr4402`` and ``no_stiffening``; the exact log map for ``default``
    when the package has ``cr4402`` beside it) against what it handles: sin φ ≤
    :data:`SINE_LIMIT` for sines, |φ| ≤ :data:`LOG_LIMIT` for the log map; checked at the
    initial configuration and at a linear static estimate under the loads, gravity and
    hinge torques at t = 0 (K u = −r, when K is regular: a grounded structure).
    """
    from latdyn.analyses.linearisation import at_rest
    from latdyn.scene.loader import FORMULATIONS

    lines = []
    scene = model.scene
    resting = at_rest(state)
    if model.n_dofs:
        frequencies = lowest_frequencies(model, assembler, resting)
        if frequencies is None:
            lines.append("  lowest non-rigid mode: not found (every mode found is rigid)")
        else:
            f = frequencies
            line = f"  lowest non-rigid mode: {f:.4g} Hz (period {1 / f:.4g} s)"
            if scene.solve.analysis == "transient" and scene.solve.dt:
                steps = 1.0 / (f * scene.solve.dt)
                line += f", {steps:.3g} steps per period at dt = {scene.solve.dt:g}"
                lines.append(line)
                if steps < STEPS_PER_PERIOD:
                    lines.append(f"  warning: dt = {scene.solve.dt:g} cannot resolve the lowest non-rigid mode "
                                 f"({f:.4g} Hz): {steps:.3g} steps per period, fewer than "
                                 f"{STEPS_PER_PERIOD}; the integrator damps it and shifts its period. "
                                 f"Take dt <= {1 / (f * STEPS_PER_PERIOD):.3g}")
            else:
                lines.append(line)
    sine = scene.solve.formulation != "default" or "cr4402" not in FORMULATIONS
    limit, what = (SINE_LIMIT, "sin φ") if sine else (LOG_LIMIT, "|φ|")
    checks = [("at the initial configuration", state)]
    estimate = static_estimate(model, assembler, resting)
    if estimate is None:
        lines.append("  rotations: no static estimate (the structure is not grounded, or has no loads)")
    else:
        checks.append(("in a linear static estimate under the loads at t = 0", estimate))
    for where, s in checks:
        if not len(model.element_nodes):
            break
        with np.errstate(all="ignore"):
            psi, _ = assembler.kernels.beam_deformation(assembler.element_geometry(s), model.element_sections)
        rotation = np.abs(psi[:, :5])  # φy1 φz1 φy2 φz2 φx2: sines, or angles for the log map
        if not np.all(np.isfinite(rotation)):
            lines.append(f"  rotations: not checked {where} (the estimate is not a configuration)")
            continue
        worst = int(np.argmax(rotation.max(axis=1)))
        value = float(rotation[worst].max())
        if value > limit:
            beam = model.element_beam[worst]
            index = worst - int(model.beam_elements[beam][0])
            lines.append(f"  warning: element {beam}.element[{index}] turns {what} = {value:.3g} against its "
                         f"chord {where}, beyond the {limit:g} its rotation measure "
                         f"({'sines, Eqs. 14-16' if sine else 'log map'}) handles; refine beam {beam!r}")
    return lines


def check_report(prepared) -> str:
    """What ``latdyn check`` prints after the scene: the model's size (:meth:`Model.size_report`)
    and the dynamics lines of :func:`dynamics_report` about the initial state."""
    model = prepared.model
    return "\n".join([model.size_report(), *dynamics_report(model, prepared.assembler, prepared.state)])
