"""Start positions for dressing (seamfit.sim.dressing): the circle fit that places a flare's
panels on their cone, and start positions that are the same bits under every BLAS kernel set
(a circle skirt settles into other folds from a start one rounding apart)."""
from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from common import SHARED_DATA
from seamfit.pattern.sectors import fit_circle


@pytest.mark.parametrize("centre", [(0.0, 0.0), (0.37, -1.9), (40.0, 25.0)])
def test_circle_fit_recovers_an_arc_far_from_the_origin(centre):
    rng = np.random.default_rng(3)
    ang = np.sort(rng.uniform(0.2, 1.4, 25))
    r = 0.31
    uv = np.c_[centre[0] + r * np.cos(ang), centre[1] + r * np.sin(ang)]
    c, radius, rms = fit_circle(uv)
    assert np.allclose(c, centre, atol=1e-9) and radius == pytest.approx(r, abs=1e-9) and rms < 1e-9


def test_circle_fit_of_a_straight_line_is_no_circle():
    uv = np.c_[np.linspace(0.0, 1.0, 9), 2.0 * np.linspace(0.0, 1.0, 9) + 0.5]
    c, radius, rms = fit_circle(uv)
    assert math.isinf(radius) and math.isinf(rms)


_PROBE = """
import hashlib, sys
import numpy as np
from seamfit.body import load_body
from seamfit.mesh import build_sewn_mesh
from seamfit.opt.sdf_region import body_field
from seamfit.pattern import load_pattern
from seamfit.sim.dressing import initial_positions
data = sys.argv[1]
body = load_body(data + "/bodies/" + sys.argv[2])
sdf, _ = body_field(body, 0.01, "body")
for g in sys.argv[3:]:
    pattern = load_pattern(data + "/patterns/" + g + "/size06/pattern.json")
    mesh = build_sewn_mesh(pattern, 3.0)
    x0, _ = initial_positions(mesh, pattern, sdf)
    print(g, hashlib.sha256(np.ascontiguousarray(x0).tobytes()).hexdigest())
"""


def _kernel_sets() -> list[str]:
    """Two OpenBLAS kernel sets this CPU runs: the SSE3 one and the widest it has."""
    flags = open("/proc/cpuinfo").read()
    wide = "Haswell" if " avx2" in flags else "Sandybridge" if " avx" in flags else "Nehalem"
    return ["Prescott", wide]


def test_start_positions_are_the_same_bits_under_every_blas_kernel_set():
    # The FreeSewing circle skirt goes onto its cone (the circle fit), the t-shirt keeps its
    # exact placement (the panel-to-world map); both went through BLAS, and their base drapes
    # differed by up to 9 cm between kernel sets.
    body = next(p.name for p in (SHARED_DATA / "bodies").iterdir() if "size06" in p.name and p.suffix == ".obj")
    out = []
    for kernels in _kernel_sets():
        env = dict(os.environ, OPENBLAS_CORETYPE=kernels, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
        run = subprocess.run([sys.executable, "-c", _PROBE, str(SHARED_DATA), body, "fs_circle_skirt", "gc_tshirt"],
                             env=env, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr[-2000:]
        out.append(run.stdout)
    assert len(out[0].splitlines()) == 2 and out[0] == out[1]
