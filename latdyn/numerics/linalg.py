"""The policy of the linear solves (storage by size and bandwidth, RCM order, BLAS threads), and the
null direction of a PSD pencil.  The solves themselves are the one factorization of
:mod:`latdyn.assembly.factorization` (C: ``csrc/factorization.c``), for the compiled step and the
analyses alike; the tables below chose its limits.

Policy, chosen by measurement: ``python benchmarks/linear_solvers.py``, full
table in benchmarks/results/linear_solvers.json.  AMD EPYC, 2 cores of a KVM
guest shared with other jobs (load average 1.6–3 during the run), OpenBLAS
0.3.30/0.3.31; median ms of one Newton solve *including* the assembly of
S = β′M + γ′C + K (Newmark, h = 0.01); "1/2" = BLAS limited to 1 / 2 threads:

    model          n      RCM bw  dense LU      SuperLU   SuperLU   SuperLU     band LU     latdyn
                                  (gesv) 1/2    COLAMD    MMD sym   scaled,     (gbsv) 1/2  policy
                                                (default)           reused
    beam 10 el     66     11      0.061/0.061   0.16      0.16      0.19        0.10        0.074 dense
    beam 20 el     126    11      0.19/0.20     0.20      0.21      0.23        0.125       0.117 dense
    beam 24 el     150    11      0.27/0.26     0.22      0.22      0.24        0.137       0.128 band
    beam 64 el     390    11      2.4/9.7       0.43      0.40      0.45        0.25        0.25  band
    beam 400 el    2406   11      665/493       6.8       6.1       2.5         1.3         1.6   band
    beam 5000 el   30006  11      —             41        41        43          22          19    band
    lattice 32 el  148    53      0.30/0.31     0.43      0.37      0.32        0.27        0.26  band
    lattice 63 el  180    65      0.50/0.51     0.73      0.57      0.53        0.63/0.85   0.55  band
    lattice 120    324    80      1.7/9.3       1.9       1.1       0.85        0.90/8.8    0.69  band
    lattice 260    680    141     24/81         6.8       3.6       2.1         3.1/321     2.1   SuperLU
    lattice 931    2352   434     456/464       47        43        13          —           14    SuperLU
    lattice 4896   11952  975     —             1660      3170      345         —           346   SuperLU

(single entries are noisy by up to ×2 on this shared machine — an earlier,
busier run had dense LU at n = 198 take 0.76 ms on one thread and 254 ms on
two — but the choices below hold in each of the three full runs.)

* **Dense only for small systems.** Dense LU costs ⅔n³ and a zero-filled n×n
  array, a sparse solve a fixed ~0.1 ms of set-up: they cross at n ≈ 120 for a
  beam (17 nonzeros a row) and n ≈ 150–180 for a 3D lattice (20–30 a row) →
  ``DENSE_LIMIT = 120``, on n alone: a nonzero-dependent limit would gain at
  most ~0.05 ms a solve for lattices of 120–180 coordinates.  The former limit,
  600, made the 64-element flying spaghetti (390 coordinates) dense: 2.4 ms a
  solve on one thread, 10–300 ms on two, against 0.25 ms now (1 s of its
  D3 run: 6–15 s before, 1.4–2 s now).
* **BLAS pinned to one thread around LAPACK calls** (dense ``gesv`` and band
  ``gbsv``): on a machine where another job holds a core, OpenBLAS's second
  thread costs far more than it gains (n = 390 dense 2.4 → 9.7 ms, n = 102 in
  a busier run 0.29 → 216 ms; the band solve of lattice 260: 3.1 → 321 ms).
  Unloaded, these sizes are still too small for two threads to pay.  SuperLU
  does not use threaded BLAS here (1 and 2 threads time alike).  The pin is
  taken and released around each factorization and solve, in C
  (``csrc/factorization.c``, through the OpenBLAS functions that
  :func:`openblas_thread_functions` finds with threadpoolctl), so the caller's
  BLAS setting is untouched; without threadpoolctl nothing is pinned.
  :func:`single_thread_blas` does the same around the LAPACK calls left in
  Python (the inertia count of static paths).
* **Sparse: band LU when the reverse Cuthill–McKee bandwidth is small, else
  SuperLU.**  A chain of beams has bandwidth 11 after RCM whatever its length,
  and LAPACK's band LU (partial pivoting) beats every SuperLU variant 1.5–2×.
  A 3D lattice's bandwidth grows like n^⅔; band LU ties with SuperLU at
  bandwidth 53–80 and loses from 141 on (×1.5 there, ×5 at 190) →
  ``BAND_LIMIT = 100``.  Beyond, SuperLU on the
  Jacobi-scaled matrix D S D (D = |diag S|^(-1/2)), minimum-degree ordering of
  AᵀA + A in symmetric mode with threshold pivoting 0.1: with a unit diagonal
  the pivots stay on the diagonal and keep the ordering's fill (lattice 6210:
  2.1 M nonzeros in L + U against 4.9 M unscaled and 5.5 M with COLAMD,
  SuperLU's default, which is 3–5× slower).  Both analyses are made once per
  sparsity pattern and reused while it lasts (it changes only when a hinge
  latches): the RCM order and the band scatter map; SuperLU's column order
  from the first factorization, after which the values are scattered straight
  into the permuted CSC matrix and factorized in that order (SuperLU has no
  separate symbolic step; skipping its ordering saves 1.2–3×).

**Beyond the band: a supernodal sparse LU in C.**  SuperLU (above) was the analyses' solver
until the factorization was made one (:mod:`latdyn.assembly.factorization`); now every matrix
whose RCM bandwidth exceeds BAND_LIMIT, the compiled step's (latdyn/step/compiled.py) and the
analyses' alike, is factorized with ``csrc/sparse_lu.c``: minimum degree on the node graph
and a supernodal symbolic analysis once per pattern (:mod:`latdyn.assembly.sparse_lu`), the matrix
assembled straight into the factor storage, a left-looking supernodal LU without pivoting
(BLAS dgemm/dtrsm blocks, every pivot checked against its row's and column's scale) and the
substitutions in C.  ``python benchmarks/sparse_lu.py --compare-band``, results in
benchmarks/results/sparse_lu.json: same 2-core AMD EPYC, load average 0.7 → 2.9 during the
run (another job took one core), OpenBLAS pinned to one thread; 3D lattices as above.  Fill:
nonzeros of L + U (the diagonal once); analysis: once per pattern; LU: one factorization and
solve of S alone (C sparse LU: scatter + factor + solve; SuperLU: scaled, order reused, as
the analyses then solved); Newton iteration: one iteration of a generalized-α step, everything included,
the element part serial in both steps (wall ms, fastest of 3 rounds of 4 steps):

    model          n      RCM   fill L+U (10³)   analysis  LU, ms              Newton iteration, ms
                          bw    ours   SuperLU   ms        C sparse  SuperLU   compiled  compiled  Python
                                       MMD                                     sparse    band      SuperLU
    lattice 120    324    80    24.2   24.2      2         0.25      0.71      3.5       3.7       7.3
    lattice 260    680    141   74.1   72.9      6         0.84      2.1       7.5       12.5      11.1
    lattice 480    1230   190   177    174       17        2.5       7.9       17.6      28.6      27.1
    lattice 931    2352   434   441    434       46        8.2       18.1      30.9      79.0      40.6
    lattice 2520   6210   814   2027   2085      239       49        115       109       —         221
    lattice 4896   11952  975   5703   5694      975       169       440       336       —         658
    beam 64 el     390    11                                                   2.0       1.8
    beam 400 el    2406   11                                                   11.4      14.0
    beam 5000 el   30006  11                                                   163       174

* **Fill and speed.**  Minimum degree on the node graph (6 coordinates a node) gives SuperLU's
  MMD fill to within −3 … +2 %, and the static order keeps it; the LU is 2.2–3.2× faster than
  SuperLU (4896 elements: 3.9 GFlop in 166 ms, 24 GFlop/s on one core, dgemm's rate) and equals
  it to 2e-14.  The compiled step's Newton iteration was 1.3–2.1× faster than the Python step's (removed by issue 17)
  on the lattices, where the element kernels share the time; a quieter run (load 1.1–1.2) gave
  the same ratios (e.g. 4896 elements: 283 against 536 ms).  The analysis (NumPy and Python
  sets) costs about three compiled iterations at 12 000 coordinates (1 s), once per pattern
  (a latch re-runs it).
* **Band LU kept up to BAND_LIMIT = 100.**  Band and sparse LU tie at RCM bandwidth 80 (3.5
  against 3.7 ms, 3.4 / 3.7 on a rerun) and on chains (bandwidth 11: within ±20 %, either way by
  size), and the sparse LU wins from 141 on (×1.7 there, ×2.6 at 434); the band LU pivots
  (partial pivoting: no pivot can fail), so it keeps the range where it ties.  Without
  pivoting the sparse LU relies on the β′M-dominated diagonal; a pivot smaller than 1e-10 of
  its row's and column's largest entry (:data:`latdyn.assembly.sparse_lu.PIVOT_TOLERANCE`) fails the
  factorization, and the step is reported not converged, like a singular band LU.
* **OpenBLAS on one thread in the compiled step too** (``openblas_thread_functions``: the
  compiled factorization sets and restores SciPy's OpenBLAS thread count around dense, band and
  sparse LU alike).  Left on two threads with the other core busy, the sparse LU's dgemm calls
  took 16 ms instead of 0.25 at n = 324 and 1.2 s instead of 49 ms at 6210; on a quieter
  machine two threads gained at most 1.3× (12 000 coordinates: 127 against 163 ms).  Before
  this, the compiled band LU ran unpinned too: lattice of 120 elements 30–120 ms an iteration
  against 4.6 ms pinned, under load.

``latdyn.assembly.factorization.solve_linear(matrix, rhs)`` dispatches on the matrix: a NumPy
array is solved densely; a SciPy sparse matrix densely when n ≤ DENSE_LIMIT, else band or
sparse LU as above (natively, BLAS held to one thread in C).  ``Assembler.assemble`` returns a
dense array exactly when n ≤ DENSE_LIMIT, so the iteration matrix is assembled in the form it is
solved in.

``psd_null_direction(A)`` finds a direction x with xᵀAx ≈ 0 for a sparse
symmetric positive semi-definite A with unit diagonal (the held-coordinate
check of the scene, see :meth:`latdyn.model.model.Model.check_held`), by inverse
iteration with one sparse LU of A + δI: at any size, without a dense
eigen-solve (10⁴ coordinates: 13 ms for a beam, 51 ms for a 3D lattice).  A dense A (a model
of at most DENSE_LIMIT coordinates, assembled as a NumPy array) gets its exact smallest
eigenpair instead (``numpy.linalg.eigh``), with neither SciPy's sparse package nor NumPy's random
generator imported.
"""
from __future__ import annotations

