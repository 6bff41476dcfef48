"""How fast this machine's CPU and GPU run the simulator, measured once and cached, so that
``--device auto`` can predict which device grades a garment faster (seamfit.device).

The measurement drapes a square sheet (no body) meshed at two resolutions and times a fixed
number of Chebyshev iterations (the grading's inner loop, the bulk of its time) on each
device after a warm-up, which takes the GPU's one-off costs (transfers, graph capture) out.
Per device the time per iteration is fitted as a line in the vertex count, t(n) = t0 + t1 n:
t0 is the GPU's launch overhead that dominates small garments, t1 the cost per vertex.

The result is cached as JSON under the cache folder (``device/<machine key>.json``), keyed
by the CPU model, the number of threads, the GPU's name and seamfit's version, and checked
when read (finite, positive numbers, the same key); a bad file is measured again.
"""
from __future__ import annotations

import json
import math
import os
import platform
import time
from typing import Optional

import numpy as np

from . import __version__
from .cache import cache_root, content_key

__all__ = ["calibration", "machine_key", "check_calibration", "predicted_seconds_per_iteration"]

# Mesh edge lengths (cm) of the 80 cm sheet: about 1,900 and 15,000 vertices, around the
# sizes where the choice changes; larger garments are extrapolated along the line.
SHEET_CM = 80.0
EDGE_LENGTHS_CM = (2.0, 0.7)
WARMUP_ITERATIONS = 8
TIMED_ITERATIONS = 48
DEVICES = ("cpu", "cuda")


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _threads() -> int:
    env = os.environ.get("OMP_NUM_THREADS", "")
    return int(env) if env.isdigit() and int(env) > 0 else (os.cpu_count() or 1)


def machine_key(gpu_name: str) -> str:
    """What the measurement depends on: CPU, threads, GPU and seamfit's own code."""
    return content_key(_cpu_model(), _threads(), gpu_name, __version__)[:32]


def _sheet():
    from .pattern.model import Edge, Panel, Pattern, Placement
    o = np.array([[0.0, 0.0], [SHEET_CM, 0.0], [SHEET_CM, SHEET_CM], [0.0, SHEET_CM]])
    edges = [Edge(id=k, start=k, end=(k + 1) % 4, kind="line", p0=tuple(o[k]), p1=tuple(o[(k + 1) % 4]))
             for k in range(4)]
    # hung vertically, as a garment panel is
    place = Placement(kind="exact", rotation=np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]),
                      translation_m=np.array([-0.4, -0.3, 0.6]))
    return Pattern(panels=[Panel(name="sheet", outline_cm=o, orientation="ccw", nodes=[0, 1, 2, 3],
                                 corners=[0, 1, 2, 3], landmarks={}, edges=edges, placement=place)],
                   stitches=[])


def _measure() -> dict:
    from .mesh import build_sewn_mesh
    from .sim.model import Fabric, SimSettings, Simulator
    sizes, per_it = [], {d: [] for d in DEVICES}
    t_start = time.perf_counter()
    for edge in EDGE_LENGTHS_CM:
        mesh = build_sewn_mesh(_sheet(), edge_length_cm=edge)
        sim = Simulator(mesh, None, Fabric(), SimSettings())
        sizes.append(int(mesh.n_vertices))
        for dev in DEVICES:
            sim.iterate(None, WARMUP_ITERATIONS, device=dev)
            t = time.perf_counter()
            sim.iterate(None, TIMED_ITERATIONS, device=dev)
            per_it[dev].append((time.perf_counter() - t) / TIMED_ITERATIONS)
    fit = {}
    for dev in DEVICES:
        (n0, n1), (s0, s1) = sizes, per_it[dev]
        slope = max((s1 - s0) / (n1 - n0), 0.0)
        fit[dev] = {"t0_s": max(s0 - slope * n0, 0.0), "t1_s": slope,
                    "measured": [{"vertices": n, "seconds_per_iteration": s} for n, s in zip(sizes, per_it[dev])]}
    return {"devices": fit, "seconds": time.perf_counter() - t_start}


def check_calibration(data, key: str) -> Optional[str]:
    """Why a loaded calibration cannot be used, or None."""
    if not isinstance(data, dict) or data.get("key") != key:
        return "written for another machine or seamfit"
    devs = data.get("devices")
    if not isinstance(devs, dict) or set(devs) != set(DEVICES):
        return "no timing for both devices"
    for dev, d in devs.items():
        vals = [d.get("t0_s"), d.get("t1_s")] if isinstance(d, dict) else [None]
        if not all(isinstance(v, (int, float)) and math.isfinite(v) and v >= 0 for v in vals) or \
                d["t0_s"] + d["t1_s"] <= 0:
            return f"{dev} timing is not a finite positive number"
    return None


def calibration(gpu_name: str) -> dict:
    """The cached measurement of this machine, measuring it first when there is none (a few
    seconds, once). Its "source" says which."""
    from .fileio import atomic_write_text
    key = machine_key(gpu_name)
    path = cache_root() / "device" / f"{key}.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if check_calibration(data, key) is None:
            return {**data, "source": f"measured earlier ({path})"}
    except (OSError, ValueError):
        pass
    data = {"key": key, "cpu": _cpu_model(), "threads": _threads(), "gpu": gpu_name,
            "seamfit": __version__, **_measure()}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(data, indent=1) + "\n")
    except OSError:
        pass                                   # a read-only cache: measure again next time
    return {**data, "source": f"measured now ({data['seconds']:.1f} s)"}


def predicted_seconds_per_iteration(data: dict, vertices: int) -> dict:
    """Per device, the predicted seconds of one simulator iteration at this many vertices."""
    return {dev: d["t0_s"] + d["t1_s"] * vertices for dev, d in data["devices"].items()}
