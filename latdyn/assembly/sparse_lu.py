"""The symbolic analysis of the compiled sparse LU (``csrc/sparse_lu.c``), made once per pattern.

A matrix too wide for a band LU (see :mod:`latdyn.numerics.linalg`) -- the compiled step's Newton
iteration matrix S = β′M + γ′C + K, or any matrix an analysis solves with -- is factorized by a
supernodal LU in C, in a static order and without pivoting.  Everything that depends only on
the sparsity pattern is done here, once, in NumPy, and reused until the pattern changes (a hinge latches):

1. *Nodes.*  Coordinates whose rows have the same pattern (the 6 of a node in 3D, the 3 of
   a planar node, a hinge's one) are indistinguishable: they are ordered together and form
   one vertex of the *node graph* (Davis, Direct Methods for Sparse Linear Systems, §7.1,
   "supervariables").  Ordering that graph is 6–36× cheaper than ordering the coordinates.
2. *Ordering.*  Minimum degree on the node graph (Tinney–Walker scheme 2, George & Liu 1989),
   the degree of a vertex being the number of coordinates it is joined to, with the graph
   of the remaining vertices updated by each elimination (the elimination graph, kept as
   sets).  The neighbours of a vertex when it is eliminated are the nodes of its column of
   L: the ordering yields the symbolic factorization as it goes.
3. *Supernodes.*  Consecutive nodes k, k + 1 share one supernode when k + 1 is k's parent in
   the elimination tree and column k's structure is k + 1's plus k + 1 itself (fundamental
   supernodes, Liu, Ng & Peyton 1993), or when the zeros that merging stores are few
   (relaxed amalgamation, :data:`RELAX`); the columns of a supernode are dense blocks.
4. *Positions.*  The offset in the factor storage (``csrc/sparse_lu.c`` describes it) of every
   entry (row, col) of S, so that the matrix is assembled straight into the factor.

:class:`latdyn.assembly.factorization.Factorization` holds an analysis for a matrix too wide for a
band LU and runs the C factorization (``csrc/factorization.c``) on it.
"""
from __future__ import annotations

import heapq
from typing import TYPE_CHECKING

import numpy as np

from latdyn.assembly.library import SparseLUStructure, cython_address, scipy_extension

if TYPE_CHECKING:
    import scipy.sparse as sps

#: A pivot whose magnitude is at most this times the largest entry of its row and column in
#: the matrix stops the factorization (csrc/sparse_lu.c): without pivoting, the factor would
#: have lost ten digits to growth, or the matrix is singular.
PIVOT_TOLERANCE = 1e-10


class PivotError(np.linalg.LinAlgError):
    """The static-order LU met a pivot too small for its row and column (singular matrix, or one
    that needs pivoting)."""


# ----------------------------------------------------------------------------- ordering


def coordinate_nodes(pattern: sps.csr_matrix) -> tuple[np.ndarray, int]:
    """Group indistinguishable coordinates: those whose rows of the (symmetric, diagonal
    included) pattern are equal.  Returns (node of each coordinate, number of nodes)."""
    n = pattern.shape[0]
    indptr, indices = pattern.indptr, pattern.indices
    seen: dict[bytes, int] = {}
    node = np.empty(n, np.int64)
    for i in range(n):
        node[i] = seen.setdefault(indices[indptr[i]:indptr[i + 1]].tobytes(), len(seen))
    return node, len(seen)


def minimum_degree(adjacency: list[set], weight: np.ndarray) -> tuple[list[int], list[list[int]]]:
    """Minimum-degree elimination order of a graph whose vertex v stands for ``weight[v]``
    coordinates; the degree of v is the total weight of its neighbours in the elimination
    graph (ties: the lower vertex).  Returns the order and, for each vertex, its neighbours
    when eliminated (the structure of its column of L).  ``adjacency`` is consumed."""
    count = len(adjacency)
    w = [int(x) for x in weight]
    degree = [sum(map(w.__getitem__, adjacency[v])) for v in range(count)]
    heap = [(degree[v], v) for v in range(count)]
    heapq.heapify(heap)
    eliminated = [False] * count
    order, structure = [], [None] * count
    while heap:
        d, p = heapq.heappop(heap)
        if eliminated[p] or d != degree[p]:
            continue  # a stale entry: p was eliminated or its degree changed since
        eliminated[p] = True
        order.append(p)
        clique = adjacency[p]
        structure[p] = list(clique)
        adjacency[p] = set()
        for u in clique:  # the neighbours of p become a clique (the elimination graph)
            neighbours = adjacency[u]
            neighbours |= clique
            neighbours.discard(u)
            neighbours.discard(p)
            degree[u] = sum(map(w.__getitem__, neighbours))
            heapq.heappush(heap, (degree[u], u))
    return order, structure


# ----------------------------------------------------------------------------- supernodes

