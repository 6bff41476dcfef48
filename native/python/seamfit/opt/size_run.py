"""A size run: one base pattern graded to several bodies in one go (``seamfit grade-run``).

The sizes stand in a row, smallest to largest, with the base among them. Grading walks
outward from the base: each size starts from its inner neighbour's result (the move its
neighbour's search made from its own initialization, ``seamfit.opt.grade.grade``'s
``warm_start``) and every size shares what depends only on the base (sewn mesh, base body
field, base drape, base ease; ``shared``).

After the run, each landmark's place is followed along the row in the nest's frame (each
panel's bounding-box top-centre, as the nest picture aligns them): a size whose landmark
moves back against the way the run carries it is a jump.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from ..pattern import Pattern

# A landmark moving back by more than this (mm) between neighbouring sizes is a jump;
# below it, refit and snapping noise.
JUMP_TOLERANCE_MM = 0.5


@dataclass
class SizeResult:
    label: str
    result: object                      # GradeResult
    warm_from: Optional[str]            # the neighbour it started from, None: from its own start
    seconds: float


@dataclass
class SizeRun:
    labels: list[str]                   # every size in order, the base included
    base_index: int
    sizes: dict[str, SizeResult] = field(default_factory=dict)
    jumps: list[dict] = field(default_factory=list)
    seconds: float = 0.0

    def patterns(self, base_pattern: Pattern) -> list[Pattern]:
        """The patterns in size order, the base pattern at its place."""
        return [base_pattern if k == self.base_index else self.sizes[lab].result.pattern
                for k, lab in enumerate(self.labels)]


def base_position(base_key: float, target_keys: Sequence[float]) -> int:
    """Where the base stands among the targets (given smallest to largest): before the first
    whose size key (a girth) exceeds the base's."""
    for k, key in enumerate(target_keys):
        if key > base_key:
            return k
    return len(target_keys)


def base_size_label(stem: str, labels: Sequence[str]) -> str:
    """The base's label in the row: its body's name, made distinct from the targets'."""
    label, j = stem, 2
    while label in labels:
        label = f"{stem} (base)" if j == 2 else f"{stem} (base {j - 1})"
        j += 1
    return label


def size_key(body) -> float:
    """A body's place in a size row: bust + waist + hip girth (cm)."""
    from ..body.measure import body_measurements
    m = body_measurements(body)
    vals = [m.get(k) for k in ("bust", "waist", "hip")]
    return sum(v for v in vals if v is not None)


def base_place(base_body, targets, warn) -> int:
    """The base's place among ``targets`` ((label, body) pairs) by girth; ``warn`` gets a
    warning when the targets are not given smallest to largest."""
    keys = [size_key(b) for _, b in targets]
    if any(b < a - 0.5 for a, b in zip(keys, keys[1:])):
        warn("the target bodies are not in size order by girth (bust + waist + hip: "
             + ", ".join(f"{lab} {k:.1f} cm" for (lab, _), k in zip(targets, keys))
             + "); sizes start from the neighbour given, and jumps are judged in the order given")
    return base_position(size_key(base_body), keys)


def grading_order(n: int, base_index: int) -> list[tuple[int, Optional[int]]]:
    """(size, neighbour it starts from) for every size but the base, walking outward from
    the base; a base neighbour starts from its own initialization (None)."""
    order = []
    for k in range(base_index + 1, n):
        order.append((k, k - 1 if k - 1 != base_index else None))
    for k in range(base_index - 1, -1, -1):
        order.append((k, k + 1 if k + 1 != base_index else None))
    return order


