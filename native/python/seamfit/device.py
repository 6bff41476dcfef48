"""Compute device selection: --device auto|cpu|cuda."""
from __future__ import annotations

from .errors import DeviceError

__all__ = ["check_device", "choose_device", "cuda_available", "cuda_device_name", "require_device",
           "resolve_device"]


def cuda_available() -> tuple[bool, str]:
    """(usable, why not) for the CUDA backend."""
    from ._native import core
    c = core()
    if not getattr(c, "built_with_cuda", False):
        return False, "this seamfit build has no CUDA backend (it was built without nvcc)"
    if c.cuda_device_count() == 0:
        return False, "no CUDA GPU or driver is present on this machine"
    return True, ""


def cuda_device_name(index: int = 0) -> str:
    """The name of CUDA device ``index`` (call after cuda_available() says yes)."""
    from ._native import core
    return str(core().cuda_device_name(index))


def require_device(device: str, what: str, error: type = DeviceError, *, runnable: bool = True) -> str:
    """``device``, a resolved device ("cpu" or "cuda") for ``what`` (the simulator, the
    cost set, ...), checked the one way for the package: another name raises ``error``
    naming ``what``; with ``runnable``, cuda raises DeviceError with the reason when it
    cannot run here."""
    if device not in ("cpu", "cuda"):
        raise error(f"unknown device {device!r} for {what} (cpu or cuda)")
    if device == "cuda" and runnable:
        ok, why = cuda_available()
        if not ok:
            raise DeviceError(f"device cuda: {why}")
    return device


def check_device(requested: str) -> None:
    """Fails at once, with the reason, for an unknown device or a cuda that cannot run
    here; measures nothing (the choice for auto waits for the garment's size)."""
    if requested not in ("auto", "cpu", "cuda"):
        raise DeviceError(f"unknown device {requested!r} (auto, cpu or cuda)")
    if requested == "cuda":
        ok, why = cuda_available()
        if not ok:
            raise DeviceError(f"--device cuda: {why}")


def resolve_device(requested: str, *, problem_size: int = 0) -> str:
    """'cpu' or 'cuda'. auto picks the device predicted to run the simulator faster for a
    garment of ``problem_size`` vertices (``choose_device``); cuda fails at once with the
    reason when it cannot run."""
    return choose_device(requested, problem_size=problem_size)["device"]


def choose_device(requested: str, *, problem_size: int = 0) -> dict:
    """The device and why: {"device", "requested", "reason"}, and for auto with a GPU the
    predicted seconds per simulator iteration on each device and where that came from
    (seamfit.device_calibration: measured once per machine and cached)."""
    check_device(requested)
    if requested != "auto":
        return {"device": requested, "requested": requested, "reason": "asked for"}
    ok, why = cuda_available()
    if not ok:
        return {"device": "cpu", "requested": requested, "reason": why}
    from ._native import core
    from .device_calibration import calibration, predicted_seconds_per_iteration
    cal = calibration(str(core().cuda_device_name(0)))
    t = predicted_seconds_per_iteration(cal, int(problem_size))
    device = "cuda" if t["cuda"] < t["cpu"] else "cpu"
    return {"device": device, "requested": requested,
            "reason": (f"predicted {1e6 * t['cuda']:.0f} us per simulator iteration on the GPU against "
                       f"{1e6 * t['cpu']:.0f} us on {cal['threads']} CPU threads at {int(problem_size)} vertices"),
            "predicted_seconds_per_iteration": t, "calibration": cal["source"]}
