"""Compile and cache: the one path by which latdyn turns C into a loaded library.

Three kinds of C unit are built at run time, all through :func:`build`:

- the generated element kernels, one unit per kernel (:mod:`latdyn.model.kernels`);
- the compiled time step, ``csrc/newton_step.c`` (:mod:`latdyn.step.compiled`), with ``-fopenmp``
  where the compiler takes it;
- a scene's laws, printed by :mod:`codegen.laws` (:mod:`latdyn.assembly.compiled_laws`).

A unit is compiled once per source, flags and compiler into the kernel cache
(``$LATDYN_CACHE_DIR``, default ``~/.cache/latdyn/kernels``) as
``<name>-<sha256 of source, flags, compiler and its version>.so``, under a file lock (runs
in parallel processes build it once), through a scratch folder and an atomic rename (a
killed build leaves no half library). Compile seconds are added to :data:`COMPILE_SECONDS`,
which runs report apart from solver time.

Two small files in the cache spare a fresh process the compiler when everything it loads is
built: the compiler's ``--version`` output (``compiler-<digest>.txt``, by the binary's path and
file identity: :func:`_stored_version`) and the macros of its ``-march=`` (``isa-<digest>.txt``);
the element kernels add an index per generated unit (:mod:`latdyn.model.kernels`).

The compiler (:func:`compiler`): ``$CC`` when set (exactly that one); otherwise ``cc``,
then Zig's C compiler from the ``ziglang`` wheel (``python -m ziglang cc``; ``pip install
"latdyn[compiler]"``), so that a machine without a system compiler still gets the compiled
kernels. :class:`NoCompiler` says why none works; :data:`NO_COMPILER_ADVICE` is how to fix
it, which a run says when it stops for want of one (the runtime evaluates natively only).

The instruction set: the element kernels are compiled for this machine's (``-march=native``)
unless ``$LATDYN_MARCH`` names another (:func:`march`: ``x86-64-v2``, ``x86-64-v3``, ``x86-64-v4``,
``haswell``, … — anything the compiler's ``-march=`` takes and this CPU runs). Every unit is
compiled with ``-ffp-contract=off`` (no fused multiply-add unless the source asks for one), so
that the instruction set changes how many elements one vector holds and not the arithmetic:
kernels built for any of them give the same results (``tests/test_instruction_sets.py``).

Runtime code: it imports neither SymPy nor the code generator.
"""
from __future__ import annotations

import ctypes
import importlib.util
import os
import re
import shutil
import sys
import time
from pathlib import Path

from latdyn.digest import sha256

#: Flags of every unit (the kernels choose their own -O level, kernels.optimisation).
#: ``-ffp-contract=off``: a compiler may not fuse a * b + c into one FMA (Clang, zig cc, does by
#: default where the instruction set has it; GCC does not in ISO C mode), which would make
#: results depend on the instruction set compiled for.
C_FLAGS = ("-O2", "-std=c99", "-fPIC", "-shared", "-ffp-contract=off")

#: The environment variable that chooses the instruction set of the element kernels (:func:`march`).
MARCH_VARIABLE = "LATDYN_MARCH"
#: The environment variable that compiles every element kernel at one -O level (:func:`kernel_optimisation`).
OPTIMISATION_VARIABLE = "LATDYN_KERNEL_OPT"
#: the -O levels :data:`OPTIMISATION_VARIABLE` may name
OPTIMISATION_LEVELS = ("-O0", "-O1", "-O2", "-O3", "-Os", "-Og")
#: the environment variable that names the kernel cache (:func:`cache_dir`)
CACHE_VARIABLE = "LATDYN_CACHE_DIR"
SUFFIX = ".dll" if sys.platform == "win32" else ".so"

#: Seconds spent compiling in this process (reported apart from solver time).
COMPILE_SECONDS = {"total": 0.0}

#: How to get a C compiler, said by a run that has none (the runtime evaluates natively only:
#: latdyn/assembly/native_model.py).
NO_COMPILER_ADVICE = (
    "a run needs a C compiler for its kernels: pip install \"latdyn[compiler]\" (Zig's C compiler, "
    "used automatically) or install cc"
)


class CacheNotWritable(RuntimeError):
    """A library that is not in the kernel cache cannot be compiled there (a read-only cache): the message
    names the library, the folder and :data:`CACHE_VARIABLE`."""


class NoCompiler(RuntimeError):
    """No working C compiler; the message says which were tried and why they failed."""


