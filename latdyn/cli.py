"""The ``latdyn`` command (also ``python -m latdyn``): ``run``, ``check``, ``plot``, ``animate``, ``study``,
``fmu``.

Exit statuses (SCENE.md):

=====  ===============================================================================
0      solved (``run``), valid (``check``), plotted (``plot``), animated (``animate``), study finished
       (failed cases are rows), FMU written (``fmu``)
1      the solver failed, or the run ended unbounded (its energy balance broke: summary.json status
       ``unbounded``; docs/energy.md), what was recorded being left complete; or an internal error
2      invalid scene, missing scene file, bad arguments, missing/invalid results folder (for
       ``animate`` also: no ParaView files in it, an extension other than .gif/.mp4, .mp4 without ffmpeg),
       ``run --resume`` without a checkpoint of this scene and version, invalid study or --scheduler,
       ``fmu`` of a scene that is not transient or to a file not ending in .fmu
130    interrupted (Ctrl-C, SIGTERM); what was recorded is left complete, with a
       checkpoint for ``run --resume``
=====  ===============================================================================

Every message goes to stderr as ``latdyn: error: <message>``; no traceback unless
``--debug`` is given, which re-raises unexpected exceptions.
"""
from __future__ import annotations

import importlib
import shutil
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING

from latdyn.errors import MissingExtra, SceneError, SolverError, UnboundedError
from latdyn.version import __version__

if TYPE_CHECKING:
    import argparse

__all__ = ["main", "build_parser", "default_out_dir"]

PROG = "latdyn"


def _error(message: str) -> None:
    print(f"{PROG}: error: {message}", file=sys.stderr)


def default_out_dir(scene_path) -> Path:
    """``<scene stem>_results`` in the current directory (SCENE.md)."""
    return Path.cwd() / f"{Path(scene_path).stem}_results"


def _module(name: str):
    # imported on use (and looked up in sys.modules) so that `latdyn plot` needs no
    # solver and the tests can substitute modules
    return importlib.import_module(name)


class _UsageError(Exception):
    """A bad command-line argument found after parsing (a missing file): exit 2."""


def _load_scene(path: str):
    scene_path = Path(path)
    if not scene_path.exists():
        raise _UsageError(f"{scene_path}: no such scene file")
    if not scene_path.is_file():
        raise _UsageError(f"{scene_path}: not a scene file (a YAML or JSON file is expected)")
    return _module("latdyn.scene.loader").load_scene(str(scene_path))


# ----------------------------------------------------------------------------- commands
def _command_run(args) -> int:
    from latdyn.timeloop.checkpoint import CheckpointError  # NumPy on use: see one_blas_thread

    scene = _load_scene(args.scene)  # SceneError -> 2 before anything is written
    out_dir = Path(args.out) if args.out else default_out_dir(args.scene)
    existed = out_dir.exists()
    solve = _module("latdyn.solve")
    options = {}  # passed only when given: stand-ins of latdyn.solve need not know them
    if args.resume:
        options["resume"] = True
    if args.checkpoint_every is not None:
        options["checkpoint_every"] = args.checkpoint_every
    try:
        result = solve.run(scene, out_dir=str(out_dir), backend=args.backend, progress=not args.quiet, **options)
    except SceneError:
        # a check that needs the model (e.g. a coordinate nothing holds): still an
        # invalid scene, and nothing may be left behind
        if not existed and out_dir.is_dir():
            shutil.rmtree(out_dir, ignore_errors=True)
        raise
    except UnboundedError as exc:  # resuming would only go on from the broken balance: no hint
        _error(str(exc))
        if out_dir.is_dir():
            print(f"{PROG}: what was recorded up to t = {exc.t:.6g} is in {out_dir}", file=sys.stderr)
        return 1
    except SolverError as exc:
        if getattr(args, "debug", False):
            import traceback

            traceback.print_exc()
        _error(f"the solver failed: {exc}")
        if out_dir.is_dir():
            print(f"{PROG}: what was recorded up to the failure is in {out_dir}", file=sys.stderr)
        _resume_hint(args, out_dir)
        return 1
    except KeyboardInterrupt:
        where = f"; what was recorded so far is in {out_dir}" if out_dir.is_dir() else ""
        print(f"\n{PROG}: interrupted{where}", file=sys.stderr)
        _resume_hint(args, out_dir)
        return 130
    except CheckpointError as exc:  # --resume refused: nothing was changed in OUT
        _error(str(exc))
        return 2
    summary = getattr(result, "summary", {}) or {}
    steps = summary.get("steps")
    wall = summary.get("wall_time_s")
    parts = [f"{PROG}: solved -> {out_dir}"]
    if steps is not None:
        parts.append(f"{steps} steps")
    if wall is not None:
        parts.append(f"{wall:.2f} s wall time")
    print(", ".join(parts))
    return 0


