"""Device selection (--device auto|cpu|cuda): the policy, with the GPU's presence
stubbed both ways so it is checked on any machine."""
import pytest

import seamfit.device as device
from seamfit.errors import DeviceError


@pytest.fixture(params=[True, False], ids=["gpu", "no-gpu"])
def gpu(request, monkeypatch):
    why = "" if request.param else "no CUDA GPU or driver is present on this machine"
    monkeypatch.setattr(device, "cuda_available", lambda: (request.param, why))
    return request.param


def test_cpu_is_always_the_cpu(gpu):
    assert device.resolve_device("cpu", problem_size=10**7) == "cpu"


def test_auto_takes_the_gpu_only_where_it_pays(gpu):
    n = device.GPU_MIN_VERTICES
    assert device.resolve_device("auto", problem_size=n - 1) == "cpu"
    assert device.resolve_device("auto", problem_size=n) == ("cuda" if gpu else "cpu")


def test_cuda_runs_or_fails_at_once_with_the_reason(gpu):
    if gpu:
        assert device.resolve_device("cuda", problem_size=1) == "cuda"
    else:
        with pytest.raises(DeviceError, match="--device cuda: no CUDA GPU"):
            device.resolve_device("cuda")


def test_an_unknown_device_is_named():
    with pytest.raises(DeviceError, match="'tpu'"):
        device.resolve_device("tpu")