class Compiler:
    """A working C compiler: its command (``argv`` prefix) and ``--version`` output."""

    def __init__(self, command: list[str], version: bytes):
        self.command, self.version = command, version

    @property
    def name(self) -> str:
        return "zig cc" if "ziglang" in self.command else " ".join(self.command)

    def identity(self) -> bytes:
        """What enters the cache digest: the command (a zig cc from another Python is the
        same compiler) and its version."""
        words = ["zig", "cc"] if "ziglang" in self.command else self.command
        return " ".join(words).encode() + b"\0" + self.version

    def __repr__(self) -> str:
        return f"Compiler({self.name!r})"


_COMPILER: dict[tuple, Compiler | NoCompiler] = {}


def package_folder(package: str):
    """The folder of the installed package ``package`` (``latdyn_generated``, ``latdyn.assembly``): what
    ``importlib.resources.files`` gives for a package in a folder, from its import spec, without importing
    ``importlib.resources`` and its readers (≈ 2 ms of a fresh process; docs/performance.md, "Eleventh
    pass"). A package that is not a plain file on disk (a zip) gets ``importlib.resources.files``' answer."""
    spec = importlib.util.find_spec(package)
    if spec is not None and spec.origin and spec.has_location and os.path.isfile(spec.origin):
        return Path(spec.origin).parent
    from importlib.resources import files

    return files(package)


def cache_dir() -> Path:
    """The kernel cache: ``$LATDYN_CACHE_DIR``, default ``~/.cache/latdyn/kernels``."""
    return Path(os.environ.get(CACHE_VARIABLE) or Path.home() / ".cache" / "latdyn" / "kernels")


def _candidates() -> list[list[str]]:
    chosen = os.environ.get("CC")
    if chosen:
        import shlex  # on use: only $CC is split (shlex, and tempfile with random: 1.3–1.5 ms of a run's imports)

        return [shlex.split(chosen)]
    found = [["cc"]]
    if importlib.util.find_spec("ziglang") is not None:
        found.append([sys.executable, "-m", "ziglang", "cc"])
    return found


def compiler() -> Compiler:
    """The C compiler this process uses (found once per ``$CC`` and ``$PATH``); :class:`NoCompiler`."""
    key = (os.environ.get("CC"), os.environ.get("PATH"))
    if key not in _COMPILER:
        failures = []
        for command in _candidates():
            if command[0] != sys.executable and shutil.which(command[0]) is None:
                failures.append(f"{' '.join(command)}: not found")
                continue
            stored = _stored_version(command)
            if stored is not None and stored.is_file():
                try:
                    _COMPILER[key] = Compiler(command, stored.read_bytes())
                    break
                except OSError:
                    pass
            import subprocess  # on use: a run that finds its compiler's version stored imports none (≈ 2 ms)

            try:
                result = subprocess.run([*command, "--version"], capture_output=True, timeout=120, check=False)
            except (OSError, subprocess.SubprocessError) as error:
                failures.append(f"{' '.join(command)}: {error}")
                continue
            if result.returncode == 0:
                _COMPILER[key] = Compiler(command, result.stdout)
                if stored is not None:
                    _store_bytes(stored, result.stdout)
                break
            failures.append(f"{' '.join(command)} --version: exit status {result.returncode}")
        else:
            _COMPILER[key] = NoCompiler("no C compiler (" + "; ".join(failures) + ")")
    found = _COMPILER[key]
    if isinstance(found, NoCompiler):
        raise NoCompiler(str(found))
    return found


def _stored_version(command: list[str]) -> Path | None:
    """Where the kernel cache keeps the ``--version`` output of the compiler ``command`` runs: by
    the command and the file its first word resolves to (path, size, modification time, inode), so
    that a fresh process does not start the compiler (8-17 ms) only to name the libraries it loads,
    and a compiler installed anew at that path is asked again. None for ``python -m ziglang cc``
    (asked every time) or a command not on ``$PATH``."""
    if command[0] == sys.executable:
        return None
    found = shutil.which(command[0])
    if found is None:
        return None
    try:
        binary = os.path.realpath(found)
        status = os.stat(binary)
    except OSError:
        return None
    digest = source_digest(*command, binary, status.st_size, status.st_mtime_ns, status.st_ino)
    return cache_dir() / f"compiler-{digest}.txt"