def _resume_hint(args, out_dir: Path) -> None:
    from latdyn.timeloop.checkpoint import CHECKPOINT_FILE

    if (out_dir / CHECKPOINT_FILE).is_file():
        print(f"{PROG}: a checkpoint of the last accepted step is in {out_dir}; continue with "
              f"`{PROG} run {args.scene} -o {out_dir} --resume`", file=sys.stderr)


def _command_check(args) -> int:
    from .analyses.check import check_report
    from .assembly.prepare import prepare
    from .scene.loader import describe

    scene = _load_scene(args.scene)
    if scene.solve.sensitivities:   # what run would refuse (SceneError -> 2)
        from .analyses.sensitivities import refusal

        refused = refusal(scene)
        if refused is not None:
            raise refused
    print(describe(scene))
    # the model, its held check (SceneError -> 2) and the initial state
    print(check_report(prepare(scene)))
    return 0


def _command_plot(args) -> int:
    from latdyn.errors import ResultsError
    from latdyn.results.plot import plot_results

    try:
        written = plot_results(args.results, plot_dir=args.out)
    except ResultsError as exc:
        _error(str(exc))
        return 2
    if not written:
        print(f"{PROG}: {args.results}: nothing to plot (no rows and no modes)")
        return 0
    print(f"{PROG}: wrote {len(written)} plots to {written[0].parent}")
    return 0


def _command_animate(args) -> int:
    from latdyn.errors import ResultsError
    from latdyn.results.animation import animate

    try:
        options = {"max_frames": args.frames} if args.frames is not None else {}
        path = animate(args.results, args.out, fps=args.fps, **options)
    except ResultsError as exc:
        _error(str(exc))
        return 2
    print(f"{PROG}: wrote {path}")
    return 0


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise _argument_type_error(f"expected a whole number >= 1, not {text!r}")
    return value


def _positive_number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 < value < float("inf"):
        raise _argument_type_error(f"expected a number > 0, not {text!r}")
    return value


def _command_study(args) -> int:
    if not Path(args.study).is_file():
        raise _UsageError(f"{args.study}: no such study file")
    try:
        table = _module("latdyn.studies.runner").study(args.study, scheduler=args.scheduler, out=args.out,
                                              progress=not args.quiet)
    except ValueError as exc:  # a malformed --scheduler, an unreachable scheduler (SceneError is caught in main)
        if isinstance(exc, SceneError):
            raise
        _error(str(exc))
        return 2
    print(f"{PROG}: study of {len(table)} cases -> {table.out_dir}")
    return 0


def _command_fmu(args) -> int:
    _load_scene(args.scene)  # SceneError -> 2 before anything is written
    out = Path(args.out) if args.out else Path.cwd() / f"{Path(args.scene).stem}.fmu"
    if out.suffix != ".fmu":
        raise _UsageError(f"{out}: an FMU file name ends in .fmu")
    built = _module("latdyn.stepping.fmu").build_fmu(args.scene, out)
    print(f"{PROG}: wrote {built} (FMI 2.0 co-simulation; it runs in a Python with latdyn installed)")
    return 0


