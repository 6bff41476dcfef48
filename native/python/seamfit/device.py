"""Compute device selection: --device auto|cpu|cuda."""
from __future__ import annotations

from .errors import DeviceError


def cuda_available() -> tuple[bool, str]:
    """(usable, why not) for the CUDA backend."""
    from ._native import core
    c = core()
    if not getattr(c, "built_with_cuda", False):
        return False, "this seamfit build has no CUDA backend (it was built without nvcc)"
    if c.cuda_device_count() == 0:
        return False, "no CUDA GPU or driver is present on this machine"
    return True, ""


def resolve_device(requested: str, *, problem_size: int = 0) -> str:
    """'cpu' or 'cuda'. auto picks the CPU unless a GPU is present and would pay; cuda
    fails at once with the reason when it cannot run."""
    if requested not in ("auto", "cpu", "cuda"):
        raise DeviceError(f"unknown device {requested!r} (auto, cpu or cuda)")
    if requested == "cpu":
        return "cpu"
    ok, why = cuda_available()
    if requested == "cuda":
        if not ok:
            raise DeviceError(f"--device cuda: {why}")
        return "cuda"
    return "cuda" if ok and problem_size >= GPU_MIN_VERTICES else "cpu"


# From this many garment vertices up, auto takes the GPU. Measured on an H100
# (docs/gpu.md, "Grading on the GPU"): at 5,458 vertices the grading's simulations ran 11x
# faster than on the host's 16 CPU threads, and one simulator iteration at 5,304 vertices
# took 21 us on an H200 against 243 us (docs/gpu_results.md); smaller garments were not measured, and
# below a few thousand vertices the per-call transfers and graph captures are a larger share.
GPU_MIN_VERTICES = 5000
