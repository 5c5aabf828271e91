"""Checkpoint and resume (SCENE.md, `latdyn run --resume`): a resumed run's files equal an
uninterrupted run's; failures leave a checkpoint; foreign or missing checkpoints exit 2."""
from __future__ import annotations

import json
import signal
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn import cli
from latdyn.timeloop import checkpoint as checkpoint
from latdyn.results import state_history
from latdyn.results.writer import Result, ResultWriter, load_state_history
from vtkhdf_frames import assert_same_frames, read_frames

#: resumed and uninterrupted files agree to this (measured: bit for bit, 0.0)
EXACT = 1e-12


def arm3d(lock_b=-0.9, every=0.01, **solve_options):
    """A 3D two-link arm under skew gravity: the base hinge (about z) latches at t ≈ 0.16,
    the elbow hinge (about a skew axis) at t ≈ 0.33."""
    return {
        "gravity": [0.0, -2.0, -9.81],
        "sections": {"s": {"EA": 1e6, "EIy": 300.0, "EIz": 500.0, "GJ": 400.0, "rhoA": 1.0,
                           "rhoIy": 1e-3, "rhoIz": 1e-3}},
        "bodies": {"base": {"at": [0, 0, 0], "fixed": True},
                   "elbow": {"at": [1, 0, 0], "mass": 0.5, "inertia": [1e-3, 2e-3, 3e-3]}},
        "beams": {
            "a": {"from": "base", "to": "elbow", "section": "s", "elements": 2,
                  "start": {"hinge": {"axis": [0, 0, 1], "torque": "3.0", "lock_at": -0.03}}},
            "b": {"from": "elbow", "to": [1.0, 0.8, 0.6], "section": "s", "elements": 2,
                  "start": {"hinge": {"axis": [1, 0.2, 0], "torque": "-1.5", "damping": 0.01,
                                      "lock_at": lock_b}}},
        },
        "solve": {"analysis": "transient", "t_end": 0.5, "dt": 0.005, **solve_options},
        "output": {**({"every": every} if every else {}), "probes": {
            "qa": {"hinge": "a.start", "quantity": "angle"},
            "qb": {"hinge": "b.start", "quantity": "angle"},
            "rb": {"hinge": "b.start", "quantity": "rate"},
            "tip_z": {"point": "b.end", "quantity": "position", "component": "z"},
            "tip_v": {"point": "b.end", "quantity": "velocity", "frame": "elbow", "component": "norm"},
            "E": {"energy": "total"}, "W": {"energy": "external_work"}, "D": {"energy": "dissipated"},
            "M": {"element": "b.element[0]", "quantity": "moment_y"},
            "Hx": {"momentum": "angular", "component": "x"}}},
    }


SCENES = {
    # generalized-α with modified Newton (its held factorization is checkpointed); interrupted
    # between the two latches
    "generalized-alpha": (arm3d(newton="modified"), 0.25),
    # every step recorded: 302 rows, a ParaView frame every 2 (paraview.default_every), the frames
    # of the checkpoint (row 151) and of the last row not due
    "explicit": (arm3d(method="explicit", dt=1e-4, t_end=0.0301, every=None), 0.0151),
    # step-size control with rejected steps, across the first latch
    "adaptive": (arm3d(adaptive=True, error_tol=1e-4, t_end=0.3, newton="modified"), 0.2),
}


