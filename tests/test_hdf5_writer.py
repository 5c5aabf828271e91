"""latdyn's own HDF5 writer (latdyn/results/hdf5_writer.py): a run's ``state.h5`` and ParaView files,
written through the front door (a YAML scene through the CLI and the API), hold every object, hard
link and its name's character set, type (class, size, byte order, string padding and character set),
dataspace, creation property (layout, chunks, fill value and its time, times tracked, filters),
attribute and value that h5py writes from the same arrays with the options latdyn gave it before
(the reference files are built here with h5py); a file is readable while it is written, and a process
killed after a flush, or during one, leaves the file of that flush."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
from h5py import h5a, h5d, h5g, h5o, h5s, h5t  # noqa: E402

from latdyn.results import hdf5_writer  # noqa: E402
from tests.test_light_run import BLOCK_FRAMES_SCENE  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

SCENE = BLOCK_FRAMES_SCENE  # a 3D arm of two flexible beams, a joint body, a hinge and a tip load


# ----------------------------------------------------------------------------- what a file holds
def _type(t) -> dict:
    out = {"class": t.get_class(), "size": t.get_size()}
    if out["class"] in (h5t.INTEGER, h5t.FLOAT):
        out["order"] = t.get_order()
    if out["class"] == h5t.INTEGER:
        out["sign"] = t.get_sign()
    if out["class"] == h5t.FLOAT:
        out["fields"] = t.get_fields()
    if out["class"] == h5t.STRING:
        out.update(cset=t.get_cset(), pad=t.get_strpad(), variable=t.is_variable_str())
    return out


def _space(s) -> dict:
    kind = s.get_simple_extent_type()
    return {"kind": kind, **({"shape": s.shape, "maxshape": s.get_simple_extent_dims(True)} if kind == h5s.SIMPLE else {})}


def _value(read, t, s):
    array = np.empty(s.shape if s.get_simple_extent_type() == h5s.SIMPLE else (), dtype=t.dtype)
    read(array)
    if array.dtype.kind == "O":
        return [x if isinstance(x, bytes) else str(x).encode() for x in array.ravel()], array.shape
    return array.dtype.str, array.shape, array.tobytes()  # bit for bit (NaN included)


def _attributes(oid) -> dict:
    out = {}
    for name in sorted(h5py.AttributeManager(h5py.Group(oid) if isinstance(oid, h5g.GroupID)
                                             else h5py.Dataset(oid)).keys()):
        a = h5a.open(oid, name.encode())
        t, s = a.get_type(), a.get_space()
        out[name] = {"cset": h5a.get_info(oid, name.encode()).cset, "type": _type(t), "space": _space(s),
                     "value": _value(lambda array: a.read(array), t, s)}
    return out


def describe(path) -> dict:
    """Every link from the root of an HDF5 file: ``{path: what it holds}`` (a second link to an object
    seen already: ``same_as`` its first path)."""
    out, seen = {}, {}
    with h5py.File(path, "r", locking=False) as f:
        def visit(group, prefix):
            names = []
            group.links.iterate(names.append, idx_type=h5py.h5.INDEX_NAME)
            for name in names:
                full, info = prefix + name.decode(), h5o.get_info(group, name)
                entry = {"link": (group.links.get_info(name).type, group.links.get_info(name).cset), "rc": info.rc,
                         "times": (info.atime, info.mtime, info.ctime, info.btime)}
                out[full] = entry
                if (info.fileno, info.addr) in seen:
                    entry["same_as"] = seen[info.fileno, info.addr]
                    continue
                seen[info.fileno, info.addr] = full
                obj = h5o.open(group, name)
                entry["attrs"] = _attributes(obj)
                if isinstance(obj, h5g.GroupID):
                    visit(obj, full + "/")
                    continue
                p, t, s = obj.get_create_plist(), obj.get_type(), obj.get_space()
                fill = np.zeros((), t.dtype)
                p.get_fill_value(fill)
                entry.update(type=_type(t), space=_space(s), value=_value(lambda a: obj.read(h5s.ALL, h5s.ALL, a), t, s),
                             layout=p.get_layout(), chunk=p.get_chunk() if p.get_layout() == h5d.CHUNKED else None,
                             fill=(p.fill_value_defined(), fill.tobytes(), p.get_fill_time(), p.get_alloc_time()),
                             track_times=p.get_obj_track_times(), filters=p.get_nfilters())
        out["/"] = {"attrs": _attributes(f.id)}
        visit(h5g.open(f.id, b"/"), "")
    return out


def differences(a: dict, b: dict, where: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted(set(a) | set(b), key=str):
            if key not in a or key not in b:
                out.append(f"{where}/{key}: only in {'ours' if key in a else 'h5py’s'}")
            else:
                out += differences(a[key], b[key], f"{where}/{key}")
        return out
    return [] if a == b else [f"{where}: {str(a)[:100]} != {str(b)[:100]}"]


# ----------------------------------------------------------------------------- what h5py writes
def _attribute(attrs, name: str, value) -> None:
    """As latdyn set its attributes through h5py: a list of str as variable-length UTF-8 strings."""
    if isinstance(value, np.ndarray) and value.dtype.kind == "O":
        attrs.create(name, [v.decode() if isinstance(v, bytes) else v for v in value.tolist()],
                     dtype=h5py.string_dtype())
    else:
        attrs[name] = value


def h5py_state(ours: Path, path: Path) -> None:
    """The state.h5 latdyn wrote through h5py (HDF5 1.8 object format) with the arrays, attributes and
    chunks of ``ours``."""
    with h5py.File(ours, "r") as src, h5py.File(path, "w", libver=("v108", "latest")) as f:
        for name, value in src.attrs.items():
            _attribute(f.attrs, name, value)
        for key, data in src.items():
            d = f.create_dataset(key, shape=(0, *data.shape[1:]), maxshape=(None, *data.shape[1:]), dtype="f8",
                                 chunks=data.chunks if key != "t" else (1024,))
            for name, value in data.attrs.items():
                _attribute(d.attrs, name, value)
            d.resize(data.shape)
            d[:] = data[()]


def h5py_vtkhdf(ours: Path, path: Path, frames_per_chunk) -> None:
    """The VTKHDF file latdyn wrote through h5py (the earliest object format) with the mesh and frames
    of ``ours``: its objects, chunks, fill values and hard links as paraview.py created them."""
    with h5py.File(ours, "r") as src, h5py.File(path, "w") as f:
        s, root = src["VTKHDF"], f.create_group("VTKHDF")
        root.attrs["Version"] = np.array((2, 0), np.int64)
        root.attrs.create("Type", np.bytes_("UnstructuredGrid"))
        for name in ("NumberOfPoints", "NumberOfCells", "NumberOfConnectivityIds", "Types", "Connectivity", "Offsets"):
            root[name] = s[name][()]
        n_points, n_cells = int(s["NumberOfPoints"][0]), int(s["NumberOfCells"][0])
        fpc = frames_per_chunk(n_points)

        def growing(group, name, data, rows, fill=None):
            width = data.shape[1:]
            d = group.create_dataset(name, shape=(0, *width), maxshape=(None, *width), dtype=data.dtype,
                                     chunks=(rows, *width), track_times=False,
                                     **({} if fill is None else {"fillvalue": fill}))
            d.resize(data.shape)
            d[:] = data[()]
            return d

        growing(root, "Points", s["Points"], n_points * fpc)
        for group, rows in (("PointData", n_points), ("CellData", n_cells)):
            g = root.create_group(group)
            for name, data in s[group].items():
                if data.chunks is None:
                    g[name] = data[()]
                else:
                    growing(g, name, data, rows * fpc)
        steps = root.create_group("Steps")
        steps.attrs["NSteps"] = np.int64(s["Steps"].attrs["NSteps"])
        growing(steps, "Values", s["Steps/Values"], 1024)
        made = {name: growing(steps, name, s["Steps"][name], 1024, fill)
                for name, fill in (("PartOffsets", 0), ("NumberOfParts", 1), ("PointOffsets", 0))}
        steps["ConnectivityIdOffsets"] = growing(steps, "CellOffsets", s["Steps/CellOffsets"], 1024)
        for name in s["PointData"]:
            steps[f"PointDataOffsets/{name}"] = made["PointOffsets"]
        changing = None
        for name in sorted(s["CellData"]):
            if s["CellData"][name].chunks is None:
                steps[f"CellDataOffsets/{name}"] = made["PartOffsets"]
            elif changing is None:
                changing = growing(steps.require_group("CellDataOffsets"), name, s[f"Steps/CellDataOffsets/{name}"], 1024)
            else:
                steps[f"CellDataOffsets/{name}"] = changing


def assert_as_h5py_writes(folder: Path, tmp_path: Path) -> int:
    """Every HDF5 file of a results folder equals, object by object, h5py's from the same arrays."""
    from latdyn.results import paraview

    files = sorted(folder.rglob("*.h5")) + sorted(folder.rglob("*.vtkhdf"))
    for k, ours in enumerate(files):
        reference = tmp_path / f"reference-{k}{ours.suffix}"
        if ours.suffix == ".h5":
            h5py_state(ours, reference)
        else:
            h5py_vtkhdf(ours, reference, lambda n: max(1, 4096 // max(1, n)))
        found = differences(describe(ours), describe(reference))
        assert not found, f"{ours.relative_to(folder)}:\n" + "\n".join(found[:20])
    assert paraview.PARAVIEW_DIR  # the folder the ParaView files are in
    return len(files)


# ----------------------------------------------------------------------------- through the front door
@pytest.fixture(scope="module")
def cli_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli")
    scene = folder / "arm.yaml"
    scene.write_text(textwrap.dedent(SCENE))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    code = ("import sys, runpy; sys.argv = ['latdyn', 'run', sys.argv[1], '-o', sys.argv[2]];"
            "runpy.run_module('latdyn', run_name='__main__')")
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", code, str(scene), str(folder / "out")],
                          env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    return folder / "out", done.stderr


def test_a_runs_files_through_the_cli_are_the_files_h5py_writes_and_h5py_is_not_imported(cli_run, tmp_path):
    out, imports = cli_run
    assert assert_as_h5py_writes(out, tmp_path) == 3  # state.h5, beams.vtkhdf, bodies.vtkhdf
    imported = {line.split("|")[-1].strip() for line in imports.splitlines() if line.startswith("import time:")}
    assert "latdyn.results.hdf5_writer" in imported
    assert not {name for name in imported if name == "h5py" or name.startswith("h5py.")}, "the run imported h5py"
    with h5py.File(out / "state.h5", "r") as f:  # what it holds: the labels, the hinge, the rows
        assert list(f.attrs["hinges"]) == ["a.start"] and f["theta"].attrs["columns"][0] == "a.start"
        assert f["t"].shape == (31,) and f["x"].shape[0] == 31


def test_a_runs_files_through_the_api_are_the_files_h5py_writes(tmp_path):
    import latdyn

    scene = tmp_path / "arm.yaml"
    scene.write_text(textwrap.dedent(SCENE).replace("paraview_every: 0.004", "paraview_every: 0.002"))
    result = latdyn.run(latdyn.load_scene(scene), tmp_path / "out")
    assert result.summary["status"] == "solved"
    assert assert_as_h5py_writes(tmp_path / "out", tmp_path) == 3
    history = result.state_history()
    assert history["t"].shape == (31,) and history["theta"].shape == (31, 1)


# ----------------------------------------------------------------------------- the writer itself
def _ours(path: Path, header_version: int, blocks) -> None:
    f = hdf5_writer.File(path, header_version=header_version)
    root = f.root
    root.set_attribute("text", "é, a str")
    root.set_attribute("labels", ["hub", "arm.node[3]:x", "", "ü"])
    root.set_attribute("empty", [])
    root.set_attribute("fixed", np.bytes_("UnstructuredGrid"))
    root.set_attribute("numbers", np.array([2, 0], np.int64))
    root.set_attribute("scalar", np.int64(7))
    root.set_attribute("half", np.float32(0.5))
    g = root.create_group("g")
    g.create_dataset("empty", np.zeros(0, np.int64))
    g.create_dataset("types", np.array([1, 3, 3], np.uint8))
    g.create_dataset("matrix", np.arange(6.0).reshape(2, 3))
    x = root.create_growing("x", (3,), "f8", (4, 3))
    x.set_attribute("columns", ["a", "b", "c"])
    n = root.create_growing("n", (), "i8", (2,), fillvalue=1)
    e = root.create_growing("never", (1,), "i8", (1024, 1))
    g.link("also x", x)
    g.link("sub/ünï", x)
    rows = 0
    for k in blocks:
        x.append(np.arange(3 * rows, 3 * (rows + k), dtype=float).reshape(k, 3))
        n.grow(k)
        rows += k
        f.flush()
    assert e.shape == (0, 1)
    f.close()


def _theirs(path: Path, header_version: int, blocks) -> None:
    rows = sum(blocks)
    with h5py.File(path, "w", **({"libver": ("v108", "latest")} if header_version == 2 else {})) as f:
        f.attrs["text"] = "é, a str"
        f.attrs.create("labels", ["hub", "arm.node[3]:x", "", "ü"], dtype=h5py.string_dtype())
        f.attrs["empty"] = []
        f.attrs.create("fixed", np.bytes_("UnstructuredGrid"))
        f.attrs["numbers"] = np.array([2, 0], np.int64)
        f.attrs["scalar"] = np.int64(7)
        f.attrs["half"] = np.float32(0.5)
        from h5py import h5p

        gcpl = h5p.create(h5p.GROUP_CREATE)
        gcpl.set_obj_track_times(False)  # as latdyn's writer, which writes no times (state.h5 has no groups)
        for name in (b"g", b"g/sub"):
            h5g.create(f.id, name, gcpl=gcpl)
        f["g/empty"] = np.zeros(0, np.int64)
        f["g/types"] = np.array([1, 3, 3], np.uint8)
        f["g/matrix"] = np.arange(6.0).reshape(2, 3)
        x = f.create_dataset("x", shape=(0, 3), maxshape=(None, 3), dtype="f8", chunks=(4, 3), track_times=False)
        x.attrs.create("columns", ["a", "b", "c"], dtype=h5py.string_dtype())
        n = f.create_dataset("n", shape=(0,), maxshape=(None,), dtype="i8", chunks=(2,), fillvalue=1, track_times=False)
        f.create_dataset("never", shape=(0, 1), maxshape=(None, 1), dtype="i8", chunks=(1024, 1), track_times=False)
        f["g/also x"] = x
        f["g/sub/ünï"] = x
        x.resize((rows, 3))
        x[:] = np.arange(3.0 * rows).reshape(rows, 3)
        n.resize((rows,))


@pytest.mark.parametrize("header_version", [1, 2])
@pytest.mark.parametrize("blocks", [[], [1], [3, 1, 9], [64 * 4 * 2 + 5]], ids=["empty", "one", "three", "levels"])
def test_the_writers_objects_are_h5pys(tmp_path, header_version, blocks):
    """Strings (variable-length UTF-8, empty ones, a fixed-length ASCII one), numbers, an empty list,
    empty datasets, a fill value never written, hard links (one through a new group, a UTF-8 name) and
    a chunk B-tree of several levels (more than 64 chunks) are h5py's, in both object header versions."""
    _ours(tmp_path / "ours.h5", header_version, blocks)
    _theirs(tmp_path / "theirs.h5", header_version, blocks)
    found = differences(describe(tmp_path / "ours.h5"), describe(tmp_path / "theirs.h5"))
    assert not found, "\n".join(found[:20])


def test_a_file_is_read_while_it_is_written(tmp_path):
    """Another process reading the file (as ParaView would) sees the rows of the last flush, not the
    rows appended since; in this process too, once it opens the file anew."""
    def rows_read_elsewhere():
        code = "import h5py, sys; print(h5py.File(sys.argv[1], 'r', locking=False)['x'][()].sum())"
        done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "f.h5")], capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 0, done.stderr
        return float(done.stdout)

    f = hdf5_writer.File(tmp_path / "f.h5")
    x = f.root.create_growing("x", (2,), "f8", (3, 2))
    x.append(np.ones((2, 2)))
    f.flush()
    with h5py.File(tmp_path / "f.h5", "r", locking=False) as r:
        assert np.array_equal(r["x"][()], np.ones((2, 2)))
    x.append(np.full((5, 2), 2.0))  # not flushed: beyond the file's extent
    assert rows_read_elsewhere() == 4.0
    f.flush()
    assert rows_read_elsewhere() == 24.0
    with h5py.File(tmp_path / "f.h5", "r", locking=False) as r:
        assert np.array_equal(r["x"][()], np.r_[np.ones((2, 2)), np.full((5, 2), 2.0)])
    f.close()


