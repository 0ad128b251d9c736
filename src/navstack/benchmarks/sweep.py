"""Run independent navigation scenarios serially, on local processes or on Ray.

Every scenario is deterministic given ``(scenario, seed, controller)`` and builds its own
stack, so the executors only differ in where :func:`run_scenario` runs:

* ``serial`` -- in this process, one after the other;
* ``local`` -- a :class:`concurrent.futures.ProcessPoolExecutor` of ``workers``
  processes (``spawn``: each worker imports navstack afresh, as a Ray worker does);
* ``ray`` -- one Ray task per scenario (``num_cpus=1`` each).  Without ``address`` a
  local Ray cluster of ``workers`` CPUs is started for the run and shut down after it
  (its workers are forked from this process's environment, so no ``runtime_env`` is
  set: one would make Ray replace the workers it prestarts at ``ray.init`` with new
  ones); with ``address`` (``ray://host:10001`` or ``host:6379``, or ``auto``) the tasks
  go to that running cluster, carrying ``NUMBA_CACHE_DIR``/``MPLBACKEND``/
  ``NAVSTACK_DATA`` in a ``runtime_env``, and ``workers`` is not used.  Ray is the
  optional extra ``navstack[sweeps]``.

Results come back in scenario order whatever the completion order, and progress is
reported per finished scenario.  Because a scenario's outcome depends on nothing but
its inputs, :meth:`Outcome.result_key` is identical across executors (tested).
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context
from typing import Any

from navstack.benchmarks.common import Progress, no_progress
from navstack.benchmarks.navigation import Outcome, Scenario, run_scenario
from navstack.core.errors import ConfigError, NavstackError

EXECUTORS: tuple[str, ...] = ("serial", "local", "ray")


class SweepError(NavstackError):
    """A sweep could not run (Ray missing, cluster unreachable, a worker died)."""


@dataclass(frozen=True)
class Job:
    """One scenario run: its seed and the FollowPath controller."""

    scenario: Scenario
    seed: int
    controller: str = ""


def _run_job(job: Job) -> Outcome:
    return run_scenario(job.scenario, seed=job.seed, controller=job.controller)


def default_workers() -> int:
    """One worker per CPU this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def check_executor(executor: str, workers: int | None, address: str | None) -> None:
    """Refuse a bad combination before any scenario runs."""
    if executor not in EXECUTORS:
        raise ConfigError(f"unknown executor '{executor}'", key_path="--executor",
                          suggestion="one of " + ", ".join(EXECUTORS))
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers must be >= 1, got {workers}", key_path="--workers",
                          suggestion="leave it out for one worker per CPU")
    if address is not None and executor != "ray":
        raise ConfigError("--address is the Ray cluster's address", key_path="--address",
                          suggestion="add --executor ray, or drop --address")


def run_jobs(jobs: Sequence[Job], executor: str = "serial", workers: int | None = None,
             address: str | None = None, progress: Progress = no_progress,
             timings: dict[str, float] | None = None) -> list[Outcome]:
    """Outcomes of ``jobs`` in order, run by ``executor`` (see the module docstring).

    ``timings``, if given, receives ``cluster_start_s``: the wall time [s] of bringing
    the Ray cluster up or connecting to it (0 for the other executors)."""
    if timings is not None:
        timings["cluster_start_s"] = 0.0
    check_executor(executor, workers, address)
    progress("scenarios", 0, len(jobs))
    if executor == "serial" or not jobs:
        out = []
        for i, job in enumerate(jobs):
            out.append(_run_job(job))
            progress("scenarios", i + 1, len(jobs))
        return out
    n = workers or default_workers()
    if executor == "local":
        return _run_local(jobs, n, progress)
    return _run_ray(jobs, n, address, progress, timings)


def _run_local(jobs: Sequence[Job], workers: int, progress: Progress) -> list[Outcome]:
    results: list[Outcome | None] = [None] * len(jobs)
    with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
        pending: dict[Future[Outcome], int] = {pool.submit(_run_job, job): i
                                               for i, job in enumerate(jobs)}
        done_count = 0
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                i = pending.pop(fut)
                results[i] = fut.result()
                done_count += 1
                progress("scenarios", done_count, len(jobs))
    return [r for r in results if r is not None]


