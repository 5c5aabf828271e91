"""The compiled time step: generalized-α with its Newton iteration in C (``csrc/newton_step.c``).

:class:`CompiledGeneralizedAlpha` is :class:`latdyn.integrators.GeneralizedAlpha` with
``step`` done by one call into C: configuration update on SO(3), prescribed motion,
element geometry (Eq. 17), the generated element kernels (called through function
pointers from the per-kernel libraries of :mod:`latdyn.kernels`), joint bodies, hinges,
point loads, scatter into a preallocated matrix, LAPACK's LU (dense ``getrf``, or banded
``gbtrf`` after a reverse Cuthill–McKee ordering, as :mod:`latdyn.linalg` chooses; the
function pointers are SciPy's ``cython_lapack``) or, for matrices too wide for a band, the
supernodal sparse LU of ``csrc/sparse_lu.c`` (analysis once per pattern in
:mod:`latdyn.sparse_lu`), and the convergence test. Python runs
once per step, around the call: it evaluates the scene's laws of time (prescribed motion,
torques, loads; compiled with ``sympy.lambdify``) at the step's end time, and keeps the
bookkeeping of the time loop (events, energies, output).

The Python step stays the reference: with ``newton: full`` the compiled step takes the
same iterations and equals it to round-off (``tests/test_engine.py``: 1e-10 relative).
``newton: modified`` keeps the factorized iteration matrix from step to step while Newton
contracts (|Δx_k| ≤ ``contraction`` · |Δx_{k−1}|) and rebuilds it when it stops doing so
or the step size changes; only the residual is evaluated between rebuilds (the internal
force, mass and quadratic-velocity kernels: ~4 µs an element against ~14 µs with the
tangents, measured by ``benchmarks/compile_levels.py``). It converges to the same
tolerance on the same invariant increment.

Threads: the element part of each evaluation (geometry and generated kernels) runs on OpenMP
threads, one contiguous range of elements each, from :data:`PARALLEL_ELEMENTS` elements on
(``LATDYN_PARALLEL_ELEMENTS`` overrides it, 0 turns it off); ``OMP_NUM_THREADS`` sets the number
of threads (default: the cores). The scatter stays serial in element order, so the results are
bit-identical whatever the threads. The library is built with ``-fopenmp`` where the compiler
accepts it, else serially (:func:`openmp_threads` says 0).

Scenes the C step does not cover run the Python step (``engine_reason`` says why): the
NumPy kernel backend (no compiler), rigid links, and hinge laws that depend on θ or θ̇.
"""
from __future__ import annotations

import ctypes
import hashlib
import importlib.resources
import os
import time

import numpy as np

from .assembly import State, free_acceleration, free_velocity
from .integrators import INERTIA_TANGENT_STEP, GeneralizedAlpha, StepStats, node_colouring
from .linalg import BAND_LIMIT, DENSE_LIMIT, openblas_thread_functions, rcm_band
from .sparse_lu import SparseLUStructure, SupernodalAnalysis, blas_kernels
from .model import PRESCRIBED

I64 = ctypes.c_int64
P = ctypes.c_void_p
_LIBRARY = None


class _Model(ctypes.Structure):
    _fields_ = [(name, I64) for name in ("n_nodes", "n_hinges", "n_elements", "n_bodies", "n_loads", "n_dofs",
                                          "n_total")] + [
        ("node_dofs", P), ("hinge_dofs", P), ("n_free_nodes", I64), ("n_free_hinges", I64),
        ("free_nodes", P), ("free_hinges", P),
        ("n_prescribed", I64), ("prescribed_nodes", P), ("translation_law", P), ("angle_law", P),
        ("rotation_axis", P), ("node_x0", P), ("hinge_angle_law", P), ("hinge_locked", P),
        ("element_nodes", P), ("element_hinges", P), ("element_dofs", P),
        ("element_axes", P), ("element_frames0", P), ("element_offsets", P), ("element_sections", P),
        ("body_nodes", P), ("body_mass", P), ("body_com", P), ("body_inertia", P),
        ("hinge_stiffness", P), ("hinge_damping", P), ("hinge_rest_angle", P), ("hinge_torque_law", P),
        ("load_node", P), ("load_force_law", P), ("load_moment_law", P), ("load_frame_node", P), ("load_r", P),
        ("gravity", ctypes.c_double * 3), ("has_gravity", I64),
        ("element_position", P), ("body_position", P), ("hinge_position", P), ("load_position", P),
        ("band", I64), ("kl", I64), ("ku", I64), ("ldab", I64), ("matrix_size", I64), ("permutation", P),
        ("internal_force", P), ("internal_force_D_q", P), ("mass_matrix", P), ("quadratic_velocity", P),
        ("quadratic_velocity_D_qdot", P), ("gravity_load", P), ("strain_energy", P), ("kinetic_energy", P),
        ("getrf", P), ("getrs", P), ("gbtrf", P), ("gbtrs", P),
        ("parallel_elements", I64), ("threads", I64),
        ("node_colour", P), ("hinge_node", P), ("n_colours", I64),
        ("sparse_lu", ctypes.POINTER(SparseLUStructure)), ("get_blas_threads", P), ("set_blas_threads", P),
        ("section_width", I64),
    ]