def interrupt_at(monkeypatch, t_stop: float, how="keyboard"):
    """Ctrl-C (or SIGTERM) when the first step from t >= t_stop begins (a step from Python, or
    the compiled loop of steps between rows; a loop of steps through rows, which would step past
    t_stop in one call, ends at it, as at its wall-time budget)."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.step.integrators import CentralDifference

    for cls, name in ((CompiledGeneralizedAlpha, "step"),
                      (CompiledGeneralizedAlpha, "advance"), (CentralDifference, "step")):
        original = getattr(cls, name)

        def step(self, state, *args, _original=original, **kwargs):
            if state.t >= t_stop:
                if how == "sigterm":
                    signal.raise_signal(signal.SIGTERM)
                raise KeyboardInterrupt
            if "stop_index" in kwargs:  # a loop of steps through rows (rows recorded in C) ends at t_stop
                dt, stop = kwargs["dt"], kwargs["stop_index"]
                k_stop = int(np.ceil(t_stop / dt - 1e-9))
                if kwargs["grid_index"] < k_stop < stop:
                    kwargs["stop_index"] = k_stop
                    kwargs["rows"] = [k for k in kwargs.get("rows") or [] if k < k_stop]
            return _original(self, state, *args, **kwargs)

        monkeypatch.setattr(cls, name, step)


def relative_difference(a: Path, b: Path) -> float:
    """Largest difference of probes.csv and state history of two folders, relative to each
    column's (dataset's) largest magnitude; the shapes must agree."""
    A, B = Result.load(a), Result.load(b)
    assert A.t.shape == B.t.shape and list(A.probes) == list(B.probes)
    worst = 0.0
    pairs = [(A.t, B.t)] + [(A.probes[k], B.probes[k]) for k in A.probes]
    HA, HB = load_state_history(a), load_state_history(b)
    assert sorted(HA) == sorted(HB)
    for k in HA:
        assert HA[k].shape == HB[k].shape, k
        pairs += [(HA[k], HB[k])]
    for x, y in pairs:
        scale = np.max(np.abs(x), initial=0.0)
        if scale > 0:
            worst = max(worst, float(np.max(np.abs(x - y))) / scale)
    return worst


def assert_same_files(uninterrupted: Path, resumed: Path, ignore=()) -> float:
    worst = relative_difference(uninterrupted, resumed)
    assert worst <= EXACT
    files = lambda p: sorted(f.name for f in (p / "paraview").iterdir())  # noqa: E731
    assert files(resumed) == files(uninterrupted) == ["beams.vtkhdf", "bodies.vtkhdf"]
    for name in files(uninterrupted):  # every frame, read by VTK: bit for bit
        assert_same_frames(uninterrupted / "paraview" / name, resumed / "paraview" / name)
    a = json.loads((uninterrupted / "summary.json").read_text())
    b = json.loads((resumed / "summary.json").read_text())
    extra = {"wall_time_s", "solver_s", "compile_s", "resumed_from_t", "resumes", *ignore}
    assert {k: v for k, v in b.items() if k not in extra} == {k: v for k, v in a.items() if k not in extra}
    assert not (resumed / checkpoint.CHECKPOINT_FILE).exists()  # finished: nothing to resume
    return worst


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """The reference runs, computed once."""
    done = {}

    def get(name):
        if name not in done:
            out = tmp_path_factory.mktemp(f"full-{name}")
            latdyn.run(SCENES[name][0], out)
            done[name] = out
        return done[name]

    return get


@pytest.mark.parametrize("name", sorted(SCENES))
def test_interrupted_and_resumed_run_equals_the_uninterrupted_one(name, tmp_path, monkeypatch, uninterrupted):
    scene, t_stop = SCENES[name]
    out = tmp_path / "out"
    with monkeypatch.context() as m:
        interrupt_at(m, t_stop)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    saved = checkpoint.load(out, checkpoint.identity(latdyn.load_scene(scene)))
    assert saved.t == pytest.approx(t_stop, abs=1e-9) and saved.t == summary["checkpoint_t"]
    if name == "generalized-alpha":  # one hinge latched before the checkpoint, the other after it
        assert saved.progress.locked.tolist() == [True, False]
    if name == "explicit":
        assert saved.factorization is None  # no Newton
    else:  # modified Newton (the default) holds a factorization over steps: the checkpoint carries it
        assert saved.factorization is not None and saved.factorization["factored_h"] > 0
    if name == "explicit":
        assert saved.writer["paraview"]["unwritten"] is not None and saved.last_recorded is not None
    if name == "adaptive":
        assert saved.progress.rejected_steps > 0

    result = latdyn.run(scene, out, resume=True)
    reference = uninterrupted(name)
    assert_same_files(reference, out)
    assert result.summary["resumed_from_t"] == saved.t and result.summary["resumes"] == 1
    if name == "generalized-alpha":
        qb = Result.load(out).probes["qb"]
        assert qb[-1] == pytest.approx(-0.9, abs=1e-6)  # the elbow latched after the resume
    np.testing.assert_array_equal(result.t, Result.load(reference).t)


@pytest.mark.parametrize("state_file", ["state.h5", "state.npz"])
def test_crash_after_a_periodic_checkpoint_is_cut_back_and_resumed(state_file, tmp_path, monkeypatch, uninterrupted):
    """A run killed well after its last checkpoint (here: checkpoints stop being written
    after the 40th step): rows, state rows and frames written since are dropped on resume
    (state.npz: the writer's fallback without h5py)."""
    scene, _ = SCENES["generalized-alpha"]
    out = tmp_path / "out"
    reference = uninterrupted("generalized-alpha")
    if state_file == "state.npz":
        monkeypatch.setattr(state_history, "h5py", None)
    save = checkpoint.Checkpointer.save

    def save_until(self, progress, *args):
        if progress.steps <= 40:
            save(self, progress, *args)

    with monkeypatch.context() as m:
        m.setattr(checkpoint.Checkpointer, "save", save_until)
        interrupt_at(m, 0.4)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out, checkpoint_every=0)
    saved = checkpoint.load(out, checkpoint.identity(latdyn.load_scene(scene)))
    assert saved.progress.steps == 40
    assert len(Result.load(out).t) > saved.writer["rows"] + 10  # the files went on past the checkpoint
    assert len(load_state_history(out)["t"]) > saved.writer["rows"] + 10
    assert (out / state_file).is_file()
    latdyn.run(scene, out, resume=True)
    assert json.loads((out / "summary.json").read_text())["state_file"] == state_file
    monkeypatch.undo()  # h5py back, to read the reference
    assert_same_files(reference, out, ignore={"state_file"})


