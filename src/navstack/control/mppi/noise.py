"""Gaussian control noise for MPPI (Nav2 ``mppi::NoiseGenerator``).

Noise is float32 ``N(0, std^2)`` per control channel (``vx_std``, ``vy_std``, ``wz_std``),
shape ``(3, time_steps, batch_size)``; the ``vy`` channel stays zero for non-holonomic
models.  As in Nav2:

* with ``regenerate_noises: false`` (default) one draw is made at construction and on
  every reset (fallback, new goal) and reused each cycle; the samples still differ
  from cycle to cycle because they perturb a different control sequence;
* with ``regenerate_noises: true`` a fresh draw is used for every iteration.  Nav2 draws
  the next noise on a background thread while the critics run; here a worker thread
  fills a spare buffer right after the current one is handed out (numpy's generator
  releases the GIL while filling), and :meth:`NoiseGenerator.current` swaps it in.

The generator is a seeded ``numpy.random.Generator`` (PCG64): the same ``seed`` gives
the same noise, so whole runs are reproducible.
"""

from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

Float32Array = NDArray[np.float32]


class NoiseGenerator:
    """Double-buffered Gaussian noise ``(3, T, B)`` with per-channel std."""

    def __init__(self, batch_size: int, time_steps: int, std: tuple[float, float, float],
                 holonomic: bool, regenerate: bool, seed: int = 0) -> None:
        self.std = tuple(float(s) for s in std)
        self.holonomic = holonomic
        self.regenerate = regenerate
        self._rng = np.random.default_rng(seed)
        self._current = np.zeros((3, time_steps, batch_size), dtype=np.float32)
        self._spare = np.zeros_like(self._current)
        self._worker: threading.Thread | None = None
        self.reset()

    def _fill(self, buf: Float32Array) -> None:
        for ch, std in enumerate(self.std):
            if std > 0.0 and (ch != 1 or self.holonomic):
                self._rng.standard_normal(out=buf[ch], dtype=np.float32)
                buf[ch] *= np.float32(std)
            else:
                buf[ch].fill(0.0)

    def _join(self) -> None:
        if self._worker is not None:
            self._worker.join()
            self._worker = None
            self._current, self._spare = self._spare, self._current

    def reset(self) -> None:
        """Draw new noise now (Nav2 regenerates on reset, initialisation and fallback)."""
        if self._worker is not None:
            self._worker.join()
            self._worker = None
        self._fill(self._current)
        self._prefetch()

    def _prefetch(self) -> None:
        if self.regenerate:
            self._worker = threading.Thread(target=self._fill, args=(self._spare,),
                                            name="mppi-noise", daemon=True)
            self._worker.start()

    def current(self) -> Float32Array:
        """The noise for this iteration (read-only use)."""
        return self._current

    def advance(self) -> None:
        """Done with the current noise: with ``regenerate`` swap in the next draw and
        start drawing the one after; otherwise keep reusing the same noise."""
        if self.regenerate:
            self._join()
            self._prefetch()
