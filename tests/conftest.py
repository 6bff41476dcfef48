"""Shared by every test folder: tests/ on sys.path (common.py, sim_helpers.py,
grading_helpers.py, opt_synthetic.py), the ``gpu`` marker and the ``device`` fixture.

A test marked ``@pytest.mark.gpu`` exists where a GPU is present (common.GPU): elsewhere it
is not collected, rather than reported as skipped. The ``device`` fixture runs a test once per
device in common.DEVICES: "cpu" always, "cuda" where a GPU is present.

tests/blender runs this file too, in Blender's Python: nothing here imports seamfit until a
test asks for a device.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))


def pytest_configure(config):
    config.addinivalue_line("markers", "gpu: exists where a CUDA GPU is present; not collected elsewhere")


@pytest.hookimpl(tryfirst=True)
def pytest_pycollect_makeitem(collector, name, obj):
    # a test marked gpu, where no GPU is present: no items at all
    marks = getattr(obj, "pytestmark", None) if collector.funcnamefilter(name) else None
    if isinstance(marks, list) and any(getattr(m, "name", None) == "gpu" for m in marks):
        from common import GPU
        if not GPU:
            return []
    return None


def pytest_generate_tests(metafunc):
    # "device": once per device present, unless the test parametrizes it itself
    if "device" in metafunc.fixturenames and "device" not in _parametrized(metafunc):
        from common import DEVICES
        metafunc.parametrize("device", DEVICES)


def _parametrized(metafunc) -> set[str]:
    names = set()
    for mark in metafunc.definition.iter_markers("parametrize"):
        args = mark.args[0] if mark.args else mark.kwargs.get("argnames", ())
        names.update(a.strip() for a in args.split(",")) if isinstance(args, str) else names.update(args)
    return names