def test_interrupt_after_the_last_step_resumes_to_the_same_files(tmp_path, monkeypatch, uninterrupted):
    """Ctrl-C while the finished run closes its files: the checkpoint of the last step is
    resumed without a step, and the last row's frame (not due) is still written."""
    scene, _ = SCENES["explicit"]
    out = tmp_path / "out"
    close = ResultWriter.close

    def interrupted_close(self, summary=None, status=None):
        if status == "solved":
            raise KeyboardInterrupt
        return close(self, summary, status)

    calls = []
    with monkeypatch.context() as m:
        m.setattr(ResultWriter, "close", interrupted_close)
        # a periodic checkpoint due at the last of the 301 steps only (the loop asks once a step)
        m.setattr(checkpoint.Checkpointer, "due", lambda self: calls.append(1) or len(calls) >= 301)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    saved = checkpoint.load(out, checkpoint.identity(latdyn.load_scene(scene)))
    assert saved.t == 0.0301 and saved.writer["paraview"]["unwritten"] == 0.0301
    # the interrupted close() wrote the last frame; resuming cuts it off and writes it again
    assert saved.writer["paraview"]["frames"] == 151
    latdyn.run(scene, out, resume=True)
    assert_same_files(uninterrupted("explicit"), out)


def test_a_resumed_writer_continues_the_frame_schedule(tmp_path):
    """Bookmark, go on, crash, reopen at the bookmark and record again: the files equal those of
    one uninterrupted writer (frames every 0.3 s of rows every 0.1 s, the last one at close)."""
    mesh = {"lines": np.array([[0, 1]]), "n_nodes": 2}

    def rows(writer, indices):
        for i in indices:
            writer.record(0.1 * i, [i, -i], state={"x": np.array([i, 2.0 * i])},
                          node_positions=np.array([[0.0, 0, 0], [1.0, i, 0]]))

    with ResultWriter(tmp_path / "a", ["p", "q"], mesh=mesh, paraview_every=0.3) as writer:
        rows(writer, range(20))
    with pytest.raises(KeyboardInterrupt), ResultWriter(tmp_path / "b", ["p", "q"], mesh=mesh, paraview_every=0.3) as w:
        rows(w, range(6))
        mark = w.bookmark()
        w.checkpoint()
        rows(w, range(6, 15))
        raise KeyboardInterrupt
    assert mark["paraview"]["unwritten"] == 0.5 and mark["paraview"]["frames"] == 2
    with ResultWriter(tmp_path / "b", ["p", "q"], mesh=mesh, paraview_every=0.3, resume=mark) as writer:
        # reopened: the file holds the bookmark's frames (0, 0.3), none after it
        assert [f.t for f in read_frames(tmp_path / "b" / "paraview" / "beams.vtkhdf")] == [0.0, 0.1 * 3]
        assert len(Result.load(tmp_path / "b").t) == 6
        writer.reattach_last_frame({"beams": {"points": np.array([[0.0, 0, 0], [1.0, 5, 0]])}})
        rows(writer, range(6, 20))
    a, b = tmp_path / "a", tmp_path / "b"
    assert (b / "probes.csv").read_bytes() == (a / "probes.csv").read_bytes()
    assert relative_difference(a, b) == 0.0
    assert sorted(p.name for p in (b / "paraview").iterdir()) == ["beams.vtkhdf"]
    assert_same_frames(a / "paraview" / "beams.vtkhdf", b / "paraview" / "beams.vtkhdf")
    assert len(read_frames(a / "paraview" / "beams.vtkhdf")) == 8  # 0, 0.3, …, 1.8 and 1.9
    sa, sb = (json.loads((p / "summary.json").read_text()) for p in (a, b))
    assert {k: v for k, v in sa.items() if k != "wall_time_s"} == {k: v for k, v in sb.items() if k != "wall_time_s"}