def _import_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise SweepError("--executor ray needs Ray: pip install 'navstack[sweeps]' "
                         "(or use --executor local)") from None
    return ray


def check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Refuse a ``host:port`` / ``ray://host:port`` Ray address nothing listens on
    (Ray itself retries for minutes); ``auto`` and addresses without a port pass."""
    host_port = address.split("://", 1)[-1]
    host, sep, port = host_port.rpartition(":")
    if address == "auto" or not sep or not port.isdigit():
        return
    try:
        socket.create_connection((host or "127.0.0.1", int(port)), timeout=timeout_s).close()
    except OSError as exc:
        raise SweepError(f"no Ray cluster answers at {address} ({exc.strerror or exc}); "
                         "start one with `ray start --head` or leave out --address "
                         "for a local cluster") from None


def _start_local_ray(ray: Any, workers: int, attempts: int = 2) -> None:
    """``ray.init`` of a local cluster; Ray gives its raylet a fixed 30 s to register,
    which a heavily loaded machine can miss, so a failed start is retried once.

    No ``runtime_env``: the raylet and its workers inherit this process's environment
    (``NUMBA_CACHE_DIR`` included), and a job with a runtime environment cannot use the
    ``workers`` processes Ray prestarts during ``ray.init`` -- it would start two more
    and pay their start-up (seconds on a loaded 2-core machine) before the first task.
    """
    for attempt in range(attempts):
        try:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False,
                     configure_logging=False)
            return
        except Exception:
            ray.shutdown()
            if attempt == attempts - 1:
                raise


def _run_ray(jobs: Sequence[Job], workers: int, address: str | None,
             progress: Progress, timings: dict[str, float] | None = None) -> list[Outcome]:
    t0 = time.perf_counter()
    ray = _import_ray()
    if address is not None:
        check_reachable(address)
    started = False
    if not ray.is_initialized():
        env = {"env_vars": {k: v for k, v in os.environ.items()
                            if k in ("NUMBA_CACHE_DIR", "MPLBACKEND", "NAVSTACK_DATA")}}
        try:
            if address is None:
                _start_local_ray(ray, workers)
            else:
                ray.init(address=address, log_to_driver=False, configure_logging=False,
                         runtime_env=env)
        except Exception as exc:  # Ray raises plain Exception on a start-up timeout
            where = (f"the Ray cluster at {address}" if address
                     else f"a local Ray cluster of {workers} CPUs")
            raise SweepError(f"could not start or reach {where}: {exc} (on an overloaded "
                             "machine Ray's start-up can time out: retry, or use "
                             "--executor local)") from None
        started = True
    if timings is not None:
        timings["cluster_start_s"] = time.perf_counter() - t0
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(_run_job)
        refs = [task.remote(job) for job in jobs]
        index = {ref: i for i, ref in enumerate(refs)}
        results: list[Outcome | None] = [None] * len(jobs)
        remaining = list(refs)
        while remaining:
            done, remaining = ray.wait(remaining, num_returns=1)
            for ref in done:
                try:
                    results[index[ref]] = ray.get(ref)
                except ray.exceptions.RayError as exc:
                    name = jobs[index[ref]].scenario.name
                    raise SweepError(f"scenario {name} failed on Ray: {exc}") from None
            progress("scenarios", len(jobs) - len(remaining), len(jobs))
        return [r for r in results if r is not None]
    finally:
        if started:
            ray.shutdown()


def timed_jobs(jobs: Sequence[Job], executor: str, workers: int | None = None,
               address: str | None = None, progress: Progress = no_progress,
               timings: dict[str, float] | None = None) -> tuple[list[Outcome], float]:
    """:func:`run_jobs` and its wall time [s] (cluster start-up and shut-down included)."""
    t0 = time.perf_counter()
    out = run_jobs(jobs, executor, workers, address, progress, timings)
    return out, time.perf_counter() - t0
