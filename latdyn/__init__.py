"""latdyn: transient dynamics of joint-dominated flexible structures (NASA CR-4402)."""
from __future__ import annotations

from latdyn.errors import SceneError, SolverError, UnboundedError

from .version import __version__


def load_scene(source):
    """Read and validate a scene (a path to YAML/JSON, or a dict); see SCENE.md."""
    from latdyn.scene.loader import load_scene as _load

    return _load(source)


def run(scene, out_dir=None, backend="auto", progress=False, *, resume=False, checkpoint_every=None):
    """Solve a scene (a Scene, a dict or a path); returns a :class:`latdyn.results.result.Result`.

    Transient runs into ``out_dir`` write a checkpoint every ``checkpoint_every``
    seconds (default 60), on Ctrl-C/SIGTERM and on failure; ``resume=True`` continues
    from it (see :mod:`latdyn.timeloop.checkpoint`). A transient run whose energy balance breaks
    raises :class:`UnboundedError` (a :class:`SolverError`) after its rows are written
    (docs/energy.md).
    """
    from latdyn.solve import run as _run

    return _run(scene, out_dir=out_dir, backend=backend, progress=progress, resume=resume,
                checkpoint_every=checkpoint_every)


def study(source, scheduler=None, out=None, *, client=None, **options):
    """Run a study (a path to a study YAML, or a mapping); returns a :class:`latdyn.studies.runner.StudyTable`.

    ``scheduler``: ``"serial"`` (default), ``"local[:N]"`` (Dask LocalCluster) or a Dask
    scheduler's address; or ``client``: a ``dask.distributed.Client`` of your own cluster
    (``LocalCluster``, ``dask_jobqueue.SLURMCluster`` …), left open. ``out`` the results
    folder (default ``<study stem>_study``). See STUDY.md, docs/studies.md and
    :mod:`latdyn.studies.runner`.
    """
    from latdyn.studies.runner import study as _study

    return _study(source, scheduler=scheduler, out=out, client=client, **options)


def __getattr__(name: str):
    """``latdyn.Simulation``: a transient run stepped from Python (imported on first use, like the
    solver behind :func:`run`); see :class:`latdyn.stepping.simulation.Simulation` and
    docs/stepping.md."""
    if name == "Simulation":
        from latdyn.stepping.simulation import Simulation

        return Simulation
    raise AttributeError(f"module 'latdyn' has no attribute {name!r}")


__all__ = ["load_scene", "run", "study", "Simulation", "SceneError", "SolverError", "UnboundedError",
           "__version__"]
