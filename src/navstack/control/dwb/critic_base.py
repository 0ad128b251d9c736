"""The DWB critic interface (``dwb_core::TrajectoryCritic``), vectorised over samples.

A critic scores a whole :class:`TrajectoryBatch` at once and returns one score per
sample.  A negative score rejects the sample, as DWB's ``IllegalTrajectoryException``:
``-k`` means "rejected for ``reasons[k - 1]``".  The planner sums ``score * get_scale()``
over the critics (lower is better), skips critics whose scale is 0, and stops scoring a
sample at its first rejection.

Lifecycle per control cycle, as in DWB: ``prepare(ctx)`` once, ``score(batch, ctx)``,
then ``debrief(cmd, ctx)`` with the command finally sent (zero when none was found).
``reset()`` runs on a new plan and on :meth:`DWBLocalPlanner.reset`.

A critic is one class with ``params_model`` (its section's model, ``scale`` included) and
one decorator, :func:`register_critic`; the controller's ``critics`` list names it and
its parameters sit under that name (``FollowPath.<name>.scale``), as in Nav2.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from navstack.control.dwb.grid import world_to_cells
from navstack.control.dwb.params import DWBParams
from navstack.control.dwb.trajectory_generator import TrajectoryBatch
from navstack.core.msgs import Pose2D, Twist2D
from navstack.core.params import Params
from navstack.core.polygon import Footprint
from navstack.core.registry import ClassRegistry
from navstack.costmap.costmap_2d import Costmap2D

FloatArray = NDArray[np.float64]


@dataclass
class CriticContext:
    """What every critic sees in one cycle (all in the costmap frame).

    ``plan`` is the pruned, transformed plan ``(M, 3)``; ``goal`` the last pose of the
    whole plan; ``batch`` all trajectories of the cycle (generated before the critics
    prepare, so grid critics can bound their work to the cells they will score);
    ``cache`` is free for critics to share derived data within the cycle.
    """

    pose: Pose2D
    velocity: Twist2D
    goal: Pose2D
    plan: FloatArray
    costmap: Costmap2D
    now: float
    batch: TrajectoryBatch | None = None
    cache: dict[Any, Any] = field(default_factory=dict)


class CriticParams(Params):
    """Parameters every critic has: ``scale`` (weight of its score in the total)."""

    scale: float = 1.0


def reject_scores(scores: FloatArray, codes: NDArray[np.integer[Any]]) -> FloatArray:
    """Replace ``scores`` by ``-code`` wherever ``code > 0`` (1-based reason codes)."""
    return np.where(codes > 0, -codes.astype(np.float64), scores)


def first_failure(codes: NDArray[np.integer[Any]]) -> NDArray[np.int64]:
    """Per row of ``(N, T)`` per-pose codes, the code of the first nonzero pose (or 0).

    DWB critics throw at the first bad pose along the trajectory, so that pose's reason
    is the one reported.
    """
    bad = codes > 0
    first = np.argmax(bad, axis=1)
    return np.where(bad.any(axis=1), codes[np.arange(len(codes)), first], 0).astype(np.int64)


P = TypeVar("P", bound=CriticParams)


class TrajectoryCritic(ABC, Generic[P]):
    """Base class of DWB critics; subclasses set ``params_model`` and ``reasons``."""

    params_model: ClassVar[type[CriticParams]] = CriticParams
    reasons: ClassVar[tuple[str, ...]] = ()
    default_scale: ClassVar[float] = 1.0

    def __init__(self, name: str, params: P, dwb: DWBParams,
                 footprint: Footprint | None = None) -> None:
        self.name = name
        self.params: P = params
        self.dwb = dwb
        self.footprint = footprint

    @classmethod
    def make_params(cls, section: dict[str, Any], *, key_path: str = "") -> CriticParams:
        """Validate this critic's parameter section (``scale`` defaults per critic)."""
        data = {"scale": cls.default_scale, **section}
        return cls.params_model.from_mapping(data, key_path=key_path)

    def get_scale(self) -> float:
        """Weight of this critic this cycle (``TrajectoryCritic::getScale``)."""
        return self.params.scale

    def reset(self) -> None:
        """Forget state carried between cycles (new plan / controller reset)."""

    def prepare(self, ctx: CriticContext) -> bool:
        """Precompute what scoring needs; False means it could not (scoring still runs)."""
        return True

    @abstractmethod
    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        """Score of each sample, ``(N,)``; negative rejects (see module docstring)."""

    def debrief(self, cmd: Twist2D, ctx: CriticContext) -> None:
        """Learn the command actually chosen (stateful critics)."""


CRITICS: ClassRegistry[TrajectoryCritic[Any]] = ClassRegistry("dwb critic", TrajectoryCritic)
"""Critic classes by Nav2 name (``PathAlign``), with ``PathAlignCritic`` and
``dwb_critics::PathAlignCritic`` accepted as aliases."""


def register_critic(name: str, namespace: str = "dwb_critics", extra_aliases: Iterable[str] = ()
                    ) -> Callable[[type[TrajectoryCritic[Any]]], type[TrajectoryCritic[Any]]]:
    """Class decorator: register a critic as ``name`` (what ``critics`` lists), with the
    aliases DWB resolves: ``<name>Critic`` and the plugin type
    ``<namespace>::<name>Critic`` (both spellings).  A critic of your own package gives
    its ``namespace`` and is listed by name, by ``<name>.class: "<namespace>::<name>Critic"``
    or through ``default_critic_namespaces``."""
    return CRITICS.plugin(name, nav2=f"{namespace}::{name}Critic",
                          aliases=(f"{name}Critic", *extra_aliases))


def resolve_critic(class_name: str, namespaces: Iterable[str]) -> type[TrajectoryCritic[Any]]:
    """``DWBLocalPlanner::resolveCriticClassName`` + lookup in :data:`CRITICS`.

    ``"PathAlign"``, ``"PathAlignCritic"`` and ``"<ns>::PathAlignCritic"`` for any
    configured ``default_critic_namespaces`` entry all resolve to the same class.
    """
    if class_name in CRITICS:
        return CRITICS.get(class_name)
    base = class_name if class_name.endswith("Critic") else class_name + "Critic"
    if "::" not in base:
        for ns in namespaces:
            if f"{ns}::{base}" in CRITICS:
                return CRITICS.get(f"{ns}::{base}")
    return CRITICS.get(base if "::" in base or base in CRITICS else class_name)


def batch_cells(batch: TrajectoryBatch, costmap: Costmap2D) -> tuple[NDArray[np.int64],
                                                                     NDArray[np.int64],
                                                                     NDArray[np.bool_]]:
    """Cells ``(mx, my, inside)`` of every trajectory pose, ``(N, T)`` each, cached per batch."""
    cached = batch.cache.get("cells")
    if cached is None:
        cached = world_to_cells(costmap, batch.poses[:, :, 0], batch.poses[:, :, 1])
        batch.cache["cells"] = cached
    mx, my, inside = cached
    return mx, my, inside
