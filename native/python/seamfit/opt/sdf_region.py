"""The region a body's SDF covers: the whole body's box, or that box cut to the garment's
height band where the whole grid would be too large for the builder (sdf_region;
docs/grading.md, "The body fields' region"), and the check that the garment stays inside
a cut field."""
from __future__ import annotations

from typing import Optional

import numpy as np

from .. import preload
from ..errors import DeviceError, SolveError

SDF_REGIONS = ("auto", "body", "garment")
# How far (m) above and below the garment's height band a cropped body field reaches. The
# band is measured where the garment starts (the placement; x-tilde on the target) and the
# garment moves from there: panels placed flat beside the body shift by several cm as the
# seams pull them round it in the base drape (the sample skirts' and bodice's tops rose 1-5
# cm), the optimisation lengthens or shortens panels, and the collision barrier (1 cm) and
# the cubic stencil read a little beyond each vertex. 15 cm is about twice their sum, for
# 0.3 m of extra grid height; the garment is checked against the box all the same.
GARMENT_REGION_MARGIN = 0.15
# A vertex less than this many cells beyond a cut face reads the field's continuation
# (boundary value plus distance), off by at most twice that distance (phi is 1-Lipschitz):
# the order of the interpolation error the grid already has inside.
OUTSIDE_TOLERANCE_CELLS = 1.0
# Hint placements (FreeSewing) are wrapped around the body before the band is known, which
# takes a field: a coarse one puts the wrap within about a cell of where the fine one will.
PLACEMENT_SDF_SPACING = 0.01


def whole_body_layout(body, spacing: float) -> tuple[np.ndarray, tuple[int, int, int]]:
    """Origin and node counts (nx, ny, nz) of build_sdf's whole-body grid, without building it."""
    from .._native import core
    from ..body import sdf as sdf_mod
    lay = core().sdf_layout(np.asarray(body.vertices, dtype=np.float64), float(spacing), sdf_mod.DEFAULT_PADDING)
    return np.asarray(lay["origin"], dtype=np.float64), tuple(int(d) for d in lay["dims"])


def check_sdf_region(region) -> None:
    from ..body import sdf as sdf_mod
    if region not in SDF_REGIONS:
        raise SolveError(f"unknown sdf_region {region!r}; choose auto (the whole body unless its grid exceeds "
                         f"{sdf_mod.MAX_NODES:,} nodes), body (the whole body) or garment (cropped to the "
                         f"garment's height band)")


def resolve_sdf_region(region: str, body, spacing: float) -> str:
    """"body" or "garment" for `region`: "auto" is "body" unless the whole body's grid would
    exceed the SDF builder's node limit (seamfit.body.sdf.MAX_NODES)."""
    from ..body import sdf as sdf_mod
    check_sdf_region(region)
    if region != "auto":
        return region
    _, dims = whole_body_layout(body, spacing)
    return "body" if int(np.prod(dims, dtype=np.int64)) <= sdf_mod.MAX_NODES else "garment"


def garment_bounds(body, spacing: float, z_range, margin: float = GARMENT_REGION_MARGIN):
    """Bounds (xmin, ymin, zmin, xmax, ymax, zmax) of the body's whole grid cut along z (up)
    to z_range +- margin; None when nothing would be cut.

    Only the height is cut: a garment wraps around the body, so its horizontal reach is
    most of the body's anyway, and a band is robust to where the panels swing. The cut
    planes lie on the whole grid's nodes, so the crop's nodes are a subset of the whole
    grid's and inside it the two fields agree."""
    origin, dims = whole_body_layout(body, spacing)
    h, nz = float(spacing), dims[2]
    k_lo = int(np.floor((float(z_range[0]) - margin - origin[2]) / h))
    k_hi = int(np.ceil((float(z_range[1]) + margin - origin[2]) / h))
    k_lo = min(max(k_lo, 0), nz - 2)          # clamped to the body's box + padding
    k_hi = min(max(k_hi, k_lo + 1), nz - 1)
    if k_lo == 0 and k_hi == nz - 1:
        return None
    top = origin + h * (np.asarray(dims) - 1)
    return (float(origin[0]), float(origin[1]), float(origin[2] + h * k_lo),
            float(top[0]), float(top[1]), float(origin[2] + h * k_hi))