import sys
from contextlib import contextmanager

import numpy as np

# scipy.sparse (and its linalg and csgraph) is imported where it is used: a model that the dense
# LU serves runs without it (the import costs more CPU time than a short run; docs/performance.md,
# "First run"). `issparse` tells a SciPy sparse matrix without importing SciPy.

#: Models with at most this many free coordinates use dense matrices and LU.
DENSE_LIMIT = 120

#: A model of at most DENSE_LIMIT coordinates whose bandwidth after reverse Cuthill–McKee
#: (:func:`small_rcm_band`) is at most this fraction of its size takes the band LU, not the dense
#: one: a chain of beams has bandwidth 11 at any length. LAPACK's factorization, one core, C calls
#: alone (2026-11-26, 2-core Intel Xeon, load 6–8): n = 48, bandwidth 11: dense 25 µs, band 7.4;
#: n = 96, 11: 92 against 12.5 (the 16-element right-angle cantilever); 96, 17: 100 / 29;
#: 120, 23: 167 / 52; 96, 24: 184 / 75; at a third of n they tie or the band loses (96, 32:
#: 157 / 120; 120, 40: 166 / 224); n = 24–32 tie (5–7 µs). Solves cost alike (4–8 µs).
SMALL_BAND_FRACTION = 0.25

