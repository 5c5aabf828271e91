"""Linear solves of the iteration matrix: dense LU for small systems, sparse LU beyond."""
from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

#: Models with at most this many free coordinates use dense matrices and LU.
DENSE_LIMIT = 600


def solve_linear(matrix, rhs: np.ndarray) -> np.ndarray:
    """Dense LU for dense or small systems, sparse LU beyond."""
    if isinstance(matrix, np.ndarray):
        return np.linalg.solve(matrix, rhs)
    if matrix.shape[0] <= DENSE_LIMIT:
        return np.linalg.solve(matrix.toarray(), rhs)
    return spla.splu(matrix.tocsc()).solve(rhs)
