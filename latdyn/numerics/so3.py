"""The maps of SO(3) the runtime uses: the skew matrix of a vector, the exponential map
(Rodrigues), and the projection of a nearly orthogonal matrix back onto SO(3)."""
from __future__ import annotations

import numpy as np


def skew(w: np.ndarray) -> np.ndarray:
    """Batched cross-product matrices, (..., 3) -> (..., 3, 3)."""
    w = np.asarray(w, float)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def expm_so3(w: np.ndarray) -> np.ndarray:
    """Batched exponential map (Rodrigues), (..., 3) -> (..., 3, 3)."""
    w = np.asarray(w, float)
    angle = np.linalg.norm(w, axis=-1)[..., None, None]
    W = skew(w)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    return np.eye(3) + a * W + b * (W @ W)


def orthonormalize(T: np.ndarray) -> np.ndarray:
    """Nearest rotations (polar decomposition), against round-off drift of long runs."""
    U, _, Vt = np.linalg.svd(T)
    return U @ Vt