#: Sparse systems whose half-bandwidth after reverse Cuthill–McKee is at most
#: this use LAPACK band LU; wider ones the supernodal sparse LU of csrc/sparse_lu.c
#: (latdyn.assembly.factorization, for the compiled step and the analyses alike).
BAND_LIMIT = 100

#: Dense symmetric eigenproblems above this size are solved with BLAS on one thread
#: (:func:`psd_null_direction`). Measured 2026-11-26 on the 2-core AMD EPYC, load ≈ 10, OpenBLAS
#: free to take both cores: n = 120 took 1.5 ms in one round and 53 ms in another, on one thread
#: 0.9 ms; n = 24–96 took 0.05–0.85 ms.
SINGLE_THREAD_EIGH = 64

#: SuperLU options of the comparisons with SciPy (tests/test_sparse_lu.py, benchmarks/sparse_lu.py): minimum
#: degree on AᵀA + A, diagonal pivots preferred.
SUPERLU_OPTIONS = {"diag_pivot_thresh": 0.1, "options": {"SymmetricMode": True}}


def issparse(matrix) -> bool:
    """Whether ``matrix`` is a SciPy sparse matrix or array; without importing scipy.sparse, which
    cannot have made one when it is not imported."""
    sparse = sys.modules.get("scipy.sparse")
    return sparse is not None and sparse.issparse(matrix)