def march() -> str:
    """The ``-march=`` value the element kernels are compiled for: ``$LATDYN_MARCH``, default
    ``native`` (this machine's instruction set). ``x86-64-v2`` (SSE4.2, 2 lanes), ``x86-64-v3``
    (AVX2, 4 lanes) and ``x86-64-v4`` (AVX-512, 8 lanes) are the usual others; any value the
    compiler takes is accepted, and :func:`vector_flags` refuses one this CPU cannot run."""
    return os.environ.get(MARCH_VARIABLE, "").strip() or "native"


def kernel_optimisation() -> str | None:
    """The -O level ``$LATDYN_KERNEL_OPT`` names for every element kernel unit, None when it is unset or empty: then
    each unit gets its own (:func:`latdyn.model.kernels.optimisation`, by its size), as a user's runs do.

    For the test suite (``tests/conftest.py`` sets ``-O0``): it compiles every kernel of every variant, and GCC
    compiles the generated straight-line code 5-40x faster at -O0 than at -O1 (its register allocation is most of
    an -O1 compile), while the results are the same (``-ffp-contract=off``, no fast-math: each operation rounded
    as the source says; ``tests/test_instruction_sets.py`` compares the two builds). The kernels then run slower
    (2.3x for the largest unit of ``default``, :data:`latdyn.model.kernels.OPT_LIMIT_OPS`). The level is in the
    flags, hence in each library's cache digest: a run without the variable never loads a library built with it.
    A value not in :data:`OPTIMISATION_LEVELS` raises :class:`latdyn.errors.SceneError` naming the variable."""
    chosen = os.environ.get(OPTIMISATION_VARIABLE, "").strip()
    if not chosen:
        return None
    if chosen not in OPTIMISATION_LEVELS:
        from latdyn.errors import SceneError

        raise SceneError("environment", OPTIMISATION_VARIABLE,
                         f"an optimisation level ({', '.join(OPTIMISATION_LEVELS)}) or nothing, not {chosen!r}")
    return chosen


def _march_error(expected: str):
    from latdyn.errors import SceneError

    return SceneError("environment", MARCH_VARIABLE, expected)


def vector_flags(using: Compiler | None = None) -> tuple[str, ...]:
    """Flags that let the batched kernels (``codegen/templates/c_source.c.j2``) use the SIMD of the
    instruction set :func:`march` names (default ``-march=native``, this machine's).

    The kernels then take as many lanes as one vector register holds doubles (8 with
    AVX-512F, 4 with AVX, 2 otherwise: the template decides from the compiler's macros; a 4-lane
    vector type without AVX would be emulated, 10x slower). The lanes are elements, each
    computed with the same operations in the same order (and ``-ffp-contract=off``, in
    :data:`C_FLAGS`), so the instruction set changes the speed, not the results. The macros the
    ``-march=`` defines are hashed into ``-DLATDYN_ISA=``, so that a cache shared by different
    machines keeps one library per instruction set (a library built for another CPU could stop
    on an illegal instruction). Found once per compiler and ``$LATDYN_MARCH``; () when the
    compiler does not take -march=native and ``$LATDYN_MARCH`` is unset.

    A ``$LATDYN_MARCH`` that is not a plain word, that the compiler refuses, or that needs an
    instruction this CPU lacks (``x86-64-v4`` on a CPU without AVX-512) raises
    :class:`latdyn.errors.SceneError` naming the variable (exit status 2 on the command line)."""
    chosen = march()
    here = isa_macros(using)
    if chosen == "native":
        defined = here
        if not defined:
            return ()
    else:
        if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.+-]*", chosen):
            raise _march_error(f"an instruction set for the compiler's -march= (native, x86-64-v2, "
                               f"x86-64-v3, x86-64-v4, ...), not {chosen!r}")
        using = using or compiler()
        defined = isa_macros(using, chosen)
        if not defined:
            raise _march_error(f"{using.name} does not take -march={chosen} (native, x86-64-v2, "
                               f"x86-64-v3 and x86-64-v4 are the usual values on x86-64)")
        # feature macros are upper case (__AVX512F__); CPU names are not (__k8, __tune_znver3__)
        lacking = sorted(macro for macro in defined - here if macro.isupper())
        if here and lacking:
            raise _march_error(f"-march={chosen} needs instructions this CPU lacks "
                               f"({', '.join(name.strip('_') for name in lacking[:6])}"
                               f"{', ...' if len(lacking) > 6 else ''}): its kernels would stop on "
                               f"an illegal instruction; unset it (native) or name a smaller set")
    key = (chosen, defined)  # the macros' digest once a process (a run asks for the flags three times)
    if key not in _FLAGS:
        _FLAGS[key] = (f"-march={chosen}", "-DLATDYN_ISA=" + sha256("\n".join(sorted(defined)).encode()).hexdigest()[:12])
    return _FLAGS[key]


