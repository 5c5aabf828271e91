"""The maps of SO(3) the runtime uses: the cross product and the skew matrix of a vector, the
exponential map (Rodrigues) and its tangent operator, the rotation vector between two rotations (the generated
logarithm), the projection of a nearly orthogonal matrix back
onto SO(3), and the composition of two rotation vectors."""
from __future__ import annotations

import numpy as np


def cross(a, b) -> np.ndarray:
    """a × b of two 3-vectors, as ``np.cross`` computes it (each component one difference of two
    products, in its order: the same bits) without its general path for any shape and axis, which
    costs 15–30 µs a call where this costs 2–5: building a model calls it for every element and node."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def skew(w: np.ndarray) -> np.ndarray:
    """Batched cross-product matrices, (..., 3) -> (..., 3, 3)."""
    w = np.asarray(w, float)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def expm_so3(w: np.ndarray) -> np.ndarray:
    """Batched exponential map (Rodrigues), (..., 3) -> (..., 3, 3): the generated kernel ``so3_exp``
    (codegen/joints.py; its NumPy form here, its C form in the compiled step), branch-free and
    exact to round-off at small angles."""
    global _SO3_EXP
    if _SO3_EXP is None:
        from latdyn_generated.joints import so3_exp

        _SO3_EXP = so3_exp
    w = np.asarray(w, float)
    (rotation,) = _SO3_EXP(np.ascontiguousarray(w.reshape(-1, 3)))
    return np.asarray(rotation).reshape(w.shape[:-1] + (3, 3))


_SO3_EXP = None


def rotation_increment(before: np.ndarray, after: np.ndarray, kernels) -> np.ndarray:
    """The spatial rotation vector φ = log(``after`` ``before``ᵀ), (..., 3, 3) twice -> (..., 3): the turn
    exp(skew φ) that takes the rotation ``before`` to ``after`` (|φ| < π), the increment the spatial
    angular velocity integrates to: the generated kernel ``so3_log_increment`` (codegen/joints.py, the element's
    branch-free log map) of ``kernels`` (a :class:`latdyn.model.kernels.KernelSet`: C where compiled, the kernel
    the loop of steps in C calls, so the two give the same bits)."""
    before, after = np.asarray(before, float), np.asarray(after, float)
    (increment,) = kernels.so3_log_increment(np.ascontiguousarray(before.reshape(-1, 9)),
                                             np.ascontiguousarray(after.reshape(-1, 9)))
    return np.asarray(increment).reshape(before.shape[:-2] + (3,))


def dexp_so3(w: np.ndarray) -> np.ndarray:
    """Batched tangent operator of the exponential map in the spatial (left) form, (..., 3) -> (..., 3, 3):
    exp(skew(w + δw)) = exp(skew(J δw)) exp(skew w) to first order, J = I + (1 − cos θ)/θ² W + (θ − sin θ)/θ³ W²,
    W = skew w, θ = |w|: the generated kernel ``so3_dexp`` (codegen/joints.py; its NumPy form here, its C form in
    the compiled sensitivity step), branch-free and exact to round-off at small angles."""
    global _SO3_DEXP
    if _SO3_DEXP is None:
        from latdyn_generated.joints import so3_dexp

        _SO3_DEXP = so3_dexp
    w = np.asarray(w, float)
    (tangent,) = _SO3_DEXP(np.ascontiguousarray(w.reshape(-1, 3)))
    return np.asarray(tangent).reshape(w.shape[:-1] + (3, 3))


_SO3_DEXP = None


def orthonormalize(T: np.ndarray) -> np.ndarray:
    """Nearest rotations (polar decomposition), against round-off drift of long runs."""
    U, _, Vt = np.linalg.svd(T)
    return U @ Vt


def compose_rotation_vectors(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched log(exp(skew a) exp(skew b)), (n, 3), (n, 3) -> (n, 3): the rotation vector of b then a
    (spatial: T ← exp(skew a) exp(skew b) T), of angle ≤ π, through unit quaternions (q = (cos θ/2,
    sin(θ/2)/θ · v), their product, θ = 2 atan2(|q_v|, q_w) with q_w ≥ 0; the series of sin(θ/2)/θ below
    θ = 1e-4 and of atan2(n, w)/n below n = 1e-8 are exact to round-off there). Arc length composes a
    step's Newton increments with it (latdyn/analyses/continuation.py, ``Path.compose``): scipy's
    ``Rotation`` composition to round-off, at a quarter of its cost for 1000 nodes."""
    def quaternion(v):
        theta2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        small = theta2 < 1e-8
        half = 0.5 * np.sqrt(theta2)
        safe = np.where(small, 1.0, half)
        return np.cos(half), np.where(small, 0.5 - theta2 / 48.0, 0.5 * np.sin(safe) / safe) * v

    (wa, va), (wb, vb) = (quaternion(np.asarray(x, float).reshape(-1, 3).T) for x in (a, b))
    w = wa * wb - (va[0] * vb[0] + va[1] * vb[1] + va[2] * vb[2])
    v = wa * vb + wb * va + np.array([va[1] * vb[2] - va[2] * vb[1], va[2] * vb[0] - va[0] * vb[2],
                                      va[0] * vb[1] - va[1] * vb[0]])
    sign = np.where(w < 0.0, -1.0, 1.0)
    w, v = sign * w, sign * v
    n = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    tiny = n < 1e-8
    factor = np.where(tiny, 2.0 / np.where(tiny, w, 1.0), 2.0 * np.arctan2(n, w) / np.where(tiny, 1.0, n))
    return (factor * v).T
