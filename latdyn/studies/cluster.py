"""Where a study's cases run: in this process, or on Dask (``--scheduler``, ``client=``, STUDY.md).

:func:`parse_scheduler` reads the option (``serial``; ``local`` or ``local:N``; any
other text is the address of a running Dask scheduler, ``tcp://host:8786``) and
:func:`open_scheduler` gives a runner whose ``run(function, tasks)`` yields
``(task, result)`` as each case finishes, in any order (the study puts its rows back in
case order, so the rows do not depend on the scheduler). A ``distributed.Client`` the
caller made (on a ``LocalCluster``, a ``dask_jobqueue.SLURMCluster``, any cluster) is
used as it is and left open (:func:`open_client`).

On Dask:

- each case runs **in the worker process**, in its task thread: the function sent is
  :func:`latdyn.studies.case.run_case` itself (this module imports nothing of the runner),
  so the worker's imports, loaded kernels and warm-up serve every case it runs after the
  first. ``run_case`` measures ``wall_s`` around :func:`latdyn.run` there, holds BLAS to
  one thread (threadpoolctl, which works on a remote cluster too) and takes a
  process-wide lock, so a worker with several threads still runs one case at a time;
- ``local:N`` starts a ``distributed.LocalCluster(n_workers=N, threads_per_worker=1,
  processes=True)``, its worker processes started with ``OMP_NUM_THREADS``,
  ``OPENBLAS_NUM_THREADS``, ``MKL_NUM_THREADS`` … = 1 so that N workers use N cores;
- isolation: what a run does (a solver error, a bad scene, any exception) is a returned
  row, never an exception, so ``retries`` of ``Client.submit`` (which reruns tasks that
  raised) stays 0. What is left is a worker process that dies under a case (a crash in
  compiled code, memory): its nanny starts a new worker and the scheduler reschedules the
  case, up to ``distributed.scheduler.allowed-failures`` times (2 on a cluster started
  here; the scheduler's own setting, 3 by default, on a passed client or an address),
  then gives up with ``KilledWorker``: the case comes back as a ``failed`` row with a
  "worker lost" message, is not cached (a rerun tries it again), and the study goes on.
  The scheduler counts a lost worker against every task the worker held, so a cluster
  started here sets ``distributed.scheduler.worker-saturation`` to 1.0 (a worker holds
  only the case it runs); set it on your own scheduler too (docs/studies.md).
"""
from __future__ import annotations

import contextlib
import logging
import os
import re

from latdyn.studies.case import failed_record

__all__ = ["parse_scheduler", "open_scheduler", "open_client", "SerialRunner", "DaskRunner", "BLAS_ENV"]

#: Environment of local worker processes: one BLAS/OpenMP thread each.
BLAS_ENV = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                                   "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")}
#: Times the Dask scheduler reruns a task whose worker died, on a local cluster.
ALLOWED_FAILURES = 2
#: Tasks a local worker holds per thread: 1.0, so that a worker holds only the case it runs
#: and a worker lost under a crashing case costs no other case one of its tries.
WORKER_SATURATION = 1.0


def parse_scheduler(text: str) -> tuple:
    """``("serial",)``, ``("local", n_workers)`` or ``("address", text)``; ValueError when malformed."""
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"--scheduler: expected serial, local[:N] or the address of a Dask scheduler, "
                         f"not {text!r}")
    text = text.strip()
    if text == "serial":
        return ("serial",)
    if text == "local" or text.startswith("local:"):
        m = re.fullmatch(r"local(?::(\d+))?", text)
        if not m or (m.group(1) is not None and int(m.group(1)) < 1):
            raise ValueError(f"--scheduler: expected local or local:N with N >= 1 workers, not {text!r}")
        return ("local", int(m.group(1)) if m.group(1) else (os.cpu_count() or 1))
    if not re.fullmatch(r"([a-z]+://)?[^\s/:]+(:\d+)?/?", text):
        raise ValueError(f"--scheduler: {text!r} is neither serial, local[:N] nor a scheduler address "
                         "(tcp://host:8786)")
    return ("address", text)


