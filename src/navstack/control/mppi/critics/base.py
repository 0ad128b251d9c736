"""Critic plumbing: the batch every critic scores and the critic base class.

Nav2's ``CriticManager`` calls each critic's ``score(CriticData&)`` in the order of the
``critics`` list; a critic adds its term to ``data.costs`` (one cost per sampled
trajectory) and a collision critic may set ``data.fail_flag`` when every trajectory
collides, which stops the remaining critics and makes the optimizer fall back.  The
same contract here: :class:`CriticData` holds the batch (arrays laid out ``(channel,
time, sample)``), :meth:`Critic.score` adds to ``data.costs`` through a ``numba`` kernel
that loops over time outside and samples inside.

State velocities: the velocity of step 0 is the robot's (``data.state[3:]``), the
velocity of step ``t >= 1`` is the clamped control ``t - 1`` (``data.controls[:, t-1]``),
exactly Nav2's ``state.vx`` / ``state.cvx`` relation.

A critic is one class in one file: its parameter model (``params_model``, a
:class:`CriticParams` subclass with Nav2's keys and code defaults, Nav2 Jazzy
``nav2_mppi_controller/src/critics/*.cpp``) next to it, and one decorator,
:func:`register_critic`, which registers it in :data:`CRITICS` under its name (what
``critics`` lists and the key of its YAML section) and ``mppi::critics::<name>``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.control.mppi.models import MotionModel
from navstack.core.params import Params
from navstack.core.polygon import Footprint
from navstack.core.registry import ClassRegistry
from navstack.costmap.costmap_2d import Costmap2D

if TYPE_CHECKING:
    from navstack.control.mppi.params import MPPIParams

FloatArray = NDArray[np.float64]
Float32Array = NDArray[np.float32]


@dataclass(frozen=True)
class RobotShape:
    """Footprint outline ``(N, 2)`` [m] and its inscribed/circumscribed radii [m]."""

    polygon: FloatArray
    inscribed_radius: float
    circumscribed_radius: float

    @staticmethod
    def from_footprint(footprint: Footprint | None) -> RobotShape:
        """A point robot (radii 0) when no footprint is given."""
        if footprint is None:
            return RobotShape(np.zeros((1, 2)), 0.0, 0.0)
        return RobotShape(np.ascontiguousarray(footprint.polygon, dtype=np.float64),
                          float(footprint.inscribed_radius),
                          float(footprint.circumscribed_radius))


@dataclass
class CriticData:
    """One iteration's batch (Nav2 ``CriticData``).

    ``state`` (6,) robot x, y, yaw, vx, vy, wz; ``controls`` and ``trajectories``
    (3, T, B) float32; ``arc`` (B,) travelled lengths; ``costs`` (B,) accumulated
    scores; ``path`` (M, 3) pruned plan and ``path_valid`` (M,) its collision-free
    points; ``goal`` (3,) the plan's last pose and ``goal_distance`` the robot's distance
    to it.  ``fail`` / ``failed_by`` report an all-colliding batch.
    """

    state: FloatArray
    controls: Float32Array
    trajectories: Float32Array
    arc: FloatArray
    costs: FloatArray
    model_dt: float
    model: MotionModel
    path: FloatArray
    path_valid: NDArray[np.bool_]
    goal: FloatArray
    goal_distance: float
    costmap: Costmap2D
    track_unknown: bool
    fail: bool = False
    failed_by: str = ""
    furthest_reached_path_point: int | None = None


class CriticParams(Params):
    """Keys every critic has (``CriticFunction``): ``enabled``."""

    enabled: bool = True


class WeightedCriticParams(CriticParams):
    """A critic whose term is ``(cost_weight * raw) ** cost_power``."""

    cost_power: int = Field(1, ge=1)
    cost_weight: float = Field(1.0, ge=0.0)


class Critic(ABC):
    """A scoring term: ``score(data)`` adds ``(weight * raw) ** power`` per sample.

    ``params`` is the critic's validated section, ``controller`` the controller's whole
    :class:`~navstack.control.mppi.params.MPPIParams` (limits, goal tolerance).
    """

    #: the critic's name, as written in ``critics`` (set by :func:`register_critic`)
    name: ClassVar[str] = ""
    #: the model of the critic's YAML section
    params_model: ClassVar[type[CriticParams]] = CriticParams

    def __init__(self, params: CriticParams, controller: MPPIParams, model: MotionModel,
                 shape: RobotShape) -> None:
        self.params = params
        self.controller_params = controller
        self.model = model
        self.shape = shape

    @property
    def enabled(self) -> bool:
        return self.params.enabled

    @abstractmethod
    def score(self, data: CriticData) -> None:
        """Add this critic's term to ``data.costs`` (may set ``data.fail``)."""


class CriticRegistry(ClassRegistry[Critic]):
    """The MPPI critic registry: registering a class also sets its ``name``."""

    def register(self, name: str, entry: type[Critic], aliases: Iterable[str] = ()
                 ) -> type[Critic]:
        registered = super().register(name, entry, aliases)
        if "name" not in vars(entry):  # a subclass of a registered critic gets its own name
            entry.name = name
        return registered


CRITICS = CriticRegistry("mppi critic", Critic)
"""MPPI critics by name (``GoalCritic``), ``mppi::critics::GoalCritic`` accepted too."""


def register_critic(name: str, namespace: str = "mppi::critics", aliases: Iterable[str] = ()
                    ) -> Callable[[type[Critic]], type[Critic]]:
    """Class decorator: register an MPPI critic as ``name`` and ``<namespace>::<name>``
    (Nav2's ``mppi::critics::GoalCritic``; a critic of your own package gives its
    ``namespace``).  ``critics`` may list either; the section is ``<name>:`` and the
    class's ``params_model`` validates it."""
    return CRITICS.plugin(name, nav2=f"{namespace}::{name}", aliases=aliases)
