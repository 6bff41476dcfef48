"""Fixtures of the optimizer's tests: a module defines the sewn ``mesh`` it runs on, and
gets its pattern parametrization here."""
from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def param(mesh):
    from seamfit.opt import Parametrization
    return Parametrization(mesh)