#: Relaxed amalgamation (CHOLMOD's rule, Chen et al. 2008, §4.1; Ashcraft & Grimes 1989): node k
#: joins the supernode of node k − 1, whose parent it is, when the merged supernode has at most
#: `columns` columns and at most `fraction` of its stored L + U entries are zeros; merges that
#: store no zeros (fundamental supernodes) are always made.  (columns, fraction) pairs, any of
#: which admits the merge.  Measured on the lattices of benchmarks/sparse_lu.py: few merges
#: beyond the fundamental ones (931 elements: 539 → 532 supernodes, 0.5 % zeros), no change in
#: the factorization time beyond the noise; nodes of 6 coordinates make wide supernodes already.
RELAX = ((16, 0.8), (48, 0.1), (1 << 62, 0.05))


def supernode_starts(parent: list[int], weight: list[int], below: list[int],
                     relax=RELAX) -> list[int]:
    """Supernode partition of nodes 0 … N − 1 in elimination order: the first node of each
    supernode, and N.  ``weight[k]``: coordinates of node k, ``below[k]``: coordinates in its
    column's structure (the nodes of L's column k below the diagonal)."""
    count = len(parent)
    starts = [0]
    columns = weight[0] if count else 0
    zeros = 0  # stored zeros of L + U in the current supernode
    for k in range(1, count):
        if parent[k - 1] == k:
            # the current supernode's columns take k's column structure: {k} ∪ struct(k)
            extra = 2 * columns * (weight[k] + below[k] - below[k - 1])
            merged_columns = columns + weight[k]
            entries = merged_columns * merged_columns + 2 * merged_columns * below[k]
            if extra == 0 or any(merged_columns <= c and zeros + extra <= f * entries for c, f in relax):
                columns, zeros = merged_columns, zeros + extra
                continue
        starts.append(k)
        columns, zeros = weight[k], 0
    starts.append(count)
    return starts


# ----------------------------------------------------------------------------- the analysis


