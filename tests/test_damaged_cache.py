"""A library cut short in the kernel cache (a disk that filled, a copy interrupted): the process that mapped it
died with a bus error (exit 135, no message). It is now built again where it is found (latdyn.native.intact: the
ELF file's section header table must lie within it), and refused with a message naming it where it is opened."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from latdyn import native

ROOT = Path(__file__).resolve().parents[1]

#: A hub driven by a law no other run compiles (its constant made per test): its laws' library is built in the
#: test's own cache, not found in the shared one
SCENE = """\
sections:
  arm: {EA: 2.8e7, EIy: 1.4e4, EIz: 1.4e4, GJ: 1.0e4, rhoA: 1.2}
bodies:
  hub:
    at: [0, 0, 0]
    motion:
      rotation: {axis: [0, 0, 1], angle: "0.3*sin(2.1*t) + CONSTANT*t**2"}
beams:
  arm: {from: hub, to: [2, 0, 0], section: arm, elements: 4}
solve: {analysis: transient, t_end: 0.1, dt: 0.005}
output:
  probes:
    tip: {point: arm.end, quantity: position, frame: hub, component: y}
"""


def _cache_beside_the_shared_one(folder: Path) -> Path:
    """A kernel cache of links to every file of the session's, so that only what a test makes anew is built."""
    folder.mkdir()
    shared = native.cache_dir()
    if shared.is_dir():
        for entry in shared.iterdir():
            if entry.is_file() and not entry.name.endswith((".lock", ".tmp")):
                (folder / entry.name).symlink_to(entry)
    return folder


def _run(scene: Path, out: Path, cache: Path) -> subprocess.CompletedProcess:
    environment = {**os.environ, native.CACHE_VARIABLE: str(cache),
                   "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)}
    return subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out)], env=environment,
                          capture_output=True, text=True, timeout=600)


def _cut_short(library: Path) -> None:
    data = library.read_bytes()
    library.unlink()   # a link into the shared cache is replaced, never written through
    library.write_bytes(data[: len(data) // 2])


def test_a_laws_library_cut_short_in_the_cache_is_built_again_and_the_run_gives_the_same_file(tmp_path):
    cache = _cache_beside_the_shared_one(tmp_path / "cache")
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE.replace("CONSTANT", f"0.0{uuid.uuid4().int % 10**8:08d}"))
    first = _run(scene, tmp_path / "first", cache)
    assert first.returncode == 0, first.stderr
    made = [p for p in cache.glob("laws-*.so") if not p.is_symlink()]
    assert len(made) == 1, made
    _cut_short(made[0])
    assert not native.intact(made[0])
    second = _run(scene, tmp_path / "second", cache)
    assert second.returncode == 0, (second.returncode, second.stderr)   # was 135: a bus error, nothing said
    assert "compiling the scene's laws" in second.stderr
    assert native.intact(made[0])
    assert (tmp_path / "second" / "probes.csv").read_bytes() == (tmp_path / "first" / "probes.csv").read_bytes()


def test_a_library_cut_short_is_refused_where_it_is_opened_naming_it(tmp_path):
    built = sorted(p for p in native.cache_dir().glob("laws-*.so") if native.intact(p))
    if not built:
        pytest.skip("no laws library in the kernel cache")
    copy = tmp_path / built[0].name
    shutil.copyfile(built[0], copy)
    assert native.intact(copy)
    _cut_short(copy)
    assert not native.intact(copy)
    with pytest.raises(RuntimeError, match=rf"cannot load {copy.name}: .*damaged.*{native.CACHE_VARIABLE}"):
        native.load(copy)


def test_an_intact_library_and_a_file_that_is_not_elf_are_taken(tmp_path):
    native.build("intact_check", b"int latdyn_intact_check(void) { return 1; }\n")   # one, whatever ran before
    built = sorted(native.cache_dir().glob("*.so"))
    assert built and all(native.intact(p) for p in built[:20])
    other = tmp_path / "other.dylib"
    other.write_bytes(b"\xcf\xfa\xed\xfe" + bytes(60))
    assert native.intact(other)
    assert not native.intact(tmp_path / "absent.so")
    empty = tmp_path / "empty.so"
    empty.write_bytes(b"")
    assert not native.intact(empty)