# ----------------------------------------------------------------------------- BLAS threads

_blas = None  # list of threadpoolctl library controllers, [] when unavailable


def _blas_controllers(refresh: bool = False) -> list:
    """threadpoolctl's controllers of the BLAS libraries loaded when first asked (``refresh``: now)."""
    global _blas
    if _blas is None or refresh:
        try:
            from threadpoolctl import ThreadpoolController

            _blas = list(ThreadpoolController().select(user_api="blas").lib_controllers)
        except Exception:  # noqa: BLE001 - threadpoolctl missing or unable to inspect: leave BLAS alone
            _blas = []
    return _blas


@contextmanager
def single_thread_blas():
    """Limit the BLAS libraries (NumPy's and SciPy's) to one thread inside the block."""
    saved = []
    for lib in _blas_controllers():
        try:
            k = lib.get_num_threads()
            if k is not None and k != 1:
                lib.set_num_threads(1)
                saved.append((lib, k))
        except Exception:  # noqa: BLE001
            pass
    try:
        yield
    finally:
        for lib, k in saved:
            lib.set_num_threads(k)


def _in_scipy_folder(path) -> bool:
    """Whether a library lies in SciPy's own folders (``scipy.libs/``, ``scipy/.dylibs/``): by the
    folders, not the file's name, which NumPy's OpenBLAS shares (``numpy.libs/libscipy_openblas64_…``)."""
    from pathlib import PurePath

    return any(part == "scipy" or part.startswith("scipy.") for part in PurePath(str(path)).parent.parts)


#: OpenBLAS's symbol affixes (threadpoolctl's ``OpenBLASController``: SciPy's wheels build it as
#: ``scipy_openblas_get_num_threads``, ILP64 builds add ``64_``).
_OPENBLAS_AFFIXES = tuple((prefix, suffix) for prefix in ("", "scipy_") for suffix in ("", "64_", "_64"))

_thread_functions: tuple[int | None, int | None] | None = None  # found once per process


def loaded_openblas(belongs):
    """Linux: the one OpenBLAS library this process has loaded whose file ``belongs(path)`` (by its folder:
    SciPy's for :func:`openblas_thread_functions`, NumPy's for :func:`latdyn.assembly.library.numpy_lapack`),
    opened without loading it again, as ``/proc/self/maps`` shows it; None where that file cannot be read, or
    none or several such libraries are loaded."""
    import ctypes
    import os

    try:
        with open("/proc/self/maps", "rb") as maps:
            paths = {line.split(maxsplit=5)[-1].strip().decode() for line in maps if b"openblas" in line}
    except (OSError, UnicodeDecodeError):
        return None
    own = sorted(p for p in paths if p.startswith("/") and "openblas" in os.path.basename(p).lower() and belongs(p))
    if len(own) != 1:
        return None
    try:
        return ctypes.CDLL(own[0], mode=getattr(os, "RTLD_NOLOAD", 0) | ctypes.RTLD_LOCAL)  # already loaded
    except OSError:
        return None


def _in_numpy_folder(path) -> bool:
    """Whether a library lies in NumPy's own folders (``numpy.libs/``, ``numpy/.dylibs/``)."""
    from pathlib import PurePath

    return any(part == "numpy" or part.startswith("numpy.") for part in PurePath(str(path)).parent.parts)


