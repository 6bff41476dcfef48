"""Checks on a graded (output) pattern against its base, for the grading report.

``output_checks(base, result)`` measures what a pattern maker looks at before cutting a
graded pattern:

* **seams**: every stitch's two sides must still sew together. Non-gathered stitches:
  ``seam_mismatch_mm`` = |length a - length b|. Gathered stitches are meant to differ, so
  their mismatch is measured against the base's gathering ratio r0 = a0 / b0:
  ``seam_mismatch_mm`` = |a - r0 b| (how far side a is from the length that keeps the
  base's gathering, given side b). A stitch passes within ``seam_tol_mm`` (2 mm) or when it
  is no worse than the base's own mismatch (drafted patterns carry designed ease, such as a
  ~3 mm shoulder ease), taken in proportion to the seam's length so that ease graded with
  the panel still counts as no worse.
* **grain**: per panel, the rotation of the best-fit similarity transform (rotation +
  uniform scale + translation) from the base outline to the result outline. The grain
  line is fixed in panel coordinates (sewpat-1: panel +v), so a panel that turned would be
  cut off grain; more than ``grain_tol_deg`` (1 deg) fails.
* **self-intersections** of every result outline (``validate.find_self_intersections``)
  and the panel's orientation (a flipped outline is a different panel).
* **displacement**: ``max_displacement_mm`` is the plain max change of an outline point in
  panel coordinates, no alignment (the paper's Table 1 "maximum displacement");
  ``max_displacement_aligned_mm`` is the same after removing the best-fit translation and
  rotation (the shape change alone, panels drifting in their own frame do not count).

Side lengths are measured along the outline polylines (what the mesher and simulator sew;
after ``refit_pattern(snap=True)`` the outline lies on the curves, and 1 cm samples
under-measure pattern curves by < 0.1 mm).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import PatternError
from .model import Panel, Pattern, Stitch, StitchSide, polyline_length, range_indices
from .validate import find_self_intersections

# Seam sides may differ by 2 mm: below what a sewer notices or has to ease in, and twice
# the ~1 mm to which pattern makers draw and true seams.
SEAM_TOL_MM = 2.0
# Grain: 1 deg puts the grain 1.7 cm off over a 1 m panel, about what laying a grain line
# on fabric by hand achieves; an off-grain woven panel hangs and twists differently (the
# paper removes the panel rotations L-BFGS introduces for this reason, section 7).
GRAIN_TOL_DEG = 1.0
# A stitch is "no worse than the base" up to this slack (mm): sub-micron rounding.
_NO_WORSE_SLACK_MM = 1e-3


def _side_length_cm(pattern: Pattern, side: StitchSide, where: str) -> float:
    try:
        panel = pattern.panel(side.panel)
    except KeyError:
        raise PatternError(f"{where}: unknown panel {side.panel!r}") from None
    n = panel.n_vertices
    if not all(0 <= i < n for i in side.range):
        raise PatternError(f"{where}: range {list(side.range)} outside panel {side.panel!r} "
                           f"(0..{n - 1})")
    return polyline_length(np.asarray(panel.outline_cm, float)[range_indices(side.range, n)])


def _stitch_name(k: int, s: Stitch) -> str:
    return (f"stitch {k} ({s.kind}: {s.a.panel} {list(s.a.range)} / "
            f"{s.b.panel} {list(s.b.range)})")


def _vertex_weights(o: np.ndarray) -> np.ndarray:
    """Half the length of the two segments at each vertex: sums become arc-length integrals,
    so unevenly sampled stretches do not weigh more."""
    seg = np.linalg.norm(np.roll(o, -1, axis=0) - o, axis=1)
    w = 0.5 * (seg + np.roll(seg, 1))
    return w / w.sum() if w.sum() > 0 else np.full(len(o), 1.0 / len(o))


def best_fit_similarity(src: np.ndarray, dst: np.ndarray, weights: np.ndarray | None = None,
                        *, scale: bool = True) -> tuple[float, float, np.ndarray]:
    """Weighted least-squares (rotation angle in radians, scale, translation) taking src
    (m, 2) onto dst: dst ~ s R(angle) src + t. With ``scale=False`` the fit is rigid (s = 1)."""
    src = np.asarray(src, float)
    dst = np.asarray(dst, float)
    w = np.full(len(src), 1.0 / len(src)) if weights is None else np.asarray(weights, float) / np.sum(weights)
    cs, cd = w @ src, w @ dst
    a, b = src - cs, dst - cd
    # 2D Procrustes: the optimal angle maximises sum w (a . R^T b)
    sxx = float(np.sum(w * (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])))
    sxy = float(np.sum(w * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])))
    angle = math.atan2(sxy, sxx)
    var = float(np.sum(w * np.sum(a * a, axis=1)))
    s = (math.hypot(sxx, sxy) / var if var > 0 else 1.0) if scale else 1.0
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    t = cd - s * rot @ cs
    return angle, s, t


def _apply(angle: float, s: float, t: np.ndarray, pts: np.ndarray) -> np.ndarray:
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    return s * np.asarray(pts, float) @ rot.T + t


def _panel_checks(bp: Panel, rp: Panel, where: str, grain_tol_deg: float) -> tuple[dict, list[str]]:
    bo = np.asarray(bp.outline_cm, float)
    ro = np.asarray(rp.outline_cm, float)
    if bo.shape != ro.shape:
        raise PatternError(f"{where}: outline has {len(ro)} points, the base {len(bo)}; output checks "
                           "compare corresponding points (same count and order)")
    if not np.all(np.isfinite(ro)):
        raise PatternError(f"{where}: outline has non-finite (NaN/inf) coordinates")
    msgs = []
    angle, scale, _ = best_fit_similarity(bo, ro, _vertex_weights(bo))
    grain = math.degrees(angle)
    # rigid alignment for the shape-change displacement (rotation + translation only)
    r_angle, _, r_t = best_fit_similarity(bo, ro, _vertex_weights(bo), scale=False)
    aligned = _apply(r_angle, 1.0, r_t, bo)
    crossings = find_self_intersections(ro)
    area_b, area_r = bp.signed_area_cm2(), rp.signed_area_cm2()
    orientation_ok = (area_b > 0) == (area_r > 0) and area_r != 0
    info = {
        "grain_rotation_deg": grain,
        "scale": scale,
        "self_intersections": crossings,
        "orientation_ok": orientation_ok,
        "area_base_cm2": abs(area_b),
        "area_cm2": abs(area_r),
        "area_change_pct": 100.0 * (abs(area_r) - abs(area_b)) / abs(area_b) if area_b else float("nan"),
        "perimeter_base_cm": polyline_length(np.vstack([bo, bo[:1]])),
        "perimeter_cm": polyline_length(np.vstack([ro, ro[:1]])),
        "max_displacement_mm": 10.0 * float(np.linalg.norm(ro - bo, axis=1).max()),
        "max_displacement_aligned_mm": 10.0 * float(np.linalg.norm(ro - aligned, axis=1).max()),
    }
    if abs(grain) > grain_tol_deg:
        msgs.append(f"{where}: grain rotated {grain:+.2f} deg against the base (best-fit rotation "
                    f"after removing translation and scale), more than {grain_tol_deg:g} deg")
    if crossings:
        n = len(ro)
        shown = ", ".join(f"{i}-{(i + 1) % n} x {j}-{(j + 1) % n}" for i, j in crossings[:5])
        msgs.append(f"{where}: self-intersecting outline: {len(crossings)} crossing(s), segments {shown}"
                    + (f" and {len(crossings) - 5} more" if len(crossings) > 5 else ""))
    if not orientation_ok:
        msgs.append(f"{where}: outline turned inside out (signed area {area_b:.1f} cm2 in the base, "
                    f"{area_r:.1f} cm2 now)")
    info["ok"] = not msgs
    return info, msgs


def output_checks(base: Pattern, result: Pattern, *, seam_tol_mm: float = SEAM_TOL_MM,
                  grain_tol_deg: float = GRAIN_TOL_DEG) -> dict:
    """Seam, grain, self-intersection and displacement checks of ``result`` (a graded copy of
    ``base`` with the same panels, point counts and stitches). Returns a dict:

    ``ok``, ``messages`` (one per failure, naming panel or stitch), ``stitches`` (one dict per
    stitch: lengths, ``seam_mismatch_mm``, ``base_mismatch_mm``, ``designed_ease_mm`` (the
    base's mismatch grown with the seam), ``excess_mm`` (the mismatch beyond it), ``ok``),
    ``panels`` (per panel:
    ``grain_rotation_deg``, ``scale``, ``self_intersections``, ``orientation_ok``, areas,
    perimeters, ``max_displacement_mm``, ``max_displacement_aligned_mm``, ``ok``), the maxima
    ``max_seam_mismatch_mm``, ``max_seam_excess_mm``, ``max_grain_rotation_deg``, ``max_displacement_mm`` (plain,
    ``displacement_alignment`` = "none") and ``max_displacement_aligned_mm`` (after the
    best-fit rotation + translation), and the tolerances used.
    Raises PatternError when the two patterns do not correspond.
    """
    src = result.source_file or "<pattern>"
    base_names = [p.name for p in base.panels]
    res_names = [p.name for p in result.panels]
    if sorted(base_names) != sorted(res_names):
        raise PatternError(f"{src}: panels {res_names} do not match the base's {base_names}")
    if len(base.stitches) != len(result.stitches):
        raise PatternError(f"{src}: {len(result.stitches)} stitches, the base has {len(base.stitches)}")
    messages: list[str] = []
    panels: dict[str, dict] = {}
    for rp in result.panels:
        info, msgs = _panel_checks(base.panel(rp.name), rp, f"{src}: panel {rp.name!r}", grain_tol_deg)
        panels[rp.name] = info
        messages += msgs
    stitches = []
    for k, (bs, rs) in enumerate(zip(base.stitches, result.stitches)):
        name = _stitch_name(k, rs)
        where = f"{src}: {name}"
        if (bs.a.panel, bs.b.panel, tuple(bs.a.range), tuple(bs.b.range)) != \
           (rs.a.panel, rs.b.panel, tuple(rs.a.range), tuple(rs.b.range)):
            raise PatternError(f"{where}: does not match base stitch {k} ({bs.a.panel} {list(bs.a.range)} / "
                               f"{bs.b.panel} {list(bs.b.range)})")
        la0 = _side_length_cm(base, bs.a, f"base {name} side a")
        lb0 = _side_length_cm(base, bs.b, f"base {name} side b")
        la = _side_length_cm(result, rs.a, f"{where} side a")
        lb = _side_length_cm(result, rs.b, f"{where} side b")
        if rs.gathered:
            if lb0 <= 0:
                raise PatternError(f"base {name}: side b has zero length; no gathering ratio")
            ratio0 = la0 / lb0
            mismatch, base_mismatch = 10.0 * abs(la - ratio0 * lb), 0.0
            allowed = 0.0
        else:
            ratio0 = None
            mismatch, base_mismatch = 10.0 * abs(la - lb), 10.0 * abs(la0 - lb0)
            # designed ease (a shoulder's ~3 mm) grows with the seam when a panel is graded
            allowed = base_mismatch * (la + lb) / (la0 + lb0) if la0 + lb0 > 0 else base_mismatch
        ok = mismatch <= seam_tol_mm or mismatch <= allowed + _NO_WORSE_SLACK_MM
        entry = {"index": k, "kind": rs.kind, "name": name, "gathered": rs.gathered,
                 "panel_a": rs.a.panel, "panel_b": rs.b.panel,
                 "length_a_cm": la, "length_b_cm": lb, "base_length_a_cm": la0, "base_length_b_cm": lb0,
                 "base_ratio": ratio0, "seam_mismatch_mm": mismatch, "base_mismatch_mm": base_mismatch,
                 "designed_ease_mm": allowed, "excess_mm": max(0.0, mismatch - allowed), "ok": ok}
        stitches.append(entry)
        if not ok:
            if rs.gathered:
                messages.append(f"{where}: gathered sides a {la:.2f} cm, b {lb:.2f} cm are {mismatch:.2f} mm "
                                f"off the base's gathering ratio {ratio0:.4f} (more than {seam_tol_mm:g} mm)")
            else:
                messages.append(f"{where}: sides a {la:.2f} cm and b {lb:.2f} cm differ by {mismatch:.2f} mm, "
                                f"more than {seam_tol_mm:g} mm and more than the base's {base_mismatch:.2f} mm")
    return {
        "ok": not messages,
        "messages": messages,
        "seam_tol_mm": seam_tol_mm,
        "grain_tol_deg": grain_tol_deg,
        "stitches": stitches,
        "panels": panels,
        "max_seam_mismatch_mm": max((s["seam_mismatch_mm"] for s in stitches), default=0.0),
        # beyond the designed ease the base pattern already had (a shoulder's few mm)
        "max_seam_excess_mm": max((s["excess_mm"] for s in stitches), default=0.0),
        "max_grain_rotation_deg": max((abs(p["grain_rotation_deg"]) for p in panels.values()), default=0.0),
        "displacement_alignment": "none",
        "max_displacement_mm": max((p["max_displacement_mm"] for p in panels.values()), default=0.0),
        "max_displacement_aligned_mm": max((p["max_displacement_aligned_mm"] for p in panels.values()),
                                           default=0.0),
        "self_intersections": sum(len(p["self_intersections"]) for p in panels.values()),
    }