class SerialRunner:
    """Runs the cases one after the other in this process."""

    def describe(self) -> dict:
        return {"kind": "serial", "workers": 1}

    def run(self, function, tasks):
        for task in tasks:
            yield task, function(task)


class DaskRunner:
    """Runs the cases on a Dask cluster (a LocalCluster it owns, one at an address, or a client's)."""

    def __init__(self, client, kind: str, workers: int, address: str, cluster=None):
        self.client, self.kind, self.workers, self.address, self.cluster = client, kind, workers, address, cluster

    def describe(self) -> dict:
        import dask
        import distributed

        return {"kind": self.kind, "workers": self.workers, "address": self.address,
                "dask": dask.__version__, "distributed": distributed.__version__,
                "threads_per_worker": 1 if self.kind == "local" else None}

    def run(self, function, tasks):
        """Submit ``function(task)`` for every task (run in a worker's task thread); yield as they finish."""
        from distributed import as_completed

        if not tasks:
            return
        futures = {}
        # the order of the study (the reference first) is kept
        for task in tasks:
            future = self.client.submit(function, task, key=f"latdyn-case-{task['hash']}", pure=False, retries=0)
            futures[future.key] = (future, task)
        for future in as_completed([f for f, _ in futures.values()]):
            task = futures[future.key][1]
            try:
                yield task, future.result()
            except Exception as exc:  # noqa: BLE001 - only a lost worker gets here (the function never raises)
                yield task, lost_worker_record(task, exc)
            finally:
                future.release()


def lost_worker_record(task: dict, exc: BaseException) -> dict:
    """The row of a case whose worker process was lost (after the scheduler's retries); not cached."""
    return failed_record(task, f"worker lost: {type(exc).__name__}: {exc}")


def open_client(client) -> DaskRunner:
    """A runner on a ``distributed.Client`` the caller made; the caller closes it (and its cluster).

    Anything with ``submit`` and ``scheduler_info`` is taken (a ``Client`` of a
    ``LocalCluster``, of a ``dask_jobqueue.SLURMCluster``, of a scheduler address). Its
    workers may still be starting (jobs in a queue): cases wait for them.
    """
    if not (callable(getattr(client, "submit", None)) and callable(getattr(client, "scheduler_info", None))):
        raise ValueError(f"client: expected a dask.distributed.Client, not {type(client).__name__}")
    if getattr(client, "status", "running") not in ("running", "connecting", "newly-created"):
        raise ValueError(f"client: the Dask client is {client.status}, not running")
    info = client.scheduler_info()
    address = getattr(getattr(client, "scheduler", None), "address", None) or info.get("address", "")
    return DaskRunner(client, "client", len(info.get("workers", {})), address)


@contextlib.contextmanager
def open_scheduler(kind: tuple):
    """A runner for ``kind`` (from :func:`parse_scheduler`, or ``("client", client)``), closed on exit
    (a cluster started here is stopped; a caller's client is left open)."""
    if kind[0] == "serial":
        yield SerialRunner()
        return
    if kind[0] == "client":
        yield open_client(kind[1])
        return
    from latdyn.errors import require

    dask, distributed = require("dask", f"a study on a Dask scheduler ({kind[0]})", "dask", "distributed")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster

    if kind[0] == "local":
        with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
                              "distributed.scheduler.worker-saturation": WORKER_SATURATION,
                              "distributed.worker.daemon": False}):
            cluster = LocalCluster(n_workers=kind[1], threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.ERROR, env=dict(BLAS_ENV))
            try:
                with Client(cluster) as client:
                    yield DaskRunner(client, "local", kind[1], cluster.scheduler_address, cluster)
            finally:
                cluster.close()
        return
    try:
        client = Client(kind[1], timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise ValueError(f"--scheduler: could not connect to a Dask scheduler at {kind[1]} ({exc})") from exc
    with client:
        workers = len(client.scheduler_info().get("workers", {}))
        yield DaskRunner(client, "address", workers, kind[1])