def _loaded_thread_functions(belongs):
    """``(get, set)`` of the thread count of the one OpenBLAS loaded from the folder ``belongs`` accepts
    (:func:`loaded_openblas`), as ctypes functions; None where there is none."""
    import ctypes

    library = loaded_openblas(belongs)
    if library is None:
        return None
    for prefix, suffix in _OPENBLAS_AFFIXES:
        get = getattr(library, f"{prefix}openblas_get_num_threads{suffix}", None)
        put = getattr(library, f"{prefix}openblas_set_num_threads{suffix}", None)
        if get is not None and put is not None:
            get.restype, get.argtypes = ctypes.c_int, []
            put.restype, put.argtypes = None, [ctypes.c_int]
            return get, put
    return None


#: The thread functions :func:`blas_on_one_thread` found, by library (``numpy``, ``scipy``): kept for the process.
_PINNABLE: dict = {}


@contextmanager
def blas_on_one_thread():
    """NumPy's and SciPy's OpenBLAS (SciPy's where its LAPACK is imported) on one thread inside the block, their
    counts restored after it: :func:`latdyn.run` as ``latdyn run`` runs (latdyn.cli.one_blas_thread), so that a
    scene gives the same bits through the API as through the command, whatever the machine's cores. A product
    that OpenBLAS splits across threads adds in another order: examples/cable_deploying_truss.yaml's probes.csv
    differed in its last bits from its third row on where NumPy's OpenBLAS ran two threads (NumPy's products in
    the run's Python), and equals the command's on one. Nothing to do where ``OPENBLAS_NUM_THREADS`` is 1 (the
    command sets it before NumPy loads); Linux's ``/proc/self/maps`` finds each library once a process (≈ 2.5
    ms), elsewhere nothing is pinned. SciPy's OpenBLAS first loaded inside the block (a modal analysis's
    eigensolver, the dense LU's LAPACK) starts on one thread (``OPENBLAS_NUM_THREADS`` is 1 inside the block) and
    is given the caller's count after it (the count NumPy's had): before, it ran on the machine's cores, and a
    free hub's modes.csv through the API differed from the command's in its last bits (fuzz4)."""
    import os

    pinned, variable = [], os.environ.get("OPENBLAS_NUM_THREADS")
    scipy_loaded = "scipy.linalg.cython_lapack" in sys.modules
    callers = None   # NumPy's OpenBLAS's count before the block: the caller's
    if variable != "1":
        for name, belongs in (("numpy", _in_numpy_folder), ("scipy", _in_scipy_folder)):
            if name == "scipy" and not scipy_loaded:
                continue   # SciPy's OpenBLAS is not loaded (nor looked for)
            if name not in _PINNABLE:
                _PINNABLE[name] = _loaded_thread_functions(belongs)
            functions = _PINNABLE[name]
            if functions is not None and functions[0]() != 1:
                pinned.append((functions[1], functions[0]()))
                functions[1](1)
            if name == "numpy" and functions is not None:
                callers = pinned[-1][1] if pinned else functions[0]()
    watched = callers is not None   # where NumPy's count is known (Linux), it is given to a SciPy loaded inside
    if watched:
        os.environ["OPENBLAS_NUM_THREADS"] = "1"   # an OpenBLAS loaded inside the block starts on one thread
    try:
        yield
    finally:
        if watched:
            if variable is None:
                os.environ.pop("OPENBLAS_NUM_THREADS", None)
            else:
                os.environ["OPENBLAS_NUM_THREADS"] = variable
            if not scipy_loaded and callers != 1 and "scipy" in sys.modules:
                functions = _loaded_thread_functions(_in_scipy_folder)   # loaded inside the block, on one thread
                if functions is not None:
                    _PINNABLE["scipy"] = functions
                    functions[1](callers)
        for put, count in pinned:
            put(count)


def _scipy_openblas_from_maps() -> tuple[int | None, int | None] | None:
    """Linux: the addresses of the thread functions of the OpenBLAS that ``/proc/self/maps`` shows loaded from SciPy's
    folder (:func:`_loaded_thread_functions`); None where that file is not there or shows no such library (then
    threadpoolctl looks, which inspects every loaded library: 8–10 ms of a 5-step run's process,
    docs/performance.md, "First run")."""
    import ctypes

    functions = _loaded_thread_functions(_in_scipy_folder)
    if functions is None:
        return None
    return tuple(ctypes.cast(function, ctypes.c_void_p).value for function in functions)


