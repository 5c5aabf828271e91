"""``latdyn-codegen``: regenerate, check or report the generated beam kernels.

    latdyn-codegen                      regenerate generated/ for every variant
    latdyn-codegen --variant default    only that variant (repeatable)
    latdyn-codegen --check              exit 1 if generated/ differs from a fresh generation
    latdyn-codegen --report [PATH]      write docs/derivation.md (codegen.report)
    latdyn-codegen --out DIR            write to (or, with --check, compare with) DIR

Exit status: 0 done / current, 1 stale (``--check``), 2 bad usage or a kernel that
cannot be emitted.  Variants are generated in parallel processes (one per core).  Each
run prints the time of every stage (see codegen/emit.py) and the op count of every kernel.
"""
from __future__ import annotations

import argparse
import importlib
import sys
import tempfile
import time
from pathlib import Path

from . import emit

PROG = "latdyn-codegen"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG, description="Regenerate the CR-4402 beam kernels (NumPy and C99)."
    )
    parser.add_argument("--out", type=Path, default=None,
                        help=f"generated folder (default: {emit.DEFAULT_OUT_DIR.name}/ next to codegen/)")
    parser.add_argument("--variant", action="append", default=None, metavar="NAME",
                        help="generate only this variant (repeatable)")
    parser.add_argument("--check", action="store_true",
                        help="regenerate into a temporary folder and compare byte for byte")
    parser.add_argument("--report", nargs="?", const="", default=None, metavar="PATH",
                        help="write the derivation report (default docs/derivation.md) and exit")
    parser.add_argument("--derivation", default="codegen.derivation", metavar="MODULE",
                        help=argparse.SUPPRESS)  # a module with VARIANTS and build_kernels (tests)
    parser.add_argument("--quiet", action="store_true", help="print only the summary")
    return parser


def _fail(message: str, status: int = 2) -> int:
    print(f"{PROG}: {message}", file=sys.stderr)
    return status


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        import symengine  # noqa: F401  the generator's derivation and CSE; a run does not need it
    except ImportError:
        return _fail('the code generator needs symengine, which is not installed: pip install "latdyn[codegen]"')
    if args.report is not None:
        from . import report

        path = Path(args.report) if args.report else emit.SOURCE_ROOT / "docs" / "derivation.md"
        report.write_report(path)
        print(f"{PROG}: wrote {path}")
        return 0

    try:
        derivation = importlib.import_module(args.derivation)
    except ImportError as error:
        return _fail(f"cannot import the derivation module {args.derivation!r}: {error}")
    variants: dict[str, str] = dict(derivation.VARIANTS)
    selected = args.variant or list(variants)
    for name in selected:
        if name not in variants:
            return _fail(f"unknown variant {name!r} (known: {', '.join(variants)})")
    selected = list(dict.fromkeys(selected))
    out_dir = (args.out or emit.DEFAULT_OUT_DIR).resolve()
    log = (lambda message: None) if args.quiet else print

    timer = emit.StageTimer()
    started = time.perf_counter()
    try:
        # a derivation module may bring its own ``joints`` unit (tests/toy_kernels.py: a small one)
        files, results = emit.generate(derivation.build_kernels, variants, selected, timer, log,
                                       joint_kernels=getattr(derivation, "build_joint_kernels", None),
                                       joint_description=getattr(derivation, "JOINT_DESCRIPTION", None))
    except emit.EmitError as error:
        return _fail(str(error))
    complete = set(selected) == set(variants)

    if args.check:
        with tempfile.TemporaryDirectory(prefix="latdyn-codegen-") as scratch:
            with timer.stage("write"):
                emit.write_files(files, Path(scratch))
            status = _compare(Path(scratch), out_dir, sorted(files), complete)
    else:
        with timer.stage("write"):
            written = emit.write_files(files, out_dir, remove_stale=complete)
        status = 0
        print(f"{PROG}: {len(files)} files in {_shown(out_dir)}, {len(written)} changed")
    _print_times(timer, results, time.perf_counter() - started)
    return status


def _shown(path: Path) -> str:
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _print_times(timer: emit.StageTimer, results: list[emit.VariantResult], wall: float) -> None:
    """Stage times summed over the variants (generated in parallel processes), and the wall time."""
    total_ops = sum(k.op_count for result in results for k in result.kernels)
    stages = "  ".join(f"{stage} {timer.seconds[stage]:.2f} s" for stage in emit.STAGES)
    print(f"{PROG}: {stages}  (total {sum(timer.seconds.values()):.2f} s over the variants, "
          f"wall {wall:.2f} s, {total_ops} ops)")


def _compare(fresh: Path, committed: Path, names: list[str], complete: bool) -> int:
    """Compare a fresh generation with ``committed``; print what differs; 1 if stale."""
    problems = []
    for name in names:
        target = committed / name
        if not target.is_file():
            problems.append(f"missing: {name}")
            continue
        new, old = (fresh / name).read_bytes(), target.read_bytes()
        if new != old:
            problems.append(f"differs: {name} ({_first_difference(old, new)})")
    if complete and committed.is_dir():
        for path in sorted(committed.iterdir()):
            if path.is_file() and path.name not in names and emit.is_generated(path):
                problems.append(f"extra:   {path.name}")
    if problems:
        print(f"{PROG}: {_shown(committed)} is stale; run `{PROG}` to regenerate")
        for line in problems:
            print(f"  {line}")
        return 1
    print(f"{PROG}: {_shown(committed)} is current ({len(names)} files)")
    return 0


def _first_difference(old: bytes, new: bytes) -> str:
    old_lines = old.decode("utf-8", "replace").splitlines()
    new_lines = new.decode("utf-8", "replace").splitlines()
    for number, (a, b) in enumerate(zip(old_lines, new_lines), start=1):
        if a != b:
            return f"first difference at line {number}: {_clip(a)!r} vs generated {_clip(b)!r}"
    number = min(len(old_lines), len(new_lines)) + 1
    return f"first difference at line {number}: lengths {len(old_lines)} vs generated {len(new_lines)} lines"


def _clip(text: str, width: int = 60) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
