"""Coverage-guided fuzzing (atheris, libFuzzer) of the file readers: sewpat-1 and
GarmentCode patterns, OBJ and PLY bodies. Each input is written to a file and read the
way the commands read it, then validated; the only exceptions allowed are seamfit's own
(PatternError, BodyError: the one-line errors users see). Anything else is a crash, and
libFuzzer keeps the input that caused it under --artifacts.

    python tests/benchmarks/fuzz_readers.py all --runs 100000 [--artifacts DIR] [--json FILE]
    python tests/benchmarks/fuzz_readers.py sewpat --runs 100000        (one reader)

Seeds are the sample files; atheris is a development tool (pip install atheris), not a
dependency of seamfit.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_files"
READERS = {
    # reader: (file suffix, seed files)
    "sewpat": (".json", [SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"]),
    "garmentcode": (".json", sorted(SAMPLES.glob("patterns/*/size06/native/*specification.json"))),
    "obj": (".obj", []),          # seeded with a small cut of a sample body (below)
    "ply": (".ply", []),
}


def _small_obj() -> bytes:
    """The first 200 triangles of a sample body as OBJ: a seed small enough to mutate."""
    lines = (SAMPLES / "bodies/women_size06.obj").read_text().splitlines()
    faces = [ln for ln in lines if ln.startswith("f ")][:200]
    used = sorted({int(t.split("/")[0]) for f in faces for t in f.split()[1:]})
    verts = [ln for ln in lines if ln.startswith("v ")]
    remap = {old: new + 1 for new, old in enumerate(used)}
    out = [verts[i - 1] for i in used]
    out += ["f " + " ".join(str(remap[int(t.split("/")[0])]) for t in f.split()[1:]) for f in faces]
    return ("\n".join(out) + "\n").encode()


def _small_ply(obj: bytes) -> bytes:
    v = [ln.split()[1:4] for ln in obj.decode().splitlines() if ln.startswith("v ")]
    f = [ln.split()[1:] for ln in obj.decode().splitlines() if ln.startswith("f ")]
    head = (f"ply\nformat ascii 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    body = "".join(" ".join(p) + "\n" for p in v) + "".join(
        f"{len(t)} " + " ".join(str(int(i) - 1) for i in t) + "\n" for t in f)
    return (head + body).encode()


def _target(reader: str):
    """The function libFuzzer calls: read the bytes as the commands read a file."""
    import atheris
    import numpy  # noqa: F401  (imported first, so that only seamfit is instrumented)
    import scipy.sparse  # noqa: F401
    with atheris.instrument_imports(include=["seamfit"]):
        from seamfit.body import load_body, validate_body
        from seamfit.errors import SeamfitError
        from seamfit.pattern import validate_pattern
        from seamfit.pattern.io import read_pattern_file
    suffix = READERS[reader][0]
    folder = Path(tempfile.mkdtemp(prefix="seamfit-fuzz-", dir="/dev/shm" if Path("/dev/shm").is_dir() else None))
    path = folder / f"input{suffix}"

    def one(data: bytes) -> None:
        path.write_bytes(data)
        try:
            if reader in ("sewpat", "garmentcode"):
                pattern, _ = read_pattern_file(path)
                validate_pattern(pattern)
            else:
                validate_body(load_body(path))
        except SeamfitError:
            pass                  # a one-line error: what bad input must give
    return one


def run_one(reader: str, runs: int, artifacts: Path) -> None:
    import atheris
    corpus = Path(tempfile.mkdtemp(prefix=f"seamfit-fuzz-{reader}-corpus-"))
    seeds = list(READERS[reader][1])
    if reader == "obj":
        (corpus / "seed.obj").write_bytes(_small_obj())
    elif reader == "ply":
        (corpus / "seed.ply").write_bytes(_small_ply(_small_obj()))
    for k, s in enumerate(seeds):
        (corpus / f"seed{k}{s.suffix}").write_bytes(s.read_bytes())
    artifacts.mkdir(parents=True, exist_ok=True)
    target = _target(reader)
    # -timeout: an input that takes longer than 10 s is a hang; -rss_limit_mb: one that
    # needs more than 2 GB is a memory blow-up (the readers' limits must stop it first).
    atheris.Setup([sys.argv[0], f"-runs={runs}", "-timeout=10", "-rss_limit_mb=2048", "-max_len=65536",
                   f"-artifact_prefix={artifacts}/{reader}-", str(corpus)], target)
    atheris.Fuzz()


def run_all(runs: int, artifacts: Path, out_json: Path | None) -> int:
    rows = []
    for reader in READERS:
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, __file__, reader, "--runs", str(runs), "--artifacts", str(artifacts)],
                              capture_output=True, text=True, env=dict(os.environ, PYTHONWARNINGS="ignore"))
        found = sorted(p.name for p in artifacts.glob(f"{reader}-*"))
        done = [ln for ln in proc.stderr.splitlines() if ln.startswith("Done ")]
        rows.append({"reader": reader, "runs": runs, "exit": proc.returncode, "artifacts": found,
                     "crashes": sum(n.startswith(f"{reader}-crash") for n in found),
                     "hangs": sum(n.startswith(f"{reader}-timeout") for n in found),
                     "memory": sum(n.startswith(f"{reader}-oom") for n in found),
                     "seconds": round(time.perf_counter() - t0, 1), "libfuzzer": done[-1] if done else None})
        print(json.dumps(rows[-1]), flush=True)
        if proc.returncode and not found:
            print(proc.stderr[-3000:], file=sys.stderr)
    if out_json:
        out_json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("reader", choices=[*READERS, "all"])
    ap.add_argument("--runs", type=int, default=100_000)
    ap.add_argument("--artifacts", type=Path, default=Path(tempfile.gettempdir()) / "seamfit-fuzz-artifacts")
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.reader == "all":
        return run_all(a.runs, a.artifacts, a.json)
    run_one(a.reader, a.runs, a.artifacts)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
