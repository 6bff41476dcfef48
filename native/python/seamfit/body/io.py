"""Body meshes in and out: Wavefront OBJ and PLY (ascii, binary little/big endian).

``load_body(path)`` returns a :class:`Body` with float64 vertices (metres) and
int32 triangles; polygons are fan-triangulated. Every malformed input raises
:class:`seamfit.errors.BodyError` naming the file and the line, vertex or face at
fault. Parsing is vectorised with numpy (a 13K-vertex body reads in well under
0.3 s).
"""
from __future__ import annotations

import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import BodyError
from ..fileio import atomic_write_bytes

__all__ = ["Body", "load_body", "save_body"]


@dataclass
class Body:
    """A triangle mesh of a body: vertices (n, 3) float64 in metres, faces (m, 3) int32."""

    vertices: np.ndarray
    faces: np.ndarray
    name: str = "body"
    source_file: str | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(self.faces, dtype=np.int32)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise BodyError(f"{self.where}: vertices must have shape (n, 3), got {self.vertices.shape}")
        if self.faces.ndim != 2 or self.faces.shape[1] != 3:
            raise BodyError(f"{self.where}: faces must have shape (m, 3), got {self.faces.shape}")

    @property
    def where(self) -> str:
        """How errors name this body: its file, else its name."""
        return self.source_file or self.name

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])


def load_body(path) -> Body:
    """Read an OBJ or PLY body mesh (by extension; PLY also by its magic line)."""
    from ..limits import check_input_file
    path = Path(path)
    check_input_file(path, "body", BodyError)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise BodyError(f"{path}: no such body file") from None
    except IsADirectoryError:
        raise BodyError(f"{path}: is a directory, not a body file") from None
    except OSError as exc:
        raise BodyError(f"{path}: cannot read body file: {exc.strerror or exc}") from None
    suffix = path.suffix.lower()
    if data.startswith(b"ply") or suffix == ".ply":
        vertices, faces = _read_ply(data, str(path))
    elif suffix == ".obj":
        vertices, faces = _read_obj(data, str(path))
    else:
        raise BodyError(f"{path}: unsupported body format {suffix or '(no extension)'!r}; use .obj or .ply")
    if faces.shape[0] == 0:
        raise BodyError(f"{path}: the mesh has no faces")
    return Body(vertices, faces, name=path.stem, source_file=str(path))


