"""Switches for measuring, kept out of seamfit's settings: no user needs them, and a
grading made with them is not one seamfit would make.

    with host_state(): ...              the search's loop on host arrays where its state
                                        could stay on the GPU (what the GPU state saves)
    with accept_unsettled_base(): ...   grade from a base drape that did not settle (timing
                                        meshes the simulator cannot settle), never cached
"""
from __future__ import annotations

import contextlib
import functools
from unittest import mock


@contextlib.contextmanager
def host_state():
    from seamfit.opt import descent
    with mock.patch.object(descent, "state_on_gpu", lambda ctx: False):
        yield


@contextlib.contextmanager
def accept_unsettled_base():
    from seamfit.opt import prepare
    with mock.patch.object(prepare, "base_drape", functools.partial(prepare.base_drape, accept_unsettled=True)):
        yield
