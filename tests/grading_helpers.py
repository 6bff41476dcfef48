"""The sample grading the adjoint and device tests share: the pencil skirt graded from the
size 6 body to size 10, prepared, and its base pattern's exact drape on the target."""
from __future__ import annotations

from common import SAMPLES



def settled_sample_grading(edge_length_cm: float, device: str, strengths=None):
    """(ctx, x): the grading context (SDFs at 5 mm) and the exact target drape x of the
    unchanged pattern, which the test asserts converged."""
    from seamfit.body import load_body
    from seamfit.opt.grade import GradeSettings
    from seamfit.opt.prepare import prepare
    from seamfit.pattern import load_pattern

    settings = GradeSettings(strengths=strengths, edge_length_cm=edge_length_cm, sdf_spacing=0.005, device=device,
                             evaluate_base_pattern=False)
    ctx = prepare(load_pattern(SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"),
                  load_body(SAMPLES / "bodies/women_size06.obj"), load_body(SAMPLES / "bodies/women_size10.obj"),
                  settings)
    res = ctx.exact(ctx.param.theta_bar, ctx.xtilde, "test")
    assert res.converged
    return ctx, res.x
