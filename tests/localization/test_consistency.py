"""NEES and the chi-square band."""

import numpy as np
import pytest

from navstack.localization.consistency import nees, nees_band


def test_nees_of_a_known_error() -> None:
    cov = np.diag([0.04, 0.01, 0.0025])
    # errors of one sigma on each axis: NEES = 3; an angle of 2*pi + 0.05 wraps to 0.05
    values = nees([[0.2, 0.1, 2 * np.pi + 0.05]], [cov])
    assert values == pytest.approx([3.0])


def test_samples_from_the_claimed_covariance_fill_the_band() -> None:
    rng = np.random.default_rng(0)
    cov = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.01]])
    errors = rng.multivariate_normal(np.zeros(3), cov, size=20000)
    band = nees_band(nees(errors, np.broadcast_to(cov, (20000, 3, 3))), dof=3)
    assert band.inside == pytest.approx(0.95, abs=0.01)
    assert band.lower == pytest.approx(0.2158, abs=1e-4)
    assert band.upper == pytest.approx(9.3484, abs=1e-4)
    # a filter claiming 1/4 of the true variance is over-confident: most steps above
    over = nees_band(nees(errors, np.broadcast_to(cov / 4, (20000, 3, 3))), dof=3)
    assert over.above > 0.3 and over.inside < 0.7
