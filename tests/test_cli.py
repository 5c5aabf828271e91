"""The `latdyn` command: exit statuses and messages (SCENE.md), plotting."""
from __future__ import annotations

import importlib
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from latdyn import cli
from latdyn.errors import SceneError, SolverError
from latdyn.results.writer import Result, ResultWriter

ROOT = Path(__file__).resolve().parents[1]

BAD_SECTION_SCENE = """\
title: a beam with an unknown section
sections:
  arm: {EA: 2.8e7, EIy: 1.4e4, EIz: 1.4e4, GJ: 1.0e4, rhoA: 1.2}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: hub, to: [10, 0, 0], section: no_such_section, elements: 2}
solve: {analysis: transient, t_end: 1, dt: 0.01}
"""


def _real_scene_module():
    try:
        return importlib.import_module("latdyn.scene.loader")
    except ImportError as exc:  # written concurrently; the lead unskips
        pytest.skip(f"latdyn.scene.loader is not importable yet ({exc})")


# ----------------------------------------------------------------------------- scene errors
def test_run_missing_scene_file_exits_2(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    status = cli.main(["run", "missing.yaml"])
    captured = capsys.readouterr()
    assert status == 2
    assert captured.err.startswith("latdyn: error: missing.yaml:")
    assert "Traceback" not in captured.err
    assert not (tmp_path / "missing_results").exists()


def test_check_missing_scene_file_exits_2_as_a_process(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    completed = subprocess.run([sys.executable, "-m", "latdyn", "check", str(tmp_path / "nope.yaml")],
                               env=env, capture_output=True, text=True, cwd=tmp_path)
    assert completed.returncode == 2
    assert completed.stderr.startswith(f"latdyn: error: {tmp_path / 'nope.yaml'}: no such scene file")


@pytest.mark.parametrize("command", ["run", "check"])
def test_invalid_scene_exits_2_and_names_the_key(tmp_path, capsys, monkeypatch, command):
    _real_scene_module()
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "bad.yaml"
    scene.write_text(BAD_SECTION_SCENE)
    status = cli.main([command, str(scene)])
    captured = capsys.readouterr()
    assert status == 2
    assert captured.err.startswith("latdyn: error: ")
    assert "bad.yaml" in captured.err and "beams.arm.section" in captured.err
    assert "Traceback" not in captured.err
    assert not (tmp_path / "bad_results").exists()  # nothing written


def test_bad_arguments_exit_2(capsys):
    assert cli.main(["run"]) == 2
    assert cli.main(["run", "x.yaml", "--backend", "fortran"]) == 2
    assert cli.main([]) == 2
    capsys.readouterr()


# ----------------------------------------------------------------------------- run, with stand-ins
class _FakeSolve:
    """Stands in for latdyn.solve: writes results with ResultWriter, then behaves as told."""

    def __init__(self, behaviour):
        self.behaviour = behaviour
        self.calls = []

    def run(self, scene, out_dir=None, backend="auto", progress=False):
        self.calls.append({"scene": scene, "out_dir": out_dir, "backend": backend, "progress": progress})
        writer = ResultWriter(out_dir, ["x"])
        try:
            writer.record(0.0, [1.0], state={"q": np.zeros(2)})
            if self.behaviour == "scene_error":
                raise SceneError("s.yaml", "bodies.hub", "a coordinate that something holds")
            if self.behaviour == "solver_error":
                raise SolverError("Newton failed at step 3 (t = 0.03)", "residual largest in beam arm")
            if self.behaviour == "interrupt":
                raise KeyboardInterrupt
            if self.behaviour == "bug":
                raise ZeroDivisionError("oops")
        except BaseException as exc:
            writer.close(status="interrupted" if isinstance(exc, KeyboardInterrupt) else "failed")
            raise
        writer.close({"steps": 7, "wall_time_s": 0.25})
        return writer.result()


@pytest.fixture
def fake_modules(monkeypatch, tmp_path):
    """Fake latdyn.scene.loader (and latdyn.solve per test) so the CLI's mapping is tested alone."""
    scene_module = types.ModuleType("latdyn.scene.loader")
    scene_module.load_scene = lambda path: {"path": path}
    scene_module.describe = lambda scene: f"scene from {Path(scene['path']).name}"
    monkeypatch.setitem(sys.modules, "latdyn.scene.loader", scene_module)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spin.yaml").write_text("title: x\n")

    def install_solve(behaviour):
        solve = _FakeSolve(behaviour)
        module = types.ModuleType("latdyn.solve")
        module.run = solve.run
        monkeypatch.setitem(sys.modules, "latdyn.solve", module)
        return solve

    return install_solve


def test_run_success_default_out_dir_and_summary_line(fake_modules, tmp_path, capsys):
    solve = fake_modules("ok")
    assert cli.main(["run", "spin.yaml", "--backend", "c", "-q"]) == 0
    call = solve.calls[0]
    assert Path(call["out_dir"]) == tmp_path / "spin_results"
    assert call["backend"] == "c" and call["progress"] is False
    out = capsys.readouterr().out
    assert "spin_results" in out and "7 steps" in out and "0.25 s" in out
    assert Result.load(tmp_path / "spin_results").summary["status"] == "solved"


def test_run_with_out_option_and_progress(fake_modules, tmp_path, capsys):
    solve = fake_modules("ok")
    assert cli.main(["run", "spin.yaml", "-o", "elsewhere"]) == 0
    assert Path(solve.calls[0]["out_dir"]) == Path("elsewhere")
    assert solve.calls[0]["progress"] is True
    assert (tmp_path / "elsewhere" / "probes.csv").is_file()


def test_solver_error_exits_1_with_diagnosis_and_complete_files(fake_modules, tmp_path, capsys):
    fake_modules("solver_error")
    assert cli.main(["run", "spin.yaml"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("latdyn: error: the solver failed: Newton failed at step 3")
    assert "residual largest in beam arm" in err and "Traceback" not in err
    result = Result.load(tmp_path / "spin_results")
    assert result.summary["status"] == "failed" and result.t.size == 1


def test_scene_error_from_the_solver_exits_2_and_leaves_nothing(fake_modules, tmp_path, capsys):
    fake_modules("scene_error")
    assert cli.main(["run", "spin.yaml"]) == 2
    assert capsys.readouterr().err.startswith("latdyn: error: s.yaml: bodies.hub:")
    assert not (tmp_path / "spin_results").exists()


def test_interrupt_exits_130_with_complete_files(fake_modules, tmp_path, capsys):
    fake_modules("interrupt")
    assert cli.main(["run", "spin.yaml"]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert Result.load(tmp_path / "spin_results").summary["status"] == "interrupted"


def test_internal_error_exits_1_with_hint_and_debug_reraises(fake_modules, capsys):
    fake_modules("bug")
    assert cli.main(["run", "spin.yaml"]) == 1
    err = capsys.readouterr().err
    assert "latdyn: internal error: ZeroDivisionError: oops" in err and "--debug" in err
    assert "Traceback" not in err
    with pytest.raises(ZeroDivisionError):
        cli.main(["run", "spin.yaml", "--debug"])
    with pytest.raises(ZeroDivisionError):
        cli.main(["--debug", "run", "spin.yaml"])


def test_check_prints_description_and_model_size(tmp_path, capsys):
    """`latdyn check` on a scene as a user types it: the description, the model's size and the
    dynamics lines (lowest non-rigid mode against dt)."""
    scene = tmp_path / "cantilever.yaml"
    scene.write_text("""\
title: cantilever
sections:
  s: {EA: 1.0e6, EIy: 100, EIz: 100, GJ: 80, rhoA: 1.0, rhoIy: 0.0, rhoIz: 0.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1, 0, 0], mass: 0.1}
beams:
  arm: {from: base, to: tip, section: s, elements: 4}
solve: {analysis: transient, t_end: 0.1, dt: 0.01}
""")
    assert cli.main(["check", str(scene)]) == 0
    out = capsys.readouterr().out
    assert "cantilever" in out and "4 elements" in out and "coordinates" in out
    assert "lowest non-rigid mode" in out and "steps per period at dt = 0.01" in out


def _write_results(folder: Path, static=False):
    t = np.linspace(0.0, 2.0, 41)
    with ResultWriter(folder, ["tip_v", "energy/total"], first_column="load_factor" if static else "t",
                      meta={"title": "test"}) as writer:
        for ti in t:
            writer.record(ti, [np.sin(ti), 1.0 + 0.01 * ti])
        writer.write_modes([0.0, 1.2, 7.5])


def test_plot_writes_pngs(tmp_path, capsys):
    out = tmp_path / "run_results"
    _write_results(out)
    assert cli.main(["plot", str(out)]) == 0
    names = sorted(p.name for p in (out / "plots").iterdir())
    assert names == ["energy_total.png", "modes.png", "overview.png", "tip_v.png"]
    for name in names:
        assert (out / "plots" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "4 plots" in capsys.readouterr().out


def test_plot_static_into_other_folder(tmp_path):
    out = tmp_path / "static_results"
    _write_results(out, static=True)
    assert cli.main(["plot", str(out), "--out", str(tmp_path / "figs")]) == 0
    assert (tmp_path / "figs" / "overview.png").is_file()
    assert not (out / "plots").exists()


def test_plot_missing_folder_exits_2(tmp_path, capsys):
    missing = tmp_path / "nothing_here"
    assert cli.main(["plot", str(missing)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("latdyn: error: ") and str(missing) in err
    assert not missing.exists()


def test_plot_folder_without_results_exits_2(tmp_path, capsys):
    assert cli.main(["plot", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path) in err and "probes.csv" in err


# ----------------------------------------------------------------------------- a plain `run` without argparse
_PLAIN_RUNS = [
    ["run", "x.yaml"], ["run", "x.yaml", "-o", "out"], ["run", "x.yaml", "--out", "out dir", "-q"],
    ["run", "-q", "x.yaml"], ["run", "--quiet", "--resume", "x.yaml"], ["--debug", "run", "x.yaml"],
    ["run", "x.yaml", "--debug"], ["--debug", "run", "x.yaml", "--debug"], ["run", "--backend", "c", "x.yaml"],
    ["run", "x.yaml", "--backend", "auto", "-o", "o", "-q", "--resume", "--debug"], ["run", "run"],
    ["run", "-o", "run", "check"], ["run", "x.json", "-o", "ünï", "--resume"],
]
_OTHER_COMMAND_LINES = [
    [], ["run"], ["check", "x.yaml"], ["plot", "out"], ["--help"], ["run", "--help"], ["run", "x.yaml", "-h"],
    ["--version"], ["run", "x.yaml", "--ou", "o"], ["run", "x.yaml", "-qo", "o"], ["run", "x.yaml", "--out=o"],
    ["run", "x.yaml", "-oo"], ["run", "x.yaml", "--checkpoint-every", "1"], ["run", "x.yaml", "-o", "-x"],
    ["run", "x.yaml", "-o"], ["run", "x.yaml", "-o", ""], ["run", ""], ["run", "a.yaml", "b.yaml"],
    ["run", "x.yaml", "--backend", "gpu"], ["run", "x.yaml", "-q", "-q"], ["run", "x.yaml", "-o", "a", "--out", "b"],
    ["run", "--", "x.yaml"], ["run", "-x.yaml"], ["run", "-1"], ["--debug", "--debug", "run", "x.yaml"],
    ["-q", "run", "x.yaml"], ["run", "x.yaml", "--nope"],
]


@pytest.mark.parametrize("argv", _PLAIN_RUNS, ids=" ".join)
def test_a_plain_run_command_line_is_read_without_argparse_as_argparse_reads_it(argv):
    """``latdyn run``'s plainest command lines are read without argparse (cli._plain_run_arguments;
    docs/performance.md, "Thirteenth pass"): the same attributes and values as the parser's."""
    plain = cli._plain_run_arguments(argv)
    assert plain is not None
    assert vars(plain) == vars(cli.build_parser().parse_args(argv))


@pytest.mark.parametrize("argv", _OTHER_COMMAND_LINES, ids=lambda argv: " ".join(argv) or "(none)")
def test_any_other_command_line_is_left_to_argparse(argv):
    """Another command, help, an abbreviated, joined or repeated option, a value or scene that starts with
    ``-`` or is empty, a second scene, a bad backend: argparse reads it, with its own messages."""
    assert cli._plain_run_arguments(argv) is None


def test_a_bad_run_command_line_still_gets_argparses_message(capsys):
    assert cli.main(["run", "x.yaml", "--backend", "gpu"]) == 2
    assert "invalid choice: 'gpu'" in capsys.readouterr().err
    assert cli.main(["run", "x.yaml", "-o"]) == 2
    assert "expected one argument" in capsys.readouterr().err