def save_body(body: Body, path, binary: bool = True) -> Path:
    """Write ``body`` as OBJ or PLY (by extension), atomically. PLY is binary
    little endian unless ``binary`` is false. Coordinates round-trip exactly."""
    path = Path(path)
    suffix = path.suffix.lower()
    v, f = body.vertices, body.faces
    if suffix == ".obj":
        buf = io.StringIO()
        buf.write(f"# seamfit body {body.name}: {len(v)} vertices, {len(f)} triangles, metres\n")
        np.savetxt(buf, v, fmt="v %.17g %.17g %.17g")
        np.savetxt(buf, f.astype(np.int64) + 1, fmt="f %d %d %d")
        data = buf.getvalue().encode("ascii")
    elif suffix == ".ply":
        fmt = "binary_little_endian" if binary else "ascii"
        header = (f"ply\nformat {fmt} 1.0\ncomment seamfit body {body.name} (metres)\n"
                  f"element vertex {len(v)}\nproperty double x\nproperty double y\nproperty double z\n"
                  f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
        if binary:
            rows = np.empty(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
            rows["n"] = 3
            rows["i"] = f
            data = header.encode("ascii") + v.astype("<f8").tobytes() + rows.tobytes()
        else:
            buf = io.StringIO()
            np.savetxt(buf, v, fmt="%.17g %.17g %.17g")
            np.savetxt(buf, f, fmt="3 %d %d %d")
            data = (header + buf.getvalue()).encode("ascii")
    else:
        raise BodyError(f"{path}: unsupported body format {suffix or '(no extension)'!r}; use .obj or .ply")
    return atomic_write_bytes(path, data)


# ----------------------------------------------------------------------------- OBJ

_SLASH_TAIL = re.compile(r"/\S*")


_V_LINE = re.compile(r"^[ \t]*v[ \t]+([^\n]*)", re.M)
_F_LINE = re.compile(r"^[ \t]*f[ \t]+([^\n]*)", re.M)


def _read_obj(data: bytes, where: str) -> tuple[np.ndarray, np.ndarray]:
    text = data.decode("utf-8", errors="replace")
    if "\\\n" in text or "\\\r\n" in text:
        # Continuation lines: join them (line numbers after a join shift by one).
        text = re.sub(r"\\\r?\n", " ", text)
    fast = _read_obj_fast(text)
    if fast is not None:
        return fast
    return _read_obj_lines(text, where)


def _read_obj_fast(text: str):
    """The common case (3 coordinates per vertex, triangles, valid indices) in a
    few vectorised steps; None sends anything else to the line-by-line reader,
    which also names the line at fault."""
    vrows = _V_LINE.findall(text)
    frows = _F_LINE.findall(text)
    try:
        coords = np.array(" ".join(vrows).split(), dtype=np.float64)
        flat = np.array(_SLASH_TAIL.sub("", " ".join(frows)).split(), dtype=np.int64)
    except (ValueError, OverflowError):   # an index past int64: the line reader names it
        return None
    nv, nf = len(vrows), len(frows)
    if coords.size != 3 * nv or flat.size != 3 * nf or nf == 0:
        return None
    if flat.min() < 0:  # relative indices count back from the vertices defined so far
        vpos = np.array([m.start() for m in _V_LINE.finditer(text)])
        fpos = np.array([m.start() for m in _F_LINE.finditer(text)])
        before = np.repeat(np.searchsorted(vpos, fpos), 3)
        idx = np.where(flat > 0, flat - 1, before + flat)
    else:
        idx = flat - 1
    if np.any(flat == 0) or idx.min() < 0 or idx.max() >= nv:
        return None
    return coords.reshape(nv, 3), idx.reshape(nf, 3).astype(np.int32)


def _read_obj_lines(text: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    v_rows: list[list[str]] = []
    v_lines: list[int] = []
    f_rows: list[list[str]] = []
    f_lines: list[int] = []
    f_nv: list[int] = []  # vertices defined before each face (for negative indices)
    for ln, line in enumerate(text.splitlines(), 1):
        if not line:
            continue
        c = line[0]
        if c in " \t":
            line = line.lstrip()
            if not line:
                continue
            c = line[0]
        if c == "v":
            if line[1:2] in (" ", "\t"):
                v_rows.append(line.split())
                v_lines.append(ln)
        elif c == "f":
            if line[1:2] in (" ", "\t"):
                f_rows.append(line.split())
                f_lines.append(ln)
                f_nv.append(len(v_rows))
        # Everything else (vt, vn, g, o, s, usemtl, mtllib, l, comments, ...) does
        # not affect the surface.
    vertices = _obj_vertices(v_rows, v_lines, where)
    faces = _obj_faces(f_rows, f_lines, f_nv, len(vertices), where)
    return vertices, faces


def _obj_vertices(rows, lines, where):
    if not rows:
        return np.zeros((0, 3))
    lengths = np.fromiter((len(r) for r in rows), dtype=np.int64, count=len(rows))
    short = np.flatnonzero(lengths < 4)
    if short.size:
        q = int(short[0])
        raise BodyError(f"{where}: line {lines[q]}: vertex needs 3 coordinates, got {len(rows[q]) - 1}")
    try:
        return np.array([r[1:4] for r in rows], dtype=np.float64)
    except ValueError:
        for q, r in enumerate(rows):
            try:
                [float(x) for x in r[1:4]]
            except ValueError:
                raise BodyError(f"{where}: line {lines[q]}: bad vertex coordinates {' '.join(r[1:4])!r}") from None
        raise


def _obj_faces(rows, lines, nv_before, n_vertices, where):
    if not rows:
        return np.zeros((0, 3), dtype=np.int32)
    counts = np.fromiter((len(r) - 1 for r in rows), dtype=np.int64, count=len(rows))
    short = np.flatnonzero(counts < 3)
    if short.size:
        q = int(short[0])
        raise BodyError(f"{where}: line {lines[q]}: face needs at least 3 vertices, got {counts[q]}")
    joined = " ".join(" ".join(r[1:]) for r in rows)
    try:
        flat = np.array(_SLASH_TAIL.sub("", joined).split(), dtype=np.int64)
    except (ValueError, OverflowError):
        for q, r in enumerate(rows):
            try:
                ids = [int(t.split("/", 1)[0]) for t in r[1:]]
            except ValueError:
                raise BodyError(f"{where}: line {lines[q]}: bad face vertex index in {' '.join(r[1:])!r}") from None
            if any(abs(i) >= 2 ** 63 for i in ids):
                raise BodyError(f"{where}: line {lines[q]}: face vertex index out of range in "
                                f"{' '.join(r[1:])[:80]!r}")
        raise
    if flat.size != counts.sum():  # e.g. a token like "/2" with an empty vertex index
        for q, r in enumerate(rows):
            if any(t.startswith("/") for t in r[1:]):
                raise BodyError(f"{where}: line {lines[q]}: face vertex without an index in {' '.join(r[1:])!r}")
        raise BodyError(f"{where}: malformed face lines")
    face_of = np.repeat(np.arange(len(rows)), counts)
    base = np.asarray(nv_before, dtype=np.int64)[face_of]
    # OBJ is 1-based; negative indices count back from the last vertex defined so far.
    idx = np.where(flat > 0, flat - 1, base + flat)
    bad = np.flatnonzero((flat == 0) | (idx < 0) | (idx >= n_vertices))
    if bad.size:
        q = int(bad[0])
        raise BodyError(f"{where}: line {lines[int(face_of[q])]}: face refers to vertex {int(flat[q])}, "
                        f"but the file has {n_vertices} vertices (OBJ indices are 1-based)")
    return _fan(idx, counts)


def _fan(idx: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons given as flat vertex indices and per-polygon counts."""
    if len(counts) == 0:                          # an empty face element
        return np.zeros((0, 3), dtype=np.int32)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    out = []
    order = []
    for k in np.unique(counts):
        sel = np.flatnonzero(counts == k)
        polys = idx[starts[sel, None] + np.arange(k)]
        tri = np.stack([np.repeat(polys[:, :1], k - 2, axis=1), polys[:, 1:k - 1], polys[:, 2:k]], axis=-1)
        out.append(tri.reshape(-1, 3))
        order.append(np.repeat(sel, k - 2) * 4096 + np.tile(np.arange(k - 2), len(sel)))
    tris = np.concatenate(out)
    if len(out) > 1:  # keep the file's face order
        tris = tris[np.argsort(np.concatenate(order), kind="stable")]
    return np.ascontiguousarray(tris, dtype=np.int32)


# ----------------------------------------------------------------------------- PLY

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


@dataclass
class _PlyElement:
    name: str
    count: int
    props: list  # (name, dtype) or (name, (count_dtype, item_dtype)) for lists


def _read_ply(data: bytes, where: str) -> tuple[np.ndarray, np.ndarray]:
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise BodyError(f"{where}: not a PLY file (no 'ply' magic line or no 'end_header')")
    nl = data.find(b"\n", end)
    body_start = len(data) if nl < 0 else nl + 1
    header = data[:end].decode("ascii", errors="replace").splitlines()
    fmt = None
    elements: list[_PlyElement] = []
    for ln, line in enumerate(header, 1):
        tok = line.split()
        if not tok or tok[0] in ("ply", "comment", "obj_info"):
            continue
        try:
            if tok[0] == "format":
                fmt = tok[1]
            elif tok[0] == "element":
                if int(tok[2]) < 0:
                    raise ValueError("negative element count")
                elements.append(_PlyElement(tok[1], int(tok[2]), []))
            elif tok[0] == "property":
                if not elements:
                    raise ValueError("property before any element")
                if tok[1] == "list":
                    elements[-1].props.append((tok[4], (_ply_type(tok[2]), _ply_type(tok[3]))))
                else:
                    elements[-1].props.append((tok[2], _ply_type(tok[1])))
            else:
                raise ValueError(f"unknown header keyword {tok[0]!r}")
        except (IndexError, ValueError, KeyError) as exc:
            raise BodyError(f"{where}: PLY header line {ln}: {line.strip()!r}: {exc}") from None
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise BodyError(f"{where}: unsupported PLY format {fmt!r}")
    names = [e.name for e in elements]
    if "vertex" not in names:
        raise BodyError(f"{where}: PLY file has no 'vertex' element")
    vprops = [p[0] for p in elements[names.index("vertex")].props]
    for axis in "xyz":
        if axis not in vprops:
            raise BodyError(f"{where}: PLY vertex element has no '{axis}' property")
    if fmt == "ascii":
        tables = _ply_ascii(data[body_start:], elements, where, header_lines=len(header) + 1)
    else:
        tables = _ply_binary(data, body_start, elements, "<" if fmt.endswith("little_endian") else ">", where)
    vt = tables["vertex"]
    vertices = np.stack([np.asarray(vt[a], dtype=np.float64) for a in "xyz"], axis=1)
    faces = np.zeros((0, 3), dtype=np.int32)
    if "face" in tables:
        lists = tables["face"]
        key = "vertex_indices" if "vertex_indices" in lists else "vertex_index" if "vertex_index" in lists else None
        if key is None:
            raise BodyError(f"{where}: PLY face element has no 'vertex_indices' list")
        counts, flat = lists[key]
        short = np.flatnonzero(counts < 3)
        if short.size:
            raise BodyError(f"{where}: PLY face {int(short[0])} has {int(counts[short[0]])} vertices (needs >= 3)")
        bad = np.flatnonzero((flat < 0) | (flat >= len(vertices)))
        if bad.size:
            face_of = np.repeat(np.arange(len(counts)), counts)
            q = int(bad[0])
            raise BodyError(f"{where}: PLY face {int(face_of[q])} refers to vertex {int(flat[q])}, "
                            f"but the file has {len(vertices)} vertices")
        faces = _fan(flat.astype(np.int64), counts.astype(np.int64))
    return vertices, faces


def _ply_type(name: str) -> str:
    if name not in _PLY_TYPES:
        raise ValueError(f"unknown property type {name!r}")
    return _PLY_TYPES[name]


def _ply_binary(data: bytes, offset: int, elements, endian: str, where: str) -> dict:
    tables = {}
    for el in elements:
        has_list = any(isinstance(t, tuple) for _, t in el.props)
        if not has_list:
            dt = np.dtype([(n, endian + t) for n, t in el.props])
            need = dt.itemsize * el.count
            if offset + need > len(data):
                raise BodyError(f"{where}: PLY file is truncated in element '{el.name}' "
                                f"({el.count} rows need {need} bytes, {len(data) - offset} left)")
            arr = np.frombuffer(data, dtype=dt, count=el.count, offset=offset)
            tables[el.name] = {n: arr[n] for n, _ in el.props}
            offset += need
            continue
        table, offset = _ply_binary_lists(data, offset, el, endian, where)
        tables[el.name] = table
    return tables


def _list_count(k: int, el, name: str, row: int, where: str) -> None:
    if k < 0:   # a signed count type read as a negative length
        raise BodyError(f"{where}: PLY element '{el.name}' row {row}: list '{name}' has length {k}")


def _ply_binary_lists(data, offset, el, endian, where):
    """An element with list properties. Fast path: every list has the length of
    the first row's (all triangles, say); otherwise row by row."""
    if el.count == 0:
        return {n: (np.zeros(0, np.int64), np.zeros(0, np.int64)) if isinstance(t, tuple) else np.zeros(0)
                for n, t in el.props}, offset
    fields = []
    pos = offset
    for n, t in el.props:
        if isinstance(t, tuple):
            cdt = np.dtype(endian + t[0])
            if pos + cdt.itemsize > len(data):
                raise BodyError(f"{where}: PLY file is truncated in element '{el.name}' (row 0)")
            k = int(np.frombuffer(data, dtype=cdt, count=1, offset=pos)[0])
            _list_count(k, el, n, 0, where)
            fields += [(n + "#n", endian + t[0]), (n, endian + t[1], (k,))]
            pos += cdt.itemsize + k * np.dtype(t[1]).itemsize
        else:
            fields.append((n, endian + t))
            pos += np.dtype(t).itemsize
    dt = np.dtype(fields)
    if offset + dt.itemsize * el.count <= len(data):
        arr = np.frombuffer(data, dtype=dt, count=el.count, offset=offset)
        uniform = all(np.all(arr[n + "#n"] == arr[n].shape[1]) for n, t in el.props if isinstance(t, tuple))
        if uniform:
            table = {}
            for n, t in el.props:
                if isinstance(t, tuple):
                    k = arr[n].shape[1]
                    table[n] = (np.full(el.count, k, dtype=np.int64), arr[n].reshape(-1).astype(np.int64))
                else:
                    table[n] = arr[n]
            return table, offset + dt.itemsize * el.count
    # General case: variable-length lists.
    cols = {n: [] for n, _ in el.props}
    counts = {n: [] for n, t in el.props if isinstance(t, tuple)}
    pos = offset
    for row in range(el.count):
        for n, t in el.props:
            if isinstance(t, tuple):
                cdt, idt = np.dtype(endian + t[0]), np.dtype(endian + t[1])
                if pos + cdt.itemsize > len(data):
                    raise BodyError(f"{where}: PLY file is truncated in element '{el.name}' (row {row})")
                k = int(np.frombuffer(data, dtype=cdt, count=1, offset=pos)[0])
                _list_count(k, el, n, row, where)
                pos += cdt.itemsize
                if pos + k * idt.itemsize > len(data):
                    raise BodyError(f"{where}: PLY file is truncated in element '{el.name}' (row {row})")
                cols[n].append(np.frombuffer(data, dtype=idt, count=k, offset=pos))
                counts[n].append(k)
                pos += k * idt.itemsize
            else:
                sdt = np.dtype(endian + t)
                if pos + sdt.itemsize > len(data):
                    raise BodyError(f"{where}: PLY file is truncated in element '{el.name}' (row {row})")
                cols[n].append(np.frombuffer(data, dtype=sdt, count=1, offset=pos)[0])
                pos += sdt.itemsize
    table = {}
    for n, t in el.props:
        if isinstance(t, tuple):
            table[n] = (np.asarray(counts[n], dtype=np.int64),
                        np.concatenate(cols[n]).astype(np.int64) if cols[n] else np.zeros(0, np.int64))
        else:
            table[n] = np.asarray(cols[n])
    return table, pos


def _ply_ascii(body: bytes, elements, where: str, header_lines: int) -> dict:
    lines = body.decode("ascii", errors="replace").splitlines()
    lines_i = 0
    tables = {}
    for el in elements:
        rows = []
        first_line = header_lines + 1 + lines_i
        while len(rows) < el.count:
            if lines_i >= len(lines):
                raise BodyError(f"{where}: PLY file ends early in element '{el.name}' "
                                f"({len(rows)} of {el.count} rows)")
            tok = lines[lines_i].split()
            lines_i += 1
            if tok:
                rows.append(tok)
        simple = all(not isinstance(t, tuple) for _, t in el.props)
        if simple:
            try:
                arr = np.array([r[:len(el.props)] for r in rows], dtype=np.float64) if rows else \
                    np.zeros((0, len(el.props)))
            except ValueError:
                arr = None
            if arr is None or arr.ndim != 2 or arr.shape[1] != len(el.props):
                for q, r in enumerate(rows):
                    try:
                        if len(r) < len(el.props):
                            raise ValueError
                        [float(x) for x in r[:len(el.props)]]
                    except ValueError:
                        raise BodyError(f"{where}: PLY line {first_line + q}: bad '{el.name}' row "
                                        f"{' '.join(r)!r}") from None
                raise BodyError(f"{where}: PLY element '{el.name}' has malformed rows")
            tables[el.name] = {n: arr[:, c] for c, (n, _) in enumerate(el.props)}
            continue
        fast = _ply_ascii_uniform(rows, el)
        if fast is not None:
            tables[el.name] = fast
            continue
        cols = {n: [] for n, _ in el.props}
        counts = {n: [] for n, t in el.props if isinstance(t, tuple)}
        for q, r in enumerate(rows):
            pos = 0
            try:
                for n, t in el.props:
                    if isinstance(t, tuple):
                        k = int(r[pos])
                        if k < 0 or pos + 1 + k > len(r):
                            raise ValueError
                        cols[n].extend(int(x) for x in r[pos + 1:pos + 1 + k])
                        counts[n].append(k)
                        pos += 1 + k
                    else:
                        cols[n].append(float(r[pos]))
                        pos += 1
            except (ValueError, IndexError):
                raise BodyError(f"{where}: PLY line {first_line + q}: bad '{el.name}' row {' '.join(r)!r}") from None
        try:
            tables[el.name] = {
                n: (np.asarray(counts[n], dtype=np.int64), np.asarray(cols[n], dtype=np.int64))
                if isinstance(t, tuple) else np.asarray(cols[n]) for n, t in el.props}
        except OverflowError:             # an index past 64 bits
            raise BodyError(f"{where}: PLY element '{el.name}': an index is too large to be a vertex index") from None
    return tables


def _ply_ascii_uniform(rows, el):
    """Rows of equal length whose lists all have the first row's lengths (all
    triangles, say): parse them as one array. None when that does not hold."""
    if not rows or len({len(r) for r in rows}) != 1:
        return None
    try:
        arr = np.array(rows, dtype=np.float64)
    except ValueError:
        return None
    table, pos = {}, 0
    for n, t in el.props:
        if isinstance(t, tuple):
            k = int(arr[0, pos])
            if k < 0 or not np.all(arr[:, pos] == k) or pos + 1 + k > arr.shape[1]:
                return None
            items = arr[:, pos + 1:pos + 1 + k]
            if not np.all(items == np.round(items)):
                return None
            table[n] = (np.full(len(rows), k, dtype=np.int64), items.reshape(-1).astype(np.int64))
            pos += 1 + k
        else:
            table[n] = arr[:, pos]
            pos += 1
    return table if pos == arr.shape[1] else None