def placement_z_range(mesh, pattern, body) -> tuple[float, float]:
    """Height band of the garment where the base drape starts it (its placement, with hint
    placements wrapped as seamfit.sim.dressing does): known before the base body's field."""
    from ..body import build_sdf
    from ..sim.dressing import initial_positions
    try:
        x0, _ = initial_positions(mesh, pattern, None, mode="auto")  # the mode base_drape dresses with
    except SolveError:  # hint placements: the wrap needs a field
        x0, _ = initial_positions(mesh, pattern, build_sdf(body, spacing=PLACEMENT_SDF_SPACING), mode="auto")
    # The wrap reads the field over the flat placement's band too.
    z = np.concatenate([np.asarray(x0)[:, 2], np.asarray(mesh.x0)[:, 2]])
    return float(z.min()), float(z.max())


def body_field(body, spacing: float, region: str, *, z_range=None, margin: float = GARMENT_REGION_MARGIN,
               device: str = "cpu"):
    """The body's SDF over its whole box ("body") or cut to z_range +- margin ("garment"),
    and its report entry (region, bounds, node counts). ``device``: where the field is
    built ("cpu" or "cuda", see seamfit.body.build_sdf). A GPU that cannot build it (short
    of memory while other gradings share it, say) hands it to the CPU: the grading goes on,
    and the entry's "built_on" and "device_note" say so."""
    from ..body import build_sdf
    origin, dims = whole_body_layout(body, spacing)
    whole_hi = origin + float(spacing) * (np.asarray(dims) - 1)
    bounds = garment_bounds(body, spacing, z_range, margin) if region == "garment" else None
    built_on, note = device, None
    # The build releases the GIL: what the run imports at its end loads meanwhile.
    preload.start()
    try:
        sdf = build_sdf(body, spacing=spacing, bounds=bounds, device=device, write_behind=True)
    except DeviceError as exc:
        if device != "cuda":
            raise
        built_on, note = "cpu", f"built on the CPU: {exc}"
        sdf = build_sdf(body, spacing=spacing, bounds=bounds, device="cpu", write_behind=True)
    lo, hi = sdf.bounds
    info = {"region": region, "body": getattr(body, "name", None) or getattr(body, "where", "body"),
            "spacing_m": float(sdf.spacing), "dims": list(sdf.dims), "nodes": int(sdf.values.size),
            "whole_body_nodes": int(np.prod(dims, dtype=np.int64)), "bounds": [*lo.tolist(), *hi.tolist()],
            "whole_body_bounds": [*origin.tolist(), *whole_hi.tolist()], "built_on": built_on}
    if note:
        info["device_note"] = note
    if region == "garment":
        info.update(garment_z=[float(z_range[0]), float(z_range[1])], margin_m=float(margin))
    return sdf, info


def distance_outside_field(info: dict, x) -> float:
    """Largest distance (m) by which a vertex of x lies beyond a face where the field was cut
    from the whole body's box (0 for a whole-body field: beyond its box there is no body)."""
    if info.get("region") != "garment" or len(x) == 0:
        return 0.0
    b, w = np.asarray(info["bounds"]), np.asarray(info["whole_body_bounds"])
    tiny = 1e-9
    cut_lo, cut_hi = b[:3] > w[:3] + tiny, b[3:] < w[3:] - tiny
    x = np.asarray(x, dtype=np.float64)
    below = np.where(cut_lo, b[:3] - x.min(axis=0), 0.0)
    above = np.where(cut_hi, x.max(axis=0) - b[3:], 0.0)
    return float(max(0.0, below.max(), above.max()))


def garment_outside_field(sdf, info: dict, x, which: str, when: str) -> Optional[str]:
    """A message when garment x leaves the cropped field of the `which` body by more than
    OUTSIDE_TOLERANCE_CELLS cells (there collisions with the body are not seen), else None."""
    d = distance_outside_field(info, x)
    info["max_outside_mm"] = 1000.0 * d if info.get("region") == "garment" else None
    if d <= OUTSIDE_TOLERANCE_CELLS * float(sdf.spacing):
        return None
    return (f"the garment {when} lies up to {1000 * d:.0f} mm beyond the {which} body's field "
            f"({info['body']}), which sdf_region cropped to the garment's height band +- "
            f"{100 * info['margin_m']:.0f} cm: collisions with the body there are not seen; grade with "
            f"sdf_region=\"body\" (--sdf-region body, at a coarser spacing if the whole body's grid is "
            f"too large) or a larger sdf_region_margin (--sdf-margin)")