def run_sizes(base_pattern: Pattern, base_body, targets: Sequence[tuple[str, object]], base_index: int,
              settings, *, base_label: str = "base", grade_fn: Callable | None = None,
              on_size: Callable | None = None, progress_for: Callable | None = None) -> SizeRun:
    """Grade ``base_pattern`` to every (label, body) of ``targets`` (in size order; the
    base stands at ``base_index`` of the row). ``on_size(size_result)`` is called as each
    size is done; ``progress_for(label)`` gives a size's progress callback."""
    import time
    from .grade import grade
    grade_fn = grade_fn or grade
    labels = [lab for lab, _ in targets]
    labels.insert(base_index, base_label)
    bodies = [b for _, b in targets]
    bodies.insert(base_index, base_body)
    run = SizeRun(labels=labels, base_index=base_index)
    shared: dict = {}
    t0 = time.perf_counter()
    for k, warm_k in grading_order(len(labels), base_index):
        warm = run.sizes[labels[warm_k]].result.warm_start if warm_k is not None else None
        t = time.perf_counter()
        result = grade_fn(base_pattern, base_body, bodies[k], settings, shared=shared, warm_start=warm,
                          progress=progress_for(labels[k]) if progress_for else None)
        done = SizeResult(labels[k], result, labels[warm_k] if warm_k is not None else None,
                          time.perf_counter() - t)
        run.sizes[labels[k]] = done
        if on_size is not None:
            on_size(done)
    run.seconds = time.perf_counter() - t0
    run.jumps = find_jumps(run.patterns(base_pattern), labels)
    return run


def nest_anchor(outline_cm: np.ndarray) -> np.ndarray:
    """The point the nest aligns a panel's copies at: its bounding box's top-centre
    (seamfit.pattern.svg)."""
    o = np.asarray(outline_cm, dtype=float)
    return np.array([0.5 * (o[:, 0].min() + o[:, 0].max()), o[:, 1].max()])


def landmark_places(pattern: Pattern) -> dict[tuple[str, str], np.ndarray]:
    """(panel, landmark) -> the landmark's place (cm) relative to its panel's nest anchor.
    Landmarks spanning several vertices are taken at their first."""
    out = {}
    for panel in pattern.panels:
        o = np.asarray(panel.outline_cm, dtype=float)
        a = nest_anchor(o)
        for name, idx in panel.landmarks.items():
            i = idx[0] if isinstance(idx, (list, tuple)) else idx
            if 0 <= int(i) < len(o):
                out[(panel.name, name)] = o[int(i)] - a
    return out


def find_jumps(patterns: Sequence[Pattern], labels: Sequence[str], *,
               tolerance_mm: float = JUMP_TOLERANCE_MM) -> list[dict]:
    """Landmarks moving out of order along a row of graded patterns (smallest to largest):
    a step from one size to the next that goes back, by more than ``tolerance_mm``, against
    the landmark's move from the first size to the last. One entry per such step: panel,
    landmark, the two sizes, how far back (mm) and the step (cm)."""
    if len(patterns) < 3:
        return []                        # two sizes have no order to break
    places = [landmark_places(p) for p in patterns]
    keys = [k for k in places[0] if all(k in pl for pl in places[1:])]
    jumps = []
    for key in keys:
        pts = np.array([pl[key] for pl in places])
        overall = pts[-1] - pts[0]
        length = float(np.linalg.norm(overall))
        if 10.0 * length <= tolerance_mm:
            continue                     # the landmark stays put across the run
        direction = overall / length
        for j in range(len(pts) - 1):
            step = pts[j + 1] - pts[j]
            back = -10.0 * float(step @ direction)
            if back > tolerance_mm:
                jumps.append({"panel": key[0], "landmark": key[1], "from": labels[j], "to": labels[j + 1],
                              "back_mm": round(back, 3), "step_cm": [round(float(v), 4) for v in step]})
    return jumps


def summary_row(label: str, report: dict, *, warm_from: Optional[str], seconds: float, folder: str) -> dict:
    """One size's line of the run's summary table."""
    seams = [float(v) for v in (report.get("seam_mismatch_mm") or {}).values() if v is not None]
    ease = (report.get("ease_cm") or {}).get("result") or {}
    return {"size": label, "folder": folder, "ease_cm": dict(ease),
            "ease_losses": list((report.get("ease_cm") or {}).get("losses") or []),
            "seam_mismatch_mm": {"max": round(max(seams), 4) if seams else None,
                                 "mean": round(float(np.mean(seams)), 4) if seams else None},
            "seconds": round(seconds, 2), "outer_iterations": report.get("outer_iterations"),
            "converged": bool(report.get("converged")), "warm_start_from": warm_from,
            "objective_final": report.get("objective_final"),
            "max_displacement_mm": report.get("max_displacement_mm")}
