"""The body's SDF built on the GPU (build_sdf(device="cuda")): exact nearest-triangle
distances at every node against brute force over all triangles, the CPU's signs, the CPU's
propagated values (never nearer than exact, at most 0.5 mm farther at 2.5 mm), bounds that
cut the mesh, and a cache key of its own.

The GPU cases exist where a GPU is present (not collected elsewhere, rather than reported
as skipped); the refusal of device cuda where it cannot run exists only there.
"""
from __future__ import annotations

import hashlib

import numpy as np
import pytest

from seamfit._native import core
from seamfit.body import Body, build_sdf, load_body
from seamfit.body import sdf as sdf_mod
from seamfit.errors import DeviceError

from sim_helpers import fresh_sdf_cache  # noqa: F401 (a fixture)
from test_sdf import box_mesh, brute_distance, icosphere
from common import GPU, SAMPLES

BODIES = SAMPLES / "bodies"
PROPAGATED_TOL = 5e-4  # metres: the CPU's propagated values against exact ones at 2.5 mm

pytestmark = pytest.mark.usefixtures("fresh_sdf_cache")


def all_nodes(sdf):
    nx, ny, nz = sdf.dims
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    return sdf.origin + sdf.spacing * np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1)


if GPU:
    def open_sphere():
        V, F = icosphere(0.3, 2)
        keep = V[F].mean(axis=1)[:, 2] < 0.15  # the cap above z = 0.15 removed
        return Body(V, F[keep], name="open sphere")

    @pytest.mark.parametrize("make, bounds", [
        (lambda: Body(*icosphere(0.3, 2), name="sphere"), None),
        (lambda: Body(*box_mesh([-0.2, -0.1, 0.0], [0.2, 0.1, 0.5], n=3), name="box"), None),
        (open_sphere, None),
        # bounds that cut the mesh: the nearest triangles lie outside the box too
        (lambda: Body(*icosphere(0.3, 2), name="sphere"), (-0.1, -0.35, -0.2, 0.35, 0.1, 0.12)),
    ])
    def test_gpu_distances_are_exact_at_every_node(make, bounds):
        body = make()
        gpu = build_sdf(body, spacing=0.02, padding=0.06, bounds=bounds, cache=False, device="cuda")
        cpu = build_sdf(body, spacing=0.02, padding=0.06, bounds=bounds, cache=False)
        assert gpu.info["device"] == "cuda" and cpu.info["device"] == "cpu"
        assert gpu.info["seconds_gpu"] > 0 and gpu.info["propagate_evaluations"] == 0
        assert np.array_equal(gpu.origin, cpu.origin) and gpu.dims == cpu.dims
        exact = brute_distance(all_nodes(gpu), body.vertices, body.faces)
        got = np.abs(gpu.values.ravel().astype(np.float64))
        # float32 values of float-rounded vertices in a grid-centred frame
        assert np.max(np.abs(got - exact)) <= 1e-6
        # the same nodes negated (signbit: a node on the surface is -0.0 on one device and
        # -1e-9 on the other, since the GPU fuses multiply-adds)
        assert np.array_equal(np.signbit(gpu.values), np.signbit(cpu.values))
        assert np.all(got <= np.abs(cpu.values.ravel()) + 1e-6)

    @pytest.mark.parametrize("spacing, bounds, tol", [
        (0.0025, (-0.3, -0.25, 0.85, 0.3, 0.25, 1.15), PROPAGATED_TOL),   # torso band, cut
        (0.0025, (-0.55, -0.25, -0.02, 0.55, 0.25, 0.25), PROPAGATED_TOL),  # feet and shins
        (0.005, None, None),                                             # whole body
    ])
    def test_gpu_field_against_the_cpu_field_on_a_body(spacing, bounds, tol):
        body = load_body(BODIES / "women_size06.obj")
        gpu = build_sdf(body, spacing=spacing, bounds=bounds, cache=False, device="cuda")
        cpu = build_sdf(body, spacing=spacing, bounds=bounds, cache=False)
        assert np.array_equal(gpu.origin, cpu.origin) and gpu.dims == cpu.dims
        g, c = gpu.values.astype(np.float64), cpu.values.astype(np.float64)
        assert np.array_equal(np.signbit(g), np.signbit(c))
        assert gpu.info["inside_nodes"] == cpu.info["inside_nodes"]
        # exact nearest is never farther than a propagated triangle's distance
        assert np.all(np.abs(g) <= np.abs(c) + 1e-6)
        if tol is not None:
            assert np.max(np.abs(g - c)) <= tol
        # at a sample of nodes: exact
        rng = np.random.default_rng(5)
        pick = rng.choice(g.size, 400, replace=False)
        P = all_nodes(gpu)[pick]
        exact = brute_distance(P, body.vertices, body.faces)
        assert np.max(np.abs(np.abs(g.ravel()[pick]) - exact)) <= 1e-6

    def test_gpu_field_has_its_own_cache_entry(tmp_path):
        V, F = box_mesh([-0.2, -0.1, 0.0], [0.2, 0.1, 0.8], n=3)
        body = Body(V, F, name="smallbox")
        cpu = build_sdf(body, spacing=0.01)
        gpu = build_sdf(body, spacing=0.01, device="cuda")
        assert cpu.source == "built" and gpu.source == "built"
        assert sdf_mod.sdf_cache_key(body, 0.01, 0.05) != sdf_mod.sdf_cache_key(body, 0.01, 0.05, device="cuda")
        assert len(list((tmp_path / "cache" / "sdf").glob("*.npz"))) == 2
        sdf_mod.clear_memory_cache()
        assert build_sdf(body, spacing=0.01, device="cuda").source == "disk cache"
        again = build_sdf(body, spacing=0.01)
        assert again.source == "disk cache" and again.info["device"] == "cpu"
        assert np.array_equal(again.values, cpu.values)
