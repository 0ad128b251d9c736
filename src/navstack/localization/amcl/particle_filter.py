"""The particle set of Nav2's AMCL: weights, KLD-sampling resampling, recovery, clusters.

* **Resampling** is low-variance (systematic) resampling (Thrun, Burgard & Fox,
  *Probabilistic Robotics*, 2005, table 4.4) of ``max_particles`` candidates, shuffled;
  the new set is the shortest prefix that satisfies the **KLD-sampling** bound (Fox,
  "Adapting the sample size in particle filters through KLD-sampling", IJRR 2003): with
  ``k`` histogram bins occupied (0.5 m x 0.5 m x 10 deg, as amcl's kd-tree) the prefix
  stops at the first ``n > (k - 1) / (2 pf_err) * (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) pf_z)^3``
  (the Wilson-Hilferty chi-square quantile with amcl's use of ``pf_z`` as ``z``), clamped
  to ``[min_particles, max_particles]``.  Drawing the prefix from a shuffled systematic
  sample keeps the low variance of systematic resampling with amcl's sequential stop.
* **Recovery** (Augmented_MCL, *Probabilistic Robotics* table 8.3): ``w_slow`` and
  ``w_fast`` low-pass the average measurement likelihood with ``recovery_alpha_slow`` and
  ``recovery_alpha_fast`` (both start at the first average, as amcl); each resampling
  replaces a fraction ``max(0, 1 - w_fast / w_slow)`` of the candidates by poses drawn
  uniformly over free map cells.  Two deliberate differences from amcl's ``pf.c``: the
  average is the measurement's marginal likelihood ``sum_i w_i p_i`` over normalised
  weights (amcl also divides by the particle count, so its trigger moves with the
  KLD-varying set size), and the averages are *not* reset to zero after an injection
  (``reset_averages_on_injection=False``): the reset re-baselines ``w_slow`` on the very
  update the random particles dilute, so recovery stops after one injection — in the
  office kidnap test of ``tests/nodes/test_amcl.py`` 0 of 5 seeds recovered
  with the reset and 5 of 5 without it.
* **Estimate** (amcl ``pf_cluster_stats``): occupied bins touching each other (also
  diagonally, and across the +-pi yaw seam) form clusters; the estimate is the weighted
  mean of the heaviest cluster (circular mean for yaw), and the covariance the weighted
  covariance of the whole set — Nav2 publishes the overall filter covariance, which stays
  honest while several hypotheses survive.  Yaw deviations are wrapped about the mean.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.core.errors import InvalidMessage
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import OccupancyGrid
from navstack.localization.amcl.motion_model import make_motion_model
from navstack.localization.amcl.params import AmclParams
from navstack.localization.amcl.sensor_model import AmclMap, AmclMapError, LaserData, LaserModel

FloatArray = NDArray[np.float64]

XY_BIN = 0.5
"""KLD / cluster histogram cell size in x and y [m] (amcl's kd-tree ``size[0..1]``)."""
YAW_BINS = 36
"""Yaw histogram bins: 10 degrees each (amcl's kd-tree ``size[2]``)."""
CONVERGENCE_DISTANCE = 0.5
"""The set has converged when every particle is within this of the mean in x and y [m]
(amcl ``pf->dist_threshold``); beam skipping only runs on a converged set."""


class InvalidInitialPose(InvalidMessage):
    """An initial pose or covariance that cannot seed the filter (NaN, wrong shape, not
    positive semi-definite)."""


@dataclass(frozen=True, eq=False)
class Cluster:
    """One hypothesis: total ``weight``, ``mean`` (x, y, yaw) and ``covariance`` (3x3)."""

    weight: float
    mean: FloatArray
    covariance: FloatArray
    count: int


def kld_limit(k: ArrayLike, pf_err: float, pf_z: float, min_particles: int,
              max_particles: int) -> NDArray[np.int64]:
    """Particles needed for ``k`` occupied bins (amcl ``pf_resample_limit``, vectorised).

    ``k <= 1`` gives ``max_particles`` (one bin says nothing about the spread)."""
    kk = np.asarray(k, np.float64)
    km1 = np.maximum(kk - 1.0, 1.0)
    b = 2.0 / (9.0 * km1)
    x = 1.0 - b + np.sqrt(b) * pf_z
    n = np.ceil(km1 / (2.0 * pf_err) * x * x * x)
    n = np.clip(n, min_particles, max_particles)
    return np.where(kk <= 1.0, max_particles, n).astype(np.int64)


def low_variance_indices(weights: FloatArray, count: int,
                         rng: np.random.Generator) -> NDArray[np.int64]:
    """``count`` indices drawn by systematic resampling of normalised ``weights``."""
    cdf = np.cumsum(weights)
    cdf[-1] = 1.0
    positions = (rng.random() + np.arange(count)) / count
    return np.minimum(np.searchsorted(cdf, positions, side="right"), len(weights) - 1)


def bin_indices(poses: FloatArray) -> tuple[NDArray[np.int64], NDArray[np.int64],
                                            NDArray[np.int64]]:
    """Histogram bin ``(ix, iy, iyaw)`` of each pose; ``iyaw`` in ``0..YAW_BINS-1``."""
    ix = np.floor(poses[:, 0] / XY_BIN).astype(np.int64)
    iy = np.floor(poses[:, 1] / XY_BIN).astype(np.int64)
    it = np.floor((poses[:, 2] + math.pi) * (YAW_BINS / (2.0 * math.pi))).astype(np.int64)
    return ix, iy, it % YAW_BINS


def bin_keys(poses: FloatArray) -> tuple[NDArray[np.int64], int]:
    """One integer per occupied bin (row-major over the set's bounding box) and the
    number of y bins of that box."""
    ix, iy, it = bin_indices(poses)
    if len(ix) == 0:
        return ix, 1
    ix -= ix.min()
    iy -= iy.min()
    ny = int(iy.max()) + 1
    return (ix * ny + iy) * YAW_BINS + it, ny


@numba.njit(cache=True)
def _find(parent: NDArray[np.int64], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True)
def label_bins(keys: NDArray[np.int64], ny: int, n_yaw: int) -> NDArray[np.int64]:
    """Connected components of sorted unique bin ``keys`` (26-neighbourhood, yaw wraps);
    labels ``0..C-1`` in order of first appearance (amcl ``pf_kdtree_cluster``)."""
    k = keys.shape[0]
    parent = np.arange(k)
    for u in range(k):
        key = keys[u]
        it = key % n_yaw
        iy = (key // n_yaw) % ny
        ix = key // (n_yaw * ny)
        for dx in range(-1, 2):
            for dy in range(-1, 2):
                if iy + dy < 0 or iy + dy >= ny or ix + dx < 0:
                    continue
                for dt in range(-1, 2):
                    if dx == 0 and dy == 0 and dt == 0:
                        continue
                    nt = (it + dt) % n_yaw
                    nkey = ((ix + dx) * ny + iy + dy) * n_yaw + nt
                    v = np.searchsorted(keys, nkey)
                    if v < k and keys[v] == nkey:
                        ru, rv = _find(parent, u), _find(parent, v)
                        if ru != rv:
                            parent[max(ru, rv)] = min(ru, rv)
    labels = np.empty(k, np.int64)
    remap = np.full(k, -1, np.int64)
    count = 0
    for u in range(k):
        r = _find(parent, u)
        if remap[r] < 0:
            remap[r] = count
            count += 1
        labels[u] = remap[r]
    return labels


@numba.njit(cache=True)
def weighted_stats(poses: FloatArray, weights: FloatArray, labels: NDArray[np.int64],
                   count: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per label: total weight ``(C,)``, mean ``(C, 3)`` (circular mean of yaw) and
    covariance ``(C, 3, 3)`` with yaw deviations wrapped about that mean."""
    total = np.zeros(count)
    acc = np.zeros((count, 4))  # sum w x, w y, w sin, w cos
    n = poses.shape[0]
    for i in range(n):
        g, w = labels[i], weights[i]
        total[g] += w
        acc[g, 0] += w * poses[i, 0]
        acc[g, 1] += w * poses[i, 1]
        acc[g, 2] += w * math.sin(poses[i, 2])
        acc[g, 3] += w * math.cos(poses[i, 2])
    mean = np.zeros((count, 3))
    for g in range(count):
        t = total[g] if total[g] > 0.0 else 1.0
        mean[g, 0] = acc[g, 0] / t
        mean[g, 1] = acc[g, 1] / t
        mean[g, 2] = math.atan2(acc[g, 2], acc[g, 3])
    cov = np.zeros((count, 3, 3))
    dev = np.empty(3)
    for i in range(n):
        g, w = labels[i], weights[i]
        dev[0] = poses[i, 0] - mean[g, 0]
        dev[1] = poses[i, 1] - mean[g, 1]
        d = (poses[i, 2] - mean[g, 2]) % (2.0 * math.pi)
        dev[2] = d - 2.0 * math.pi if d > math.pi else d
        for a in range(3):
            for b in range(a, 3):
                cov[g, a, b] += w * dev[a] * dev[b]
    for g in range(count):
        t = total[g] if total[g] > 0.0 else 1.0
        for a in range(3):
            for b in range(a, 3):
                cov[g, a, b] /= t
                cov[g, b, a] = cov[g, a, b]
    return total, mean, cov


class ParticleFilter:
    """Weighted particle set ``poses (N, 3)`` / ``weights (N,)`` with amcl's adaptive
    resampling.  Pure: randomness only from ``rng``; free space (for global
    initialisation and recovery) from :meth:`set_free_space`.
    ``reset_averages_on_injection=True`` reproduces amcl's reset of ``w_slow``/``w_fast``
    after an injection (see the module notes for why it is off by default)."""

    def __init__(self, min_particles: int, max_particles: int, pf_err: float, pf_z: float,
                 alpha_slow: float, alpha_fast: float, rng: np.random.Generator,
                 reset_averages_on_injection: bool = False) -> None:
        self.min_particles, self.max_particles = min_particles, max_particles
        self.pf_err, self.pf_z = pf_err, pf_z
        self.alpha_slow, self.alpha_fast = alpha_slow, alpha_fast
        self.rng = rng
        self.reset_averages_on_injection = reset_averages_on_injection
        self.poses = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self.w_slow = 0.0
        self.w_fast = 0.0
        self.converged = False
        self.injected = 0
        self.injected_total = 0
        self._free: FloatArray = np.zeros((0, 2))
        self._cell = 0.0
        self._clusters: list[Cluster] | None = None
        self._set_stats: tuple[FloatArray, FloatArray] | None = None

    def __len__(self) -> int:
        return len(self.poses)

    @property
    def initialized(self) -> bool:
        return len(self.poses) > 0

    # --- initialisation ------------------------------------------------------------------
    def set_free_space(self, cell_centres: FloatArray, cell_size: float) -> None:
        """Free cells ``(M, 2)`` (centres, map frame) of size ``cell_size`` [m]."""
        self._free = np.asarray(cell_centres, np.float64).reshape(-1, 2)
        self._cell = float(cell_size)

    def uniform_poses(self, count: int) -> FloatArray:
        """``count`` poses uniform over the free cells (anywhere inside a drawn cell) with
        uniform yaw (amcl's ``uniformPoseGenerator``)."""
        if len(self._free) == 0:
            raise InvalidInitialPose("no free cells to sample from: the map has no free "
                                     "space (cells of value 0..19), or no map was received")
        cells = self._free[self.rng.integers(0, len(self._free), count)]
        jitter = (self.rng.random((count, 2)) - 0.5) * self._cell
        yaw = normalize_angle(self.rng.uniform(-math.pi, math.pi, count))
        return np.column_stack((cells + jitter, yaw))

    def init_uniform(self) -> None:
        """``max_particles`` particles spread over free space (global localization)."""
        self._reset(self.uniform_poses(self.max_particles))

    def init_gaussian(self, mean: ArrayLike, covariance: ArrayLike) -> None:
        """``max_particles`` particles from ``N(mean, covariance)`` (amcl ``pf_init``);
        ``covariance`` 3x3 over (x, y, yaw).  Raises :class:`InvalidInitialPose`."""
        m = np.asarray(mean, np.float64)
        c = np.asarray(covariance, np.float64)
        if m.shape != (3,) or not np.isfinite(m).all():
            raise InvalidInitialPose(f"initial pose must be 3 finite numbers (x, y, yaw), "
                                     f"got {m.tolist()}")
        if c.shape != (3, 3):
            raise InvalidInitialPose(f"initial covariance must be a 3x3 matrix over "
                                     f"(x, y, yaw), got shape {c.shape}")
        if not np.isfinite(c).all():
            raise InvalidInitialPose("initial covariance has NaN or infinite entries")
        if not np.allclose(c, c.T, atol=1e-9) or np.linalg.eigvalsh(c).min() < -1e-9:
            raise InvalidInitialPose("initial covariance must be symmetric positive "
                                     "semi-definite")
        vals, vecs = np.linalg.eigh(c)
        noise = self.rng.standard_normal((self.max_particles, 3)) * np.sqrt(np.clip(vals, 0,
                                                                                   None))
        poses = m + noise @ vecs.T
        poses[:, 2] = normalize_angle(poses[:, 2])
        self._reset(poses)

    def _reset(self, poses: FloatArray) -> None:
        self.poses = poses
        self.weights = np.full(len(poses), 1.0 / len(poses))
        self.w_slow = self.w_fast = 0.0
        self._update_converged()
        self._invalidate()

    # --- updates -------------------------------------------------------------------------
    def set_poses(self, poses: FloatArray) -> None:
        """Replace the poses (after a motion update), keeping the weights."""
        self.poses = poses
        self._invalidate()

    def update_weights(self, log_likelihood: FloatArray, factors: int = 1,
                       temper: float = 1.0) -> float:
        """Multiply the weights by the measurement likelihoods (given as logs), normalise,
        and feed the recovery averages; returns the average ``sum w_i p_i^(1/factors)``.

        ``factors``: how many independent per-beam factors the likelihood is a product of
        (``likelihood_field_prob``); the recovery averages then follow the per-beam
        geometric mean.  A product of 100 beams swings by orders of magnitude from one
        ordinary scan to the next, so ``w_fast`` falls below ``w_slow`` all the time and
        random particles are injected into a well-localized filter; per beam the scale is
        stable and only a real mismatch (a kidnap) drops it.  The cube-sum models are one
        bounded score per scan (``factors`` 1, amcl's averages).  ``temper`` scales the
        log-likelihood of the weights only (annealing), never the recovery averages.
        """
        logw = np.log(np.maximum(self.weights, 1e-300))
        log_post = logw + log_likelihood * temper
        top = float(log_post.max())
        if not math.isfinite(top):  # every particle impossible: start over evenly
            self.weights = np.full(len(self.poses), 1.0 / len(self.poses))
            self._invalidate()
            return 0.0
        w = np.exp(log_post - top)
        self.weights = w / float(w.sum())
        log_avg = logw + log_likelihood / max(factors, 1)
        peak = float(log_avg.max())
        w_avg = float(np.exp(log_avg - peak).sum()) * math.exp(peak) if peak < 700.0 \
            else math.inf
        if 0.0 < w_avg < math.inf:
            self.w_slow = w_avg if self.w_slow == 0.0 else \
                self.w_slow + self.alpha_slow * (w_avg - self.w_slow)
            self.w_fast = w_avg if self.w_fast == 0.0 else \
                self.w_fast + self.alpha_fast * (w_avg - self.w_fast)
        self._invalidate()
        return w_avg

    def recovery_fraction(self) -> float:
        """``max(0, 1 - w_fast / w_slow)``: the share of random particles to inject."""
        if self.w_slow <= 0.0:
            return 0.0
        return max(0.0, 1.0 - self.w_fast / self.w_slow)

    def resample(self) -> int:
        """KLD-sampling low-variance resampling with recovery; returns the new size."""
        count = self.max_particles
        cand = self.poses[low_variance_indices(self.weights, count, self.rng)]
        w_diff = self.recovery_fraction() if len(self._free) else 0.0
        self.injected = 0
        if w_diff > 0.0:
            inject = self.rng.random(count) < w_diff
            self.injected = int(inject.sum())
            self.injected_total += self.injected
            cand[inject] = self.uniform_poses(self.injected)
            if self.reset_averages_on_injection:
                self.w_slow = self.w_fast = 0.0  # amcl pf_update_resample
        cand = cand[self.rng.permutation(count)]
        keys, _ = bin_keys(cand)
        _, first = np.unique(keys, return_index=True)
        first.sort()
        n = np.arange(1, count + 1)
        occupied = np.searchsorted(first, n, side="left")
        stop = np.flatnonzero(n > kld_limit(occupied, self.pf_err, self.pf_z,
                                            self.min_particles, self.max_particles))
        size = int(stop[0]) + 1 if len(stop) else count
        self.poses = np.ascontiguousarray(cand[:size])
        self.weights = np.full(size, 1.0 / size)
        self._update_converged()
        self._invalidate()
        return size

    def _update_converged(self) -> None:
        """amcl ``pf_update_converged``: all particles within 0.5 m of the mean in x, y."""
        xy = self.poses[:, :2]
        self.converged = bool(len(xy)) and bool(
            np.all(np.abs(xy - xy.mean(axis=0)) <= CONVERGENCE_DISTANCE))

    def _invalidate(self) -> None:
        self._clusters = None
        self._set_stats = None

    # --- estimates -----------------------------------------------------------------------
    def clusters(self) -> list[Cluster]:
        """Hypotheses, heaviest first (amcl ``pf_cluster_stats``)."""
        if self._clusters is None:
            if not self.initialized:
                return []
            keys, ny = bin_keys(self.poses)
            unique, inverse = np.unique(keys, return_inverse=True)
            bin_label = label_bins(unique, ny, YAW_BINS)
            labels = bin_label[inverse]
            count = int(bin_label.max()) + 1
            total, mean, cov = weighted_stats(self.poses, self.weights, labels, count)
            sizes = np.bincount(labels, minlength=count)
            order = np.argsort(-total, kind="stable")
            self._clusters = [Cluster(float(total[i]), mean[i], cov[i], int(sizes[i]))
                              for i in order]
        return self._clusters

    def set_statistics(self) -> tuple[FloatArray, FloatArray]:
        """Weighted mean ``(3,)`` and covariance ``(3, 3)`` of the whole set."""
        if self._set_stats is None:
            labels = np.zeros(len(self.poses), np.int64)
            _, mean, cov = weighted_stats(self.poses, self.weights, labels, 1)
            self._set_stats = (mean[0], cov[0])
        return self._set_stats

    def estimate(self) -> tuple[FloatArray, FloatArray]:
        """``(mean (3,), covariance (3, 3))`` of the heaviest cluster.

        amcl publishes the heaviest cluster's mean with the covariance of the whole set.
        The estimate is that cluster's mean, so its uncertainty is that cluster's
        spread: the set covariance also counts the other hypotheses and every randomly
        injected particle (recovery), which made it metres wide while the estimate was
        centimetres off (docs/localization.md).  With one cluster the two are equal.
        """
        clusters = self.clusters()
        if not clusters:
            return np.full(3, np.nan), np.full((3, 3), np.nan)
        return clusters[0].mean.copy(), clusters[0].covariance.copy()


class AmclFilter:
    """Nav2 AMCL's filter without the bus: map, motion model, laser model, particle set.

    One :meth:`update` is amcl's ``laserReceived`` work once the node has decided to
    update: odometry motion for every particle, laser weighting, and every
    ``resample_interval``-th time KLD resampling (``pf_update_resample``).  Usable from a
    notebook: ``f = AmclFilter(params, rng); f.set_map(grid); f.initialize_pose(...)``.
    """

    def __init__(self, params: AmclParams, rng: np.random.Generator) -> None:
        p = params
        self.params = p
        self.rng = rng
        self.pf = ParticleFilter(p.min_particles, p.max_particles, p.pf_err, p.pf_z,
                                 p.recovery_alpha_slow, p.recovery_alpha_fast, rng)
        self.motion = make_motion_model(p)
        self.map: AmclMap | None = None
        self.laser: LaserModel | None = None
        self.resample_count = 0
        self.anneal_left = 0
        self.last_update_ms = 0.0

    def set_map(self, grid: OccupancyGrid) -> None:
        """Use ``grid`` (raises :class:`AmclMapError`); particles are kept (Nav2)."""
        amcl_map = AmclMap.from_occupancy_grid(grid, self.params.laser_likelihood_max_dist,
                                               self.params.freespace_downsampling)
        self.map = amcl_map
        self.laser = LaserModel(self.params, amcl_map)
        self.pf.set_free_space(amcl_map.free_cells, amcl_map.resolution *
                               (2.0 if self.params.freespace_downsampling else 1.0))

    def initialize_pose(self, mean: ArrayLike, covariance: ArrayLike) -> None:
        """Particles around a known pose (``covariance`` 3x3 over x, y, yaw)."""
        self.pf.init_gaussian(mean, covariance)
        self.resample_count = 0
        self.anneal_left = 0

    def initialize_global(self) -> None:
        """Particles uniform over the map's free space (needs a map); the next
        ``global_localization_anneal_updates`` updates are tempered."""
        self.pf.init_uniform()
        self.resample_count = 0
        self.anneal_left = self.params.global_localization_anneal_updates

    def update(self, odom_pose: ArrayLike, delta: ArrayLike | None,
               scan: LaserData) -> bool:
        """Motion (unless ``delta`` is None: the first update after initialisation),
        measurement and, every ``resample_interval`` updates, resampling.  Returns whether
        it resampled; ``last_update_ms`` is the wall time it took."""
        if self.laser is None:
            raise AmclMapError("no map yet: AMCL needs an occupancy grid before updating")
        t0 = time.perf_counter()
        pf = self.pf
        if delta is not None:
            pf.set_poses(self.motion.sample(pf.poses, np.asarray(odom_pose, np.float64),
                                            np.asarray(delta, np.float64), self.rng))
        log_likelihood = self.laser.log_likelihood(pf.poses, scan, pf.converged)
        temper = 1.0
        if self.anneal_left > 0:  # tempered updates after a global initialisation
            n = self.params.global_localization_anneal_updates
            temper = (n + 1 - self.anneal_left) / (n + 1)
            self.anneal_left -= 1
        pf.update_weights(log_likelihood, self.laser.factors, temper)
        self.resample_count += 1
        resampled = self.resample_count % self.params.resample_interval == 0
        if resampled:
            pf.resample()
        pf.clusters()
        self.last_update_ms = (time.perf_counter() - t0) * 1e3
        return resampled
