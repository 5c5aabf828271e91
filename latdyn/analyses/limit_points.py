"""A limit point of a static path located between the path points about it.

Where the load factor λ turns at a path point m (λ_m above or below both neighbours'), the limit point
lies on the path between the neighbours m − 1 and m + 1.  It is found on the family of hyperplanes

    cᵀW (q ⊖ q_m) = σ,        c the chord q_{m+1} ⊖ q_{m−1} of the two steps about m,

each crossing the path once near m: every σ gives a path point by Newton on the bordered system
(r(q, λ) = 0 with the hyperplane; regular at the limit point, where K is singular), and with it
dλ/dσ from the same bordered matrix.  The limit point is the σ where dλ/dσ = 0: regula falsi
(the Illinois variant) between the neighbours, where dλ/dσ has opposite signs, until |dλ/dσ| is
below :data:`SLOPE_TOLERANCE` of its larger value at the neighbours, or, where the round-off of
the points' residuals keeps dλ/dσ above that (a slope of 1e-10 that changes sign from one
iterate to the next, measured on DaDeppo's arch), until it is below :data:`ROUND_OFF_SLOPE` of it
and λ moved by at most :data:`LOAD_TOLERANCE` (relative) from the iterate before.  Near the turn
λ(σ) is a parabola, so λ there is exact to about the square of the slope's fraction, far below the
Newton tolerance of the points themselves (docs/static_paths.md, "Limit points").

Used by every path method that reports limit points (latdyn.analyses.continuation.Path.accept) and
by the limit load's sensitivities (latdyn.analyses.sensitivities.ArcLengthSensitivities.limit_points).
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.factorization import solve_linear
from latdyn.errors import SolverError

#: The regula falsi stops where |dλ/dσ| is below this fraction of its larger value at the neighbours.
SLOPE_TOLERANCE = 1e-11
#: Or below this fraction, where λ moved by at most LOAD_TOLERANCE (relative) from the iterate before.
ROUND_OFF_SLOPE = 1e-8
LOAD_TOLERANCE = 1e-12
#: Most regula falsi iterations.
MAX_ITERATIONS = 60


def locate_limit(path, start, load_factor: float, chord: np.ndarray, ends: tuple[float, float]):
    """(state, λ) of the limit point between σ = ends[0] and ends[1] on the hyperplanes cᵀW Δ = σ
    through the path point (``start``, ``load_factor``), ``chord`` = cᵀW; None where dλ/dσ has the
    same sign at both ends or a Newton solve on a hyperplane fails (``path``:
    latdyn.analyses.continuation.Path, its evaluate, step_to, increment_size, tol and max_iter)."""
    def on_path(sigma):   # Newton from the start onto the hyperplane cᵀW Δ = σ: (state, λ, dλ/dσ)
        state, lam, moved = start, load_factor, np.zeros(len(chord))
        for _ in range(path.max_iter):
            residual, stiffness, load = path.evaluate(state, lam)
            rhs = np.concatenate([-residual, [sigma - float(chord @ moved)]])[:, None]
            step = bordered_solve(stiffness, -load, chord, rhs, lam)[:, 0]
            state, lam, moved = path.step_to(state, step[:-1]), lam + step[-1], moved + step[:-1]
            if path.increment_size(step[:-1]) <= path.tol and abs(step[-1]) <= path.tol * max(1.0, abs(lam)):
                residual, stiffness, load = path.evaluate(state, lam)
                unit = np.zeros((len(residual) + 1, 1))
                unit[-1] = 1.0
                slope = float(bordered_solve(stiffness, -load, chord, unit, lam)[-1, 0])
                return state, lam, slope
        return None

    # regula falsi (Illinois) on dλ/dσ between the neighbours, where its sign differs
    (a, fa), (b, fb) = ((sigma, (on_path(sigma) or (None, None, None))[2]) for sigma in ends)
    if fa is None or fb is None or fa * fb > 0.0:
        return None
    scale, before = max(abs(fa), abs(fb)), None
    for _ in range(MAX_ITERATIONS):
        c = (a * fb - b * fa) / (fb - fa)
        got = on_path(c)
        if got is None:
            return None
        fc = got[2]
        if abs(fc) <= SLOPE_TOLERANCE * scale or (abs(fc) <= ROUND_OFF_SLOPE * scale and before is not None
                                                  and abs(got[1] - before) <= LOAD_TOLERANCE * abs(got[1])):
            return got[0], got[1]
        before = got[1]
        if fc * fb < 0.0:
            a, fa = b, fb
        else:
            fa /= 2
        b, fb = c, fc
    return None


def bordered_solve(stiffness, column: np.ndarray, row: np.ndarray, rhs: np.ndarray, load_factor: float) -> np.ndarray:
    """Solve [[K, column], [rowᵀ, 0]] x = rhs ((n + 1, k) → (n + 1, k)), the bordered system of a path
    that stays regular where K is singular (a limit point), through the package's LU."""
    import scipy.sparse as sp

    from latdyn.numerics.linalg import use_dense

    if isinstance(stiffness, np.ndarray) or use_dense(len(column) + 1):
        dense = stiffness if isinstance(stiffness, np.ndarray) else stiffness.toarray()
        matrix = np.block([[dense, column[:, None]], [row[None, :], np.zeros((1, 1))]])
    else:
        matrix = sp.bmat([[stiffness, sp.csr_matrix(column[:, None])], [sp.csr_matrix(row[None, :]), None]],
                         format="csr")
    try:
        return np.asarray(solve_linear(matrix, rhs)).reshape(len(column) + 1, -1)
    except np.linalg.LinAlgError:
        raise SolverError(f"the sensitivities at load factor {load_factor:.6g} need the path's bordered "
                          "matrix, which is singular there (a bifurcation point)") from None