# ----------------------------------------------------------------------------- parser
def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value >= 0.0 or value == float("inf"):
        raise _argument_type_error(f"expected a number of seconds >= 0, not {text!r}")
    return value


def _argument_type_error(message: str) -> Exception:
    import argparse

    return argparse.ArgumentTypeError(message)


def build_parser() -> argparse.ArgumentParser:
    import argparse

    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Transient dynamics of joint-dominated flexible structures (NASA CR-4402).",
        epilog="Exit status: 0 ok, 1 solver failure or internal error, 2 invalid scene or "
        "arguments, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of unexpected errors")
    # the same flag after the sub-command; SUPPRESS keeps it from overriding the one before
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show tracebacks of unexpected errors")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    commands.required = True

    run = commands.add_parser("run", parents=[common], help="solve a scene and write its results",
                              description="Solve SCENE and write probes.csv, the state history, "
                              "summary.json (and modes.csv, ParaView frames) into OUT.")
    run.add_argument("scene", metavar="SCENE", help="scene file (YAML or JSON)")
    run.add_argument("-o", "--out", metavar="OUT", help="results folder (default: ./<SCENE stem>_results)")
    run.add_argument("--backend", choices=("auto", "c"), default="auto",
                     help="element kernels: compiled C (auto: the same, saying how to get a compiler when none works)")
    run.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    run.add_argument("--resume", action="store_true",
                     help="continue an interrupted or failed transient run from the checkpoint in OUT "
                     "(exit 2 when there is none, or it is of another scene or latdyn version)")
    run.add_argument("--checkpoint-every", metavar="SECONDS", type=_seconds, default=None,
                     help="wall-clock seconds between checkpoints of a transient run (default 60; "
                     "0: every step); a checkpoint is also written on Ctrl-C, SIGTERM and failure")
    run.set_defaults(handler=_command_run)

    check = commands.add_parser("check", parents=[common], help="validate a scene and print the model size",
                                description="Validate SCENE, describe it and print the model's size; "
                                "nothing is solved or written.")
    check.add_argument("scene", metavar="SCENE", help="scene file (YAML or JSON)")
    check.set_defaults(handler=_command_check)

    plot = commands.add_parser("plot", parents=[common], help="plot the probes and the structure of a results folder",
                               description="Write one PNG per probe, overview.png (and modes.png), and "
                               "structure.png (the structure at several recorded times, from the ParaView "
                               "files) into OUT/plots or DIR.")
    plot.add_argument("results", metavar="OUT", help="results folder written by `latdyn run`")
    plot.add_argument("--out", metavar="DIR", help="where to write the PNGs (default: OUT/plots)")
    plot.set_defaults(handler=_command_plot)
    animate = commands.add_parser("animate", parents=[common], help="animate the structure's motion in a results folder",
                                  description="Write an animation of the structure (from OUT's ParaView files) "
                                  "to FILE: .gif (Pillow) or .mp4 (needs ffmpeg on PATH), by its extension.")
    animate.add_argument("results", metavar="OUT", help="results folder written by `latdyn run`")
    animate.add_argument("-o", "--out", metavar="FILE", help="animation file, .gif or .mp4 (default: OUT/animation.gif)")
    animate.add_argument("--frames", metavar="N", type=_positive_int, default=None,
                         help="at most N frames, taken evenly from the recorded ParaView frames (default 120)")
    animate.add_argument("--fps", metavar="FPS", type=_positive_number, default=20.0,
                         help="frames per second of the animation (default 20)")
    animate.set_defaults(handler=_command_animate)
    study = commands.add_parser("study", parents=[common], help="run a study: work-precision, stability map, sweep, Campbell diagram",
                                description="Run the cases of STUDY (shared/STUDY.md) and write study.csv, "
                                "work_precision.png, stability.png (campbell.png for a modes scene), cases/ "
                                "and summary.json into OUT.")
    study.add_argument("study", metavar="STUDY", help="study file (YAML)")
    study.add_argument("-o", "--out", metavar="OUT", help="study folder (default: ./<STUDY stem>_study)")
    study.add_argument("--scheduler", default="serial", metavar="serial|local[:N]|ADDRESS",
                       help="serial (default), a local Dask cluster of N processes, or a Dask scheduler address")
    study.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    study.set_defaults(handler=_command_study)
    fmu = commands.add_parser("fmu", parents=[common], help="build an FMI 2.0 co-simulation FMU of a transient scene",
                              description="Write an FMI 2.0 co-simulation FMU of SCENE (a transient scene) to "
                              "FILE.fmu, packed by PythonFMU: its real inputs are the scene's inputs (start values "
                              "the scene's), its real outputs the scene's probes; each communication step advances "
                              "the run to the next communication point. The FMU runs latdyn in an embedded Python: "
                              "where it runs, that Python needs latdyn installed (pip install \"latdyn[fmu]\").")
    fmu.add_argument("scene", metavar="SCENE", help="scene file (YAML or JSON)")
    fmu.add_argument("-o", "--out", metavar="FILE.fmu", help="the FMU file (default: ./<SCENE stem>.fmu)")
    fmu.set_defaults(handler=_command_fmu)
    return parser


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """latdyn's own warnings (``latdyn: ...``, e.g. no C compiler) as one line on stderr;
    others as Python shows them."""
    text = str(message)
    if text.startswith(f"{PROG}:"):
        print(text, file=sys.stderr if file is None else file, flush=True)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line), end="",
              file=sys.stderr if file is None else file)


