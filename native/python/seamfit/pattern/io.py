"""Load a pattern from any format seamfit reads; save it as ``sewpat-1``."""
from __future__ import annotations

import json
import os
from pathlib import Path

from ..errors import PatternError
from ..limits import check_readable_file
from .garmentcode import garment_id_from_path, is_garmentcode_spec, pattern_from_garmentcode
from .model import Pattern
from .sewpat import FORMAT, pattern_from_dict, write_sewpat

READABLE = "a sewpat-1 pattern (.json), a GarmentCode *_specification.json or a DXF-AAMA/ASTM pattern (.dxf)"


def detect_format(d) -> str | None:
    """'sewpat-1', 'garmentcode' or None for a parsed JSON document."""
    if isinstance(d, dict) and d.get("format") == FORMAT:
        return FORMAT
    if is_garmentcode_spec(d):
        return "garmentcode"
    return None


def load_pattern(path: str | Path) -> Pattern:
    """Read a pattern file, detecting its format from its content.

    Raises PatternError naming the file when it is missing, unreadable, not JSON, or
    neither sewpat-1 nor a GarmentCode specification.
    """
    return read_pattern_file(path)[0]


def read_pattern_file(path: str | Path, *, dxf_units: str | None = None,
                      seams: str | Path | None = None, size: str | None = None,
                      rul: str | Path | None = None) -> tuple[Pattern, str]:
    """:func:`load_pattern`, also returning the detected format ('sewpat-1', 'garmentcode',
    'dxf-aama' or 'dxf-astm').

    A ``.dxf`` file is read by seamfit.pattern.dxf (``dxf_units`` overrides the units it
    declares); its stitches and placements come from ``seams`` or, when that is not given,
    from the seams sidecar beside it (``<name>.seams.json``) if there is one. The reader's
    notes (what it dropped or guessed) are in ``pattern.extra["source"]["notes"]``. A DXF
    holding several sizes, or graded by a RUL table (``rul``), needs ``size`` (PatternError
    listing them otherwise)."""
    path = Path(path)
    if path.suffix.lower() == ".dxf":
        from .dxf_sizes import one_size
        sizes = read_dxf_size_file(path, dxf_units=dxf_units, seams=seams, size=size, rul=rul)
        return one_size(sizes, size), f"dxf-{sizes.flavor}"
    if rul is not None:
        raise PatternError(f"{path}: --rul {Path(rul).name} grades a base DXF file, not this one")
    if size is not None:
        raise PatternError(f"{path}: --size {size!r} applies to a multi-size DXF file, not to this one")
    check_readable_file(path, "pattern", READABLE, PatternError)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise PatternError(f"{path}: not a text file; expected {READABLE}") from exc
    except OSError as exc:
        raise PatternError(f"{path}: cannot read ({exc.strerror})") from exc
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        if path.suffix.lower() != ".json":
            raise PatternError(f"{path}: unsupported file type {path.suffix or '(no extension)'!r}; "
                               f"expected {READABLE}") from exc
        raise PatternError(f"{path}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from exc
    except RecursionError:
        raise PatternError(f"{path}: JSON nested too deeply to be a pattern") from None
    except ValueError as exc:                    # an integer of thousands of digits
        raise PatternError(f"{path}: unreadable JSON value ({str(exc).split(';')[0]})") from None
    fmt = detect_format(d)
    try:
        if fmt == FORMAT:
            return pattern_from_dict(d, str(path)), fmt
        if fmt == "garmentcode":
            return pattern_from_garmentcode(d, str(path), garment_id=garment_id_from_path(path)), fmt
    except (TypeError, ValueError, AttributeError, KeyError, IndexError, OverflowError, ZeroDivisionError) as exc:
        # A shape the readers' own checks did not foresee: still a one-line error on the file.
        raise PatternError(f"{path}: malformed {fmt} file ({type(exc).__name__}: "
                           f"{' '.join(str(exc).split())[:200]})") from exc
    if isinstance(d, dict) and "format" in d:
        raise PatternError(f"{path}: unsupported pattern format {d['format']!r}; expected {READABLE}")
    raise PatternError(f"{path}: JSON file is not a pattern; expected {READABLE}")


def read_dxf_size_file(path: str | Path, *, dxf_units: str | None = None, seams: str | Path | None = None,
                       size: str | None = None, rul: str | Path | None = None):
    """A DXF as seamfit.pattern.dxf_sizes.DxfSizes (one pattern per size: its pieces' Size
    texts, or with ``rul`` the base graded by that RUL table, seamfit.pattern.dxf_graded),
    the reader's notes in each pattern's ``extra["source"]["notes"]`` and the seams sidecar
    (``seams``, else the one beside the file) applied to each size, or only to ``size``."""
    from .dxf_sizes import read_dxf_sizes, size_notes
    from .seams import apply_sidecar, sidecar_path
    path = Path(path)
    if rul is not None:
        from .dxf_graded import read_graded_dxf
        sizes = read_graded_dxf(path, rul, units=dxf_units)
    else:
        sizes = read_dxf_sizes(path, units=dxf_units)
    side = Path(seams) if seams is not None else sidecar_path(path)
    for label, pattern in sizes.patterns.items():
        source = pattern.extra.setdefault("source", {})
        notes = size_notes(sizes, label)
        if notes:
            source["notes"] = notes
        if (seams is not None or side.exists()) and (size is None or label == size):
            apply_sidecar(pattern, side)
            source["seams"] = side.name
    return sizes


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def save_pattern(pattern: Pattern, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``pattern`` as sewpat-1, atomically.

    Refuses to replace the file the pattern was read from (``pattern.source_file``)
    unless ``overwrite=True``, so a run never destroys its own input by accident.
    """
    path = Path(path)
    if not overwrite and pattern.source_file and _same_file(path, Path(pattern.source_file)):
        raise PatternError(f"{path}: is the file this pattern was read from; not overwritten "
                           "(write elsewhere or pass overwrite=True)")
    if path.is_dir():
        raise PatternError(f"{path}: is a directory; give a file name for the sewpat-1 output")
    return write_sewpat(pattern, path)
