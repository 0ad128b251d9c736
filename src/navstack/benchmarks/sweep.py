"""Run independent navigation scenarios serially, on local processes or on Ray.

Every scenario is deterministic given ``(scenario, seed, controller)`` and builds its own
stack, so the executors only differ in where :func:`run_scenario` runs:

* ``serial`` -- in this process, one after the other;
* ``local`` -- a :class:`concurrent.futures.ProcessPoolExecutor` of ``workers``
  processes (``spawn``: each worker imports navstack afresh, as a Ray worker does);
* ``ray`` -- one long-lived Ray actor per CPU, each pulling the next scenario when it
  is free (:mod:`navstack.benchmarks.sweep_ray`).  Without ``address`` a lean local
  Ray cluster of ``workers`` CPUs is started for the run and shut down after it; with
  ``address`` (``ray://host:10001`` or ``host:6379``, or ``auto``) the actors go to that
  running cluster, one per CPU it has, and ``workers`` is not used.  Ray is the
  optional extra ``navstack[sweeps]``.

:func:`open_executor` makes the executor ready before the jobs are known (a Ray cluster
starts in the background at once); :func:`run_jobs` is open, run and close in one.
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

    ``timings``, if given, receives the executor's :attr:`Executor.timings`
    (``cluster_start_s`` 0 for the executors without a cluster)."""
    ex = open_executor(executor, workers, address)
    try:
        return ex.run(jobs, progress)
    finally:
        ex.close()
        if timings is not None:
            timings.update({"cluster_start_s": 0.0, **ex.timings})


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


class Executor:
    """An executor made ready before the jobs are known: :func:`open_executor` starts a
    Ray cluster in the background at once, so drawing the jobs overlaps its start-up.

    ``timings`` holds what the executor measured (Ray: ``cluster_start_s``,
    ``cluster_wait_s``, ``shutdown_s``; see :class:`~navstack.benchmarks.sweep_ray.RayPool`).
    """

    def __init__(self, executor: str, workers: int | None = None,
                 address: str | None = None) -> None:
        check_executor(executor, workers, address)
        self.executor = executor
        self.workers = workers or default_workers()
        self.address = address
        self.timings: dict[str, float] = {}
        self._pool: Any = None
        if executor == "ray":
            from navstack.benchmarks.sweep_ray import RayPool

            self._pool = RayPool(self.workers, address)
            self.timings = self._pool.timings

    def run(self, jobs: Sequence[Job], progress: Progress = no_progress) -> list[Outcome]:
        """Outcomes of ``jobs`` in order (see the module docstring)."""
        progress("scenarios", 0, len(jobs))
        if self.executor == "serial" or not jobs:
            out = []
            for i, job in enumerate(jobs):
                out.append(_run_job(job))
                progress("scenarios", i + 1, len(jobs))
            return out
        if self.executor == "local":
            return _run_local(jobs, self.workers, progress)
        return list(self._pool.run(jobs, progress))

    def close(self) -> None:
        """Shut down what the executor started (a local Ray cluster)."""
        if self._pool is not None:
            self._pool.close()

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_executor(executor: str, workers: int | None = None,
                  address: str | None = None) -> Executor:
    """An :class:`Executor`; bad options raise :class:`ConfigError` before anything starts."""
    return Executor(executor, workers, address)


def timed_jobs(jobs: Sequence[Job], executor: str, workers: int | None = None,
               address: str | None = None, progress: Progress = no_progress,
               timings: dict[str, float] | None = None) -> tuple[list[Outcome], float]:
    """:func:`run_jobs` and its wall time [s] (cluster start-up and shut-down included)."""
    t0 = time.perf_counter()
    out = run_jobs(jobs, executor, workers, address, progress, timings)
    return out, time.perf_counter() - t0