def main(argv=None) -> int:
    """Run the command line; returns the exit status. Called as the process's own command
    (``argv`` None: ``python -m latdyn``, the ``latdyn`` script), the garbage collector leaves
    alone what the process imported before it and, as the process ends next, what the command made
    (:func:`_freeze_collector`); and ``latdyn run``, where it is the whole program, ends the process
    itself with its exit status, without the interpreter's teardown (:func:`_end_without_teardown`)."""
    if argv is None:
        _freeze_collector()
    try:
        status = _main(argv, command=argv is None)
    finally:
        if argv is None:
            _freeze_collector()
    if argv is None and _RAN[0] and _the_whole_process(sys._getframe(1)):
        _end_without_teardown(status)
    return status


#: Whether this process's command was ``run`` (set by :func:`_main`, read by :func:`main`).
_RAN = [False]


def _the_whole_process(caller) -> bool:
    """Whether the command is all this process does after it: ``main`` called by the ``latdyn`` script or by
    ``latdyn/__main__.py`` run as ``python -m latdyn`` (``caller`` the frame that called it: the top level of
    one of those two files, run as the program, only runpy's frames outside it; not a script or ``python -c``
    of the user's that may go on after ``main()``), no profiler or tracer (``python -m cProfile -m latdyn``
    writes its report after the command; coverage, a debugger) and no thread but this one that the
    interpreter would wait for."""
    import threading
    from pathlib import Path

    code = caller.f_code
    ours = Path(code.co_filename).name == "latdyn" or code.co_filename == str(Path(__file__).with_name("__main__.py"))
    if sys.getprofile() is not None or sys.gettrace() is not None or code.co_name != "<module>" or not ours \
            or caller.f_globals.get("__name__") != "__main__":
        return False
    outer = caller.f_back
    while outer is not None:
        if outer.f_globals.get("__name__") != "runpy" or outer.f_code.co_name not in ("_run_code",
                                                                                        "_run_module_as_main"):
            return False
        outer = outer.f_back
    return all(t.daemon or t is threading.current_thread() for t in threading.enumerate())


