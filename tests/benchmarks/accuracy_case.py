"""One case of the accuracy benchmark: a garment's base pattern graded to one body, every
method and both baselines scored against the drafting system's own pattern for that body.

Used by bench_accuracy.py (each case runs in its own process); returns a JSON-able dict.
"""
from __future__ import annotations

import dataclasses
import json
import time
import traceback
from pathlib import Path

import numpy as np

from seamfit.body import load_body
from seamfit.body.measure import body_measurements
from seamfit.pattern import baseline_errors, change_captured, landmark_errors, load_pattern, save_pattern
from seamfit.pattern.scale import proportional_scale

EASE_LEVELS = ("bust", "waist", "hip")


def body_file(bodies: Path, body_id: str) -> Path:
    """The mesh of a pattern body id: size10 -> women_size10.obj, man_medium -> men_medium.obj."""
    stem = body_id.removeprefix("man_")
    for name in (f"women_{body_id}.obj", f"men_{stem}.obj", f"{body_id}.obj"):
        if (bodies / name).is_file():
            return bodies / name
    raise FileNotFoundError(f"no body mesh for {body_id!r} in {bodies}")


def measurements_cm(bodies: Path, path: Path, body) -> dict:
    """height/bust/waist/hip (cm): the data set's achieved values when listed, else measured."""
    table = bodies / "measurements.json"
    if table.is_file():
        entry = json.loads(table.read_text()).get("bodies", {}).get(path.stem)
        if entry and "achieved_cm" in entry:
            return {k: float(v) for k, v in entry["achieved_cm"].items()}
    m = body_measurements(body)
    return {k: float(v) for k, v in m.items() if isinstance(v, (int, float))}


def _error(exc: BaseException) -> dict:
    tb = traceback.format_exception(type(exc), exc, exc.__traceback__)
    return {"ok": False, "error": f"{type(exc).__name__}: {exc}", "traceback": "".join(tb[-3:])}


def _score(rep) -> dict:
    return {"max_cm": rep.max_cm, "mean_cm": rep.mean_cm, "n_points": rep.n_points,
            "worst": list(rep.worst) if rep.worst else None,
            "panels": {n: {"max_cm": p.max_cm, "mean_cm": p.mean_cm, "matching": p.matching,
                           "perimeter_diff_cm": p.perimeter_diff_cm, "area_diff_pct": p.area_diff_pct}
                       for n, p in rep.panels.items()},
            "order_matched": [n for n, p in rep.panels.items() if p.matching == "order"],
            "only_in_truth": rep.only_in_truth, "only_in_result": rep.only_in_result}


def captured(result, base, truth) -> dict:
    """How much of the drafted change the result makes: in all, across the grain (u) and
    along it (v) (seamfit.pattern.compare.change_captured)."""
    return {"change_captured": change_captured(result, base, truth),
            "change_captured_uv": [change_captured(result, base, truth, axis=a) for a in (0, 1)]}


def ease_errors(base: dict, ease: dict | None) -> dict:
    """|ease - base ease| per level both have (cm) and their max (None when none)."""
    if not ease:
        return {"levels": {}, "max_cm": None}
    lv = {k: abs(ease[k] - base[k]) for k in EASE_LEVELS
          if base.get(k) is not None and ease.get(k) is not None}
    return {"levels": lv, "max_cm": max(lv.values()) if lv else None}


