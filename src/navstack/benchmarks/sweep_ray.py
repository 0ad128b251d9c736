"""Sweeps on Ray: a lean local cluster and one warm actor per CPU pulling scenarios.

:class:`RayPool` brings its cluster up in a background thread as soon as it is made,
so a caller that still has work to do before the first scenario (``navstack bench
navigation`` draws the chaos scenarios) overlaps it with importing Ray, starting the
cluster and warming the workers.  On the cluster it creates one :class:`ScenarioWorker`
actor per CPU (``num_cpus=1`` each).  An actor lives for the whole sweep: its process
imports the stack once when it is created -- while the driver is still drawing -- and
every scenario after the first finds the stack's modules, numba kernels and caches
warm.  The driver hands each actor one scenario at a time and the next one as soon as
it returns (dynamic pulling: a long scenario does not hold up a queue behind it), so
the load is balanced to the last scenario whatever the durations.  Only the small
:class:`~navstack.benchmarks.sweep.Job` (start, goal, fault) travels to an actor and
its :class:`~navstack.benchmarks.navigation.Outcome` back; worlds and robots are
loaded by the worker from the installed package.

The local cluster is lean: no dashboard, usage statistics off, and neither the log
monitor, the autoscaler monitor nor the dashboard's API server (:data:`LEAN_SKIPPED`;
``ray.init`` cannot switch them off, so their start methods are skipped while it runs,
and a plain cluster is started if that fails), which leaves the GCS, the raylet, its
two agents and the workers -- ~1.2 s less CPU at start and ~1 s less to shut down
(``docs/sweeps.md``).  Its workers run at nice 0 like a serial run
(``RAY_worker_niceness``; Ray's default of 15 starved them on a loaded machine).  It
gets no ``runtime_env`` (the raylet's workers inherit this
process's environment, ``NUMBA_CACHE_DIR`` included; a job with a ``runtime_env``
cannot use the workers the raylet prestarts during start-up and would wait for new
ones).

With ``address`` the pool joins a running cluster: one actor per CPU the cluster has,
and a ``runtime_env`` carrying ``NUMBA_CACHE_DIR``/``MPLBACKEND``/``NAVSTACK_DATA`` (a
remote machine's workers do not share this process's environment).
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import os
import threading
import time
from collections.abc import Iterator, Sequence
from typing import Any

from navstack.benchmarks.common import Progress, no_progress
from navstack.benchmarks.navigation import Outcome, run_scenario
from navstack.benchmarks.sweep import Job, SweepError, check_reachable

_ENV_KEYS = ("NUMBA_CACHE_DIR", "MPLBACKEND", "NAVSTACK_DATA")


class ScenarioWorker:
    """A Ray actor running scenarios one at a time in one long-lived, warm process."""

    def __init__(self) -> None:
        # Importing the stack here runs as the actor is created, before the first job.
        import navstack.interfaces.stack  # noqa: F401

    def run(self, job: Job) -> Outcome:
        return run_scenario(job.scenario, seed=job.seed, controller=job.controller)


def import_ray() -> Any:
    try:
        import ray
    except ImportError as exc:
        raise SweepError(f"--executor ray needs Ray ({exc}): pip install 'navstack[sweeps]' "
                         "(or use --executor local)") from None
    return ray


#: head-node services a sweep's private cluster does without: the log monitor (worker
#: logs are not sent to the driver), the autoscaler monitor (the cluster is fixed) and
#: the dashboard's API server (nobody submits jobs or queries state on it)
LEAN_SKIPPED = ("start_log_monitor", "start_monitor", "start_api_server")


@contextlib.contextmanager
def _lean_head(ray: Any) -> Iterator[None]:
    """While a local cluster starts, skip :data:`LEAN_SKIPPED` (Ray's ``Node`` methods;
    ``ray.init`` has no option for them).  Does nothing when Ray has no such methods."""
    node_cls = getattr(getattr(getattr(ray, "_private", None), "node", None), "Node", None)
    saved = {name: getattr(node_cls, name) for name in LEAN_SKIPPED
             if node_cls is not None and callable(getattr(node_cls, name, None))}
    if len(saved) != len(LEAN_SKIPPED):
        yield
        return
    try:
        for name in saved:
            setattr(node_cls, name, lambda self, *args, **kwargs: None)
        yield
    finally:
        for name, method in saved.items():
            setattr(node_cls, name, method)


def _start_local(ray: Any, workers: int) -> None:
    """``ray.init`` of a lean local cluster of ``workers`` CPUs (module docstring).

    If the lean start fails, a plain local cluster is tried (Ray gives its raylet a
    fixed 30 s to register, which a heavily loaded machine can miss, too)."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    # Ray runs its workers at nice 15 so that its daemons come first; here the workers
    # are the sweep, and a serial run is not niced: on a machine with other load,
    # niced workers got a fraction of the CPU a serial run gets.
    os.environ.setdefault("RAY_worker_niceness", "0")
    with contextlib.suppress(ImportError):  # the Node class _lean_head adjusts
        importlib.import_module("ray._private.node")

    for lean in (True, False):
        try:
            with _lean_head(ray) if lean else contextlib.nullcontext():
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False,
                         configure_logging=False)
            return
        except Exception:
            ray.shutdown()
            if not lean:
                raise


