"""Shortest Dubins and Reeds-Shepp curves between SE(2) poses, in numba.

Both are needed inside the Hybrid-A* search (distance-heuristic table, analytic
expansions, smoother boundary checks), so they are written as ``numba.njit`` kernels
rather than taken from PyPI: the packages that exist (``dubins`` 1.0.1 from 2018,
``reeds-shepp`` 1.0.7 from 2020, both Cython; ``rsplan`` pure Python) are unmaintained or
cannot be called from numba code, and a per-call Python round trip would cost more than
the whole search step (see ``docs/hybrid_astar.md``).

* Dubins (forward only): the six words LSL, RSR, LSR, RSL, RLR, LRL in the closed forms
  of Shkel & Lumelsky, "Classification of the Dubins set", Robotics and Autonomous
  Systems 34 (2001) — the same set OMPL's ``DubinsStateSpace`` searches.
* Reeds-Shepp (forward and reverse): the 48 words of Reeds & Shepp, "Optimal paths for a
  car that goes both forwards and backwards", Pacific J. Math. 145 (1990), formulas
  8.1-8.11 with the time-flip / reflection / backwards symmetries, as organised in OMPL's
  ``ReedsSheppStateSpace`` (which Nav2's Smac planner calls).

A path is a list of up to 5 segments: ``types[i]`` in ``LEFT``, ``STRAIGHT``, ``RIGHT``
(``NOP`` = unused) and signed ``lengths[i]`` in units of the turning radius (negative =
driven in reverse).  All kernels work in normalised coordinates: the start at the
origin heading +x, radius 1; :func:`shortest_path` does the change of frame.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

LEFT, STRAIGHT, RIGHT, NOP = 0, 1, 2, -1
DUBIN, REEDS_SHEPP = 0, 1
TWO_PI = 2.0 * math.pi
HALF_PI = 0.5 * math.pi
_ZERO = 1e-12
_EPS = 1e-10
_INF = math.inf

# Reeds-Shepp path types (OMPL's table): segment letters of the 18 base words
_RS_TYPES = np.array([
    [LEFT, RIGHT, LEFT, NOP, NOP], [RIGHT, LEFT, RIGHT, NOP, NOP],
    [LEFT, RIGHT, LEFT, RIGHT, NOP], [RIGHT, LEFT, RIGHT, LEFT, NOP],
    [LEFT, RIGHT, STRAIGHT, LEFT, NOP], [RIGHT, LEFT, STRAIGHT, RIGHT, NOP],
    [LEFT, STRAIGHT, RIGHT, LEFT, NOP], [RIGHT, STRAIGHT, LEFT, RIGHT, NOP],
    [LEFT, RIGHT, STRAIGHT, RIGHT, NOP], [RIGHT, LEFT, STRAIGHT, LEFT, NOP],
    [RIGHT, STRAIGHT, RIGHT, LEFT, NOP], [LEFT, STRAIGHT, LEFT, RIGHT, NOP],
    [LEFT, STRAIGHT, RIGHT, NOP, NOP], [RIGHT, STRAIGHT, LEFT, NOP, NOP],
    [LEFT, STRAIGHT, LEFT, NOP, NOP], [RIGHT, STRAIGHT, RIGHT, NOP, NOP],
    [LEFT, RIGHT, STRAIGHT, LEFT, RIGHT], [RIGHT, LEFT, STRAIGHT, RIGHT, LEFT],
], dtype=np.int64)
# per Reeds-Shepp family (formulas 8.1, 8.2, 8.3, 8.7, 8.8, 8.9, 8.10, 8.11): path type,
# reflected type, type of the "backwards" variant (-1: none) and its reflection
_FAM_TYPE = np.array([14, 12, 0, 2, 2, 4, 8, 16], dtype=np.int64)
_FAM_TYPE_REFLECT = np.array([15, 13, 1, 3, 3, 5, 9, 17], dtype=np.int64)
_FAM_BACK_TYPE = np.array([-1, -1, 0, -1, -1, 6, 10, -1], dtype=np.int64)
_FAM_BACK_TYPE_REFLECT = np.array([-1, -1, 1, -1, -1, 7, 11, -1], dtype=np.int64)
# Dubins words LSL, RSR, LSR, RSL, RLR, LRL
_DUBINS_TYPES = np.array([[LEFT, STRAIGHT, LEFT], [RIGHT, STRAIGHT, RIGHT],
                          [LEFT, STRAIGHT, RIGHT], [RIGHT, STRAIGHT, LEFT],
                          [RIGHT, LEFT, RIGHT], [LEFT, RIGHT, LEFT]], dtype=np.int64)


@nb.njit(cache=True)
def _dubins_best(x: float, y: float, phi: float) -> tuple[float, int, float, float, float]:
    """``(length, word, t, p, q)`` of the shortest Dubins path from the origin (heading 0)
    to ``(x, y, phi)`` with radius 1 (words: LSL, RSR, LSR, RSL, RLR, LRL)."""
    d = math.hypot(x, y)
    th = math.atan2(y, x) if d > 0.0 else 0.0
    a = -th - TWO_PI * math.floor(-th / TWO_PI)
    b = (phi - th) - TWO_PI * math.floor((phi - th) / TWO_PI)
    sa, sb, ca, cb = math.sin(a), math.sin(b), math.cos(a), math.cos(b)
    cab = math.cos(a - b)
    best = _INF
    bt, bp, bq, word = 0.0, 0.0, 0.0, -1
    for w in range(6):
        ok = True
        t = p = q = 0.0
        if w <= 1:  # LSL, RSR
            sg = 1.0 if w == 0 else -1.0
            p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * sg * (sa - sb)
            ok = p2 >= -_EPS
            if ok:
                tmp = math.atan2(sg * (cb - ca), d + sg * (sa - sb))
                t, p, q = sg * (tmp - a), math.sqrt(max(p2, 0.0)), sg * (b - tmp)
        elif w <= 3:  # LSR, RSL
            sg = 1.0 if w == 2 else -1.0
            p2 = -2.0 + d * d + 2.0 * cab + 2.0 * d * sg * (sa + sb)
            ok = p2 >= -_EPS
            if ok:
                p = math.sqrt(max(p2, 0.0))
                tmp = math.atan2(sg * (-ca - cb), d + sg * (sa + sb)) - math.atan2(-2.0 * sg, p)
                t, q = sg * (tmp - a), sg * (tmp - b)
        else:  # RLR, LRL
            sg = 1.0 if w == 4 else -1.0
            tmp = (6.0 - d * d + 2.0 * cab + 2.0 * d * sg * (sa - sb)) / 8.0
            ok = abs(tmp) <= 1.0 + _EPS
            if ok:
                p = TWO_PI - math.acos(min(1.0, max(-1.0, tmp)))
                t = sg * (a - math.atan2(sg * (ca - cb), d - sg * (sa - sb))) + 0.5 * p
                q = sg * (a - b) - t + p
        if not ok:
            continue
        t -= TWO_PI * math.floor(t / TWO_PI)
        p -= TWO_PI * math.floor(p / TWO_PI) if w >= 4 else 0.0
        q -= TWO_PI * math.floor(q / TWO_PI)
        if t + p + q < best:
            best, bt, bp, bq, word = t + p + q, t, p, q, w
    return best, word, bt, bp, bq


@nb.njit(cache=True)
def _rs_best(x: float, y: float, phi: float, above: float = -1.0
             ) -> tuple[float, int, int, int, float, float, float]:
    """``(length, family, backwards, variant, t, u, v)`` of the shortest Reeds-Shepp path
    from the origin (heading 0) to ``(x, y, phi)`` with radius 1 that is longer than
    ``above`` (the next candidate after one of that length; family ``-1`` if none).

    Families are formulas 8.1, 8.2, 8.3, 8.7, 8.8, 8.9, 8.10 and 8.11 of Reeds & Shepp;
    each is evaluated on the plain goal and its time-flip (variant 1), reflection (2) and
    both (3), and the CCC/CCSC families also on the "backwards" goal, as in OMPL.
    Angles are wrapped to [-pi, pi] (OMPL's ``mod2pi``).
    """
    phi = phi - TWO_PI * math.floor(phi / TWO_PI + 0.5)
    best = _INF
    bf, bb, bv, bt, bu, bw = -1, 0, 0, 0.0, 0.0, 0.0
    sphi, cphi = math.sin(phi), math.cos(phi)
    xb = x * cphi + y * sphi
    yb = x * sphi - y * cphi
    for fam in range(8):
        n_back = 2 if _FAM_BACK_TYPE[fam] >= 0 else 1
        for back in range(n_back):
            px, py = (xb, yb) if back == 1 else (x, y)
            for variant in range(4):
                xx = -px if variant == 1 or variant == 3 else px
                yy = -py if variant >= 2 else py
                neg = variant == 1 or variant == 2
                ph = -phi if neg else phi
                sp = -sphi if neg else sphi
                cp = cphi
                ok = False
                t = u = v = 0.0
                extra = 0.0
                if fam == 0:  # 8.1 L+S+L+
                    u = math.hypot(xx - sp, yy - 1.0 + cp)
                    t = math.atan2(yy - 1.0 + cp, xx - sp)
                    v = ph - t
                    v -= TWO_PI * math.floor(v / TWO_PI + 0.5)
                    ok = t >= -_ZERO and v >= -_ZERO
                elif fam == 1:  # 8.2 L+S+R+
                    xi, eta = xx + sp, yy - 1.0 - cp
                    u1 = xi * xi + eta * eta
                    if u1 >= 4.0:
                        u = math.sqrt(u1 - 4.0)
                        t = math.atan2(eta, xi) + math.atan2(2.0, u)
                        t -= TWO_PI * math.floor(t / TWO_PI + 0.5)
                        v = t - ph
                        v -= TWO_PI * math.floor(v / TWO_PI + 0.5)
                        ok = t >= -_ZERO and v >= -_ZERO
                elif fam == 2:  # 8.3 L+R-L
                    xi, eta = xx - sp, yy - 1.0 + cp
                    u1 = math.hypot(xi, eta)
                    if u1 <= 4.0:
                        u = -2.0 * math.asin(0.25 * u1)
                        t = math.atan2(eta, xi) + 0.5 * u + math.pi
                        t -= TWO_PI * math.floor(t / TWO_PI + 0.5)
                        v = ph - t + u
                        v -= TWO_PI * math.floor(v / TWO_PI + 0.5)
                        ok = t >= -_ZERO and u <= _ZERO
                elif fam <= 4:  # 8.7 L+R+L-R- / 8.8 L+R-L-R+
                    xi, eta = xx + sp, yy - 1.0 - cp
                    rho = (0.25 * (2.0 + math.hypot(xi, eta)) if fam == 3
                           else (20.0 - xi * xi - eta * eta) / 16.0)
                    if (fam == 3 and rho <= 1.0) or (fam == 4 and 0.0 <= rho <= 1.0):
                        u = math.acos(rho) if fam == 3 else -math.acos(rho)
                        if fam == 3 or u >= -HALF_PI:
                            uu = u
                            vv = -u if fam == 3 else u
                            delta = uu - vv
                            delta -= TWO_PI * math.floor(delta / TWO_PI + 0.5)
                            ta = math.sin(uu) - math.sin(delta)
                            tb = math.cos(uu) - math.cos(delta) - 1.0
                            t1 = math.atan2(eta * ta - xi * tb, xi * ta + eta * tb)
                            t2 = 2.0 * (math.cos(delta) - math.cos(vv) - math.cos(uu)) + 3.0
                            t = t1 + math.pi if t2 < 0.0 else t1
                            t -= TWO_PI * math.floor(t / TWO_PI + 0.5)
                            v = t - uu + vv - ph
                            v -= TWO_PI * math.floor(v / TWO_PI + 0.5)
                            ok = t >= -_ZERO and (v <= _ZERO if fam == 3 else v >= -_ZERO)
                            extra = abs(u)
                elif fam == 5:  # 8.9 L+R-(pi/2)S-L-
                    xi, eta = xx - sp, yy - 1.0 + cp
                    rho = math.hypot(xi, eta)
                    if rho >= 2.0:
                        r = math.sqrt(rho * rho - 4.0)
                        u = 2.0 - r
                        t = math.atan2(eta, xi) + math.atan2(r, -2.0)
                        t -= TWO_PI * math.floor(t / TWO_PI + 0.5)
                        v = ph - HALF_PI - t
                        v -= TWO_PI * math.floor(v / TWO_PI + 0.5)
                        ok = t >= -_ZERO and u <= _ZERO and v <= _ZERO
                        extra = HALF_PI
                elif fam == 6:  # 8.10 L+R-(pi/2)S-R-
                    xi, eta = xx + sp, yy - 1.0 - cp
                    rho = math.hypot(-eta, xi)
                    if rho >= 2.0:
                        t = math.atan2(xi, -eta)
                        u = 2.0 - rho
                        v = t + HALF_PI - ph
                        v -= TWO_PI * math.floor(v / TWO_PI + 0.5)
                        ok = t >= -_ZERO and u <= _ZERO and v <= _ZERO
                        extra = HALF_PI
                else:  # 8.11 L+R-(pi/2)S-L-(pi/2)R+
                    xi, eta = xx + sp, yy - 1.0 - cp
                    rho = math.hypot(xi, eta)
                    if rho >= 2.0:
                        u = 4.0 - math.sqrt(rho * rho - 4.0)
                        if u <= _ZERO:
                            t = math.atan2((4.0 - u) * xi - 2.0 * eta, -2.0 * xi + (u - 4.0) * eta)
                            t -= TWO_PI * math.floor(t / TWO_PI + 0.5)
                            v = t - ph
                            v -= TWO_PI * math.floor(v / TWO_PI + 0.5)
                            ok = t >= -_ZERO and v >= -_ZERO
                            extra = math.pi
                if not ok:
                    continue
                total = abs(t) + abs(u) + abs(v) + extra
                if above + 1e-9 < total < best:
                    best, bf, bb, bv, bt, bu, bw = total, fam, back, variant, t, u, v
    return best, bf, bb, bv, bt, bu, bw


@nb.njit(cache=True)
def shortest_path(model: int, x0: float, y0: float, th0: float, x1: float, y1: float,
                  th1: float, radius: float, types: NDArray[np.int64],
                  lengths: NDArray[np.float64], above: float = -1.0) -> float:
    """Shortest path of ``model`` (DUBIN / REEDS_SHEPP) between two poses.

    Coordinates in any consistent unit; ``radius`` is the minimum turning radius in that
    unit.  Fills ``types[:5]`` (NOP for unused) and the signed ``lengths[:5]``, which
    come back normalised (multiply by ``radius``); returns the length in the caller's
    unit.  ``above`` (REEDS_SHEPP only, caller's unit): the shortest path longer than
    that instead, ``inf`` when there is none.
    """
    dx, dy = x1 - x0, y1 - y0
    c, s = math.cos(th0), math.sin(th0)
    x = (c * dx + s * dy) / radius
    y = (-s * dx + c * dy) / radius
    for i in range(5):
        types[i] = NOP
        lengths[i] = 0.0
    if model == DUBIN:
        best, word, t, p, q = _dubins_best(x, y, th1 - th0)
        for i in range(3):
            types[i] = _DUBINS_TYPES[word, i]
        lengths[0], lengths[1], lengths[2] = t, p, q
        return radius * best
    best, fam, back, variant, t, u, v = _rs_best(x, y, th1 - th0, above / radius)
    if fam < 0:
        return math.inf
    # segment layout of the family (the pi/2 segments are fixed)
    n = 3
    if fam == 2 and back == 1:
        lengths[0], lengths[1], lengths[2] = v, u, t
    elif fam <= 2:
        lengths[0], lengths[1], lengths[2] = t, u, v
    elif fam <= 4:
        lengths[0], lengths[1], lengths[2], lengths[3] = t, u, -u if fam == 3 else u, v
        n = 4
    elif fam <= 6:
        if back == 1:
            lengths[0], lengths[1], lengths[2], lengths[3] = v, u, -HALF_PI, t
        else:
            lengths[0], lengths[1], lengths[2], lengths[3] = t, -HALF_PI, u, v
        n = 4
    else:
        lengths[0], lengths[1], lengths[2], lengths[3], lengths[4] = (t, -HALF_PI, u,
                                                                      -HALF_PI, v)
        n = 5
    reflect = variant >= 2
    flip = variant == 1 or variant == 3
    if back == 1:
        ptype = _FAM_BACK_TYPE_REFLECT[fam] if reflect else _FAM_BACK_TYPE[fam]
    else:
        ptype = _FAM_TYPE_REFLECT[fam] if reflect else _FAM_TYPE[fam]
    for i in range(n):
        types[i] = _RS_TYPES[ptype, i]
        if flip:
            lengths[i] = -lengths[i]
    return radius * best


@nb.njit(cache=True)
def path_distance(model: int, x0: float, y0: float, th0: float, x1: float, y1: float,
                  th1: float, radius: float) -> float:
    """Length of the shortest ``model`` path between two poses (same units as input)."""
    dx, dy = x1 - x0, y1 - y0
    c, s = math.cos(th0), math.sin(th0)
    x = (c * dx + s * dy) / radius
    y = (-s * dx + c * dy) / radius
    if model == DUBIN:
        return radius * _dubins_best(x, y, th1 - th0)[0]
    return radius * _rs_best(x, y, th1 - th0)[0]


@nb.njit(cache=True)
def segment_samples(kind: int, seg: float, radius: float, step: float,
                    dth_step: float) -> int:
    """Samples for one segment: ``<= step`` of arc length and, on a turn, ``<= dth_step``
    [rad] of heading apart."""
    m = max(1, math.ceil(abs(seg) * radius / step - 1e-9))
    if kind != STRAIGHT and dth_step > 0.0:
        m = max(m, math.ceil(abs(seg) / dth_step - 1e-9))
    return m


@nb.njit(cache=True)
def sample_path(x0: float, y0: float, th0: float, types: NDArray[np.int64],
                lengths: NDArray[np.float64], radius: float, step: float,
                out: NDArray[np.float64], direction: NDArray[np.int8],
                dth_step: float = 0.0) -> int:
    """Poses along a path every ``<= step`` of arc length (and, on turns, every
    ``<= dth_step`` rad of heading when it is positive), start excluded.

    Every segment end (cusps included) is a sample, so a reversal point is never skipped.
    ``out[k] = (x, y, theta)``, ``direction[k]`` is +1 / -1 for the motion that reaches
    sample ``k``.  Returns the number of samples, or minus the number needed when ``out``
    is too small (nothing written then).
    """
    need = 0
    for i in range(5):
        if types[i] != NOP and lengths[i] != 0.0:
            need += segment_samples(types[i], lengths[i], radius, step, dth_step)
    if need > out.shape[0]:
        return -need
    k = 0
    x, y, th = x0, y0, th0
    for i in range(5):
        kind = types[i]
        seg = lengths[i]
        if kind == NOP or seg == 0.0:
            continue
        m = segment_samples(kind, seg, radius, step, dth_step)
        for j in range(1, m + 1):
            ln = seg * j / m
            if kind == STRAIGHT:
                px = x + ln * radius * math.cos(th)
                py = y + ln * radius * math.sin(th)
                pth = th
            elif kind == LEFT:
                pth = th + ln
                px = x + radius * (math.sin(pth) - math.sin(th))
                py = y - radius * (math.cos(pth) - math.cos(th))
            else:
                pth = th - ln
                px = x - radius * (math.sin(pth) - math.sin(th))
                py = y + radius * (math.cos(pth) - math.cos(th))
            out[k, 0] = px
            out[k, 1] = py
            out[k, 2] = pth
            direction[k] = 1 if seg > 0.0 else -1
            k += 1
        x, y, th = out[k - 1, 0], out[k - 1, 1], out[k - 1, 2]
    return k


def shortest(model: int, start: tuple[float, float, float], goal: tuple[float, float, float],
             radius: float) -> tuple[float, NDArray[np.int64], NDArray[np.float64]]:
    """Python convenience: ``(length, types, lengths_normalised)`` between two poses."""
    types = np.empty(5, dtype=np.int64)
    lengths = np.empty(5)
    d = shortest_path(model, *start, *goal, radius, types, lengths)
    return float(d), types, lengths


def sample(model: int, start: tuple[float, float, float], goal: tuple[float, float, float],
           radius: float, step: float, dth_step: float = 0.0
           ) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Python convenience: ``(poses (K, 3), directions (K,))`` along the shortest path,
    the start pose included as the first row (direction of the first motion)."""
    _, types, lengths = shortest(model, start, goal, radius)
    n = sum(segment_samples(int(t), float(ln), radius, step, dth_step)
            for t, ln in zip(types, lengths, strict=True) if t != NOP and ln != 0.0)
    out = np.empty((n + 1, 3))
    direction = np.empty(n + 1, dtype=np.int8)
    out[0] = start
    k = sample_path(*start, types, lengths, radius, step, out[1:], direction[1:], dth_step)
    direction[0] = direction[1] if k else 1
    return out[:k + 1], direction[:k + 1]
