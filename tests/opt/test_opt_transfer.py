"""Deformation transfer (Eq. 15): exactness for identity, rigid and scaled bodies,
continuity across the switch between two body parts, topology checks and speed."""
import time

import numpy as np
import pytest

import opt_synthetic as S
from seamfit.errors import BodyError
from seamfit.opt import transfer_garment
from common import SAMPLES

BODIES = SAMPLES / "bodies"


@pytest.fixture(scope="module")
def base_body():
    return S.load_obj(BODIES / "women_size06.obj")


def points_near(body, n, rng, lo=-0.005, hi=0.06):
    """Random points offset from the body surface along face normals (a loose garment)."""
    v, f = body
    t = rng.integers(0, len(f), n)
    b = rng.dirichlet(np.ones(3), n)
    a, bb, c = v[f[t, 0]], v[f[t, 1]], v[f[t, 2]]
    nrm = np.cross(bb - a, c - a)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return b[:, :1] * a + b[:, 1:2] * bb + b[:, 2:] * c + rng.uniform(lo, hi, (n, 1)) * nrm


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_identity_rigid_and_scaled_bodies_are_exact(base_body):
    rng = np.random.default_rng(0)
    v, f = base_body
    x = points_near(base_body, 3000, rng)
    xt, info = transfer_garment(x, base_body, base_body, return_info=True)
    assert np.abs(xt - x).max() < 1e-12
    assert (info["t1"] >= 0).any() and (info["w0"] < 1).any()  # blending is exercised
    R, t = rotation([0.2, 1.0, 0.3], 0.4), np.array([0.1, -0.2, 0.05])
    assert np.abs(transfer_garment(x, base_body, (v @ R.T + t, f)) - (x @ R.T + t)).max() < 1e-12
    assert np.abs(transfer_garment(x, base_body, (1.1 * v, f)) - 1.1 * x).max() < 1e-12


def test_topology_must_match(base_body):
    v, f = base_body
    x = v[:10] + 0.01
    with pytest.raises(BodyError, match="topology"):
        transfer_garment(x, base_body, (v[:-1], f[:-1]))
    with pytest.raises(BodyError, match="topology"):
        transfer_garment(x, base_body, (v, f[:, [0, 2, 1]]))


def path_steps(xt):
    return np.linalg.norm(np.diff(xt, axis=0), axis=1)


def check_continuity(base, target, path, bandwidth):
    """Blended transfer has no jump along the path; the closest-triangle-only transfer
    (a vanishing bandwidth) does, at the switch between the two body parts."""
    smooth, info = transfer_garment(path, base, target, bandwidth, return_info=True)
    hard = transfer_garment(path, base, target, 1e-9)
    s_smooth, s_hard = path_steps(smooth), path_steps(hard)
    spacing = np.median(path_steps(path))
    switch = np.flatnonzero(np.diff(info["t0"] // (len(base[1]) // 2)) != 0)  # which body part
    assert len(switch) == 1, "the path should cross from one body part to the other once"
    assert s_hard.max() > 20 * spacing          # the simple transfer jumps
    assert s_smooth.max() < 3 * spacing         # ours does not
    i = switch[0]
    assert abs(info["w0"][i] - 0.5) < 0.01      # equal weights at the tie
    return s_smooth.max() / spacing, s_hard.max() / spacing


def test_continuous_between_the_legs():
    base = S.merge(S.tube([-0.09, 0.0], 0.07, 0.0, 1.0), S.tube([0.09, 0.0], 0.07, 0.0, 1.0))
    v, f = base
    n = len(v) // 2
    tv = v.copy()
    tv[:n, :2] = (v[:n, :2] - [-0.09, 0.0]) * (0.08 / 0.07) + [-0.09, 0.0]   # left leg thicker
    tv[n:] += [0.012, 0.004, 0.0]                                               # right leg moved
    xs = np.linspace(-0.1, 0.1, 2001)
    path = np.stack([xs, np.full_like(xs, 0.1), np.full_like(xs, 0.5)], 1)    # in front of both legs
    check_continuity(base, (tv, f), path, bandwidth=0.02)


def test_continuous_between_arm_and_torso():
    base = S.merge(S.tube([0.0, 0.0], 0.15, 0.0, 1.0, n_around=96), S.tube([0.21, 0.0], 0.04, 0.0, 1.0, n_around=96))
    v, f = base
    n = len(v) // 2
    tv = v.copy()
    tv[:n, :2] *= 1.1                      # torso grows
    tv[n:] += [0.015, 0.0, 0.0]            # arm moves out with it
    xs = np.linspace(0.10, 0.30, 2001)
    path = np.stack([xs, np.full_like(xs, 0.1), np.full_like(xs, 0.5)], 1)
    check_continuity(base, (tv, f), path, bandwidth=0.02)


def test_thirty_thousand_vertices_in_about_a_second(base_body):
    rng = np.random.default_rng(1)
    target = S.load_obj(BODIES / "women_size10.obj")
    x = points_near(base_body, 30000, rng, -0.005, 0.06)
    t0, c0 = time.perf_counter(), time.process_time()
    xt = transfer_garment(x, base_body, target)
    dt = time.perf_counter() - t0
    print(f"\ntransfer of 30000 vertices: {dt:.2f} s wall, {time.process_time() - c0:.2f} s CPU")
    assert np.isfinite(xt).all()
    # Size 10 is larger than size 6: the garment moves, but stays in proportion.
    d = np.linalg.norm(xt - x, axis=1)
    assert 0.001 < np.median(d) < 0.05
    assert dt < 30.0  # generous: the test machine's cores are shared; about a second when idle