class _Work(ctypes.Structure):
    _fields_ = [(name, P) for name in (
        "geometry", "rates", "accelerations", "gravity_rows", "force", "tangent", "mass", "quadratic",
        "quadratic_D", "gravity_force", "gravity_potential", "first_moment", "body_vector", "body_mass",
        "body_damping", "body_stiffness", "load_blocks", "strain",
        "section_forces", "kinetic", "total",
        "matrix", "pivots", "rhs",
        "inertia_tangent", "forces_plus", "forces_minus", "perturbed_x", "perturbed_T", "perturbed_theta",
        "p_geometry", "p_rates", "p_accelerations", "p_mass", "p_quadratic", "p_gravity_force",
        "p_gravity_potential", "p_first_moment")]


class _Configuration(ctypes.Structure):
    _fields_ = [(name, P) for name in ("x", "T", "v", "w", "a", "alpha", "theta", "theta_dot", "theta_ddot")]


class _Vectors(ctypes.Structure):
    _fields_ = [(name, P) for name in ("v_n", "vdot_n", "a_n", "v", "vdot", "dq", "dx", "a_new")]

    @classmethod
    def _fields_and_names(cls):
        return [name for name, _ in cls._fields_]


class _Control(ctypes.Structure):
    _fields_ = [(name, ctypes.c_double) for name in ("h", "alpha_m", "alpha_f", "gamma", "beta", "tol",
                                                      "length")] + [
        ("max_iterations", I64), ("modified", I64), ("inertia_tangent", I64), ("tangent_step", ctypes.c_double),
        ("contraction", ctypes.c_double),
        ("factored_h", ctypes.c_double), ("iterations", I64), ("converged", I64), ("factorizations", I64),
        ("power", ctypes.c_double), ("contraction_seen", ctypes.c_double)]


# ----------------------------------------------------------------------------- the library


#: Element count from which the element part of an evaluation (geometry and kernels) runs on
#: OpenMP threads (csrc/newton_step.c): measured with benchmarks/step_scaling.py --threads on
#: the 2-core machine (docs/performance.md, "Threads": quiet, 2 threads gained 1.18× at 100
#: elements, 1.31× at 10³, 1.72× at 10⁴; with both cores busy with other work they lost up
#: to 3000 elements). ``LATDYN_PARALLEL_ELEMENTS`` overrides it (0: never); ``OMP_NUM_THREADS``
#: sets the number of threads.
PARALLEL_ELEMENTS = 1_000
#: OpenMP flag tried first; a compiler without it builds the serial library (the same results).
OPENMP_FLAGS = ("-fopenmp",)


def parallel_threshold() -> int:
    """The threshold in force: ``LATDYN_PARALLEL_ELEMENTS`` or :data:`PARALLEL_ELEMENTS`."""
    value = os.environ.get("LATDYN_PARALLEL_ELEMENTS", "").strip()
    try:
        return max(0, int(value)) if value else PARALLEL_ELEMENTS
    except ValueError:
        return PARALLEL_ELEMENTS


