"""Stability of a static path under non-conservative (follower) loads: divergence and flutter.

A load given in a body's axes (``loads: [{frame: BODY}]`` on a body that moves) turns with that
body: a follower load.  It has no potential, and its load stiffness makes the tangent of the
static path K_T(λ) unsymmetric.  The symmetric part of K_T then says nothing about stability
(Beck's column, a cantilever under a tangential tip force, has ½(K_T + K_Tᵀ) singular at
P L²/EI ≈ π², neither its dead-load value π²/4 nor any instability: it is stable up to
P L²/EI = 20.05; Bolotin 1963, Ch. 1; Ziegler 1968, §3).  Two instabilities are distinguished (Ziegler 1968):

- **divergence** (static): a real eigenvalue of the full tangent K_T(λ) passes through zero;
  the equilibrium stops being isolated, as in buckling.  Found along the path as the zero of
  d(λ) = the smallest *real* eigenvalue of the pencil (K_T(λ), K₀) (1 unloaded; K₀ the symmetric,
  positive definite tangent of the unloaded structure; complex pairs do not count: a pair of
  real eigenvalues that meets and leaves the real axis is no static instability).
- **flutter** (dynamic): about the loaded equilibrium, the modes of M s² + C s + K_T(λ) (the
  linearisation of :mod:`latdyn.analyses.linearise`, inertial frame, directions without inertia
  condensed) have a pair of roots s that meets and leaves the imaginary axis: an oscillation of
  growing amplitude, while det K_T ≠ 0.  Its measure is the growth g(λ) = max Re s/|s| over the
  oscillatory roots (−ζ of the least damped mode); flutter where g > :data:`FLUTTER_TOL`.  Without
  damping (C = 0) the roots come from the eigenvalues μ = ω² of (K_r, M_r): s = ±√(−μ), and a
  pair μ meeting and becoming complex is flutter (Re s ≠ 0).  With damping (hinge dampers) the
  least damped root's Re s crosses zero (:data:`DAMPED_FLUTTER_TOL`); vanishing damping lowers the
  flutter load (Ziegler's paradox: his pendulum with equal small hinge dampers flutters at
  Pl/k = 41/28 instead of 7/2 − √2).

Both are followed from λ = 0 along the equilibrium path (Newton of the static analysis at each λ,
:func:`latdyn.analyses.continuation.newton_fixed`), with steps that grow to at most half the load
factor reached, up to :data:`SEARCH_LIMIT`; the first instability met is bracketed and the
bracket narrowed to :data:`~latdyn.analyses.linearise.STABILITY_TOL` (relative) by regula falsi
(Illinois) on a measure that crosses zero linearly there (d; for flutter :meth:`Growth.margin`),
bisecting where it does not halve the bracket in two tries.  The divergence
load is the zero of d by linear interpolation in the final bracket, the flutter load the upper
end of the final bracket without damping (g grows as √(λ − λ_f) past it), the zero of g
interpolated in it with damping.

References: M. Beck, ZAMP 3 (1952) 225–228; H. Ziegler, Principles of Structural Stability
(1968); V. V. Bolotin, Nonconservative Problems of the Theory of Elastic Stability (1963).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latdyn.analyses import continuation
from latdyn.analyses.followers import REAL_TOL
from latdyn.analyses.linearisation import Frame, at_rest, linearise, reduce, tangent_q
from latdyn.numerics.linalg import single_thread_blas

#: Growth ratio Re s/|s| above which an oscillatory root is unstable (flutter), without damping.
#: Past the flutter load the ratio grows as c √(λ − λ_f); the threshold moves the load by
#: ~(1e-6/c)², nothing, and stays clear of the round-off of nearly equal ω² (~√ε).
FLUTTER_TOL = 1e-6
#: The same with damping, where Re s crosses zero linearly, with a slope as small as the damping
#: (Ziegler's pendulum with hinge dampers c = 1e-3: 4e-4 per unit load factor, so that 1e-6 would
#: move the load by 0.2 %); the roots of the first-order form are not near a double root there, and
#: their round-off is ~ε.  The load is then the zero of the ratio, interpolated in the final bracket.
DAMPED_FLUTTER_TOL = 1e-10
#: The search along the path stops at this load factor when nothing was found before.
SEARCH_LIMIT = 1000.0
#: The most steps the search takes along the path, and again points in narrowing a bracket: past
#: either it stops, says so in ``warnings`` and reports what it searched (a measure that falls towards
#: zero without crossing it shrinks the steps without end; Beck's column and Ziegler's pendulum take
#: 8–14 evaluations in all).
MAX_POINTS = 200
def divergence_measure(K, K0_cholesky) -> float:
    """d = the smallest real eigenvalue of the pencil (K, K₀) (module docstring), from the
    standard eigenproblem L⁻¹ K L⁻ᵀ (K₀ = L Lᵀ); +inf when every eigenvalue is complex."""
    import scipy.linalg as sla

    L = K0_cholesky
    B = sla.solve_triangular(L, sla.solve_triangular(L, K.T, lower=True).T, lower=True)
    mu = np.linalg.eigvals(B)
    real = mu[np.abs(mu.imag) <= REAL_TOL * np.maximum(1.0, np.abs(mu))].real
    return float(real.min()) if len(real) else np.inf


@dataclass
class Growth:
    """The least stable oscillatory root of a linearisation: g = Re s/|s| (−ζ) and |Im s|/2π."""
    ratio: float
    frequency_hz: float
    damped: bool = False
    #: without damping: the eigenvalues ω² of (K_r, M_r), for :meth:`margin`
    omega2: np.ndarray | None = None

    def margin(self, meeting: float | None) -> float:
        """A measure that crosses zero linearly at the flutter load (positive below), for the regula
        falsi of :func:`search`: with damping 1e-10 − g; without, below flutter the squared relative
        distance of the two real ω² about ``meeting`` (the real part of the pair that is complex
        past it: the pair meets as a ± √(c(λ_f − λ))), past it −(Im ω²/|ω²|)² of that pair."""
        if self.damped:
            return DAMPED_FLUTTER_TOL - self.ratio
        w2 = self.omega2
        if w2 is None:  # the unloaded start, not measured: bisection
            return np.inf
        complex_ = np.abs(w2.imag) > REAL_TOL * np.maximum(np.abs(w2), 1e-300)
        if np.any(complex_):
            k = np.flatnonzero(complex_)
            if meeting is not None:
                k = k[np.argmin(np.abs(w2[k].real - meeting))]
            return -float(np.max(np.abs(w2[k].imag) / np.abs(w2[k]))) ** 2
        real = np.sort(w2.real)
        if len(real) < 2 or meeting is None:
            return np.inf  # no pair to follow: bisection
        distance = np.maximum(np.maximum(real[:-1] - meeting, meeting - real[1:]), 0.0)
        i = int(np.argmin(distance))
        return float((real[i + 1] - real[i]) / max(abs(real[i + 1]) + abs(real[i]), 1e-300)) ** 2

    def meeting(self) -> float | None:
        """Without damping, the real part of the least stable complex pair of ω² (None: none)."""
        if self.damped or self.omega2 is None:
            return None
        w2 = self.omega2
        complex_ = np.abs(w2.imag) > REAL_TOL * np.maximum(np.abs(w2), 1e-300)
        if not np.any(complex_):
            return None
        k = np.flatnonzero(complex_)
        return float(w2[k[np.argmax(np.abs(w2[k].imag) / np.abs(w2[k]))]].real)

    @property
    def unstable(self) -> bool:
        return self.ratio > (DAMPED_FLUTTER_TOL if self.damped else FLUTTER_TOL)


def flutter_measure(lin) -> Growth:
    """g(λ) of the module docstring about the linearisation ``lin`` (inertial frame, at rest)."""
    import scipy.linalg as sla


    red = reduce(lin)
    M, C, K = red.mass, red.damping, red.stiffness
    m = M.shape[0]
    if m == 0:
        return Growth(0.0, 0.0)
    undamped = np.abs(C).max() <= 1e-12 * max(float(np.sqrt(np.abs(K).max() * np.abs(M).max())), 1e-300)
    if undamped:  # μ = ω²: s = ±√(−μ); the principal root has Re s >= 0
        mu = sla.eigvals(K, M)
        mu = mu[np.isfinite(mu)]
        s = np.sqrt(-mu.astype(complex))
    else:
        Minv = np.linalg.inv(M)
        A = np.block([[np.zeros((m, m)), np.eye(m)], [-Minv @ K, -Minv @ C]])
        s = np.linalg.eigvals(A)
    size = np.maximum(np.abs(s), 1e-300)
    oscillatory = np.abs(s.imag) > REAL_TOL * size
    omega2 = mu if undamped else None
    if not np.any(oscillatory):
        return Growth(0.0, 0.0, not undamped, omega2)
    ratio = s.real / size
    k = np.flatnonzero(oscillatory)[np.argmax(ratio[oscillatory])]
    return Growth(float(ratio[k]), float(abs(s[k].imag)) / (2 * np.pi), not undamped, omega2)


@dataclass
class PathState:
    """A converged point of the path and its two measures."""
    load_factor: float
    state: object
    divergence: float
    growth: Growth | None

    @property
    def diverged(self) -> bool:
        return self.divergence <= 0.0

    @property
    def fluttered(self) -> bool:
        return self.growth is not None and self.growth.unstable


def search(prepared, path, reference, K0s, first_step: float, flutter: bool, tol: float) -> dict:
    """Divergence and (``flutter``) flutter along the static path from ``reference`` at λ = 0
    (module docstring): the summary's keys (SCENE.md, docs/linearisation.md)."""

    from latdyn.analyses.not_equilibria import states_not_at_rest, stops_passed  # the path's own caveats

    assembler = prepared.assembler
    cholesky = np.linalg.cholesky(K0s)
    evaluations = 0
    warnings = []
    passed = []  # the first stable state of the path past a rigid stop or latch, or off a controller's rest

    def not_the_structures(point) -> list[str]:
        """What a stable state of the path past a rigid stop or latch, or off a controller's rest, says."""
        return (stops_passed(prepared.model, point.state, load_factor=point.load_factor)
                or states_not_at_rest(assembler, point.state,
                                      f"buckling: the static path at load factor {point.load_factor:.6g}"))

    asked = flutter  # searched, or said not to be (the structure has no mass)
    if flutter and not np.any(assembler.evaluate(reference, matrices=True, load_factor=0.0).combined(
            1.0, 0.0, 0.0, dense=True)):
        flutter = False  # no dynamic eigenproblem: said, never reported as "no flutter"
        warnings.append("buckling: flutter not searched: the structure has no mass (sections' rhoA, "
                        "bodies' mass), so it has no modes about the loaded states")

    def measure(lam, state) -> PathState:
        nonlocal evaluations
        evaluations += 1
        state = at_rest(state)
        with single_thread_blas():  # small dense problems: threads cost more than they give
            return measure_at(lam, state)

    def measure_at(lam, state) -> PathState:
        if flutter:  # at rest in the inertial frame the linearisation's K is the static tangent
            lin = linearise(assembler, state, Frame.inertial(), lam)
            return PathState(lam, state, divergence_measure(lin.stiffness, cholesky), flutter_measure(lin))
        K = tangent_q(assembler, state, lam, inertia=False)
        return PathState(lam, state, divergence_measure(K, cholesky), None)

    below = PathState(0.0, reference, 1.0, Growth(0.0, 0.0) if flutter else None)
    above, limit_point = None, False
    step = first_step
    walked = 0
    while below.load_factor < SEARCH_LIMIT:
        if walked == MAX_POINTS:
            warnings.append(f"buckling: the stability search stopped after {MAX_POINTS} steps along the path, at load "
                            f"factor {below.load_factor:.6g}: nothing found below it (divergence_searched_to); "
                            "the measures approach an instability without reaching it")
            break
        walked += 1
        target = min(below.load_factor + step, SEARCH_LIMIT)
        trial, _, _, converged = continuation.newton_fixed(path, below.state, target)
        if converged and path.left_the_path(below.state, below.load_factor, trial, target):
            converged = False  # only on another branch, past a fold (continuation.Path.left_the_path)
        if not converged:  # no equilibrium there: a limit point (the path folds, det K_T = 0) or a cut
            step *= 0.5
            if step <= tol * max(below.load_factor, 1e-12):
                limit_point = True
                break
            continue
        point = measure(target, trial)
        if point.diverged or point.fluttered:
            above = point
            break
        previous, below = below, point
        passed = passed or not_the_structures(point)
        step = min(2.0 * step, max(first_step, 0.5 * below.load_factor))
        falling = np.isfinite(previous.divergence) and below.divergence < previous.divergence
        if falling:  # towards a fold or a divergence: not far past the secant's zero of d (a step
            # beyond a fold may land on another branch; exactly on a divergence, K is singular)
            guess = below.divergence * (below.load_factor - previous.load_factor) / (previous.divergence - below.divergence)
            step = min(step, max(1.1 * guess, 0.05 * step))
    if above is not None:  # narrow the bracket: Illinois regula falsi on the measure that turned
        diverging = above.diverged

        def signed(point, meeting):
            return point.divergence if diverging else point.growth.margin(meeting)

        scale, moved, widths = [1.0, 1.0], 0, []  # Illinois: the weights of the ends kept
        while above.load_factor - below.load_factor > tol * below.load_factor:
            if len(widths) == MAX_POINTS:
                warnings.append(f"buckling: the stability search stopped narrowing the instability after {MAX_POINTS} "
                                f"points: it lies between load factors {below.load_factor:.9g} and "
                                f"{above.load_factor:.9g}, not within the tolerance {tol:g}")
                break
            lo, hi = below.load_factor, above.load_factor
            slow = len(widths) >= 2 and hi - lo > 0.5 * widths[-2]  # not halved in two tries: bisect
            widths.append(hi - lo)
            meeting = None if diverging or above.growth is None else above.growth.meeting()
            f_below = scale[0] * signed(below, meeting)
            f_above = scale[1] * signed(above, meeting) if above.state is not None else -np.inf
            target = 0.5 * (lo + hi)
            if not slow and np.isfinite(f_below) and np.isfinite(f_above) and f_below > 0.0 > f_above:
                target = lo + (hi - lo) * f_below / (f_below - f_above)
                # a quarter of the tolerance past the estimate, towards the end that moved least
                # recently: once the estimate is good, the next point closes the bracket
                target += 0.25 * tol * lo * (-1.0 if moved < 0 else 1.0)
                target = min(max(target, lo + 1e-3 * (hi - lo)), hi - 1e-3 * (hi - lo))
            trial, _, _, converged = continuation.newton_fixed(path, below.state, target)
            if converged and path.left_the_path(below.state, below.load_factor, trial, target):
                converged = False
            if not converged:
                above = PathState(target, None, -np.inf, None)  # a fold inside
                limit_point = True
                continue
            point = measure(target, trial)
            if point.diverged or point.fluttered:
                above = point
                scale = [scale[0] * (0.5 if moved < 0 else 1.0), 1.0]
                moved = -1
            else:
                below = point
                passed = passed or not_the_structures(point)
                scale = [1.0, scale[1] * (0.5 if moved > 0 else 1.0)]
                moved = 1
    warnings += passed
    out = {"conservative": False, "stability_evaluations": evaluations}
    kind = None
    if limit_point and (above is None or above.state is None):
        kind = "divergence"
        factor = below.load_factor if above is None else above.load_factor
        out.update(divergence_factor=float(factor), divergence_searched_to=float(factor),
                   buckling_kind="limit point (Newton finds no equilibrium beyond)")
    elif above is not None and above.diverged and not above.fluttered:
        kind = "divergence"
        d0, d1 = below.divergence, above.divergence
        factor = below.load_factor
        if np.isfinite(d0) and np.isfinite(d1) and d0 > d1:
            factor = below.load_factor + (above.load_factor - below.load_factor) * d0 / (d0 - d1)
        out.update(divergence_factor=float(factor), divergence_searched_to=float(factor),
                   buckling_kind="divergence (a real eigenvalue of the full tangent through zero)")
    else:
        reached = below.load_factor if above is None else above.load_factor
        out.update(divergence_factor=None, divergence_searched_to=float(reached),
                   buckling_kind=None)
    if warnings:
        out["warnings"] = warnings
    if asked and not flutter:  # no mass: flutter said not to be searched
        out.update(flutter_factor=None, flutter_searched_to=None)
    if flutter:
        if above is not None and above.fluttered:
            kind = kind or "flutter"
            factor = above.load_factor
            g0, g1 = below.growth.ratio, above.growth.ratio
            if above.growth.damped and below.growth.damped and g0 < g1:  # Re s crosses zero linearly
                factor = below.load_factor + (above.load_factor - below.load_factor) * min(max(
                    -g0 / (g1 - g0), 0.0), 1.0)
            out.update(flutter_factor=float(factor), flutter_searched_to=float(factor),
                       flutter_frequency_hz=above.growth.frequency_hz)
            if out["divergence_factor"] is None:
                out["divergence_searched_to"] = float(factor)
        else:
            out.update(flutter_factor=None, flutter_searched_to=out["divergence_searched_to"],
                       flutter_frequency_hz=None)
    out["instability"] = kind or "none"
    out["buckling_factor"] = out["divergence_factor"]
    return out