class BaselineDrapes:
    """Drapes of fixed patterns on the target body, to measure the ease of the baselines.

    The same start as the grading (base garment draped on the base body, carried to the
    target by Transfer, Eq. 15) and the same exact solve as its 'base pattern on target'
    step; the pattern only changes the rest shape, through per-panel affine maps of the
    base mesh's pattern coordinates."""

    def __init__(self, base_pattern, base_body, target_body, settings):
        from seamfit.body import build_sdf
        from seamfit.mesh import build_sewn_mesh
        from seamfit.opt.fit import ease_report
        from seamfit.opt.grade import base_drape
        from seamfit.opt.transfer import transfer_garment
        from seamfit.sim.model import Fabric, SimSettings, Simulator

        self.pattern, self.target_body = base_pattern, target_body
        self.mesh = build_sewn_mesh(base_pattern, edge_length_cm=settings.edge_length_cm)
        base_sdf = build_sdf(base_body, spacing=settings.sdf_spacing)
        target_sdf = build_sdf(target_body, spacing=settings.sdf_spacing)
        self.sim_settings = SimSettings()
        xbar, _ = base_drape(self.mesh, base_pattern, base_body, base_sdf, Fabric(), self.sim_settings)
        self.xtilde = transfer_garment(xbar, base_body, target_body, settings.bandwidth)
        self.sim = Simulator(self.mesh, target_sdf, Fabric(), self.sim_settings)
        self.tolerance = self.sim_settings.tolerance
        self._ease = ease_report
        self.base_ease = ease_report(base_body, xbar, self.mesh.triangles)

    def ease(self, sx: float = 1.0, sy: float = 1.0) -> dict:
        """Ease (cm) of the base pattern scaled by (sx, sy) per panel, as scale_pattern does,
        draped on the target; with the solve's convergence."""
        uv = np.asarray(self.mesh.uv_cm, dtype=float).copy()
        vp = np.asarray(self.mesh.vertex_panel)
        for k, name in enumerate(self.mesh.panel_names):
            o = self.pattern.panel(name).outline_cm
            c = 0.5 * (o.min(axis=0) + o.max(axis=0))
            idx = vp == k
            uv[idx] = c + (uv[idx] - c) * np.array([sx, sy])
        return self._drape(0.01 * uv)

    def draft_ease(self, draft) -> dict:
        """Ease (cm) of the drafted pattern for the target, put on the base mesh edge by edge
        (``draft_on_mesh``) and draped the same way: the ease the drafting system gives that
        body. Raises ValueError where the draft's panels have other edges than the base's."""
        from draft_on_mesh import truth_on_mesh
        from seamfit.opt.parametrization import Parametrization
        param = Parametrization(self.mesh)
        return self._drape(param.pattern(truth_on_mesh(self.mesh, param, self.pattern, draft)))

    def _drape(self, uv_m) -> dict:
        self.sim.set_pattern(uv_m)
        t0 = time.perf_counter()
        res = self.sim.solve(self.xtilde, tolerance=self.tolerance)
        return {"ease_cm": self._ease(self.target_body, res.x, self.mesh.triangles),
                "drape_converged": bool(res.converged), "drape_residual": float(res.residual),
                "drape_seconds": time.perf_counter() - t0}


def _grade_settings(method: str, kw: dict):
    from seamfit.opt.grade import GradeSettings
    if method != "adjoint":
        if "method" not in {f.name for f in dataclasses.fields(GradeSettings)}:
            raise ValueError(f"method {method!r} is not available: this build's GradeSettings has "
                             "no 'method' option (only the adjoint solver)")
        kw = {**kw, "method": method}
    return GradeSettings(**kw)