def _end_without_teardown(status: int) -> None:
    """End ``latdyn run``'s process with ``status`` without the interpreter's teardown (freeing every module
    and object, ≈ 15 ms of the 16-bay lattice's process; docs/performance.md, "Seventh pass"): the atexit
    functions run as at any exit, then Python's and the C library's buffered output is flushed and the
    process ends (``os._exit``). Only where nothing is lost: no file but stdin, stdout and stderr is open
    for writing (every file of the run was closed and synced by its writer, ResultWriter.close), else, or
    where a flush fails, the process ends as before, by returning."""
    import atexit
    import ctypes
    import os

    if _open_for_writing():
        return
    atexit._run_exitfuncs()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        ctypes.CDLL(None).fflush(None)  # the C library's streams (NULL: all of them)
    except Exception:  # noqa: BLE001 - e.g. a closed pipe: the interpreter's own exit reports it, as before
        return
    os._exit(status)


def _open_for_writing() -> bool:
    """Whether this process holds a file other than stdin, stdout and stderr open for writing (Linux's
    /proc/self/fd; True where that cannot be read: then nothing is assumed)."""
    import os
    import stat

    try:
        descriptors = [int(fd) for fd in os.listdir("/proc/self/fd")]
    except OSError:
        return True
    for fd in descriptors:
        if fd <= 2:
            continue
        try:
            mode, flags = os.fstat(fd).st_mode, _fd_flags(fd)
        except OSError:  # the listing's own descriptor, closed by now
            continue
        if stat.S_ISREG(mode) and flags & os.O_ACCMODE != os.O_RDONLY:
            return True
    return False


def _fd_flags(fd: int) -> int:
    """The open flags of a descriptor (fcntl's F_GETFL)."""
    import fcntl

    return fcntl.fcntl(fd, fcntl.F_GETFL)


def _freeze_collector() -> None:
    """``gc.freeze``, at the command's start and again as the process ends. At the start: what the
    process holds before the command (the modules imported, their functions and classes, which live as
    long as the process) is no longer traced by the collector's passes during the run (the 16-bay
    lattice's ``latdyn run``: 0.84 → 0.76 s of CPU, medians of 8 at load 5-6, docs/performance.md);
    what the command makes is collected as before. At the end: the passes at exit traced every object
    of the run (70–100 ms of CPU after a 16-bay lattice's run; docs/performance.md, "Where a run's time
    goes") only to free memory the operating system takes back anyway. Nothing is skipped that a result
    needs: every file of the run was closed and synced by its writer before (ResultWriter.close), the
    atexit functions and the flush of stdout and stderr still run, and objects still go when their last
    reference does; only cycles of unreachable objects are left to the operating system."""
    import gc

    gc.freeze()


#: The garbage collector's first threshold while ``latdyn run`` is its process's command (Python's default: 700).
RUN_COLLECTOR_THRESHOLD = 100_000


def collect_less_often() -> None:
    """``latdyn run`` as the process's own command: the collector's first generation is collected after
    :data:`RUN_COLLECTOR_THRESHOLD` new container objects instead of Python's 700. A run's start
    (NumPy's, h5py's and latdyn's imports, the scene, the model) makes objects that nearly all live as long
    as the process: the collector's 90-odd passes over them found nothing to free and cost the 16-bay
    lattice's ``latdyn run`` ≈ 9 ms of its ≈ 0.24 s (docs/performance.md, "Eleventh pass"). Cycles of
    unreachable objects are still collected, every 100 000 allocations: at most that many wait, a few
    MB; objects without cycles go when their last reference does, as before. The API
    (:func:`latdyn.run`) and ``main([...])`` leave the calling process's collector as it is."""
    import gc

    gc.set_threshold(RUN_COLLECTOR_THRESHOLD, *gc.get_threshold()[1:])