else:
    def test_device_cuda_refused_without_a_gpu():
        V, F = box_mesh([-0.2, -0.1, 0.0], [0.2, 0.1, 0.8], n=3)
        body = Body(V, F, name="smallbox")
        with pytest.raises(DeviceError, match="device cuda: .*(no CUDA backend|no CUDA GPU)"):
            build_sdf(body, spacing=0.02, device="cuda")
        # the compiled core says so too, in one line
        with pytest.raises((ValueError, DeviceError), match="device cuda: .*(no CUDA backend|no CUDA GPU)"):
            core().sdf_build(V, F, spacing=0.02, device="cuda")


def test_cpu_cache_key_unchanged_and_unknown_device_refused():
    V, F = box_mesh([-0.2, -0.1, 0.0], [0.2, 0.1, 0.8], n=3)
    body = Body(V, F, name="smallbox")
    # the CPU's key is the one from before the GPU builder: its cached fields stay valid
    h = hashlib.sha256(f"{sdf_mod.FORMAT}/{sdf_mod.ALGORITHM_VERSION}".encode())
    h.update(V.astype(np.float64).tobytes() + b"|faces|" + F.astype(np.int32).tobytes())
    h.update(repr((0.01, 0.05, None)).encode())
    assert sdf_mod.sdf_cache_key(body, 0.01, 0.05) == h.hexdigest()[:40]
    assert sdf_mod.sdf_cache_key(body, 0.01, 0.05, device="cpu") == h.hexdigest()[:40]
    assert sdf_mod.sdf_cache_key(body, 0.01, 0.05, device="cuda") != h.hexdigest()[:40]
    with pytest.raises(DeviceError, match="unknown device"):
        build_sdf(body, spacing=0.02, device="gpu")
    with pytest.raises(ValueError, match="unknown device"):
        core().sdf_build(V, F.astype(np.int32), spacing=0.02, device="gpu")


def test_a_base_drape_keeps_to_the_builder_of_its_field(monkeypatch):
    """The base drape's cache key: the same as before for a CPU-built field (its cached
    drapes stay valid), its own for a GPU-built one (a drape settled on one field is not
    served for the other)."""
    from seamfit.mesh import build_sewn_mesh
    from seamfit.opt import prepare as prep
    from seamfit.pattern import load_pattern
    from seamfit.sim import Fabric, SimSettings
    samples = BODIES.parent
    pattern = load_pattern(samples / "patterns/gc_pencil_skirt/size06/pattern.json")
    mesh = build_sewn_mesh(pattern, edge_length_cm=6.0)
    body = load_body(BODIES / "women_size06.obj")
    keys = []

    def hit(kind, key, expect=None):   # a cache hit: no drape is run
        keys.append(key)
        return {"x": mesh.x0.copy(), "residual": np.float64(0), "seconds": np.float64(0)}

    monkeypatch.setattr(prep, "load_arrays", hit)
    settings, fabric = SimSettings(), Fabric()
    cpu_field = build_sdf(body, spacing=0.02)
    gpu_like = sdf_mod.SignedDistanceField(cpu_field.values, cpu_field.origin, cpu_field.spacing,
                                           {**cpu_field.info, "device": "cuda"})
    for sdf in (cpu_field, gpu_like):
        prep.base_drape(mesh, pattern, body, sdf, fabric, settings)
    from dataclasses import asdict
    physics = {k: v for k, v in asdict(settings).items() if k != "device"}
    before = prep.content_key(prep.DRAPE_CACHE_VERSION, mesh.cache_key(), body.vertices, body.faces, 0.02,
                              asdict(fabric), physics)
    assert keys[0] == before and keys[1] != before