def openblas_thread_functions() -> tuple[int | None, int | None]:
    """Addresses of ``openblas_get_num_threads`` and ``openblas_set_num_threads`` of the OpenBLAS
    behind SciPy's cython_blas / cython_lapack (the library under SciPy's folder, or the only
    OpenBLAS loaded), for the compiled step to pin its LAPACK and BLAS calls to one thread as
    :func:`single_thread_blas` does; (None, None) when there is no such library or no
    threadpoolctl (then nothing is pinned). Ask after SciPy's LAPACK is loaded
    (:func:`latdyn.assembly.library.lapack_address`): on Linux the library is then found in
    ``/proc/self/maps``, without threadpoolctl, and the answer kept for the process."""
    import ctypes

    global _thread_functions
    if _thread_functions is not None:
        return _thread_functions
    found = _scipy_openblas_from_maps()
    if found is not None:
        _thread_functions = found
        return found

    def openblas(controllers):
        found = [lib for lib in controllers if getattr(lib, "internal_api", "") == "openblas"]
        return found, [lib for lib in found if _in_scipy_folder(getattr(lib, "filepath", ""))]

    candidates, scipy_own = openblas(_blas_controllers())
    if not scipy_own:  # asked before SciPy's LAPACK was loaded (it is loaded on use): look again
        candidates, scipy_own = openblas(_blas_controllers(refresh=True))
    chosen = scipy_own or (candidates if len(candidates) == 1 else [])
    if not chosen:
        return None, None
    lib = chosen[0]
    try:
        prefix, suffix = lib._find_affixes()
        get = getattr(lib.dynlib, f"{prefix}openblas_get_num_threads{suffix}")
        put = getattr(lib.dynlib, f"{prefix}openblas_set_num_threads{suffix}")
    except Exception:  # noqa: BLE001 - another threadpoolctl or OpenBLAS: leave BLAS alone
        return None, None
    found = ctypes.cast(get, ctypes.c_void_p).value, ctypes.cast(put, ctypes.c_void_p).value
    if scipy_own:  # SciPy's own library does not change within the process
        _thread_functions = found
    return found


# ----------------------------------------------------------------------------- solves


def use_dense(n: int) -> bool:
    """Whether a system of n coordinates is assembled and solved densely."""
    return n <= DENSE_LIMIT


#: Models of at most this many coordinates keep SciPy's sparse package out of the process (its import,
#: with scipy.sparse.linalg and scipy.linalg: ≈0.1 s of CPU, more than the whole short run of a mid-size
#: lattice): their matrices are latdyn's own CSR. Every size is put in reverse Cuthill–McKee order by
#: :func:`reverse_cuthill_mckee` (Python: ~2 ms at 400 coordinates, ~50 ms at 5 000, ~0.2 s at 20 000
#: under load, once a pattern), whose order does not depend on the CPU.
RCM_IN_PYTHON = 5000


#: The last pattern :func:`reverse_cuthill_mckee` ordered and its order: a run orders the same
#: pattern twice (the held check's M + K and the step's iteration matrix, ~2 ms each at 400 coordinates).
_LAST_ORDER: tuple | None = None


def reverse_cuthill_mckee(rows: np.ndarray, cols: np.ndarray, n: int) -> np.ndarray:
    """Reverse Cuthill–McKee order of the pattern (rows, cols), SciPy's ``csgraph.reverse_cuthill_mckee``
    with ``symmetric_mode=False`` but for its ties: on the pattern of A + Aᵀ, the degree of a node is its
    row's entries, its diagonal counted twice; each connected part is searched breadth first from its
    first node in a *stable* sort of the degrees (the lowest index among equal degrees), the unvisited
    neighbours of each node (by index) appended in a stable order of increasing degree; the order is
    reversed. SciPy seeds its parts by NumPy's default ``argsort``, whose ties follow the SIMD sort NumPy
    dispatches on the CPU (AVX-512, AVX2 or neither: the 16-bay lattice's order, and so its band LU's last
    bits, differed between AVX-512 and AVX2 machines); this order is the same on every CPU, and SciPy's
    wherever its seeds' ties do not arise (tests/test_light_run.py checks both). Used for every size
    (:func:`rcm_band`). The same (rows, cols, n) as the last call's, entry for entry, gives a copy of
    its order without searching again."""
    global _LAST_ORDER
    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    key = (n, rows.tobytes(), cols.tobytes())
    last = _LAST_ORDER   # read once: another thread may replace it
    if last is not None and last[0] == key:
        return last[1].copy()
    order = _reverse_cuthill_mckee(rows, cols, n)
    _LAST_ORDER = (key, order.copy())
    return order


