"""A variant's kernel libraries opened when first used (issue 31): a run opens those its model calls,
not all of the variant's, and a kernel asked for later opens then and computes as before."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

CHAIN = """\
title: 3D chain with a joint body under gravity
sections:
  s: {EA: 1.0e6, EIy: 2.0e3, EIz: 1.0e3, GJ: 8.0e2, rhoA: 2.0, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
bodies:
  wall: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.3, 0.2], mass: 0.5, inertia: [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]}
beams:
  arm: {from: wall, to: tip, section: s, elements: 4}
gravity: [0, 0, -9.81]
solve: {analysis: transient, t_end: 0.01, dt: 0.002}
output:
  probes:
    z: {point: tip, quantity: displacement, component: z}
"""


def test_a_run_opens_only_the_kernel_libraries_its_model_calls(tmp_path):
    """In a fresh process: after load_kernels only the parts of the composed beam_dynamics are open,
    every library still counted and found (``in``, ``len``); after a run of a chain with a joint body
    the open ones are fewer than the variant's; a kernel not yet open (beam_deformation) opens when
    asked for."""
    scene = tmp_path / "chain.yaml"
    scene.write_text(CHAIN)
    code = textwrap.dedent(f"""
        import json
        import latdyn
        from latdyn.model import kernels as module
        from latdyn.model.kernels import COMPOSED, ON_DEMAND, load_kernels
        kernels = load_kernels("c", "default")
        libraries = kernels.libraries
        after_load = sorted(dict.keys(libraries))
        compiled = [name for name in kernels.info if name not in ON_DEMAND]
        counted, found = len(libraries), all(name in libraries for name in compiled)
        result = latdyn.run(latdyn.load_scene({str(scene)!r}))
        opened = {{variant: (dict.__len__(k.libraries), len(k.libraries)) for (backend, variant), k in module._LOADED.items()}}
        closed_before = "beam_deformation" not in dict.keys(libraries)
        deformation = kernels.beam_deformation  # opened here
        print(json.dumps({{"after_load": after_load, "parts": sorted(p for ps in COMPOSED.values() for p in ps),
                          "counted": counted, "compiled": len(compiled), "found": found, "opened": opened,
                          "status": result.summary["status"], "closed_before": closed_before,
                          "open_now": "beam_deformation" in dict.keys(libraries) and callable(deformation)}}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["after_load"] == found["parts"]
    assert found["found"] and found["counted"] == found["compiled"] >= 30
    assert found["status"] == "solved"
    assert all(0 < opened < count for opened, count in found["opened"].values()), found["opened"]
    assert found["closed_before"] and found["open_now"]


def test_a_kernel_opened_through_its_set_is_counted_once_and_seen_by_keys_get_and_dict():
    """Reviewer B: a kernel opened through ``KernelSet`` (``_build`` stores its library) stayed among the
    files not yet opened, so ``len`` grew 34 → 35 and iteration named it twice, while ``keys``, ``get`` and
    ``dict()`` saw only the opened ones. In a fresh process: the count and the names stay the variant's,
    once each, before and after; ``keys``, ``get`` and ``dict()`` see every kernel."""
    code = textwrap.dedent("""
        import json
        from latdyn.model.kernels import ON_DEMAND, load_kernels
        kernels = load_kernels("c", "default")
        libraries = kernels.libraries
        before = sorted(libraries)
        name = next(n for n in kernels._deferred if n not in ON_DEMAND)
        kernels.library(name)
        unopened = next(n for n in libraries if n not in dict.keys(libraries))
        print(json.dumps({"before": before, "after": list(libraries), "len": [len(before), len(libraries)],
                          "keys": sorted(libraries.keys()), "get": libraries.get(unopened) is not None,
                          "missing": libraries.get("no such kernel", 7), "dict": sorted(dict(libraries)),
                          "opened_once": list(libraries).count(name)}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["len"][0] == found["len"][1] == len(found["after"]) >= 30
    assert sorted(found["after"]) == found["before"] == found["keys"] == found["dict"]
    assert found["opened_once"] == 1 and found["get"] and found["missing"] == 7


def test_a_run_finds_the_generated_sources_without_importlib_resources(tmp_path):
    """``native.package_folder`` is ``importlib.resources.files``' folder for latdyn's packages, and a run
    in a fresh process (kernels and step library from the cache) imports neither ``importlib.resources``
    nor its readers (≈ 2 ms of the lattice's process), nor ``tempfile`` and ``shlex``, which only a compile,
    a store into the cache or ``$CC`` need (≈ 1.4 ms; docs/performance.md, "Eleventh pass")."""
    scene = tmp_path / "chain.yaml"
    scene.write_text(CHAIN)
    code = textwrap.dedent(f"""
        import json, sys
        WATCHED = ("zipfile", "tempfile", "shlex")
        for name in [m for m in sys.modules if m.startswith("importlib.re") or m in WATCHED]:
            del sys.modules[name]  # a site's .pth may have imported them (certifi's): forgotten, seen if imported again
        import latdyn
        latdyn.run(latdyn.load_scene({str(scene)!r}))  # fills the cache if need be
        print(json.dumps({{"imported": sorted(m for m in sys.modules if m.startswith("importlib.re") or m in WATCHED)}}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for _ in range(2):  # the second process finds everything in the cache
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"imported": []}
    from importlib.resources import files

    from latdyn.native import package_folder

    for package in ("latdyn_generated", "latdyn.assembly", "latdyn"):
        assert package_folder(package) == files(package)


def test_a_process_that_finds_its_compiler_stored_imports_no_subprocess(tmp_path):
    """The compiler, its ``-march`` flags and the kernels' cache are found in a process after the first
    without starting a process, and without importing ``subprocess`` (≈ 2 ms of a fresh run's imports;
    docs/performance.md, "Twelfth pass"): only a compile or a compiler asked anew imports it."""
    code = textwrap.dedent("""
        import json, sys
        sys.modules.pop("subprocess", None)  # a site's .pth may have imported it: forgotten, seen if imported again
        from latdyn import native
        native.vector_flags(native.compiler())  # the first process asks the compiler and stores its answers
        print(json.dumps({"subprocess": "subprocess" in sys.modules}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               LATDYN_CACHE_DIR=str(tmp_path / "cache"))
    env.pop("CC", None)
    seen = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        seen.append(json.loads(done.stdout.strip().splitlines()[-1])["subprocess"])
    if not list((tmp_path / "cache").glob("compiler-*.txt")):
        pytest.skip("no compiler version stored (no cc on PATH)")
    assert seen == [True, False]


def test_the_cache_keys_are_hashlibs_sha256_and_a_run_loads_no_openssl(tmp_path):
    """:func:`latdyn.digest.sha256` is ``hashlib.sha256`` digest for digest (the kernel cache's keys and the
    scene's ``source_hash`` unchanged), and a run in a fresh process (kernels from the cache) imports neither
    ``hashlib`` nor OpenSSL's ``_hashlib`` where Python has its own SHA-256 (≈ 3 ms of a fresh run;
    docs/performance.md, "Twelfth pass")."""
    import hashlib

    from latdyn.digest import sha256
    from latdyn.native import source_digest

    rng = np.random.default_rng(3)
    for size in (0, 1, 55, 56, 64, 1000, 300_000):
        data = rng.integers(0, 256, size, dtype=np.uint8).tobytes()
        assert sha256(data).hexdigest() == hashlib.sha256(data).hexdigest()
        ours, theirs = sha256(), hashlib.sha256()
        for chunk in (data[: size // 3], data[size // 3:], b"\0"):
            ours.update(chunk)
            theirs.update(chunk)
        assert ours.hexdigest() == theirs.hexdigest() and ours.digest() == theirs.digest()
    assert source_digest("a", b"b", 3) == hashlib.sha256(b"a\0b\x003\0").hexdigest()[:20]
    scene = tmp_path / "chain.yaml"
    scene.write_text(CHAIN)
    code = textwrap.dedent(f"""
        import importlib.util, json, sys
        for name in [m for m in sys.modules if m in ("hashlib", "_hashlib")]:
            del sys.modules[name]  # a site's .pth may have imported them: forgotten, seen if imported again
        import latdyn
        result = latdyn.run(latdyn.load_scene({str(scene)!r}))  # fills the cache if need be
        own = any(importlib.util.find_spec(m) is not None for m in ("_sha256", "_sha2"))
        print(json.dumps({{"own": own, "imported": sorted(m for m in sys.modules if m in ("hashlib", "_hashlib"))}}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for _ in range(2):  # the second process finds everything in the cache
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    if not seen["own"]:
        pytest.skip("this Python has no SHA-256 of its own: hashlib's serves")
    assert seen["imported"] == []


def _calls(monkeypatch, owner, name: str) -> list:
    """The first arguments of every call of ``owner.name`` from now on (the function still runs)."""
    calls, real = [], getattr(owner, name)

    def recorded(first, *args, **kwargs):
        calls.append(first)
        return real(first, *args, **kwargs)

    monkeypatch.setattr(owner, name, recorded)
    return calls


def test_the_laws_generator_version_is_found_by_its_index_without_reading_codegen(monkeypatch, tmp_path):
    """``compiled_laws.generator_version`` in a process after the first comes from its index in the cache
    (``index-laws-generator-*.txt``, under the files' identities) without reading the 0.38 MB of codegen/ and
    expressions.py (≈ 1.3 ms of a fresh run; docs/performance.md, "Twelfth pass"): the same version as the
    files' digest. A file whose identity changes (edited) changes the index's name."""
    from pathlib import Path as _Path

    from latdyn import native
    from latdyn.assembly import compiled_laws
    from latdyn.scene.expressions import sympy_version

    monkeypatch.setenv("LATDYN_CACHE_DIR", str(tmp_path / "cache"))
    folder = ROOT / "codegen"
    files = sorted(folder.glob("*.py")) + sorted((folder / "templates").glob("*.j2"))
    files.append(ROOT / "latdyn" / "scene" / "expressions.py")
    expected = native.source_digest(*[path.read_bytes() for path in files], sympy_version())
    read = _calls(monkeypatch, _Path, "read_bytes")
    for reads in (True, False):  # the first process digests the files, the next finds the index
        monkeypatch.setattr(compiled_laws, "_VERSION", [])
        read.clear()
        assert compiled_laws.generator_version() == expected
        assert bool(read) is reads
    assert len(list((tmp_path / "cache").glob("index-laws-generator-*.txt"))) == 1
    edited = tmp_path / "edited.py"
    edited.write_text("a = 1\n")
    before = compiled_laws._version_index([edited], None)
    edited.write_text("a = 22\n")
    assert compiled_laws._version_index([edited], None) != before


def test_the_step_library_is_found_by_its_index_without_reading_its_sources(monkeypatch, tmp_path):
    """``native_library`` in a process after the first finds the compiled step through its index in the
    cache (``index-newton_step-*.txt``, under the csrc files' identities) without reading and digesting its
    0.23 MB of source (≈ 2 ms of a fresh run); the same library as from the source. A csrc file whose
    identity changes (edited) changes the index's digest, so the library is found from the source again."""
    import shutil

    from latdyn import native
    from latdyn.assembly import library

    read = _calls(monkeypatch, library, "library_source")
    monkeypatch.setattr(library, "_LIBRARY", None)
    first = library.native_library()._name  # fills the index if this cache has none
    monkeypatch.setattr(library, "_LIBRARY", None)  # a later process
    read.clear()
    assert library.native_library()._name == first and read == []
    using = native.compiler()
    serial = (*native.C_FLAGS, *library.LIBRARY_FLAGS, *native.vector_flags(using))
    assert library._indexed_library(library._library_index(using, serial)) == Path(first)
    copy = tmp_path / "assembly"
    shutil.copytree(native.package_folder("latdyn.assembly") / "csrc", copy / "csrc")
    monkeypatch.setattr(native, "package_folder", lambda package: copy)
    before = library._library_index(using, serial)
    (copy / "csrc" / "newton_step.c").write_bytes((copy / "csrc" / "newton_step.c").read_bytes() + b"\n")
    assert library._library_index(using, serial) != before