#: The variables by which a user chooses OpenBLAS's threads (OpenBLAS reads them in this order).
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def one_blas_thread() -> bool:
    """``latdyn run`` as the process's own command: NumPy's and SciPy's OpenBLAS start with one
    thread (``OPENBLAS_NUM_THREADS=1`` set before NumPy is imported), unless the user chose their
    threads with one of :data:`BLAS_THREAD_VARIABLES` or NumPy is loaded already. Returns whether it set it.

    The time step is one thread of C whose LAPACK and BLAS calls are pinned to one thread already
    (:func:`latdyn.numerics.linalg.openblas_thread_functions`); what the thread pools of the two
    OpenBLAS libraries still cost is their start and their workers' spinning after a threaded call:
    ≈ 80 ms of CPU of the 16-bay lattice's 0.57 s (docs/performance.md, "Where a run's time goes"),
    no wall time on an idle second core, all of it on a busy one. The results are the same: the
    step does not use the pools, and the files of the runs compared were equal to the byte with and
    without (tests/test_light_run.py; docs/performance.md). The API (:func:`latdyn.run`) leaves the
    calling process's threads as they are."""
    import os

    if "numpy" in sys.modules or any(os.environ.get(name) for name in BLAS_THREAD_VARIABLES):
        return False
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    return True


#: ``latdyn run``'s options that :func:`_plain_run_arguments` reads: a flag's attribute, or an option's attribute
#: and the values it takes (None: any).
_RUN_FLAGS = {"-q": "quiet", "--quiet": "quiet", "--resume": "resume", "--debug": "debug"}
_RUN_OPTIONS = {"-o": ("out", None), "--out": ("out", None), "--backend": ("backend", ("auto", "c"))}


def _plain_run_arguments(argv: list) -> SimpleNamespace | None:
    """The arguments of a plain ``latdyn run`` command line, read without argparse (its import and the
    parser of the six sub-commands: ≈ 4 ms of a fresh process; docs/performance.md, "Thirteenth pass"): ``[--debug]
    run SCENE`` with any of ``-o/--out OUT``, ``--backend auto|c``, ``-q/--quiet``, ``--resume``, ``--debug``,
    each once and written out whole, in any order. The same attributes and values as
    ``build_parser().parse_args(argv)`` (tests/test_cli.py). None for any other command line (another command,
    ``--help``, ``--checkpoint-every``, an abbreviated or joined option, a value or a SCENE that starts with ``-``
    or is empty, a second SCENE, a bad backend …): argparse reads it, as before, with its messages."""
    debug = argv[:1] == ["--debug"]
    words = argv[1:] if debug else argv
    if words[:1] != ["run"]:
        return None
    args = {"debug": debug, "command": "run", "out": None, "backend": "auto", "quiet": False, "resume": False,
            "checkpoint_every": None, "handler": _command_run}
    given, scene = set(), None
    words = iter(words[1:])
    for word in words:
        if not word or word.startswith("-"):
            name = _RUN_FLAGS.get(word) or _RUN_OPTIONS.get(word, (None,))[0]
            if name is None or name in given:
                return None
            given.add(name)
            if word in _RUN_FLAGS:
                args[name] = True
                continue
            value = next(words, "")
            allowed = _RUN_OPTIONS[word][1]
            if not value or value.startswith("-") or (allowed is not None and value not in allowed):
                return None
            args[name] = value
        elif scene is None:
            scene = word
        else:
            return None
    if scene is None:
        return None
    return SimpleNamespace(scene=scene, **args)


def _main(argv=None, command: bool = False) -> int:
    args = _plain_run_arguments(sys.argv[1:] if argv is None else list(argv))
    if args is None:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # argparse: 2 on bad arguments, 0 for --help/--version
            return int(exc.code or 0)
    if command and args.command == "run":
        one_blas_thread()
        collect_less_often()
        _RAN[0] = True
    debug = getattr(args, "debug", False)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning
            return args.handler(args)
    except MissingExtra as exc:  # a feature of an extra that is not installed: the message names it
        _error(str(exc))
        return 1
    except (SceneError, _UsageError) as exc:
        _error(str(exc))
        return 2
    except SolverError as exc:
        if debug:
            import traceback

            traceback.print_exc()
        _error(f"the solver failed: {exc}")
        return 1
    except KeyboardInterrupt:
        print(f"\n{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `latdyn check x | head`
        return 1
    except Exception as exc:  # noqa: BLE001 - the last line of defence
        if debug:
            raise
        print(f"{PROG}: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        print(f"{PROG}: rerun with --debug to see the traceback, and please report it", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
