"""Resource limits: inputs that would take too long or too much memory are refused before
any work, with a message that names the limit and how to raise it.

Each limit is defined here once; its environment variable overrides it (a whole number;
0 turns the limit off). The defaults sit well above every real garment and body seamfit
has seen (docs/cli.md, "Limits") and below sizes that take minutes or gigabytes.
"""
from __future__ import annotations

import math
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from .errors import LimitError, SeamfitError


@dataclass(frozen=True)
class Limit:
    env: str
    default: int
    unit: str            # what is counted, as a plural noun phrase

    def value(self) -> int:
        """The limit in force (0: none); a malformed override is an error, not ignored."""
        raw = os.environ.get(self.env, "").strip()
        if not raw:
            return self.default
        try:
            v = int(raw)
        except ValueError:
            raise SeamfitError(f"{self.env}={raw!r}: must be a whole number (0 for no limit)") from None
        if v < 0:
            raise SeamfitError(f"{self.env}={raw!r}: must be >= 0 (0 for no limit)")
        return v

    def check(self, amount: float, where: str, what: str | None = None, error=LimitError) -> None:
        """Raise ``error`` (the reader's own class, so callers catching PatternError or
        BodyError catch this too) when ``amount`` exceeds the limit."""
        limit = self.value()
        if limit and amount > limit:
            raise error(f"{where}: {what or f'{amount:,.0f} {self.unit}'}, more than the limit of "
                             f"{limit:,} {self.unit} (set {self.env} to raise it, 0 for no limit)")


# A 13K-vertex body is 1 MB of OBJ and a drafted pattern 50 KB of JSON; 256 MB of either
# takes seconds to parse and holds millions of vertices.
FILE_MB = Limit("SEAMFIT_MAX_FILE_MB", 256, "MB per input file")
# Real garments have 2-40 panels.
PANELS = Limit("SEAMFIT_MAX_PANELS", 500, "panels")
# Outlines are sampled at ~1 cm: 100,000 vertices is a kilometre of outline.
OUTLINE_VERTICES = Limit("SEAMFIT_MAX_OUTLINE_VERTICES", 100_000, "outline vertices")
# The largest gradings measured have 150K vertices (300K triangles); memory and time grow
# with the mesh (about 2 GB and minutes per iteration at a million vertices).
MESH_VERTICES = Limit("SEAMFIT_MAX_MESH_VERTICES", 500_000, "mesh vertices")


def check_input_file(path, kind: str, error=SeamfitError) -> int:
    """Refuse what cannot be read as a file before opening it: a FIFO (open blocks until a
    writer comes), a device such as /dev/zero (read without end), or a file over the size
    limit. Returns the file's size in bytes. Missing files and folders are the readers'."""
    path = Path(path)
    try:
        st = os.stat(path)
    except OSError:
        return 0                                  # the reader reports it with its own words
    if stat.S_ISDIR(st.st_mode):
        return 0
    if not stat.S_ISREG(st.st_mode):
        what = ("a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else
                "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        raise error(f"{path}: is {what}, not a regular file; give the {kind} as a file")
    FILE_MB.check(st.st_size / 2**20, str(path), f"{st.st_size / 2**20:,.1f} MB", error)
    return st.st_size


def check_readable_file(path, kind: str, expected: str, error=SeamfitError) -> int:
    """check_input_file, with a missing file and a folder refused too (``expected``: the
    kind of file that was wanted, for the message)."""
    path = Path(path)
    if not path.exists():
        raise error(f"{path}: no such file")
    if path.is_dir():
        raise error(f"{path}: is a directory, expected {expected}")
    return check_input_file(path, kind, error)


def read_text_file(path: Path, what: str, error=SeamfitError) -> str:
    """The text of the ``what`` file at ``path`` (UTF-8, a byte-order mark dropped), its
    absence or unreadability as ``error`` naming the file."""
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read the {what}: {exc}") from None


def estimated_mesh_vertices(pattern, edge_length_cm: float) -> float:
    """Vertices a mesh of ``pattern`` at ``edge_length_cm`` will have, to within ~20 %:
    equilateral triangles of that edge (two per vertex inside) plus the boundary vertices."""
    import numpy as np
    h = float(edge_length_cm)
    if not (math.isfinite(h) and h > 0):
        return 0.0                                # not an edge length: the mesher says so
    total = 0.0
    for p in pattern.panels:
        o = np.asarray(p.outline_cm, dtype=float)
        if o.ndim != 2 or len(o) < 3 or not np.all(np.isfinite(o)):
            continue
        u, v = o[:, 0], o[:, 1]
        with np.errstate(all="ignore"):
            area = abs(0.5 * float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v)))
            perimeter = float(np.sum(np.linalg.norm(np.roll(o, -1, axis=0) - o, axis=1)))
        total += area / (math.sqrt(3) / 2 * h * h) + perimeter / h
    return total


def check_mesh_size(pattern, edge_length_cm: float) -> None:
    """Refuse a mesh that would exceed MESH_VERTICES, before any meshing."""
    n = estimated_mesh_vertices(pattern, edge_length_cm)
    src = pattern.source_file or "<pattern>"
    MESH_VERTICES.check(n, src, f"a mesh at edge length {edge_length_cm:g} cm would have about "
                                f"{n:,.0f} mesh vertices")