def _reverse_cuthill_mckee(rows: np.ndarray, cols: np.ndarray, n: int) -> np.ndarray:
    """:func:`reverse_cuthill_mckee`, searched."""
    keys = np.sort(np.concatenate([rows * n + cols, cols * n + rows]))  # np.unique would import numpy.ma
    keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])] if len(keys) else keys  # each entry once
    row, col = keys // max(n, 1), keys % max(n, 1)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(row, minlength=n))])
    degree = (np.diff(indptr) + np.bincount(row[row == col], minlength=n)).astype(np.int32)
    columns, bounds = col.tolist(), indptr.tolist()  # each row's columns as a list: slices, not np.split
    neighbours = [columns[bounds[i]:bounds[i + 1]] for i in range(n)]
    degrees = degree.tolist()
    visited = [False] * n
    order: list[int] = []
    for seed in np.argsort(degree, kind="stable").tolist():  # equal degrees: the lowest index first, on every CPU
        if visited[seed]:
            continue
        visited[seed] = True
        order.append(seed)
        head = len(order) - 1
        while head < len(order):
            found = [j for j in neighbours[order[head]] if not visited[j]]
            head += 1
            for j in found:
                visited[j] = True
            found.sort(key=degrees.__getitem__)
            order += found
        if len(order) == n:
            break
    return np.array(order[::-1], dtype=np.int64)


def rcm_band(rows: np.ndarray, cols: np.ndarray, n: int):
    """Reverse Cuthill–McKee order of the pattern (rows, cols) of an n × n matrix:
    (perm, new, lower, upper) with ``perm`` the old index at each new place, ``new`` its
    inverse, and the lower and upper bandwidths in the new order."""
    perm = reverse_cuthill_mckee(rows, cols, n)   # every size: SciPy's ties follow the CPU (its docstring)
    new = np.empty_like(perm)
    new[perm] = np.arange(n)
    i, j = new[rows], new[cols]
    return perm, new.astype(np.int64), int(np.max(i - j, initial=0)), int(np.max(j - i, initial=0))


def small_rcm_band(rows: np.ndarray, cols: np.ndarray, n: int):
    """:func:`rcm_band` for a pattern of at most DENSE_LIMIT coordinates, in NumPy and Python
    (SciPy's sparse package is not imported for a model the dense or band LU serves: see the top
    of the module): breadth-first from a node of least degree, neighbours by increasing degree,
    component by component, the order reversed, the degrees sorted stably (the same order on every
    CPU). Not :func:`reverse_cuthill_mckee`'s search: its degrees are SciPy's (a row's entries, the
    diagonal counted twice), these a node's neighbours, and the two orders differ on 31 of 154 small
    patterns of the shipped scenes; small models keep this one, and with it the results they had."""
    adjacent = np.zeros((n, n), bool)
    adjacent[rows, cols] = adjacent[cols, rows] = True
    np.fill_diagonal(adjacent, False)
    degree = adjacent.sum(axis=1)
    visited = np.zeros(n, bool)
    order = []
    for seed in np.argsort(degree, kind="stable"):
        if visited[seed]:
            continue
        visited[seed] = True
        queue, head = [int(seed)], 0
        while head < len(queue):
            found = np.flatnonzero(adjacent[queue[head]] & ~visited)
            head += 1
            found = found[np.argsort(degree[found], kind="stable")]
            visited[found] = True
            queue += found.tolist()
        order += queue
    perm = np.array(order[::-1], dtype=np.int64)
    new = np.empty(n, np.int64)
    new[perm] = np.arange(n)
    i, j = new[rows], new[cols]
    return perm, new, int(np.max(i - j, initial=0)), int(np.max(j - i, initial=0))


# ----------------------------------------------------------------------------- null directions