class SupernodalAnalysis:
    """Order, supernodes, row structures and storage of the LU of an n × n matrix with the
    pattern (rows, cols) (duplicates allowed; symmetrized, and the diagonal added).

    ``new[i]``: the place of coordinate i in the factor's order, ``perm`` its inverse;
    ``first``: the first column of each supernode (and n); ``rows_start``/``rows``: each
    supernode's row structure below its diagonal block; ``lower``/``upper``: the offsets of its
    panels in the factor storage of ``size`` doubles (the zeros of relaxed supernodes
    included); ``nonzeros``: the structural nonzeros of L + U (the diagonal once)."""

    def __init__(self, rows: np.ndarray, cols: np.ndarray, n: int):
        import scipy.sparse as sps  # on use: the dense and band LU's models run without it

        rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
        self.n = n
        diagonal = np.arange(n)
        pattern = sps.csr_matrix((np.ones(2 * len(rows) + n), (np.concatenate([rows, cols, diagonal]),
                                                                np.concatenate([cols, rows, diagonal]))),
                                 shape=(n, n))
        pattern.sum_duplicates()
        pattern.sort_indices()
        node, count = coordinate_nodes(pattern)
        weight = np.bincount(node, minlength=count)
        coo = pattern.tocoo()
        a, b = node[coo.row], node[coo.col]
        keep = a != b
        pairs = np.unique(a[keep] * count + b[keep])
        adjacency = [set() for _ in range(count)]
        for v, u in zip((pairs // count).tolist(), (pairs % count).tolist()):
            adjacency[v].add(u)
        order, structure = minimum_degree(adjacency, weight)

        # coordinates in node order (a node's coordinates consecutive, in their own order)
        rank = np.empty(count, np.int64)
        rank[order] = np.arange(count)
        self.perm = np.lexsort((np.arange(n), rank[node])).astype(np.int64)
        self.new = np.empty(n, np.int64)
        self.new[self.perm] = np.arange(n)
        self.nodes = count
        node_first = np.concatenate([[0], np.cumsum(weight[order])]).astype(np.int64)
        # each node's structure as sorted node places, and its parent in the elimination tree
        places = [np.sort(rank[structure[v]]) if structure[v] else np.zeros(0, np.int64) for v in order]
        parent = [int(s[0]) if len(s) else -1 for s in places]

        node_weight = weight[order]
        node_below = np.array([int(np.sum(node_weight[p])) for p in places], np.int64)
        starts = supernode_starts(parent, node_weight.tolist(), node_below.tolist(), RELAX)
        first, rows_start, row_lists = [], [0], []
        for s, e in zip(starts[:-1], starts[1:]):
            first.append(node_first[s])
            last = places[e - 1]
            if len(last):
                row_lists.append(np.concatenate([np.arange(node_first[q], node_first[q + 1]) for q in last]))
            else:
                row_lists.append(np.zeros(0, np.int64))
            rows_start.append(rows_start[-1] + len(row_lists[-1]))
        first.append(n)
        self.first = np.asarray(first, np.int64)
        self.rows_start = np.asarray(rows_start, np.int64)
        self.rows = np.concatenate(row_lists).astype(np.int64) if row_lists else np.zeros(0, np.int64)
        self.n_supernodes = len(first) - 1
        columns = np.diff(self.first)
        below = np.diff(self.rows_start)
        self.supernode = np.repeat(np.arange(self.n_supernodes), columns).astype(np.int64)
        panel = (columns + below) * columns
        self.lower = np.concatenate([[0], np.cumsum(panel + below * columns)[:-1]]).astype(np.int64)
        self.upper = self.lower + panel
        self.size = int(np.sum(panel + below * columns))
        self.nonzeros = int(np.sum(node_weight * node_weight + 2 * node_weight * node_below))
        self.update_size = int(max(below.max(initial=0), 1) * max(columns.max(initial=0), 1))
        # the key of every row-structure entry, for rank lookups: supernode · n + row
        self._keys = np.repeat(np.arange(self.n_supernodes), below) * n + self.rows
        self._structure = None

    def _below(self, J: np.ndarray, row: np.ndarray) -> np.ndarray:
        """Index of each row in its supernode J's row structure (it must be there)."""
        keys = J * self.n + row
        found = np.searchsorted(self._keys, keys)
        if np.any(found >= len(self._keys)) or np.any(self._keys[np.minimum(found, len(self._keys) - 1)] != keys):
            raise AssertionError("sparse LU analysis: a matrix entry outside the factor's structure")
        return found - self.rows_start[J]

    def position(self, rows, cols) -> np.ndarray:
        """Offsets in the factor storage of the entries (rows, cols) of the matrix; −1 where a
        row or column is ≥ n (a constrained coordinate)."""
        rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
        shape = np.broadcast(rows, cols).shape
        rows, cols = np.broadcast_to(rows, shape).ravel(), np.broadcast_to(cols, shape).ravel()
        out = np.full(rows.shape, -1, np.int64)
        ok = (rows >= 0) & (rows < self.n) & (cols >= 0) & (cols < self.n)
        r, c = self.new[rows[ok]], self.new[cols[ok]]
        lower = r >= c
        J = self.supernode[np.where(lower, c, r)]  # the supernode holding column c of L or row r of U
        c0, c1 = self.first[J], self.first[J + 1]
        ld = (c1 - c0) + np.diff(self.rows_start)[J]
        below = np.diff(self.rows_start)[J]
        pos = np.empty(len(r), np.int64)
        in_block = np.where(lower, r, c) < c1  # both in J's diagonal block
        d = in_block
        pos[d] = self.lower[J[d]] + (r[d] - c0[d]) + (c[d] - c0[d]) * ld[d]
        m = lower & ~in_block  # L21
        pos[m] = self.lower[J[m]] + (c1[m] - c0[m]) + self._below(J[m], r[m]) + (c[m] - c0[m]) * ld[m]
        u = ~lower & ~in_block  # U12, stored transposed
        pos[u] = self.upper[J[u]] + self._below(J[u], c[u]) + (r[u] - c0[u]) * below[u]
        out[ok] = pos
        return out.reshape(shape)

    def structure(self, gemm: int, trsm: int) -> SparseLUStructure:
        """The C view of the analysis with its scratch (made once, kept by the analysis)."""
        if self._structure is None:
            self._arrays = {name: np.ascontiguousarray(getattr(self, name)) if len(getattr(self, name))
                            else np.zeros(1, np.int64)
                            for name in ("first", "rows_start", "rows", "lower", "upper", "supernode")}
            self._scratch = {"map": np.zeros(max(self.n, 1), np.int64),
                             "head": np.zeros(max(self.n_supernodes, 1), np.int64),
                             "next": np.zeros(max(self.n_supernodes, 1), np.int64),
                             "cursor": np.zeros(max(self.n_supernodes, 1), np.int64),
                             "update": np.zeros(self.update_size), "scale": np.zeros(max(self.n, 1)),
                             "relative": np.zeros(max(self.n, 1), np.int64)}
            pointers = {name: a.ctypes.data for name, a in {**self._arrays, **self._scratch}.items()}
            self._structure = SparseLUStructure(n=self.n, n_supernodes=self.n_supernodes,
                                                pivot_tolerance=PIVOT_TOLERANCE, gemm=gemm, trsm=trsm,
                                                failed_column=-1, failed_ratio=0.0, **pointers)
        return self._structure

    def pivot_failure(self) -> str | None:
        """What stopped the last factorization, or None."""
        s = self._structure
        if s is None or s.failed_column < 0:
            return None
        coordinate = int(self.perm[s.failed_column])
        return (f"sparse LU: the pivot of coordinate {coordinate} is {s.failed_ratio:.3g} × the largest entry of "
                f"its row and column (at most {PIVOT_TOLERANCE:g}): the matrix is singular or needs pivoting")


# ----------------------------------------------------------------------------- BLAS


def blas_kernels() -> tuple[int, int]:
    """(dgemm, dtrsm) from SciPy's BLAS."""
    blas = scipy_extension("linalg.cython_blas")

    return cython_address(blas, "dgemm"), cython_address(blas, "dtrsm")


__all__ = ["PIVOT_TOLERANCE", "PivotError", "SupernodalAnalysis", "minimum_degree", "blas_kernels"]
