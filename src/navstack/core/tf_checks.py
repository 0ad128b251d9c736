"""TF consistency checks (the textbook frame contract): chain resolvable, no jumps.

``check_chain`` verifies that each frame is the direct parent of the next (REP-105
``map -> odom -> base_link -> sensors``) and that the chain resolves at a time;
``find_jumps`` lists consecutive samples of one edge that move more than allowed, except
at declared resets (relocalisation, kidnapping).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise

import numpy as np

from navstack.core.errors import (
    ConnectivityError,
    ExtrapolationError,
    InvalidMessage,
    UnknownFrameError,
)
from navstack.core.msgs import TransformStamped
from navstack.core.tf import TIME_TOLERANCE, TransformTree, tf_from_msg


def check_chain(tree: TransformTree, frames: Sequence[str], t: float | None) -> list[str]:
    """Problems with the parent chain ``frames[0] -> frames[1] -> ...`` at time ``t``.

    Each frame must exist and be the direct parent of the next (REP-105:
    ``map -> odom -> base_link -> sensor``), each edge must resolve at ``t`` and, for
    ``t=None``, the whole chain at its latest common time.  Empty list when all is well.
    """
    problems: list[str] = []
    for frame in frames:
        try:
            tree.parent_of(frame)
        except UnknownFrameError as exc:
            problems.append(str(exc))
    if problems:
        return problems
    for parent, child in pairwise(frames):
        actual = tree.parent_of(child)
        if actual != parent:
            has = f"its parent is '{actual}'" if actual else "it is a root"
            problems.append(f"'{parent}' is not the parent of '{child}' ({has}); expected "
                            f"chain {' -> '.join(frames)}")
            continue
        try:
            tree.lookup(parent, child, t)
        except (ConnectivityError, ExtrapolationError) as exc:
            problems.append(str(exc))
    if not problems and len(frames) > 2:
        try:
            tree.lookup(frames[0], frames[-1], t)
        except (ConnectivityError, ExtrapolationError) as exc:
            problems.append(str(exc))
    return problems


def find_jumps(samples: Sequence[TransformStamped], max_linear: float, max_angular: float,
               declared_resets: Sequence[float] = ()) -> list[tuple[float, float, float]]:
    """Consecutive samples of one edge that moved more than the bounds allow.

    Returns ``(stamp, linear [m], angular [rad])`` of the later sample of each step whose
    translation change exceeds ``max_linear`` or whose rotation angle exceeds
    ``max_angular``, except steps ``(t_prev, t_next]`` that contain a declared reset
    time (a relocalisation, an odometry reset).  Samples are sorted by stamp first.
    """
    if len(samples) < 2:
        return []
    edges = {(s.header.frame_id, s.child_frame_id) for s in samples}
    if len(edges) > 1:
        names = ", ".join(sorted(f"{p}->{c}" for p, c in edges))
        raise InvalidMessage(f"find_jumps needs samples of one edge; got {names}")
    stamps = np.array([s.header.stamp for s in samples], dtype=np.float64)
    values = np.array([tf_from_msg(s.transform) for s in samples], dtype=np.float64)
    order = np.argsort(stamps, kind="stable")
    stamps, values = stamps[order], values[order]
    trans = values[:, :3]
    quat = values[:, 3:] / np.linalg.norm(values[:, 3:], axis=1, keepdims=True)
    linear = np.linalg.norm(np.diff(trans, axis=0), axis=1)
    v0, w0, v1, w1 = quat[:-1, :3], quat[:-1, 3], quat[1:, :3], quat[1:, 3]
    rel_w = w0 * w1 + np.sum(v0 * v1, axis=1)  # conj(q0) * q1
    rel_v = w0[:, None] * v1 - w1[:, None] * v0 - np.cross(v0, v1)
    angular = 2.0 * np.arctan2(np.linalg.norm(rel_v, axis=1), np.abs(rel_w))
    bad = (linear > max_linear) | (angular > max_angular)
    resets = np.sort(np.asarray(declared_resets, dtype=np.float64))
    if resets.size:
        n_upto_next = np.searchsorted(resets, stamps[1:] + TIME_TOLERANCE, side="right")
        n_upto_prev = np.searchsorted(resets, stamps[:-1], side="right")
        bad &= n_upto_next == n_upto_prev
    idx = np.flatnonzero(bad)
    return [(float(stamps[i + 1]), float(linear[i]), float(angular[i])) for i in idx]
