"""Fixtures shared by the mapping tests."""

from __future__ import annotations

import pytest

from navstack.sim.worlds import load_world


@pytest.fixture(scope="module")
def office():
    """The built-in office world."""
    return load_world("office")