def _library() -> ctypes.CDLL:
    """Compile (once, into the kernel cache) and load csrc/newton_step.c, with OpenMP where the
    compiler has it (a failed -fopenmp build is remembered in the cache by an empty marker file)."""
    global _LIBRARY
    if _LIBRARY is None:
        from .kernels import C_FLAGS, COMPILE_SECONDS, _build, _compiler, cache_dir

        source = _source("newton_step.c")
        compiler = _compiler()
        for flags in ((*C_FLAGS, *OPENMP_FLAGS), C_FLAGS):
            digest = hashlib.sha256(source + b"\0" + " ".join([*compiler, *flags]).encode()).hexdigest()[:20]
            target = cache_dir() / f"newton_step-{digest}.so"
            failed = target.with_suffix(".failed")
            if flags != C_FLAGS and failed.exists():
                continue
            if not target.exists():
                from filelock import FileLock

                target.parent.mkdir(parents=True, exist_ok=True)
                with FileLock(str(target) + ".lock", timeout=600):
                    if not target.exists():
                        started = time.perf_counter()
                        try:
                            _build(compiler, source, target, "newton_step", flags)
                        except RuntimeError:
                            if flags == C_FLAGS:
                                raise
                            failed.touch()
                            continue
                        finally:
                            COMPILE_SECONDS["total"] += time.perf_counter() - started
            break
        library = ctypes.CDLL(str(target))
        library.latdyn_threads.restype = I64
        library.latdyn_threads.argtypes = []
        library.latdyn_energies.restype = None
        library.latdyn_energies.argtypes = [ctypes.POINTER(_Model), ctypes.POINTER(_Work),
                                            ctypes.POINTER(_Configuration), P]
        library.latdyn_newton_step.restype = I64
        library.latdyn_newton_step.argtypes = [ctypes.POINTER(_Model), ctypes.POINTER(_Work),
                                               ctypes.POINTER(_Control), ctypes.POINTER(_Configuration),
                                               ctypes.POINTER(_Configuration), ctypes.POINTER(_Vectors), P]
        _LIBRARY = library
    return _LIBRARY


def _source(name: str) -> bytes:
    """csrc/<name> with its local ``#include "x.c"`` lines replaced by those files (one source
    file to compile, and the cache digest covers all of it)."""
    folder = importlib.resources.files("latdyn") / "csrc"
    lines = []
    for number, line in enumerate((folder / name).read_bytes().splitlines(keepends=True), start=1):
        words = line.split()
        if len(words) >= 2 and words[0] == b"#include" and words[1].startswith(b'"'):
            included = words[1].strip(b'"')
            lines += [b'#line 1 "%s"\n' % included, (folder / included.decode()).read_bytes(),
                      b'\n#line %d "%s"\n' % (number + 1, name.encode())]  # compiler messages keep their files
        else:
            lines.append(line)
    return b"".join(lines)


def openmp_threads() -> int:
    """Threads the compiled step uses above the threshold: 0 when it was built without OpenMP."""
    return int(_library().latdyn_threads())


def _lapack(name: str) -> int:
    """The address of a LAPACK routine from SciPy's cython_lapack capsules."""
    import scipy.linalg.cython_lapack as lapack

    capsule = lapack.__pyx_capi__[name]
    get_name = ctypes.pythonapi.PyCapsule_GetName
    get_name.restype, get_name.argtypes = ctypes.c_char_p, [ctypes.py_object]
    get_pointer = ctypes.pythonapi.PyCapsule_GetPointer
    get_pointer.restype, get_pointer.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]
    return get_pointer(capsule, get_name(capsule))


def _kernel_address(kernels, name: str) -> int:
    library = kernels.libraries[name]
    return ctypes.cast(getattr(library, name), ctypes.c_void_p).value


# ----------------------------------------------------------------------------- availability


def _constant(law) -> float | None:
    """A hinge coefficient as a number, or None when it is a law of θ, θ̇ or t."""
    if law is None:
        return 0.0
    if isinstance(law, (int, float)):
        return float(law)
    return float(law.constant) if getattr(law, "is_constant", False) else None


def _torque_of_time(law) -> bool:
    return law is None or not hasattr(law, "depends_on") or set(law.depends_on) <= {"t"}


def unsupported(assembler) -> str | None:
    """Why the compiled step cannot run this model, or None when it can."""
    model = assembler.model
    if getattr(model, "links", None) is not None:
        return "rigid links (dependent nodes, latdyn/links.py) run in the Python step"
    if getattr(assembler.kernels, "backend", "numpy") != "c" or not hasattr(assembler.kernels, "libraries"):
        return "the element kernels are not compiled (NumPy backend)"
    for k, hinge in enumerate(model.hinges):
        if _constant(hinge.stiffness) is None or _constant(hinge.damping) is None:
            return f"hinge {model.hinges[k].beam}.{model.hinges[k].end} has a stiffness or damping law"
        if not _torque_of_time(hinge.torque):
            return f"hinge {model.hinges[k].beam}.{model.hinges[k].end} has a torque law in θ or θ̇"
    try:
        _library()
    except RuntimeError as error:
        return f"the step library could not be built ({error})"
    return None


