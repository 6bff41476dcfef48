"""Device selection (--device auto|cpu|cuda): the policy, with the GPU's presence and the
machine's measured speeds stubbed so it is checked on any machine; the calibration itself
(measured on the CPU here) and its cache."""
import json
import math

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


def _fake_calibration(monkeypatch, cpu, cuda):
    import seamfit.device_calibration as dc
    from seamfit import _native

    class Core:
        def cuda_device_name(self, i=0):
            return "Fake GPU"
    monkeypatch.setattr(_native, "core", lambda: Core())
    data = {"threads": 2, "source": "stub",
            "devices": {"cpu": {"t0_s": cpu[0], "t1_s": cpu[1]}, "cuda": {"t0_s": cuda[0], "t1_s": cuda[1]}}}
    monkeypatch.setattr(dc, "calibration", lambda gpu_name: data)


def test_auto_takes_the_device_predicted_faster(gpu, monkeypatch):
    # CPU 100 ns per vertex, GPU 50 us launch overhead + 5 ns per vertex: they cross at 526.
    _fake_calibration(monkeypatch, (0.0, 1e-7), (5e-5, 5e-9))
    small = device.choose_device("auto", problem_size=400)
    large = device.choose_device("auto", problem_size=700)
    assert small["device"] == "cpu"
    assert large["device"] == ("cuda" if gpu else "cpu")
    if gpu:
        t = large["predicted_seconds_per_iteration"]
        assert math.isclose(t["cpu"], 7e-5) and math.isclose(t["cuda"], 5e-5 + 3.5e-6)
        assert "us per simulator iteration" in large["reason"]
    else:
        assert "no CUDA GPU" in large["reason"]


def test_cuda_runs_or_fails_at_once_with_the_reason(gpu):
    if gpu:
        assert device.resolve_device("cuda", problem_size=1) == "cuda"
    else:
        with pytest.raises(DeviceError, match="--device cuda: no CUDA GPU"):
            device.resolve_device("cuda")


def test_an_unknown_device_is_named():
    with pytest.raises(DeviceError, match="'tpu'"):
        device.resolve_device("tpu")


def test_a_cached_calibration_is_checked_before_use():
    from seamfit.device_calibration import check_calibration
    good = {"key": "k", "devices": {"cpu": {"t0_s": 0.0, "t1_s": 1e-7}, "cuda": {"t0_s": 2e-5, "t1_s": 1e-9}}}
    assert check_calibration(good, "k") is None
    assert "another machine" in check_calibration(good, "other")
    bad = json.loads(json.dumps(good))
    bad["devices"]["cuda"]["t1_s"] = float("nan")
    assert "cuda timing" in check_calibration(bad, "k")
    del bad["devices"]["cuda"]
    assert "both devices" in check_calibration(bad, "k")
    assert check_calibration([1, 2], "k") is not None


def test_the_cpu_half_of_the_calibration_measures_a_line(monkeypatch):
    # The measurement itself, CPU only (no GPU here): per-iteration time grows with size.
    import seamfit.device_calibration as dc
    monkeypatch.setattr(dc, "DEVICES", ("cpu",))
    monkeypatch.setattr(dc, "EDGE_LENGTHS_CM", (4.0, 2.0))
    monkeypatch.setattr(dc, "TIMED_ITERATIONS", 8)
    m = dc._measure()
    cpu = m["devices"]["cpu"]
    n0, n1 = (r["vertices"] for r in cpu["measured"])
    assert n1 > 2 * n0
    assert cpu["t1_s"] > 0 and cpu["t0_s"] >= 0
    for r in cpu["measured"]:
        assert r["seconds_per_iteration"] > 0


def test_a_bad_calibration_file_is_measured_again(tmp_path, monkeypatch):
    import seamfit.device_calibration as dc
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path))
    calls = []
    fresh = {"devices": {"cpu": {"t0_s": 0.0, "t1_s": 1e-7}, "cuda": {"t0_s": 2e-5, "t1_s": 1e-9}}, "seconds": 0.1}
    monkeypatch.setattr(dc, "_measure", lambda: calls.append(1) or fresh)
    key = dc.machine_key("Fake GPU")
    path = tmp_path / "device" / f"{key}.json"
    path.parent.mkdir(parents=True)
    path.write_text("{not json")
    first = dc.calibration("Fake GPU")
    assert calls == [1] and first["source"].startswith("measured now")
    assert dc.check_calibration(json.loads(path.read_text()), key) is None
    second = dc.calibration("Fake GPU")
    assert calls == [1] and second["source"].startswith("measured earlier")