def psd_null_direction(A, factorization, tol: float = 1e-10, shift: float = 1e-9, iterations: int = 12,
                       seed: int = 0) -> tuple[float, np.ndarray]:
    """The smallest Rayleigh quotient found for a sparse symmetric PSD matrix with
    unit diagonal (SciPy's, or a :class:`latdyn.numerics.csr.CSR`), and its vector (max-norm 1).

    Inverse iteration with one LU of A + δI (δ = ``shift``; positive
    definite, so the factorization exists however singular A is): each step
    multiplies a null component by 1/δ and a held one, of eigenvalue λ, by
    1/(λ + δ).  The Rayleigh quotient xᵀAx/xᵀx is never below λ_min(A), so a
    result ≤ ``tol`` proves a near-null direction, and a held matrix (λ_min > tol)
    can never be reported unheld; with a null space the quotient falls to
    round-off (~1e-16) within two or three steps.  Iteration stops when the
    quotient is ≤ tol·1e-3 or no longer falls.

    A dense ``A`` (a NumPy array: a model of at most DENSE_LIMIT coordinates, the held check of a
    model the dense LU serves) is solved exactly instead: its smallest eigenvalue and eigenvector
    (LAPACK ``syevd``; ≤ 120 coordinates: ~1 ms), λ_min to round-off, without SciPy and without
    NumPy's random generator, whose import alone costs more than that (docs/performance.md,
    "First run").

    ``factorization``: the sparse LU to solve with, a class built as ``factorization(rows, columns, n)``
    whose ``factor(values)`` returns an object with ``solve`` (the package's
    :class:`latdyn.assembly.factorization.Factorization`, handed down by the layer that owns it:
    no scipy.sparse.linalg).
    """
    from latdyn.numerics.csr import CSR

    n = A.shape[0]
    if n == 0:
        return np.inf, np.zeros(0)
    if not issparse(A) and not isinstance(A, CSR):
        A = np.asarray(A, float)
        if n > SINGLE_THREAD_EIGH:  # OpenBLAS may thread here; on a busy core that costs ×30
            with single_thread_blas():
                eigenvalues, vectors = np.linalg.eigh(A)
        else:
            eigenvalues, vectors = np.linalg.eigh(A)
        x = vectors[:, 0]
        return float(eigenvalues[0]), x / np.max(np.abs(x))
    if isinstance(A, CSR):  # without SciPy (numerics.csr)
        diagonal = np.arange(n)
        shifted = CSR.from_coo(np.concatenate([A.data, np.full(n, shift)]), np.concatenate([A.rows, diagonal]),
                               np.concatenate([A.indices, diagonal]), A.shape)
        solve = factorization(shifted.rows, shifted.indices, n).factor(shifted.data).solve
        multiply = A.matvec
        # a fixed start without NumPy's random generator (its import costs more than this check):
        # the fractional parts of k·φ, centred, miss a direction no more than a random vector would
        x = (np.arange(1, n + 1) * 0.6180339887498949) % 1.0 - 0.5
    else:
        import scipy.sparse as sps  # only for SciPy's sparse matrices (see the top of the module)

        A = sps.csr_matrix(A)
        shifted = (A + shift * sps.identity(n, format="csr")).tocsr()
        shifted.sum_duplicates()
        solve = factorization(np.repeat(np.arange(n), np.diff(shifted.indptr)), shifted.indices, n).factor(shifted).solve
        multiply = A.__matmul__
        x = np.random.default_rng(seed).standard_normal(n)
    x /= np.linalg.norm(x)
    best = (np.inf, x)
    for _ in range(iterations):
        y = solve(x)
        norm = np.linalg.norm(y)
        if not np.isfinite(norm) or norm == 0.0:
            break
        x = y / norm
        rho = float(x @ multiply(x))
        previous = best[0]
        if rho < previous:
            best = (rho, x)
        if rho <= 1e-3 * tol or rho > 0.99 * previous:
            break
    rho, x = best
    return rho, x / np.max(np.abs(x))


__all__ = ["DENSE_LIMIT", "SMALL_BAND_FRACTION", "BAND_LIMIT", "SINGLE_THREAD_EIGH", "issparse", "use_dense", "rcm_band",
           "small_rcm_band", "reverse_cuthill_mckee", "RCM_IN_PYTHON", "single_thread_blas",
           "openblas_thread_functions", "psd_null_direction", "blas_on_one_thread"]