KILLED = """\
import os, signal, sys
import numpy as np
from latdyn.results import hdf5_writer
f = hdf5_writer.File(sys.argv[1], header_version=2)
x = f.root.create_growing("x", (2,), "f8", (3, 2))
x.set_attribute("columns", ["a", "b"])
x.append(np.ones((4, 2)))
f.flush()
x.append(np.full((7, 2), 2.0))
if sys.argv[2] == "in-flush":  # killed after the new metadata, before the superblock points at it
    real = hdf5_writer.File._write
    hdf5_writer.File._write = lambda self, at, data: os.kill(os.getpid(), signal.SIGKILL) if at == 0 else \
        real(self, at, data)
    f.flush()
os.kill(os.getpid(), signal.SIGKILL)
"""


@pytest.mark.parametrize("when", ["after-flush", "in-flush"])
def test_a_process_killed_leaves_the_file_of_its_last_flush(tmp_path, when):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", KILLED, str(tmp_path / "f.h5"), when], env=env, timeout=60)
    assert done.returncode == -9
    with h5py.File(tmp_path / "f.h5", "r") as r:
        assert np.array_equal(r["x"][()], np.ones((4, 2))) and list(r["x"].attrs["columns"]) == ["a", "b"]


def test_a_message_too_large_for_an_object_header_is_refused(tmp_path):
    f = hdf5_writer.File(tmp_path / "f.h5")
    f.root.set_attribute("labels", [f"n{k}" for k in range(5000)])  # 80 000 bytes of references
    with pytest.raises(hdf5_writer.TooLarge, match="at most 65535"):
        f.flush()