def isa_macros(using: Compiler | None = None, chosen: str = "native") -> frozenset[str]:
    """The macros ``-march=<chosen>`` makes the compiler define (``__AVX512F__``, …); empty when it
    does not take the option. Found once per compiler and instruction set: asked of the compiler
    (a preprocessor run, 15–40 ms of a fresh process) once per compiler, instruction set and CPU,
    then read from the kernel cache (:func:`_stored_macros`)."""
    using = using or compiler()
    key = (using.identity(), chosen)
    if key not in _VECTOR_FLAGS:
        stored = _stored_macros(using, chosen)
        macros = None
        if stored is not None:
            try:
                macros = stored.read_text()
            except (OSError, UnicodeDecodeError):
                macros = None
        if macros is None:
            import subprocess

            try:
                result = subprocess.run([*using.command, f"-march={chosen}", "-dM", "-E", "-x", "c", os.devnull],
                                        capture_output=True, timeout=120, check=False)
                macros = result.stdout.decode(errors="replace") if result.returncode == 0 else ""
            except (OSError, subprocess.SubprocessError):
                macros = ""
            if macros and stored is not None:
                _store(stored, macros)
        _VECTOR_FLAGS[key] = frozenset(line.split()[1] for line in macros.splitlines()
                                       if line.startswith("#define "))
    return _VECTOR_FLAGS[key]


def _cpu_identity() -> bytes | None:
    """What identifies this CPU's instruction set: the vendor, model and feature flags of the first
    processor in ``/proc/cpuinfo`` (what ``-march=native`` reads through CPUID; ``Features`` and the
    CPU part on ARM); None where there is no such file or it lists no features (then the compiler
    is asked in every process)."""
    try:
        text = Path("/proc/cpuinfo").read_bytes()
    except OSError:
        return None
    first = text.split(b"\n\n", 1)[0]
    wanted = (b"vendor_id", b"cpu family", b"model", b"model name", b"stepping", b"flags", b"Features",
              b"CPU implementer", b"CPU architecture", b"CPU variant", b"CPU part", b"CPU revision")
    lines = [line for line in first.splitlines() if line.split(b":", 1)[0].strip() in wanted]
    if not any(line.split(b":", 1)[0].strip() in (b"flags", b"Features") for line in lines):
        return None
    return b"\n".join(lines)


def _stored_macros(using: Compiler, chosen: str) -> Path | None:
    """Where the kernel cache keeps the macros of ``-march=<chosen>`` for this compiler (its
    :meth:`Compiler.identity`) on this CPU (:func:`_cpu_identity`): a cache shared by machines keeps
    one file per CPU, so that no machine reads another's instruction set. None without a CPU identity."""
    cpu = _cpu_identity()
    if cpu is None:
        return None
    digest = sha256(b"\0".join([using.identity(), chosen.encode(), cpu])).hexdigest()[:16]
    return cache_dir() / f"isa-{digest}.txt"


def _store(path: Path, text: str) -> None:
    """``text`` into ``path`` atomically (a scratch file renamed); a cache that cannot be written
    is left alone (the compiler is asked again next time)."""
    _store_bytes(path, text.encode())


def _store_bytes(path: Path, data: bytes) -> None:
    """:func:`_store` of bytes."""
    import tempfile  # on use: a run that finds everything in the cache writes nothing there

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("wb", dir=path.parent, prefix=path.name, suffix=".tmp",
                                         delete=False) as scratch:
            scratch.write(data)
        os.replace(scratch.name, path)
    except OSError:
        pass


_VECTOR_FLAGS: dict[tuple[bytes, str], frozenset[str]] = {}
_FLAGS: dict[tuple[str, frozenset[str]], tuple[str, str]] = {}  # vector_flags' result by -march= and its macros


def target(name: str, source: bytes, flags=C_FLAGS, using: Compiler | None = None) -> Path:
    """The cache path of ``source`` built with ``flags`` by ``using`` (default :func:`compiler`).
    ``source`` may stand for the source: anything that determines it (see ``key`` of :func:`build`)."""
    using = using or compiler()
    return cache_dir() / f"{name}-{source_digest(source, ' '.join(flags), using.identity())}{SUFFIX}"