class RayPool:
    """A Ray cluster (started or joined in the background) with one warm actor per CPU.

    ``timings`` receives ``workers`` (actors made), ``cluster_start_s`` (importing Ray
    and starting or joining the cluster, measured in the background thread) and, after
    :meth:`run`, ``cluster_wait_s`` (how long :meth:`run` waited for the cluster: the
    part of the start not hidden behind the caller's own work) and ``shutdown_s``."""

    def __init__(self, workers: int, address: str | None = None) -> None:
        self.workers = workers
        self.address = address
        self.timings: dict[str, float] = {}
        self._ray: Any = None
        self._owns = False
        self._actors: list[Any] = []
        self._error: BaseException | None = None
        self._started = threading.Event()
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._own_cluster, name="navstack-ray",
                                        daemon=True)
        self._thread.start()

    # --- the cluster's thread ------------------------------------------------------------
    def _own_cluster(self) -> None:
        """Start the cluster, then keep it until :meth:`close` and shut it down.

        The same thread must do both: Ray starts its daemons with the parent-death
        signal (``PR_SET_PDEATHSIG``), which Linux sends when the *thread* that started
        them ends -- a start-up thread that returned would take the cluster with it."""
        try:
            self._start()
        finally:
            self._started.set()
        self._closing.wait()
        t0 = time.perf_counter()
        try:
            self._stop()
        finally:
            self.timings["shutdown_s"] = time.perf_counter() - t0

    def _start(self) -> None:
        t0 = time.perf_counter()
        try:
            ray = self._ray = import_ray()
            if self.address is not None:
                check_reachable(self.address)
            if not ray.is_initialized():
                # ray.init off the main thread only warns that it sets no SIGTERM handler
                # (the CLI installs its own); keep that warning off the terminal
                quiet = logging.getLogger("ray._private.worker")
                level = quiet.level
                quiet.setLevel(logging.ERROR)
                try:
                    self._init(ray)
                finally:
                    quiet.setLevel(level)
                self._owns = True
            count = self.workers
            if self.address is not None:
                count = max(1, int(ray.cluster_resources().get("CPU", 1)))
            actor = ray.remote(num_cpus=1, max_restarts=0, max_task_retries=0)(
                ScenarioWorker)
            self._actors = [actor.remote() for _ in range(count)]
            self.timings["workers"] = float(count)
        except BaseException as exc:  # re-raised in the caller's thread by run()
            self._error = exc
        self.timings["cluster_start_s"] = time.perf_counter() - t0

    def _init(self, ray: Any) -> None:
        try:
            if self.address is None:
                _start_local(ray, self.workers)
            else:
                env = {k: v for k, v in os.environ.items() if k in _ENV_KEYS}
                ray.init(address=self.address, log_to_driver=False, configure_logging=False,
                         runtime_env={"env_vars": env})
        except Exception as exc:  # Ray raises plain Exception on a start-up timeout
            where = (f"the Ray cluster at {self.address}" if self.address
                     else f"a local Ray cluster of {self.workers} CPUs")
            hint = ("on an overloaded machine Ray's start-up can time out: retry, or use "
                    "--executor local")
            if self.address not in (None, "auto") and "RAY_AUTH_MODE" not in os.environ:
                hint = ("a cluster started by `ray start` or `ray.init` uses token "
                        "authentication, which Ray never assumes for an explicit address: "
                        "set RAY_AUTH_MODE=token with the cluster's token in "
                        "~/.ray/auth_token or RAY_AUTH_TOKEN_PATH; or " + hint)
            raise SweepError(f"could not start or reach {where}: {exc} ({hint})") from None

    def _ready(self) -> Any:
        t0 = time.perf_counter()
        self._started.wait()
        self.timings["cluster_wait_s"] = time.perf_counter() - t0
        if self._error is not None:
            if isinstance(self._error, SweepError):
                raise self._error
            raise SweepError(f"could not start the Ray sweep: {self._error}") from None
        return self._ray

    # --- running -------------------------------------------------------------------------
    def run(self, jobs: Sequence[Job], progress: Progress = no_progress) -> list[Outcome]:
        """Outcomes of ``jobs`` in order; each actor gets the next job when it is free."""
        ray = self._ready()
        results: list[Outcome | None] = [None] * len(jobs)
        running: dict[Any, tuple[int, Any]] = {}  # ref -> (job index, actor)
        following = iter(range(len(jobs)))

        def give(actor: Any) -> None:
            i = next(following, None)
            if i is not None:
                running[actor.run.remote(jobs[i])] = (i, actor)

        for actor in self._actors:
            give(actor)
        done_count = 0
        while running:
            done, _ = ray.wait(list(running), num_returns=1)
            for ref in done:
                i, actor = running.pop(ref)
                try:
                    results[i] = ray.get(ref)
                except ray.exceptions.RayError as exc:
                    raise SweepError(f"scenario {jobs[i].scenario.name} failed on Ray: "
                                     f"{exc}") from None
                done_count += 1
                progress("scenarios", done_count, len(jobs))
                give(actor)
        return [r for r in results if r is not None]

    # --- shutting down ---------------------------------------------------------------
    def close(self) -> None:
        """Stop the actors; shut a cluster this pool started down."""
        self._closing.set()
        self._thread.join()

    def _stop(self) -> None:
        ray = self._ray
        if ray is None or not ray.is_initialized():
            return
        actors, self._actors = self._actors, []
        if not self._owns:
            for actor in actors:
                with contextlib.suppress(Exception):
                    ray.kill(actor)
            return
        ray.shutdown()
