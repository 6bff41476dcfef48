# SPDX-License-Identifier: GPL-3.0-or-later
"""DXF-AAMA/ASTM for the add-on, through seamfit's own readers and writers (no bpy here):
the sizes of a file, reading one size with its seams sidecar or the proposed stitches,
confirming stitches, exporting a pattern and a graded size run."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from .compute import AddonError, seamfit_module

# Export formats of the Export Sewing Pattern operator: file extension and DXF flavour.
EXPORT_FORMATS = {
    "SEWPAT": (".json", None),
    "SVG": (".svg", None),
    "DXF_AAMA": (".aama.dxf", "aama"),
    "DXF_ASTM": (".astm.dxf", "astm"),
}


def extension_of(path: str) -> str:
    """The export extension ``path`` ends in ("" when none of EXPORT_FORMATS')."""
    low = str(path).lower()
    found = [ext for ext, _ in EXPORT_FORMATS.values() if low.endswith(ext)]
    return max(found, key=len) if found else ""

_sizes_memo: dict = {}


def _need_ezdxf() -> None:
    """seamfit reads and writes DXF with ezdxf: a one-line error when it is not installed."""
    import importlib.util
    if importlib.util.find_spec("ezdxf") is None:
        raise AddonError("DXF needs the ezdxf package, which this installation of the seamfit extension lacks; "
                         "reinstall the extension")


def is_dxf(path: str) -> bool:
    return str(path).lower().endswith(".dxf")


def file_sizes(path: str) -> tuple[list[str], str | None]:
    """(size names in file order, sample size or None) of a DXF; ([], None) for a file of
    one size or one that cannot be read (the import then says why). Remembered per file
    version: the file dialog asks on every redraw."""
    try:
        st = os.stat(path)
    except OSError:
        return [], None
    key = (str(path), st.st_mtime_ns, st.st_size)
    if key not in _sizes_memo:
        try:
            sizes = seamfit_module("pattern").read_dxf_sizes(path)
            _sizes_memo[key] = (list(sizes.labels), sizes.sample_size)
        except Exception:       # shown by the import itself, as one line
            _sizes_memo[key] = ([], None)
    return _sizes_memo[key]


def read(path: str, size: str | None):
    """(pattern, proposed stitches) of one size of a DXF. The seams sidecar beside the file
    gives its stitches (and placements) when there is one; otherwise the library proposes
    stitches (sidecar entries, each ``confirmed: false``) for the user to confirm."""
    _need_ezdxf()
    patterns = seamfit_module("pattern")
    sizes = patterns.read_dxf_size_file(path, size=size)
    pattern = patterns.one_size(sizes, size)
    pattern.source_file = str(path)
    has_sidecar = bool((pattern.extra.get("source") or {}).get("seams"))
    proposals = [] if has_sidecar else patterns.propose_stitches(pattern)
    return pattern, proposals


def notes(pattern) -> list[str]:
    """What the DXF reader dropped or guessed, for the user."""
    return list((pattern.extra.get("source") or {}).get("notes") or [])


def apply_choices(pattern, entries: list[dict]):
    """``pattern`` with the stitches of the sidecar entries marked confirmed (seamfit's
    sidecar reader checks and applies them; one-line error naming the entry)."""
    seams = seamfit_module("pattern")
    d = seams.sidecar_dict(pattern, entries)
    with tempfile.TemporaryDirectory(prefix="seamfit-seams-") as tmp:
        side = Path(tmp) / "stitches.seams.json"
        seams.write_sidecar(side, d)
        try:
            seams.apply_sidecar(pattern, side)
        except seamfit_module("errors").PatternError as exc:
            raise AddonError(str(exc).replace(str(side), "confirmed stitches")) from None
    return pattern


def check_drapable(pattern) -> None:
    """seamfit's refusal to drape a DXF pattern without confirmed stitches and placements."""
    seamfit_module("pattern").check_drapable(pattern)


def _inputs(*sources: str | None) -> list:
    """The files an export must never replace: the patterns' sources and their seams sidecars."""
    out = []
    for source in filter(None, sources):
        out.append(Path(source))
        if is_dxf(source):
            out.append(seamfit_module("pattern").sidecar_path(source))
    return out


def export_dxf(pattern, path: str, flavor: str, allowance_cm: float | None = None, corners: str = "mitre",
               protect: tuple = ()) -> list[str]:
    """Write ``pattern`` as DXF-AAMA or DXF-ASTM with seamfit's pattern writer (``seamfit convert``'s): the DXF
    and, when the pattern has stitches or placements, its seams sidecar, as one set written
    atomically, never over the pattern's source file, the files in ``protect`` (a graded
    pattern's base) or their sidecars. ``allowance_cm``: seam allowance for edges without
    their own (None: only those measured on reading). Returns the lines saying what was
    written."""
    _need_ezdxf()
    path = Path(path)
    if not is_dxf(path):
        raise AddonError(f"{path}: a DXF export's file name must end in .dxf (.aama.dxf, .astm.dxf)")
    return seamfit_module().write_pattern_files(pattern, path, inputs=_inputs(pattern.source_file, *protect),
                                                force=True, flavor=flavor, units="mm",
                                                seam_allowance_cm=allowance_cm, corners=corners)


def corner_styles() -> tuple:
    """Seam allowance corners as seamfit offers them (seamfit.pattern.ALLOWANCE_CORNERS)."""
    try:
        return tuple(seamfit_module("pattern").ALLOWANCE_CORNERS)
    except AddonError:
        return ("mitre", "square")


def write_size_run(patterns: list, labels: list[str], base_index: int, dxf_path: str, source: str | None = None
                   ) -> list[str]:
    """A graded size run as ``seamfit grade-run`` writes it: every size in one DXF-ASTM
    (``nest.dxf``'s form) and the base with grade-rule numbers plus its RUL table (``.rul``
    beside it), written as one set."""
    _need_ezdxf()
    OutputSet = seamfit_module("output_set").OutputSet
    sizes = seamfit_module("pattern")
    path = Path(dxf_path)
    if not path.name.lower().endswith(".dxf"):
        raise AddonError(f"{path}: the size run's file must end in .dxf")
    stem = path.name[:-4]
    graded, rul = f"{stem}.graded.dxf", f"{stem}.rul"
    with OutputSet(path.parent, inputs=_inputs(source), force=True, files=[path.name, graded, rul]) as tmp:
        sizes.write_size_run_dxf(tmp / path.name, patterns, labels, base_index)
        sizes.write_graded_dxf(tmp / graded, tmp / rul, patterns, labels, base_index)
    return [str(path), str(path.with_name(graded)), str(path.with_name(rul))]

