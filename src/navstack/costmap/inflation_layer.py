"""Inflation layer (Nav2 ``nav2_costmap_2d::InflationLayer``), with uncertainty-aware radius.

Costs fall off with the Euclidean distance ``d`` from the nearest LETHAL cell:

* ``d = 0``: LETHAL (254); ``d <= inscribed radius`` of the footprint: INSCRIBED (253);
* beyond: ``int(252 * exp(-cost_scaling_factor * (d - inscribed_radius)))``, for cells
  with ``d <= inflation_radius`` (in whole cells, Nav2 ``cellDistance``).

Costs are combined with ``max`` (an unknown cell only becomes >= INSCRIBED, or any
inflated cost with ``inflate_unknown``); ``inflate_around_unknown`` also inflates from
NO_INFORMATION cells, which - as in Nav2 - turns those cells LETHAL.  Distances come from
an exact EDT (:mod:`navstack.costmap.inflation_kernel`) over the update window grown by
the inflation radius, so obstacles just outside the window still inflate into it.

Uncertainty-aware inflation (navstack extension, off by default): with
``uncertainty_inflation.enabled`` and a pose covariance given by
:meth:`InflationLayer.set_pose_covariance`, the robot's true position lies, with
probability ``alpha``, inside the ellipse ``(p - mu)^T Sigma^-1 (p - mu) <= chi2_2(alpha)``
whose semi-major axis is ``sqrt(lambda_max(Sigma) * chi2_2(alpha))`` (the standard
confidence-ellipse result for a bivariate Gaussian, e.g. Bar-Shalom, Li & Kirubarajan,
*Estimation with Applications to Tracking and Navigation*, 2001, Sec. 2.4 / 3.7).  For 2
degrees of freedom ``chi2_2(alpha) = -2 ln(1 - alpha)``.  The inflation band grows by
``r_unc = min(sqrt(lambda_max) * sqrt(chi2_2(alpha)), max_radius_increase)``: cells within
``inscribed + r_unc`` get MAX_NON_OBSTACLE (252, very expensive but not a certain
collision) and the exponential decay starts ``r_unc`` further out, up to
``inflation_radius + r_unc``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from navstack.core.params import Params
from navstack.costmap.costmap_2d import Costmap2D
from navstack.costmap.inflation_kernel import cell_distance, cost_lut, inflate
from navstack.costmap.layer import Bounds, CellWindow, Layer, LayerParams, register_layer


class UncertaintyInflationParams(Params):
    """Grow the inflation band with the localisation covariance (navstack extension)."""

    enabled: bool = False
    alpha: float = Field(0.95, gt=0.0, lt=1.0)
    max_radius_increase: float = Field(0.5, ge=0.0)


class InflationLayerParams(LayerParams):
    """Nav2 InflationLayer parameters (names and defaults)."""

    inflation_radius: float = Field(0.55, ge=0.0)
    cost_scaling_factor: float = Field(10.0, ge=0.0)
    inflate_unknown: bool = False
    inflate_around_unknown: bool = False
    uncertainty_inflation: UncertaintyInflationParams = UncertaintyInflationParams()


def chi2_ppf_2dof(alpha: float) -> float:
    """Quantile of the chi-square distribution with 2 degrees of freedom: ``-2 ln(1-alpha)``."""
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    return -2.0 * math.log1p(-alpha)


def uncertainty_radius(cov_xy: ArrayLike, alpha: float) -> float:
    """Semi-major axis of the ``alpha`` confidence ellipse of a 2x2 position covariance [m]."""
    cov = np.asarray(cov_xy, dtype=np.float64)
    if cov.shape != (2, 2) or not np.all(np.isfinite(cov)):
        raise ValueError(f"cov_xy must be a finite 2x2 matrix, got shape {cov.shape}")
    lam = np.linalg.eigvalsh(0.5 * (cov + cov.T))
    if lam[0] < -1e-12:
        raise ValueError(f"cov_xy must be positive semi-definite, got eigenvalues {lam}")
    lam_max = float(lam[-1])
    return math.sqrt(max(lam_max, 0.0) * chi2_ppf_2dof(alpha))


@register_layer("InflationLayer", nav2="nav2_costmap_2d::InflationLayer")
class InflationLayer(Layer):
    """Exponential cost decay around lethal cells; see the module docstring."""

    params_model = InflationLayerParams
    params: InflationLayerParams

    def __init__(self, name: str = "inflation_layer",
                 params: InflationLayerParams | None = None) -> None:
        super().__init__(name, params)
        self._r_unc = 0.0
        self._radius_cells = 0
        self._lut: NDArray[np.uint8] = np.zeros(2, np.uint8)
        self._lut_key: tuple[float, ...] = ()
        self._lut_changed = False
        self._last = Bounds()
        self._need_reinflation = False
        self.current = True  # Nav2 onInitialize: the layer has no inputs of its own

    # --- geometry --------------------------------------------------------------------
    @property
    def inscribed_radius(self) -> float:
        return self.layered.inscribed_radius if self.layered is not None else 0.0

    @property
    def uncertainty_increase(self) -> float:
        """``r_unc`` [m] as applied: rounded up to whole cells (0 when disabled).

        Whole cells so that small covariance changes do not force a full re-inflation
        every cycle; rounding up keeps the band conservative.
        """
        if not self.params.uncertainty_inflation.enabled or self._r_unc <= 0.0:
            return 0.0
        res = self.master.resolution if self.layered is not None else 1.0
        return math.ceil(self._r_unc / res - 1e-9) * res

    @property
    def effective_inflation_radius(self) -> float:
        return self.params.inflation_radius + self.uncertainty_increase

    @property
    def radius_cells(self) -> int:
        self._refresh_lut()
        return self._radius_cells

    def set_pose_covariance(self, cov_xy: ArrayLike) -> float:
        """Set the 2x2 position covariance [m^2]; returns the capped ``r_unc`` [m]."""
        ui = self.params.uncertainty_inflation
        r = min(uncertainty_radius(cov_xy, ui.alpha), ui.max_radius_increase)
        self._r_unc = r
        self._refresh_lut()
        if self._lut_changed:
            self._need_reinflation = True
        return r

    def cost_at_distance(self, distance_m: float) -> int:
        """The cost this layer assigns at ``distance_m`` from a lethal cell (no grid)."""
        res = self.master.resolution
        d2 = round((distance_m / res) ** 2)
        self._refresh_lut()
        r2 = self._radius_cells ** 2
        return int(self._lut[min(d2, r2 + 1)])

    def _refresh_lut(self) -> None:
        res = self.master.resolution if self.layered is not None else 1.0
        key = (res, self.effective_inflation_radius, self.inscribed_radius,
               self.params.cost_scaling_factor, self.uncertainty_increase)
        self._lut_changed = key != self._lut_key
        if self._lut_changed:
            self._radius_cells = cell_distance(self.effective_inflation_radius, res)
            self._lut = cost_lut(self._radius_cells, res, self.inscribed_radius,
                                 self.params.cost_scaling_factor, self.uncertainty_increase)
            self._lut_key = key

    # --- Layer hooks -----------------------------------------------------------------
    def match_size(self) -> None:
        self._refresh_lut()

    def on_footprint_changed(self) -> None:
        self._refresh_lut()
        self._need_reinflation = True

    def reset(self) -> None:
        super().reset()
        self._need_reinflation = True

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        """Nav2: grow by the inflation radius, including last cycle's box; everything
        after a parameter/footprint change."""
        if self._need_reinflation:
            self._last = bounds.copy()
            self._need_reinflation = False
            return Bounds.everything()
        prev = self._last
        self._last = bounds.copy()
        out = bounds.copy()
        out.union(prev)
        if out.empty:
            return out
        r = self.effective_inflation_radius
        return Bounds(out.min_x - r, out.min_y - r, out.max_x + r, out.max_y + r)

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        self._refresh_lut()
        r = self._radius_cells
        if r == 0 or window.empty:
            self.current = True
            return
        seed = (max(0, window.min_i - r), max(0, window.min_j - r),
                min(master.size_x, window.max_i + r), min(master.size_y, window.max_j + r))
        inflate(master.data, seed, (window.min_i, window.min_j, window.max_i, window.max_j),
                r, self._lut, self.params.inflate_around_unknown, self.params.inflate_unknown)
        self.current = True