def test_a_run_killed_after_a_checkpoint_leaves_readable_files(tmp_path):
    """A CLI run killed (SIGKILL) after its first checkpoint: state.h5 and the ParaView files open with
    h5py, their datasets agree with each other (rows, steps), and what they hold is the run's first rows."""
    import signal
    import time

    scene = tmp_path / "arm.yaml"
    scene.write_text(textwrap.dedent(SCENE).replace("t_end: 0.06", "t_end: 60.0"))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    run = subprocess.Popen([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "out")], env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    state = tmp_path / "out" / "state.h5"
    try:
        deadline = time.monotonic() + 90
        while not state.exists() and time.monotonic() < deadline and run.poll() is None:
            time.sleep(0.05)
        time.sleep(0.5)  # and, likely, a flush or two more
    finally:
        run.send_signal(signal.SIGKILL)
        run.wait(timeout=30)
    assert run.returncode == -9, "the run ended before it was killed"
    with h5py.File(state, "r") as f:
        rows = f["t"].shape[0]
        assert rows >= 1 and all(f[k].shape[0] == rows for k in f)
        assert np.array_equal(f["t"][()], 0.002 * np.arange(rows)) or np.allclose(f["t"][()], 0.002 * np.arange(rows))
    for part in ("beams", "bodies"):
        with h5py.File(tmp_path / "out" / "paraview" / f"{part}.vtkhdf", "r") as f:
            steps = int(f["VTKHDF/Steps"].attrs["NSteps"])
            n_points = int(f["VTKHDF/NumberOfPoints"][0])
            assert steps >= 1 and f["VTKHDF/Steps/Values"].shape == (steps,)
            assert f["VTKHDF/Points"].shape == (steps * n_points, 3)


