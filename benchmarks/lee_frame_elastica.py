"""Lee's frame as the continuum: the extensible, shear-rigid elastica's limit load and snap-back minimum.

    python benchmarks/lee_frame_elastica.py [--inextensible]

The reference of tests/test_literature_cases_heldout5.py (``LEE_LIMIT``, ``LEE_MINIMUM``) and of
docs/verification.md ("Lee's frame"). L = 120 in, EA = 43200 kip, EI = 14400 kip in²; the column from
the pinned base (0, 0) to the rigid corner (0, 120), the beam to the pinned far end (120, 120), a dead
load P down at 24 in from the corner. Along each member: x' = (1 + ε) cos θ, y' = (1 + ε) sin θ,
θ' = m/EI, m' = −(x' n_y − y' n_x), ε = n·t/EA, with n the force the rest of the frame exerts on the
part from the base, −R before the load and −R + (0, P) after it (R the base's reaction). Unknowns
(θ₀, R_x, R_y, P); conditions: the far end at (120, 120) with m = 0. The path is traced by
pseudo-arc-length continuation from the unloaded frame (DOP853, rtol 1e-12; Newton to 1e-11), each turn
of P located by bisecting the step on the sign of dP/ds. Prints each extreme: P [kip], the load
point's deflection v [in] and its horizontal move u [in]. About a minute.
"""
from __future__ import annotations

import math
import sys

import numpy as np
from scipy.integrate import solve_ivp

EA, EI = 43200.0, 14400.0
EXTENSIBLE = "--inextensible" not in sys.argv
SCALE = np.array([1.0, 10.0, 10.0, 10.0])  # of θ₀, R_x, R_y, P in the continuation


def member(state, n, length):
    """Integrate one member from ``state`` = (x, y, θ, m) under the constant section force n."""
    def rates(s, u):
        c, s_ = math.cos(u[2]), math.sin(u[2])
        eps = (n[0] * c + n[1] * s_) / EA if EXTENSIBLE else 0.0
        xp, yp = (1 + eps) * c, (1 + eps) * s_
        return [xp, yp, u[3] / EI, -(xp * n[1] - yp * n[0])]
    return solve_ivp(rates, (0, length), state, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]


def far_end(theta0, rx, ry, P):
    """(the far end's misfit (x − 120, y − 120, m/EI), the load point (x, y))."""
    n = np.array([-rx, -ry])
    x, y, th, m = member([0.0, 0.0, theta0, 0.0], n, 120.0)
    x, y, th, m = member([x, y, th - math.pi / 2, m], n, 24.0)  # the rigid corner
    load = (x, y)
    x, y, th, m = member([x, y, th, m], n + np.array([0.0, P]), 96.0)
    return np.array([x - 120.0, y - 120.0, m / EI]), load


def residual(z):
    return far_end(*(z * SCALE))[0]


def jacobian(z):
    J = np.zeros((3, 4))
    for i in range(4):
        d = np.zeros(4)
        d[i] = 1e-7
        J[:, i] = (residual(z + d) - residual(z - d)) / 2e-7
    return J


def tangent(z, previous=None):
    t = np.linalg.svd(jacobian(z))[2][-1]
    return -t if previous is not None and t @ previous < 0 else t


def step(z, t, h):
    """The next point at arc length h along t (Newton on the residual and t·(z − z_pred) = 0)."""
    predicted = z + h * t
    z = predicted.copy()
    for _ in range(30):
        r, c = residual(z), t @ (z - predicted)
        if max(np.max(np.abs(r)), abs(c)) < 1e-11:
            return z, tangent(z, t)
        z = z - np.linalg.solve(np.vstack([jacobian(z), t]), np.r_[r, c])
    raise RuntimeError(f"Newton failed at arc length {h} from {z * SCALE}")


def main() -> None:
    z = np.array([math.pi / 2, 0.0, 0.0, 0.0])
    t = tangent(z)
    t = -t if t[3] < 0 else t
    path, h = [(z, t)], 0.02
    while len(path) < 2000:
        z, t = step(z, t, h)
        path.append((z, t))
        if path[-2][1][3] * t[3] < 0:  # P turned within the last step: bisect the step
            z0, t0 = path[-2]
            lo, hi = 0.0, h
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if step(z0, t0, mid)[1][3] * t0[3] > 0:
                    lo = mid
                else:
                    hi = mid
            zz = step(z0, t0, 0.5 * (lo + hi))[0] * SCALE
            load = far_end(*zz)[1]
            print(f"{'extensible' if EXTENSIBLE else 'inextensible'}: P = {zz[3]:.10f} kip, "
                  f"v = {120 - load[1]:.6f} in, u = {load[0] - 24:.6f} in", flush=True)
            if zz[3] < 0:
                break


if __name__ == "__main__":
    main()
