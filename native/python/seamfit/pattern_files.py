"""A pattern written to one file, as every front end writes it (``seamfit convert``, the
Blender add-on's DXF export): the format by the file's extension, and for a DXF of a
pattern with stitches or placements its seams sidecar beside it, the two as one set that
``seamfit.output_set.OutputSet`` moves into place together, never over an input.
"""
from __future__ import annotations

import copy
from pathlib import Path

from .errors import SeamfitError
from .output_set import OutputSet

__all__ = ["OUT_KINDS", "output_kind", "write_pattern_files"]

# extension -> what is written there
OUT_KINDS = {".json": "sewpat-1", ".svg": "svg", ".dxf": "dxf"}


def output_kind(out) -> str:
    """What ``out``'s extension writes: sewpat-1, svg or dxf; SeamfitError for another."""
    out = Path(out)
    kind = OUT_KINDS.get(out.suffix.lower())
    if kind is None:
        raise SeamfitError(f"{out}: unknown output type {out.suffix or '(no extension)'!r}; "
                           "expected .json (sewpat-1), .svg or .dxf")
    return kind


def write_pattern_files(pattern, out, *, inputs=(), force: bool = False, flavor: str | None = None,
                        units: str = "mm", seam_allowance_cm: float | None = None, corners: str = "mitre",
                        title: str | None = None) -> list[str]:
    """Write ``pattern`` to ``out`` (.json sewpat-1, .svg, .dxf) and, for a DXF, its seams
    sidecar; ``inputs``: files never to be written over; ``flavor``: the DXF's (``aama`` or
    ``astm``; None: from the name, else aama). Returns a line per file written."""
    from .pattern.dxf import flavor_from_path
    from .pattern.seams import sidecar_dict, sidecar_path

    out = Path(out)
    kind = output_kind(out)
    if kind == "dxf":
        flavor = flavor or flavor_from_path(out) or "aama"
    files = [out.name]
    sidecar = d = None
    if kind == "dxf":
        d = sidecar_dict(pattern)
        if d["stitches"] or d.get("placements"):
            sidecar = sidecar_path(out)
            files.append(sidecar.name)
    with OutputSet(out.parent, inputs=inputs, force=force, files=files) as tmp:
        if kind == "sewpat-1":
            from .pattern.sewpat import write_sewpat
            written = copy.copy(pattern)
            written.source_file = None     # the file written is its own source, not the input's
            write_sewpat(written, tmp / out.name)
        elif kind == "svg":
            from .pattern import write_svg
            write_svg(tmp / out.name, pattern, title=title or out.name)
        else:
            from .pattern.dxf import write_dxf
            from .pattern.seams import write_sidecar
            write_dxf(pattern, tmp / out.name, flavor=flavor, units=units,
                      seam_allowance_cm=seam_allowance_cm, corners=corners)
            if sidecar is not None:
                write_sidecar(tmp / sidecar.name, d)
    shown = [f"{out}" + (f" (DXF-{flavor.upper()})" if kind == "dxf" else "")]
    if sidecar is not None:
        shown.append(f"{sidecar} ({len(pattern.stitches)} stitches)")
    return shown