def build(name: str, source: bytes, flags=C_FLAGS, *, using: Compiler | None = None,
          key: bytes | None = None, announce: str | None = None) -> Path:
    """The cached library of ``source`` (compiled now if it is not in the cache); its path.

    ``name`` names the file (``<name>-<digest>.so``); the digest is of ``key`` instead of the
    source when given (what the source is made from, so that it is found without making it:
    a scene's laws by their text); ``announce``, when given, is printed on stderr before a
    compile. RuntimeError (:class:`NoCompiler`, :class:`CacheNotWritable` among them) says why not."""
    using = using or compiler()
    path = target(name, source if key is None else key, flags, using)
    if intact(path):
        return path
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise RuntimeError(f"cannot create the kernel cache {path.parent}: {error}") from None
    from filelock import FileLock

    try:
        with FileLock(str(path) + ".lock", timeout=900):
            if not intact(path):   # absent, or cut short: built (again)
                if announce:
                    print(announce, file=sys.stderr, flush=True)
                started = time.perf_counter()
                try:
                    _compile(using, source, path, name, flags)
                finally:
                    COMPILE_SECONDS["total"] += time.perf_counter() - started
    except OSError as error:  # a read-only cache that lacks this library: no lock file, no scratch folder
        raise CacheNotWritable(f"cannot write {path.name} into the kernel cache {path.parent} "
                               f"({error.strerror or error}); set {CACHE_VARIABLE} to a folder this process "
                               "can write") from None
    return path


def intact(path: Path) -> bool:
    """Whether the library file ``path`` exists and is as long as its ELF header says: its section header table,
    which the linker writes last, lies within the file. A library cut short in the cache (a disk that filled, a
    copy interrupted) otherwise kills the process that maps it with a bus error instead of being built again.
    One read of 64 bytes; a file that is not ELF (another platform's format) is taken as it is."""
    import struct

    try:
        with open(path, "rb") as file:
            header = file.read(64)
            size = os.fstat(file.fileno()).st_size
    except OSError:
        return False
    if header[:4] != b"\x7fELF":
        return len(header) > 0
    if len(header) < 64 or header[4] not in (1, 2) or header[5] not in (1, 2):
        return False
    order = "<" if header[5] == 1 else ">"
    if header[4] == 2:   # ELF64: e_shoff at 0x28, e_shentsize and e_shnum at 0x3A
        (table,), (entry, count) = struct.unpack_from(order + "Q", header, 0x28), struct.unpack_from(order + "HH", header, 0x3A)
    else:                # ELF32: e_shoff at 0x20, e_shentsize and e_shnum at 0x2E
        (table,), (entry, count) = struct.unpack_from(order + "I", header, 0x20), struct.unpack_from(order + "HH", header, 0x2E)
    return table + entry * count <= size


def load(path: Path) -> ctypes.CDLL:
    """``ctypes.CDLL`` of a built library; RuntimeError naming it when it does not load or is cut short
    (:func:`intact`: mapping it would end the process with a bus error)."""
    if not intact(path):
        raise RuntimeError(f"cannot load {path.name}: the file in the kernel cache {Path(path).parent} is damaged "
                           f"(shorter than its header says); delete it (or set {CACHE_VARIABLE} to an empty folder) "
                           "and run again")
    try:
        return ctypes.CDLL(str(path))
    except OSError as error:
        raise RuntimeError(f"cannot load {path.name}: {error}") from None


def _compile(using: Compiler, source: bytes, path: Path, name: str, flags) -> None:
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory(dir=path.parent, prefix=".build-") as scratch:
        c_file = Path(scratch) / f"{name}.c"
        c_file.write_bytes(source)
        partial = Path(scratch) / path.name
        command = [*using.command, *flags, str(c_file), "-o", str(partial), "-lm"]
        try:
            result = subprocess.run(command, capture_output=True, text=True, timeout=900)
        except (OSError, subprocess.SubprocessError) as error:
            raise RuntimeError(f"{using.name} failed to run: {error}") from None
        if result.returncode != 0:
            lines = (result.stderr or result.stdout).strip().splitlines()
            first = lines[0] if lines else f"exit status {result.returncode}"
            raise RuntimeError(f"{using.name} failed: {first}")
        os.replace(partial, path)


def source_digest(*parts) -> str:
    """sha256 (first 20 hex) of text or bytes parts, each closed by a NUL."""
    digest = sha256()
    for part in parts:
        digest.update((part if isinstance(part, bytes) else str(part).encode()) + b"\0")
    return digest.hexdigest()[:20]
