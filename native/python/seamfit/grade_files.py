"""The files of one grading, written one way for every front end (``seamfit grade`` and
``grade-run``, the Blender add-on and its batch script):

  pattern.json   the adjusted pattern (sewpat-1)
  pattern.svg    the graded nest: base pattern in black, adjusted pattern in colour
  garment.obj    the final drape on the target body (vt = adjusted pattern, cm)
  report.json    the grading's report, with what the caller adds to it
  pattern.png    the nest as a picture        } drawn last: one that cannot be drawn is a
  drape.png      front, side and back views   } ``pictures`` entry, never a lost result

The folder is the caller's: a temporary one that ``seamfit.output_set.OutputSet`` moves
into place as a whole set.
"""
from __future__ import annotations

import copy
import json
from pathlib import Path

__all__ = ["FILES", "PICTURES", "write_grade_files", "written_files"]

FILES = ("pattern.json", "pattern.svg", "garment.obj", "report.json")
PICTURES = ("pattern.png", "drape.png")


def write_grade_files(folder, result, base_pattern, report: dict, *, base_name: str, target_name: str,
                      target_body=None, graded=None, title: str | None = None, pictures: bool = True) -> dict:
    """Write the files of ``result`` (a ``GradeResult``) into ``folder``; ``graded`` is the
    adjusted pattern to save when it is not ``result.pattern``. Returns ``report`` as written,
    with its ``pictures`` entry."""
    from .fileio import atomic_write_text, json_default
    from .mesh import write_obj
    from .pattern import save_pattern, write_svg
    from .pictures import draw_pictures, skipped

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    graded = result.pattern if graded is None else graded
    labels = [f"base ({base_name})", f"graded ({target_name})"]
    title = title or base_pattern.garment_id or "pattern"
    save_pattern(graded, folder / "pattern.json", overwrite=True)
    write_svg(folder / "pattern.svg", [base_pattern, graded], labels=labels)
    mesh = copy.copy(result.mesh)         # the sewn mesh with the adjusted pattern coordinates
    mesh.uv_cm = result.uv_cm
    write_obj(folder / "garment.obj", mesh, positions=result.x)
    report = dict(report)

    def write_report():
        atomic_write_text(folder / "report.json", json.dumps(report, indent=1, default=json_default) + "\n")

    write_report()                        # the results first: a picture costs only itself

    def nest(path):
        from .pattern.nest_png import render_nest_png
        render_nest_png(path, [base_pattern, graded], labels=labels, title=f"{title}: graded nest")

    def drape(path):
        from .sim.render import render_drape
        tb = target_body
        render_drape(path, result.x, result.mesh.triangles, result.mesh.triangle_panel,
                     body_vertices=None if tb is None else tb.vertices, body_faces=None if tb is None else tb.faces,
                     title=f"{title} graded to {target_name}")

    report["pictures"] = (draw_pictures(folder, dict(zip(PICTURES, (nest, drape))), command="grade") if pictures
                          else skipped(PICTURES))
    write_report()
    return report


def written_files(folder, report: dict) -> list[Path]:
    """The files ``write_grade_files`` wrote, pictures that were drawn included."""
    folder = Path(folder)
    return [folder / name for name in FILES] + [folder / name for name, s in report["pictures"].items()
                                                if s.get("written")]