def failing_scene(jump_at: float = 0.1):
    """The elbow torque jumps at t = ``jump_at`` beyond what Newton can follow in 4 iterations (full
    Newton: it converges in 4 before the jump; modified Newton, converging linearly, needs more
    from the first step). The steps land on the jump and the run restarts after it
    (latdyn.timeloop.jumps): the last step accepted ends there, the first one after it fails."""
    scene = arm3d(t_end=0.3, max_iterations=4, dt_min=0.004, newton="full")
    scene["beams"]["b"]["start"]["hinge"]["torque"] = f"Piecewise((-1.5, t < {jump_at}), (-2000, True))"
    return scene


def write_scene(path: Path, scene: dict) -> Path:
    path.write_text(yaml.safe_dump(scene))
    return path


def test_a_failed_run_leaves_a_checkpoint_of_its_last_accepted_step(tmp_path, capsys):
    scene_file = write_scene(tmp_path / "fails.yaml", failing_scene(jump_at=0.1025))
    out = tmp_path / "out"
    assert cli.main(["run", str(scene_file), "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert "the solver failed" in err and "--resume" in err
    saved = checkpoint.load(out, checkpoint.identity(latdyn.load_scene(str(scene_file))))
    assert saved.t == pytest.approx(0.1025, abs=1e-9)  # the last accepted step: onto the jump, off the rows
    # the checkpoint holds the rows of the output grid; the failed run adds its last accepted state
    # as a row (issue 22), which a resumed run cuts back to the checkpoint's rows first
    assert saved.writer["rows"] == 11
    assert len(Result.load(out).t) == 12 and Result.load(out).t[-1] == pytest.approx(0.1025, abs=1e-9)
    assert json.loads((out / "summary.json").read_text())["status"] == "failed"
    # resumed unchanged, it fails at the same place, leaving the same files
    before = (out / "probes.csv").read_bytes()
    assert cli.main(["run", str(scene_file), "-o", str(out), "-q", "--resume"]) == 1
    assert (out / "probes.csv").read_bytes() == before
    assert checkpoint.load(out, checkpoint.identity(latdyn.load_scene(str(scene_file)))).t == saved.t


@pytest.fixture
def sigterm_run(tmp_path, monkeypatch, capsys):
    """A run of arm3d stopped by SIGTERM at t = 0.1 through the command line (exit 130), with modified Newton (its factorization is checkpointed)."""
    scene_file = write_scene(tmp_path / "arm.yaml", arm3d(t_end=0.2, newton="modified"))
    out = tmp_path / "out"
    handler = signal.getsignal(signal.SIGTERM)
    with monkeypatch.context() as m:
        interrupt_at(m, 0.1, how="sigterm")
        assert cli.main(["run", str(scene_file), "-o", str(out), "-q"]) == 130
    assert signal.getsignal(signal.SIGTERM) is handler  # restored
    err = capsys.readouterr().err
    assert "interrupted" in err and "--resume" in err
    assert (out / checkpoint.CHECKPOINT_FILE).is_file()
    return scene_file, out


def _refused(argv, capsys) -> str:
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("latdyn: error: ") and "Traceback" not in err
    return err


def test_checkpoint_of_another_scene_is_refused(sigterm_run, tmp_path, capsys):
    scene_file, out = sigterm_run
    other = write_scene(tmp_path / "other.yaml", arm3d(lock_b=-0.8, t_end=0.2))
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    err = _refused(["run", str(other), "-o", str(out), "-q", "--resume"], capsys)
    assert str(out / checkpoint.CHECKPOINT_FILE) in err and "scene hash" in err
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before  # nothing touched
    # the right scene resumes, finishes and removes the checkpoint
    assert cli.main(["run", str(scene_file), "-o", str(out), "-q", "--resume"]) == 0
    assert not (out / checkpoint.CHECKPOINT_FILE).exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "solved" and summary["resumes"] == 1
    # a finished run has nothing to resume
    err = _refused(["run", str(scene_file), "-o", str(out), "-q", "--resume"], capsys)
    assert "finished" in err


def test_checkpoint_of_another_version_is_refused(sigterm_run, monkeypatch, capsys):
    scene_file, out = sigterm_run
    monkeypatch.setattr(latdyn.version, "__version__", "99.0")
    err = _refused(["run", str(scene_file), "-o", str(out), "-q", "--resume"], capsys)
    assert str(out / checkpoint.CHECKPOINT_FILE) in err and "package version" in err and "99.0" in err
    monkeypatch.undo()
    # a checkpoint of a future format too
    path = out / checkpoint.CHECKPOINT_FILE
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    meta = json.loads(str(arrays["__meta__"]))
    meta["identity"]["format"] = checkpoint.FORMAT_VERSION + 1
    arrays["__meta__"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    err = _refused(["run", str(scene_file), "-o", str(out), "-q", "--resume"], capsys)
    assert str(path) in err and "checkpoint format" in err


def _rewrite(path: Path, change) -> None:
    """Rewrite the checkpoint at ``path`` with ``change(meta, arrays)`` applied."""
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    meta = json.loads(str(arrays["__meta__"]))
    change(meta, arrays)
    arrays["__meta__"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)


def test_checkpoint_of_format_1_or_with_a_factorization_that_does_not_fit_is_refused(sigterm_run, capsys):
    """Format 1 (before modified Newton's factorization was carried) is refused; so is a held
    factorization whose matrix does not fit the model's."""
    scene_file, out = sigterm_run
    path = out / checkpoint.CHECKPOINT_FILE
    saved = checkpoint.load(out, checkpoint.identity(latdyn.load_scene(str(scene_file))))
    assert saved.factorization is not None
    key = json.loads(str(np.load(path)["__meta__"]))["factorization"]["__dict__"]["matrix"]["__array__"]
    _rewrite(path, lambda meta, arrays: arrays.__setitem__(key, arrays[key][:-1]))
    with pytest.raises(checkpoint.CheckpointError, match="does not fit this model"):
        latdyn.run(str(scene_file), out, resume=True)
    assert path.is_file()  # kept
    _rewrite(path, lambda meta, arrays: meta["identity"].__setitem__("format", 1))
    err = _refused(["run", str(scene_file), "-o", str(out), "-q", "--resume"], capsys)
    assert str(path) in err and "checkpoint format 1 differs" in err


def test_resume_without_a_checkpoint_exits_2(tmp_path, capsys):
    scene_file = write_scene(tmp_path / "arm.yaml", arm3d(t_end=0.02))
    err = _refused(["run", str(scene_file), "-o", str(tmp_path / "none"), "-q", "--resume"], capsys)
    assert f"no checkpoint in {tmp_path / 'none'}" in err
    assert not (tmp_path / "none").exists()
    with pytest.raises(checkpoint.CheckpointError, match="no checkpoint in"):
        latdyn.run(arm3d(t_end=0.02), tmp_path / "none", resume=True)


def test_checkpoints_follow_the_interval(tmp_path, monkeypatch):
    """checkpoint_every=0: one per accepted step; the default (60 s): none in a short run;
    a fresh run into the folder discards an old checkpoint."""
    saves = []
    save = checkpoint.Checkpointer.save
    monkeypatch.setattr(checkpoint.Checkpointer, "save",
                        lambda self, progress, *a: (saves.append(progress.steps), save(self, progress, *a)))
    result = latdyn.run(arm3d(t_end=0.05), tmp_path, checkpoint_every=0)
    assert saves == list(range(1, result.summary["steps"] + 1))
    saves.clear()
    (tmp_path / checkpoint.CHECKPOINT_FILE).write_bytes(b"stale")
    latdyn.run(arm3d(t_end=0.05), tmp_path)
    assert saves == [] and not (tmp_path / checkpoint.CHECKPOINT_FILE).exists()
    assert cli.main(["run", "x.yaml", "--checkpoint-every", "-1"]) == 2  # argparse refuses it


def test_a_failed_run_whose_last_step_is_a_row_resumes_without_a_second_row(tmp_path, capsys):
    """The same failing run with a row every step (dt = 0.005): its last accepted state (the jump at
    t = 0.1, on the grid) is a row of the grid already, in the checkpoint's rows. Resumed, it fails at the same place; the row at 0.1
    (1e-9·dt after the jump, where the run restarted) is not recorded a second time (it was, when the checkpoint's rows reached that state: the loop
    asked only whether it had recorded the row itself — found by benchmarks/fuzz_runs.py --joints)."""
    scene = failing_scene()
    scene["output"].update(every=0.005, paraview_every=0)
    scene_file = write_scene(tmp_path / "fails.yaml", scene)
    out = tmp_path / "out"
    assert cli.main(["run", str(scene_file), "-o", str(out), "-q"]) == 1
    first = Result.load(out).t
    assert first[-1] == pytest.approx(0.1, abs=1e-9) and np.all(np.diff(first) > 0)
    before = (out / "probes.csv").read_bytes()
    assert cli.main(["run", str(scene_file), "-o", str(out), "-q", "--resume"]) == 1
    capsys.readouterr()
    assert (out / "probes.csv").read_bytes() == before
    history = load_state_history(out)
    assert np.all(np.diff(history["t"]) > 0)
