"""Campbell diagrams from a study (issue 20 item 3; shared/STUDY.md, docs/studies.md).

A study of a ``solve.analysis: modes`` scene needs no ``error`` or ``reference``: each case's
frequencies go to study.csv (``spin_rate``, ``mode_k_hz``, ``mode_k_damping_ratio``,
``mode_k_direction``) and ``campbell.png`` draws them against the varied key. The scene is
examples/rotating_beam_modes.yaml (a 10 m cantilever on a hub spinning about z, 10 elements,
modes about the steady spin), whose flapwise frequencies are tabulated by Wright et al. (1982).
"""
from __future__ import annotations

import csv
import itertools
import json
import math
import struct
import subprocess
import sys
from pathlib import Path

import pytest

import latdyn
from latdyn import cli

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "studies" / "campbell_rotating_beam.yaml"
SCENE = ROOT / "examples" / "rotating_beam_modes.yaml"
#: sqrt(rhoA L^4 / EI) of the example's arm [s]: gamma = Omega * T, frequencies omega * T.
T = math.sqrt(1.2 * 10.0 ** 4 / 1.4e4)
#: First flapwise frequency of a uniform rotating cantilever, omega*T against gamma = Omega*T
#: (Wright, Smith, Thresher & Wang 1982, J. Appl. Mech. 49; also Hodges & Rutkowski 1981).
WRIGHT_FLAP_1 = {0: 3.5160, 5: 6.4495, 10: 11.2023}


def _png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    return struct.unpack(">II", data[16:24])


def _first(row: dict, direction: str) -> float:
    """The lowest frequency [Hz] of the row whose dominant direction is ``direction``."""
    k = 1
    while f"mode_{k}_hz" in row:
        if row[f"mode_{k}_direction"] == direction:
            return float(row[f"mode_{k}_hz"])
        k += 1
    raise AssertionError(f"no {direction} mode in {row}")