def test_a_state_whose_labels_do_not_fit_an_object_header_is_written_by_h5py(tmp_path):
    """More than 4092 labels in one list (a model of more than 454 nodes: 9 columns of T a node) do not
    fit an object header message of latdyn's writer: h5py writes that state.h5 (its dense attribute
    storage), as before, resumable; a model of 454 nodes is latdyn's."""
    from latdyn.results.state_history import StateHistory, state_labels

    for nodes, ours in ((454, True), (455, False)):
        names = [f"n{k}" for k in range(nodes)]
        labels = state_labels(names, [])
        history = StateHistory(tmp_path / str(nodes), "t", {"m": 1}, labels, {"nodes": names, "hinges": []})
        (tmp_path / str(nodes)).mkdir()
        for r in range(3):
            history.add(0.1 * r, {"x": np.full(3 * nodes, r), "T": np.full(9 * nodes, r), "v": np.zeros(3 * nodes),
                                  "w": np.zeros(3 * nodes)})
        assert history.write() and history._ours() is ours
        history.close()
        with h5py.File(tmp_path / str(nodes) / "state.h5", "r") as f:
            assert list(f["T"].attrs["columns"]) == labels["T"] and f["T"][()][:, 0].tolist() == [0, 1, 2]
        again = StateHistory(tmp_path / str(nodes), "t", {"m": 1}, labels, {"nodes": names, "hinges": []})
        again.reopen(2)
        again.close()
        with h5py.File(tmp_path / str(nodes) / "state.h5", "r") as f:
            assert f["x"].shape == (2, 3 * nodes) and list(f.attrs["nodes"]) == names