def _band_plan(assembler):
    """RCM order of the iteration matrix's pattern (:func:`latdyn.linalg.rcm_band`):
    (bandwidth, new index of each coordinate, lower, upper)."""
    _, new, lower, upper = rcm_band(assembler._csr_rows, assembler._csr_cols, assembler.model.n_dofs)
    return max(lower, upper), new, lower, upper


# ----------------------------------------------------------------------------- the step


class _Laws:
    """The scene's functions of time, numbered; ``at(t)`` gives their (value, rate, acceleration)
    (:class:`~latdyn.expressions.TimeFunction` evaluates one float time through ``math`` lambdas)."""

    def __init__(self):
        self.functions = []

    def add(self, function) -> int:
        if function is None:
            return -1
        self.functions.append(function)
        return len(self.functions) - 1

    def at(self, t: float) -> np.ndarray:
        out = np.zeros((max(len(self.functions), 1), 3))
        for k, f in enumerate(self.functions):
            if hasattr(f, "rate"):  # a TimeFunction
                out[k] = f.value(t), f.rate(t), f.accel(t)
            else:  # a hinge torque law of t alone
                out[k, 0] = f.value(0.0, 0.0, t)
        return out


class CompiledGeneralizedAlpha(GeneralizedAlpha):
    """:class:`GeneralizedAlpha` whose step runs in C (see the module docstring)."""

    def __init__(self, assembler, params, tol, max_iterations, length_scale, newton: str = "full",
                 contraction: float = 0.5, parallel_elements: int | None = None, threads: int = 0):
        super().__init__(assembler, params, tol, max_iterations, length_scale)
        #: element count from which the element kernels run on threads (0: never), and how
        #: many threads (0: OMP_NUM_THREADS or the cores); the results do not depend on either
        self.parallel_elements = parallel_threshold() if parallel_elements is None else parallel_elements
        self.threads = threads
        self.modified = newton == "modified"
        self.contraction = contraction
        self.factorizations = 0
        self._key = None
        self._library = _library()
        self._last_trial = self._mass_for = None
        self._empty = np.zeros(1)
        self._energy_out = np.zeros(3)
        self._made = None  # (the last state made, its C view, the C view of its base)

    # -- the model as arrays, rebuilt when the numbering changes (a latch) --------------------
    def _setup(self) -> None:
        model = self.assembler.model
        key = (model.n_dofs, model.locked.tobytes(), self.inertia_tangent)
        if key == self._key:
            return
        self._key = key
        a, m = self.assembler, model
        colour = node_colouring(m)
        keep = []  # arrays the C structures point into

        def arr(values, dtype=np.float64):
            array = np.ascontiguousarray(values, dtype=dtype)
            if array.size == 0:
                array = np.zeros(1, dtype)
            keep.append(array)
            return array.ctypes.data

        def ints(values):
            return arr(values, np.int64)

        laws = _Laws()
        prescribed = [i for i, node in enumerate(m.nodes) if node.kind == PRESCRIBED]
        translation, angle, axis = [], [], []
        for i in prescribed:
            body = m.scene.bodies[m.nodes[i].body]
            if body.translation is not None:
                translation.append([laws.add(g) for g in body.translation])
            else:
                translation.append([-1, -1, -1])
            if body.rotation_angle is not None:
                angle.append(laws.add(body.rotation_angle))
                axis.append(np.asarray(body.rotation_axis, float))
            else:
                angle.append(-1)
                axis.append(np.zeros(3))
        hinge_angle = [laws.add(h.angle) for h in m.hinges]
        torque = [laws.add(h.torque) for h in m.hinges]
        load_node, load_r, force_law, moment_law, frame_node = [], [], [], [], []
        for load in a.loads:
            node, r = m.point(load.at)
            load_node.append(node)
            load_r.append(r)
            force_law.append([laws.add(g) for g in load.force] if load.force else [-1, -1, -1])
            moment_law.append([laws.add(g) for g in load.moment] if load.moment else [-1, -1, -1])
            frame_node.append(-1 if load.frame == "global" else m.body_node[load.frame])
        self._laws = laws

        n = m.n_dofs
        dense = n <= DENSE_LIMIT
        if dense:
            new = np.arange(n, dtype=np.int64)
            kl = ku = 0
            ldab = n
            size = n * n

            def position(rows, cols):
                return np.where((rows < n) & (cols < n), rows + cols * n, -1)
        else:
            bandwidth, new, kl, ku = _band_plan(a)
            ldab = 2 * kl + ku + 1
            size = ldab * n

            def position(rows, cols):
                ok = (rows < n) & (cols < n)
                i = new[np.where(ok, rows, 0)]
                j = new[np.where(ok, cols, 0)]
                return np.where(ok, (kl + ku + i - j) + j * ldab, -1)
        sparse_lu = None
        if not dense and bandwidth > BAND_LIMIT:  # the supernodal LU of csrc/sparse_lu.c (linalg.py)
            analysis = SupernodalAnalysis(a._csr_rows, a._csr_cols, n)
            sparse_lu = analysis.structure(*blas_kernels())
            keep.append(analysis)
            new, kl, ku, ldab, size, position = analysis.new, 0, 0, 0, max(analysis.size, 1), analysis.position

        def block_positions(dofs):
            rows = np.broadcast_to(dofs[:, :, None], dofs.shape + (dofs.shape[1],))
            cols = np.broadcast_to(dofs[:, None, :], dofs.shape + (dofs.shape[1],))
            return position(rows, cols)

        body_dofs = m.node_dofs[m.body_nodes].reshape(-1, 6)
        load_dofs = np.array([m.node_dofs[node, 3:6] for node in load_node], np.int64).reshape(-1, 3)
        hd = m.hinge_dofs
        hinge_position = np.where(hd < n, position(hd, hd), -1)

        blas_threads = openblas_thread_functions()
        kernels = a.kernels
        E, B, L = len(m.element_nodes), len(m.body_nodes), len(a.loads)
        H = len(m.hinges)
        self._model = _Model(
            n_nodes=len(m.nodes), n_hinges=H, n_elements=E, n_bodies=B, n_loads=L, n_dofs=n, n_total=m.n_total,
            node_dofs=ints(m.node_dofs), hinge_dofs=ints(m.hinge_dofs),
            n_free_nodes=len(m.free_nodes), n_free_hinges=len(m.free_hinges),
            free_nodes=ints(m.free_nodes), free_hinges=ints(m.free_hinges),
            n_prescribed=len(prescribed), prescribed_nodes=ints(prescribed),
            translation_law=ints(np.array(translation, np.int64).reshape(-1, 3)), angle_law=ints(angle),
            rotation_axis=arr(np.array(axis).reshape(-1, 3)),
            node_x0=arr(np.array([nd.position for nd in m.nodes], float).reshape(-1, 3)),
            hinge_angle_law=ints(hinge_angle), hinge_locked=ints(np.asarray(m.locked, np.int64)),
            element_nodes=ints(m.element_nodes), element_hinges=ints(m.element_hinges),
            element_dofs=ints(m.element_dofs), element_axes=arr(m.element_axes),
            element_frames0=arr(m.element_frames0), element_offsets=arr(m.element_offsets),
            element_sections=arr(m.element_sections),
            body_nodes=ints(m.body_nodes), body_mass=arr(m.body_mass), body_com=arr(m.body_com),
            body_inertia=arr(m.body_inertia),
            hinge_stiffness=arr([_constant(h.stiffness) for h in m.hinges]),
            hinge_damping=arr([_constant(h.damping) for h in m.hinges]),
            hinge_rest_angle=arr([float(getattr(h, "rest_angle", 0.0)) for h in m.hinges]),
            hinge_torque_law=ints(torque),
            load_node=ints(load_node), load_force_law=ints(np.array(force_law, np.int64).reshape(-1, 3)),
            load_moment_law=ints(np.array(moment_law, np.int64).reshape(-1, 3)), load_frame_node=ints(frame_node),
            load_r=arr(np.array(load_r, float).reshape(-1, 3)),
            gravity=(ctypes.c_double * 3)(*a.gravity), has_gravity=int(a.has_gravity),
            element_position=ints(block_positions(m.element_dofs)), body_position=ints(block_positions(body_dofs)),
            hinge_position=ints(hinge_position), load_position=ints(block_positions(load_dofs)),
            band=int(not dense and sparse_lu is None), kl=kl, ku=ku, ldab=ldab, matrix_size=size, permutation=ints(new),
            internal_force=_kernel_address(kernels, "beam_internal_force"),
            internal_force_D_q=_kernel_address(kernels, "beam_internal_force_D_q"),
            mass_matrix=_kernel_address(kernels, "beam_mass_matrix"),
            quadratic_velocity=_kernel_address(kernels, "beam_quadratic_velocity"),
            quadratic_velocity_D_qdot=_kernel_address(kernels, "beam_quadratic_velocity_D_qdot"),
            gravity_load=_kernel_address(kernels, "beam_gravity"),
            strain_energy=_kernel_address(kernels, "beam_strain_energy"),
            kinetic_energy=_kernel_address(kernels, "beam_kinetic_energy"),
            getrf=_lapack("dgetrf"), getrs=_lapack("dgetrs"), gbtrf=_lapack("dgbtrf"), gbtrs=_lapack("dgbtrs"),
            parallel_elements=self.parallel_elements, threads=self.threads,
            node_colour=ints(colour), hinge_node=ints([h.node for h in m.hinges]), n_colours=int(colour.max(initial=-1)) + 1,
            sparse_lu=ctypes.pointer(sparse_lu) if sparse_lu is not None else None,
            get_blas_threads=blas_threads[0] if blas_threads[1] else None, set_blas_threads=blas_threads[1],
            section_width=m.element_sections.shape[1],
        )
        work = {
            "geometry": (E, 36), "rates": (E, 14), "accelerations": (E, 14), "gravity_rows": (E, 3),
            "force": (E, 14), "tangent": (E, 14, 14), "mass": (E, 14, 14), "quadratic": (E, 14),
            "quadratic_D": (E, 14, 14), "gravity_force": (E, 14), "gravity_potential": (E,),
            "first_moment": (E, 3), "body_vector": (B, 6), "body_mass": (B, 6, 6), "body_damping": (B, 6, 6),
            "body_stiffness": (B, 6, 6),
            "load_blocks": (L, 9), "strain": (E,), "section_forces": (E, 4), "kinetic": (E,), "total": (m.n_total + 1,), "matrix": (size,), "rhs": (n,)}
        # the inertia tangent's buffers (integrators.inertia_tangent), only once the run needs them
        N, H = len(m.nodes), len(m.hinges)
        tangent = {"inertia_tangent": (E, 14, 14), "forces_plus": (E, 14), "forces_minus": (E, 14),
                   "perturbed_x": (N, 3), "perturbed_T": (N, 3, 3), "perturbed_theta": (H,),
                   "p_geometry": (E, 36), "p_rates": (E, 14), "p_accelerations": (E, 14), "p_mass": (E, 14, 14),
                   "p_quadratic": (E, 14), "p_gravity_force": (E, 14), "p_gravity_potential": (E,),
                   "p_first_moment": (E, 3)}
        work.update({name: shape if self.inertia_tangent else (0,) for name, shape in tangent.items()})
        self._buffers = {name: np.zeros(shape) for name, shape in work.items()}
        self._buffers["gravity_rows"][:] = a.gravity
        self._buffers["pivots"] = np.zeros(max(n, 1), np.int32)
        self._work = _Work(**{name: b.ctypes.data if b.size else arr(np.zeros(1)) for name, b in self._buffers.items()})
        self._keep = keep
        self._control = _Control(max_iterations=self.max_iterations, modified=int(self.modified),
                                 inertia_tangent=int(self.inertia_tangent), tangent_step=INERTIA_TANGENT_STEP,
                                 contraction=self.contraction, factored_h=0.0, tol=self.tol,
                                 length=self.length_scale)
        for name in ("alpha_m", "alpha_f", "gamma", "beta"):
            setattr(self._control, name, getattr(self.p, name))
        size = max(n, 1)
        self._step_vectors = {name: np.zeros(size) for name in _Vectors._fields_and_names()}
        self._a_n, self._a_new = self._step_vectors["a_n"], self._step_vectors["a_new"]
        self._vectors = _Vectors(**{name: b.ctypes.data for name, b in self._step_vectors.items()})
        self._model_ref, self._work_ref = ctypes.byref(self._model), ctypes.byref(self._work)
        self._control_ref, self._vectors_ref = ctypes.byref(self._control), ctypes.byref(self._vectors)
        self._step = self._library.latdyn_newton_step
        self._layout()

    _FIELDS = ("x", "T", "v", "w", "a", "alpha", "theta", "theta_dot", "theta_ddot")

    def _layout(self) -> None:
        """Offsets of a state's arrays in one flat buffer (a new state per step: the loop
        keeps the old one for its events and checkpoints)."""
        model = self.assembler.model
        N, H = len(model.nodes), len(model.hinges)
        shapes = {"x": (N, 3), "T": (N, 3, 3), "v": (N, 3), "w": (N, 3), "a": (N, 3), "alpha": (N, 3),
                  "theta": (H,), "theta_dot": (H,), "theta_ddot": (H,)}
        self._shapes, self._offsets, offset = shapes, {}, 0
        for name in self._FIELDS:
            self._offsets[name] = offset
            offset += max(int(np.prod(shapes[name])), 1)
        self._state_size = offset
        self._slices = [(self._offsets[name], self._offsets[name] + int(np.prod(shapes[name])), shapes[name])
                        for name in self._FIELDS]

    def _new_state(self, t: float) -> tuple[State, _Configuration]:
        buffer = np.empty(self._state_size)
        base = buffer.ctypes.data
        state = State(t, *(buffer[start:stop].reshape(shape) for start, stop, shape in self._slices))
        return state, _Configuration(*(base + 8 * start for start, _, _ in self._slices))

    def _configuration_of(self, state: State) -> _Configuration:
        """The C view of a state: the last state this step made is viewed in place; any other
        (the start, a state after an event) through contiguous float64 copies of its arrays,
        kept alive until the next call. Nothing is attached to the state (it is pickled into
        checkpoints)."""
        if self._made is not None and self._made[0] is state:
            return self._made[1]
        arrays = [np.ascontiguousarray(getattr(state, name), dtype=np.float64) for name in self._FIELDS]
        pointers = [array.ctypes.data if array.size else self._empty.ctypes.data for array in arrays]
        self._copies = arrays
        return _Configuration(*pointers)

    def step(self, state: State, h: float, t_new: float | None = None) -> tuple[State, StepStats]:
        self._setup()
        model = self.assembler.model
        n = model.n_dofs
        t_new = state.t + h if t_new is None else t_new
        base = self._configuration_of(state)
        trial_state, trial = self._new_state(t_new)
        self._a_n[:n] = self.a
        laws = self._laws.at(t_new)
        control = self._control
        control.h = h
        failed = self._step(self._model_ref, self._work_ref, self._control_ref, ctypes.byref(base),
                            ctypes.byref(trial), self._vectors_ref, laws.ctypes.data)
        self.factorizations += control.factorizations
        self._last_trial = trial_state
        self._made = (trial_state, trial, base)
        total = self._buffers["total"]
        stats = StepStats(iterations=control.iterations, converged=bool(control.converged) and not failed,
                          factorizations=control.factorizations, contraction=control.contraction_seen)
        self.last_evaluation = _LastEvaluation(total, n, model.n_total, control.power)
        if not stats.converged:
            stats.residual = total[:n].copy()
            control.factored_h = 0.0  # a failed step may leave a partial factorization
        else:
            self.a_candidate = self._a_new[:n].copy()
        return trial_state, stats

    def energies(self, state: State) -> dict[str, float]:
        """:meth:`latdyn.assembly.Assembler.energies` in C (the time loop asks at every recorded row)."""
        self._setup()
        out = self._energy_out
        self._library.latdyn_energies(self._model_ref, self._work_ref, ctypes.byref(self._configuration_of(state)),
                                      out.ctypes.data)
        return {"kinetic": float(out[0]), "strain": float(out[1]), "potential": float(out[2])}

    def error_estimate(self, h: float) -> float:
        """As :meth:`GeneralizedAlpha.error_estimate`, with the mass matrix of the step's end
        state evaluated in Python (adaptive runs: once per step, outside the Newton iteration)."""
        if self.assembler.model.n_dofs == 0 or getattr(self, "_last_trial", None) is None:
            return 0.0
        if self._mass_for is not self._last_trial:
            self._mass_ev = self.assembler.evaluate(self._last_trial, matrices=True)
            self._mass_for = self._last_trial
        saved, self.last_evaluation = self.last_evaluation, self._mass_ev
        try:
            return super().error_estimate(h)
        finally:
            self.last_evaluation = saved


class _LastEvaluation:
    """What the time loop reads of the last Newton evaluation: the reaction on the
    constrained coordinates and the external power (the residual only on failure)."""

    def __init__(self, total, n, n_total, external_power):
        self.reaction = total[n:n_total].copy()
        self.external_power = external_power
