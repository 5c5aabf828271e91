"""Where a study's cases run: in this process, or on Dask (``--scheduler``, STUDY.md).

:func:`parse_scheduler` reads the option (``serial``; ``local`` or ``local:N``; any
other text is the address of a running Dask scheduler, ``tcp://host:8786``) and
:func:`open_scheduler` gives a runner whose ``run(function, tasks)`` yields
``(task, result)`` as each case finishes, in any order (the study puts its rows back in
case order, so the rows do not depend on the scheduler).

On Dask:

- ``local:N`` starts a ``distributed.LocalCluster(n_workers=N, threads_per_worker=1,
  processes=True)``, its worker processes started with ``OMP_NUM_THREADS``,
  ``OPENBLAS_NUM_THREADS``, ``MKL_NUM_THREADS`` … = 1 so that N workers use N cores;
  every task also holds BLAS to one thread with threadpoolctl (which works on a
  remote cluster too, whose environment is not ours to set);
- each case runs in a child process of its worker (``run_case_in_subprocess``): a
  worker runs tasks in threads, and a run may need a main thread (the compiled step
  library segfaulted in a thread at commit 9a0de9d); a case that crashes is then a
  ``failed`` row, not a lost worker;
- retries happen only when a worker is lost: the case function never raises for what
  a run does (a diverged or failed case is a returned row), so the only failures left are
  a worker process that dies (a crash, memory), which the Dask scheduler reschedules
  on another worker up to ``distributed.scheduler.allowed-failures`` times (2 here for a
  local cluster) — ``retries`` of ``Client.submit``, which would also rerun tasks that
  raised, stays 0. A case whose workers were all lost comes back as a ``failed`` row
  with a "worker lost" message and is not cached, so a rerun tries it again.
"""
from __future__ import annotations

import contextlib
import logging
import os
import re

__all__ = ["parse_scheduler", "open_scheduler", "SerialRunner", "DaskRunner", "BLAS_ENV"]

#: Environment of local worker processes: one BLAS/OpenMP thread each.
BLAS_ENV = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                                   "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")}
#: Times the Dask scheduler reruns a task whose worker died, on a local cluster.
ALLOWED_FAILURES = 2


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
    """Runs the cases on a Dask cluster (a LocalCluster it owns, or one at an address)."""

    def __init__(self, client, kind: str, workers: int, address: str, cluster=None):
        self.client, self.kind, self.workers, self.address, self.cluster = client, kind, workers, address, cluster

    def describe(self) -> dict:
        import dask
        import distributed

        return {"kind": self.kind, "workers": self.workers, "address": self.address,
                "dask": dask.__version__, "distributed": distributed.__version__,
                "threads_per_worker": 1 if self.kind == "local" else None}

    def run(self, function, tasks):
        from distributed import as_completed

        from .study_runner import run_case, run_case_in_subprocess

        if not tasks:
            return
        # each case in its own child process of the worker (see run_case_in_subprocess)
        isolated = run_case_in_subprocess if function is run_case else function
        futures = {}
        # longest first is unknown; the order of the study (the reference first) is kept
        for task in tasks:
            future = self.client.submit(isolated, task, key=f"latdyn-case-{task['hash']}", pure=False, retries=0)
            futures[future.key] = (future, task)
        for future in as_completed([f for f, _ in futures.values()]):
            task = futures[future.key][1]
            try:
                yield task, future.result()
            except Exception as exc:  # noqa: BLE001 - only a lost worker gets here (the task never raises)
                yield task, lost_worker_record(task, exc)
            finally:
                future.release()


def lost_worker_record(task: dict, exc: BaseException) -> dict:
    """The row of a case whose worker process was lost; it is not written to the cache."""
    return {"hash": task["hash"], "overrides": task.get("overrides", {}), "status": "failed",
            "message": f"worker lost: {type(exc).__name__}: {exc}", "wall_times": [], "wall_s": None,
            "steps": None, "newton_iterations": None, "rejected_steps": None, "coordinates": None,
            "t_reached": None}


@contextlib.contextmanager
def open_scheduler(kind: tuple):
    """A runner for ``kind`` (from :func:`parse_scheduler`), closed (cluster stopped) on exit."""
    if kind[0] == "serial":
        yield SerialRunner()
        return
    from .errors import require

    dask, distributed = require("dask", f"a study on a Dask scheduler ({kind[0]})", "dask", "distributed")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster

    if kind[0] == "local":
        with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
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
