"""``latdyn fmu SCENE -o FILE.fmu``: an FMI 2.0 co-simulation FMU of a transient scene, packed by
PythonFMU (SCENE.md, "``latdyn fmu``"; docs/stepping.md).

The FMU holds the scene (``resources/scene.yaml``, the file as written), a small slave module
(a subclass of :class:`latdyn.stepping.fmu_slave.LatdynSlave` named after the FMU) and PythonFMU's
binaries, which run the slave in an embedded Python: where the FMU runs, that Python needs
latdyn installed (``pip install latdyn[fmu]``); the FMU carries no solver of its own."""
from __future__ import annotations

import keyword
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from latdyn.errors import SceneError, require
from latdyn.scene.loader import load_scene

#: The scene inside the FMU, under ``resources/``.
SCENE_RESOURCE = "scene.yaml"

#: The slave module written into the FMU (``resources/<identifier>_slave.py``).
SLAVE_MODULE = """\"\"\"The FMU's slave: latdyn's Simulation of resources/{scene} (latdyn.stepping.fmu_slave).\"\"\"
from latdyn.stepping.fmu_slave import LatdynSlave, hold_module_namespace

hold_module_namespace(globals())  # PythonFMU's loader releases it once per instance (fmu_slave)


class {name}(LatdynSlave):
    \"\"\"{title}\"\"\"
"""


def model_identifier(fmu_path) -> str:
    """The FMU's model identifier (its slave class and binaries): the file's stem made a Python
    identifier (other characters become ``_``; a leading digit or keyword gets a ``latdyn_``)."""
    name = re.sub(r"\W", "_", Path(fmu_path).stem, flags=re.ASCII) or "latdyn_scene"
    if name[0].isdigit() or keyword.iskeyword(name):
        name = f"latdyn_{name}"
    return name


def build_fmu(scene_path, fmu_path) -> Path:
    """Write the FMU of the scene file ``scene_path`` to ``fmu_path`` (ending in ``.fmu``); returns
    its path. The scene is validated first (:class:`latdyn.SceneError`, also for one that is not
    transient); PythonFMU missing is a :class:`latdyn.errors.MissingExtra`.

    PythonFMU packs it in a process of its own (``python -m pythonfmu build``): its builder imports
    the slave module and takes its binaries from the ``pythonfmu`` this process imported, which,
    once an FMU has run here, may be the copy inside that FMU (its resources go first on sys.path),
    without binaries."""
    scene_path, fmu_path = Path(scene_path), Path(fmu_path)
    scene = load_scene(str(scene_path))
    if scene.solve.analysis != "transient":
        raise SceneError(scene.file, "solve.analysis",
                         f"expected transient: an FMU steps a transient run, and this scene's analysis is "
                         f"{scene.solve.analysis}")
    if fmu_path.suffix != ".fmu":
        raise ValueError(f"{fmu_path}: an FMU file name ends in .fmu")
    require("fmu", "latdyn fmu", "pythonfmu")
    name = model_identifier(fmu_path)
    fmu_path = fmu_path.resolve()
    fmu_path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="latdyn_fmu_") as folder:
        folder = Path(folder)
        # the module is not named after the identifier itself: an FMU named json.fmu must not import json
        script = folder / f"{name}_slave.py"
        title = (scene.title or scene_path.name).replace('"', "'").replace("\\", "/")
        script.write_text(SLAVE_MODULE.format(scene=SCENE_RESOURCE, name=name, title=title))
        resource = folder / "resources"
        resource.mkdir()
        shutil.copyfile(scene_path, resource / SCENE_RESOURCE)
        package_root = str(Path(__file__).resolve().parents[2])  # latdyn importable in the builder
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [package_root, os.environ.get("PYTHONPATH")])))
        packed = subprocess.run([sys.executable, "-m", "pythonfmu", "build", "-f", str(script), "-d", str(fmu_path),
                                 str(resource / SCENE_RESOURCE)], cwd=folder, env=env, capture_output=True,
                                text=True, check=False)
    if packed.returncode != 0 or not fmu_path.is_file():
        raise RuntimeError(f"PythonFMU could not pack {fmu_path}: {(packed.stderr or packed.stdout).strip()[-2000:]}")
    return fmu_path