# ----------------------------------------------------------------------------- its cost (issue 31)
def test_lookup3_in_c_is_the_python_reference():
    """The checksum of state.h5's headers: ``latdyn_lookup3`` of the runtime's library (csrc/checksum.c),
    which a run uses, gives the Python ``lookup3`` (the reference: Bob Jenkins' own test values) for every
    length of a last block and for large data; ``checksum`` takes it once the library is loaded."""
    from latdyn.assembly import library

    words = b"Four score and seven years ago"
    assert [hdf5_writer.lookup3(b"", 0), hdf5_writer.lookup3(b"", 0xDEADBEEF), hdf5_writer.lookup3(words, 0),
            hdf5_writer.lookup3(words, 1)] == [0xDEADBEEF, 0xBD5B7DDE, 0x17770551, 0xCD628161]
    native = library.native_library()
    data = np.random.default_rng(3).integers(0, 256, 30_000, dtype=np.uint8).tobytes()
    for n in [*range(0, 40), 9932, 30_000]:
        for initval in (0, 1, 0xDEADBEEF):
            assert native.latdyn_lookup3(data[:n], n, initval) == hdf5_writer.lookup3(data[:n], initval), (n, initval)
    assert library.loaded_library() is native
    calls = []
    real = native.latdyn_lookup3
    try:
        native.latdyn_lookup3 = lambda *a: calls.append(a) or real(*a)
        assert hdf5_writer.checksum(data) == hdf5_writer.lookup3(data) and len(calls) == 1
    finally:
        native.latdyn_lookup3 = real


