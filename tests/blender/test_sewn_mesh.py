# SPDX-License-Identifier: GPL-3.0-or-later
"""The sewn mesh: seamfit's mesh of the pattern in Blender's cloth convention."""
import bpy
import numpy as np

from helpers import PENCIL, object_fingerprint


def test_sewn_mesh_matches_seamfit(scene):
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    s = scene.seamfit
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    base = s.pattern
    before = sorted(object_fingerprint(o) for o in base.objects)
    s.edge_length_cm = 4.0
    assert bpy.ops.seamfit.build_mesh() == {"FINISHED"}
    want = build_sewn_mesh(load_pattern(PENCIL), edge_length_cm=4.0)
    coll = bpy.data.collections[f"{base.name} sewn mesh"]
    (obj,) = coll.objects
    me = obj.data
    assert len(me.vertices) == len(want.uv_cm) and len(me.polygons) == len(want.triangles)
    co = np.empty(3 * len(me.vertices))
    me.vertices.foreach_get("co", co)
    assert np.allclose(co.reshape(-1, 3), want.x0, atol=1e-6)
    # Sewing pairs are loose edges (in no face), each tagged with its stitch.
    stitch = np.empty(len(me.edges), dtype=np.int32)
    me.attributes["stitch"].data.foreach_get("value", stitch)
    ev = np.empty(2 * len(me.edges), dtype=np.int64)
    me.edges.foreach_get("vertices", ev)
    ev = np.sort(ev.reshape(-1, 2), axis=1)
    sewn = {tuple(e): k for e, k in zip(ev, stitch) if k >= 0}
    assert sewn == {tuple(sorted(p)): int(k) for p, k in zip(want.sewing_pairs, want.pair_stitch)}
    loose = {e for p in me.polygons for e in p.edge_keys}
    assert not (set(sewn) & loose)
    panel = np.empty(len(me.polygons), dtype=np.int32)
    me.attributes["panel"].data.foreach_get("value", panel)
    assert np.array_equal(panel, want.triangle_panel)
    # Flat at the placements, nothing is stretched.
    ratio = np.empty(len(me.vertices), dtype=np.float32)
    me.attributes["stretch_ratio"].data.foreach_get("value", ratio)
    assert np.allclose(ratio, 1.0, atol=1e-5)
    # The base pattern is untouched.
    assert sorted(object_fingerprint(o) for o in base.objects) == before
