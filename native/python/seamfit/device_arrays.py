"""Arrays that stay on the GPU between exact checkpoints (seamfit._core.DeviceArray).

The search's GPU pieces (costs, regularizers, R^seam, p(theta), the adjoint, df/dp, the
simulator) take a DeviceArray wherever they take a NumPy array and then answer with
DeviceArrays, so the garment state, the pattern and the gradients of an outer iteration
never cross to the host; only scalars do (objective values, residuals, the step's largest
move). A piece that runs on the CPU (a pattern too large for GPU memory, say) takes them
too: it copies in and out, so every combination of devices works.

A piece's DeviceArray results live in buffers it owns and reuses (``Buffers``): each is
valid until that piece's next call.
"""
from __future__ import annotations

import numpy as np

from ._native import core


def is_device(a) -> bool:
    """True for a seamfit._core.DeviceArray (never in a build without CUDA)."""
    cls = getattr(core(), "DeviceArray", None)
    return cls is not None and isinstance(a, cls)


def host(a) -> np.ndarray:
    """A NumPy array of a (a copy from the GPU for a DeviceArray)."""
    return a.numpy() if is_device(a) else np.asarray(a)


def to_device(a) -> object:
    """A new DeviceArray holding the 2-D array a."""
    return core().DeviceArray(np.ascontiguousarray(a, dtype=np.float64))


def all_finite(a) -> bool:
    if is_device(a):
        return bool(np.isfinite(a.max_abs()))
    return bool(np.all(np.isfinite(a)))


class Buffers:
    """Named DeviceArrays a piece writes its results into, made on first use and
    reused while their shape holds."""

    def __init__(self):
        self._bufs: dict[str, object] = {}

    def get(self, name: str, rows: int, cols: int):
        b = self._bufs.get(name)
        if b is None or tuple(b.shape) != (rows, cols):
            b = core().DeviceArray.zeros(int(rows), int(cols))
            self._bufs[name] = b
        return b

    def put(self, name: str, a):
        """a (NumPy) in the buffer `name`: how a CPU piece answers a DeviceArray caller."""
        a = np.ascontiguousarray(a, dtype=np.float64).reshape(np.shape(a)[0], -1)
        b = self.get(name, a.shape[0], a.shape[1])
        b.upload(a)
        return b