def test_a_flush_with_nothing_new_writes_nothing_and_a_first_flush_encodes_once(tmp_path, monkeypatch):
    """A flush after another with nothing appended, grown or set writes nothing (a durable one syncs the
    file once where the last flush did not); rows appended or grown within a chunk, an attribute or a
    link set since, and it writes. A file's first flush encodes its headers once."""
    writes, syncs, encodes = [], [], []
    real_write, real_metadata = hdf5_writer.File._write, hdf5_writer.File._metadata
    monkeypatch.setattr(hdf5_writer.File, "_write", lambda self, at, data: writes.append(at) or real_write(self, at, data))
    monkeypatch.setattr(hdf5_writer.File, "_metadata", lambda self, base: encodes.append(base) or real_metadata(self, base))
    monkeypatch.setattr(hdf5_writer.os, "fsync", lambda fd: syncs.append(fd))
    f = hdf5_writer.File(tmp_path / "f.h5", header_version=2)
    x = f.root.create_growing("x", (2,), "f8", (8, 2))
    n = f.root.create_growing("n", (), "i8", (8,), fillvalue=1)
    x.set_attribute("columns", ["a", "b"])
    x.append(np.ones((3, 2)))
    f.flush()
    assert len(encodes) == 1
    for change in (lambda: None, lambda: x.append(np.ones((1, 2))), lambda: n.grow(1), lambda: n.grow(1),
                   lambda: x.set_attribute("unit", "m"), lambda: f.root.link("also x", x)):
        change()
        before = len(writes)
        f.flush()
        assert (len(writes) > before) is (change.__code__.co_names != ()), change.__code__.co_names
    before = len(writes), len(syncs)
    f.flush(durable=True)
    f.flush(durable=True)
    f.flush()
    assert (len(writes), len(syncs)) == (before[0], before[1] + 1)
    f.close(durable=True)
    assert (len(writes), len(syncs)) == (before[0], before[1] + 1)
    with h5py.File(tmp_path / "f.h5", "r") as r:
        assert r["x"].shape == (4, 2) and r["n"][()].tolist() == [1, 1] and r["also x"].attrs["unit"] == "m"
