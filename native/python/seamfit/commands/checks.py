"""What every command checks before its expensive work: options, then inputs, with the
same checks and messages as ``seamfit validate`` (seamfit.pattern.validate,
seamfit.body.validate) and the resource limits of seamfit.limits."""
from __future__ import annotations

import math

from ..errors import SeamfitError


def number(option: str, value: float, *, allow_zero: bool = False) -> float:
    """A finite option value > 0 (>= 0 with ``allow_zero``)."""
    ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        raise SeamfitError(f"{option} {value:g}: must be a {'non-negative' if allow_zero else 'positive'} "
                           "finite number")
    return value


def whole(option: str, value: int | None, minimum: int) -> None:
    if value is not None and value < minimum:
        raise SeamfitError(f"{option} {value}: must be >= {minimum}")


def checked_pattern(path, edge_length_cm: float | None = None, warn=None, *, drape: bool = True):
    """The pattern at ``path``, read within the size limits and validated as ``seamfit
    validate`` does (ValidationError lists every error; ``warn`` gets each warning); with
    ``edge_length_cm``, also the mesh it would make held to the mesh size limit; with
    ``drape``, a DXF's stitches and placements present (seamfit.pattern.seams)."""
    from ..limits import check_mesh_size
    from ..pattern import check_pattern, load_pattern
    from ..pattern import check_drapable
    pattern = load_pattern(path)
    for m in check_pattern(pattern).warnings:
        if warn is not None:
            warn(m)
    if drape:
        check_drapable(pattern)
    if edge_length_cm is not None:
        check_mesh_size(pattern, edge_length_cm)
    return pattern