def test_campbell_example_through_the_cli(tmp_path):
    out = tmp_path / "campbell"
    done = subprocess.run([sys.executable, "-m", "latdyn", "study", str(EXAMPLE), "-o", str(out)],
                          check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    with open(out / "study.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    columns = list(rows[0])
    assert columns[0] == "bodies.hub.motion.rotation.angle"
    for k in range(1, 7):
        assert {f"mode_{k}_hz", f"mode_{k}_damping_ratio", f"mode_{k}_direction"} <= set(columns)
    assert [r["status"] for r in rows] == ["solved"] * 7
    assert [float(r["spin_rate"]) for r in rows] == [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0]
    assert all(r["error"] == "" for r in rows)  # no error asked for
    flap = [_first(r, "z") for r in rows]
    chord = [_first(r, "y") for r in rows]
    assert all(b > a for a, b in itertools.pairwise(flap)), flap  # centrifugal stiffening
    assert flap[-1] / flap[0] > 3.0  # 0.604 -> 2.11 Hz at gamma = 11
    assert chord[-1] / chord[0] < 1.6  # the in-plane -Omega^2 softening: 0.604 -> 0.904 Hz
    for r in rows:  # sorted order, as modes.csv
        hz = [float(r[f"mode_{k}_hz"]) for k in range(1, 7)]
        assert hz == sorted(hz)
    width, height = _png_size(out / "campbell.png")
    assert width >= 1000 and height >= 600, (width, height)
    assert (out / "campbell.png").stat().st_size > 30_000
    summary = json.loads((out / "summary.json").read_text())
    assert summary["pictures"] == ["campbell.png"] and summary["error"] is None
    case = json.loads((out / "cases" / rows[3]["case"] / "summary.json").read_text())
    assert case["spin_rate"] == pytest.approx(6.0) and case["frame_omega"] == pytest.approx([0.0, 0.0, 6.0])


def test_campbell_study_api_against_the_published_table(tmp_path):
    """Rates at gamma = 0, 5, 10: the first flapwise frequency within 0.02 % of Wright et al., the
    first chordwise one within 0.02 % of sqrt(omega_flap^2 - Omega^2) (its rotating-frame value).
    Measured on 10 elements: +0.001, +0.001, +0.002 % (flap) and +0.001, +0.001, +0.006 % (chord)."""
    rates = {gamma: gamma / T for gamma in WRIGHT_FLAP_1}
    text = (f"scene: {SCENE}\n"
            "set: {solve.mode_shapes: false, solve.count: 4}\n"
            "vary:\n"
            "  bodies.hub.motion.rotation.angle: [" + ", ".join(f'"{w!r}*t"' for w in rates.values()) + "]\n")
    path = tmp_path / "spin.yaml"
    path.write_text(text)
    table = latdyn.study(str(path), out=tmp_path / "out", progress=False)
    assert table["spin_rate"] == pytest.approx(list(rates.values()), rel=1e-12)
    assert "mode_4_hz" in table.columns and "mode_5_hz" not in table.columns
    for gamma, row in zip(WRIGHT_FLAP_1, table.rows):
        flap = 2 * math.pi * _first(row, "z") * T
        chord = 2 * math.pi * _first(row, "y") * T
        assert flap == pytest.approx(WRIGHT_FLAP_1[gamma], rel=2e-4), (gamma, flap)
        assert chord == pytest.approx(math.sqrt(WRIGHT_FLAP_1[gamma] ** 2 - gamma ** 2), rel=2e-4), (gamma, chord)
    assert _png_size(tmp_path / "out" / "campbell.png")[0] >= 1000


def test_campbell_over_a_numeric_key(tmp_path):
    """Over a numeric key (the mesh) at one spin: x is the key's value, spin_rate a constant column."""
    path = tmp_path / "mesh.yaml"
    path.write_text(f"scene: {SCENE}\nset: {{solve.mode_shapes: false, solve.count: 2}}\n"
                    "vary: {beams.arm.elements: [4, 8]}\nplots: [campbell]\n")
    table = latdyn.study(str(path), out=tmp_path / "out", progress=False)
    assert table["spin_rate"] == pytest.approx([5.400617248673217] * 2)
    assert table["mode_2_hz"][1] < table["mode_2_hz"][0]  # a finer mesh is softer
    assert (tmp_path / "out" / "campbell.png").is_file()


@pytest.mark.parametrize("text, key, words", [
    ("vary: {bodies.hub.motion.rotation.angel: ['1*t']}\n", "vary.bodies.hub.motion.rotation.angel", "angel"),
    ("vary: {bodies.hub.motion.rotation.angle: ['1*t']}\nreference: {overrides: {}}\n", "reference",
     "needs error"),
    ("vary: {bodies.hub.motion.rotation.angle: ['1*t']}\nplots: [work-precision]\n", "plots", "needs error"),
    ("vary: {bodies.hub.motion.rotation.angle: ['1*t']}\nplots: [campbel]\n", "plots", "campbell"),
    ("vary: {bodies.hub.motion.rotation.angle: ['1*t'], beams.arm.elements: [4, 8]}\nplots: [campbell]\n",
     "plots", "one vary key"),
])
def test_bad_modal_study_exits_2_naming_the_key(tmp_path, capsys, text, key, words):
    path = tmp_path / "bad.yaml"
    path.write_text(f"scene: {SCENE}\n" + text)
    assert cli.main(["study", str(path), "-o", str(tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: {key}:" in err and words in err, err
    assert not (tmp_path / "out" / "cases").exists()  # nothing ran


def test_campbell_needs_a_modal_scene_and_a_transient_study_still_needs_error(tmp_path):
    spinup = ROOT / "examples" / "spinup.yaml"
    path = tmp_path / "bad.yaml"
    path.write_text(f"scene: {spinup}\nvary: {{solve.dt: [0.01]}}\n")
    done = subprocess.run([sys.executable, "-m", "latdyn", "study", str(path), "-o", str(tmp_path / "out")],
                          check=False, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and f"{path}: error: missing required key 'error'" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr
    path.write_text(f"scene: {spinup}\nvary: {{solve.dt: [0.01]}}\nreference: {{overrides: {{solve.dt: 0.005}}}}\n"
                    "error: {probe: tip_v}\nplots: [campbell]\n")
    assert cli.main(["study", str(path), "-o", str(tmp_path / "out"), "-q"]) == 2