def run_case(data: Path, garment: str, body: str, base_id: str, methods: list[str], grade_kw: dict,
             *, save_dir: Path | None = None, baseline_ease: bool = True) -> dict:
    """Score every method and both baselines on (garment, body); errors are recorded per
    method, never raised."""
    from seamfit.opt.grade import grade

    pdir, bodies = data / "patterns" / garment, data / "bodies"
    case: dict = {"garment": garment, "body": body, "base": base_id, "methods": {}}
    t_case = time.perf_counter()
    try:
        base = load_pattern(pdir / base_id / "pattern.json")
        truth = load_pattern(pdir / body / "pattern.json")
        b0_path, b1_path = body_file(bodies, base_id), body_file(bodies, body)
        b0, b1 = load_body(b0_path), load_body(b1_path)
        m0, m1 = measurements_cm(bodies, b0_path, b0), measurements_cm(bodies, b1_path, b1)
    except Exception as exc:                      # the case cannot start: say why, once
        case["error"] = _error(exc)
        return case
    case["garment_type"] = base.garment_type
    case["measurements_cm"] = {"base": {k: m0.get(k) for k in ("height", "bust", "waist", "hip")},
                               "target": {k: m1.get(k) for k in ("height", "bust", "waist", "hip")}}

    t0 = time.perf_counter()
    unchanged = {"ok": True, **_score(baseline_errors(base, truth)), "seconds": 0.0}
    unchanged["score_seconds"] = time.perf_counter() - t0
    try:
        t0 = time.perf_counter()
        scaled_pattern, ratios = proportional_scale(base, m0, m1)
        scaled = {"ok": True, "seconds": time.perf_counter() - t0, "ratios": ratios,
                  **_score(landmark_errors(scaled_pattern, truth)),
                  **captured(scaled_pattern, base, truth)}
        if save_dir is not None:
            save_pattern(scaled_pattern, save_dir / "scaled.json", overwrite=True)
    except Exception as exc:
        scaled = _error(exc)

    base_ease = None
    if baseline_ease:
        try:
            drapes = BaselineDrapes(base, b0, b1, _grade_settings("adjoint", grade_kw))
            base_ease = drapes.base_ease
            unchanged.update(drapes.ease())
            if scaled.get("ok"):
                scaled.update(drapes.ease(scaled["ratios"]["sx"], scaled["ratios"]["sy"]))
            try:
                case["draft"] = drapes.draft_ease(truth)
            except Exception as exc:
                case["draft"] = {"ease_note": f"not measured: {type(exc).__name__}: {exc}"}
        except Exception as exc:
            note = f"not measured: {type(exc).__name__}: {exc}"
            unchanged["ease_note"] = scaled["ease_note"] = note
    else:
        unchanged["ease_note"] = scaled["ease_note"] = "not measured (--no-baseline-ease)"

    for name in methods:
        try:
            settings = _grade_settings(name, grade_kw)
            res = grade(base, b0, b1, settings)
            rep = res.report
            out = {"ok": True, **_score(landmark_errors(res.pattern, truth)), "seconds": rep["seconds_total"],
                   **captured(res.pattern, base, truth),
                   "ease_cm": rep["ease_cm"]["result"], "converged": rep["converged"],
                   "message": rep["message"], "outer_iterations": rep["outer_iterations"],
                   "objective_initial": rep["objective_initial"], "objective_final": rep["objective_final"],
                   "objective_base_pattern": rep.get("objective_base_pattern"),
                   "refit_ok": rep["refit"]["ok"], "max_displacement_mm": rep["max_displacement_mm"],
                   "max_seam_mismatch_mm": rep["checks"].get("max_seam_mismatch_mm"),
                   "max_seam_excess_mm": rep["checks"].get("max_seam_excess_mm"),
                   "seams_ok": all(s_["ok"] for s_ in rep["checks"].get("stitches", []))}
            base_ease = base_ease or rep["ease_cm"]["base"]
            if save_dir is not None:
                res.pattern.body_id = body
                save_pattern(res.pattern, save_dir / f"{name}.json", overwrite=True)
        except Exception as exc:
            out = _error(exc)
        case["methods"][name] = out

    case["base_ease_cm"] = base_ease
    draft_ease = (case.get("draft") or {}).get("ease_cm")
    if base_ease is not None and draft_ease:
        case["draft"]["ease_error"] = ease_errors(base_ease, draft_ease)
    for entry in (*case["methods"].values(), unchanged, scaled):
        if entry.get("ok") and base_ease is not None and "ease_cm" in entry:
            entry["ease_error"] = ease_errors(base_ease, entry["ease_cm"])
        if entry.get("ok") and draft_ease and "ease_cm" in entry:
            # against the ease the drafting system gave this body, which need not be the base's
            entry["ease_vs_draft"] = ease_errors(draft_ease, entry["ease_cm"])
    case["methods"]["unchanged"] = unchanged
    case["methods"]["scaled"] = scaled
    case["seconds"] = time.perf_counter() - t_case
    return case
