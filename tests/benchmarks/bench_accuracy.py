"""Grading accuracy against the drafting systems' own patterns.

For every garment in the data, the base pattern (size06) is graded to each other body and
compared with the same system's draft for that body: per panel, a rigid alignment over the
landmarks both share (matched by name; ``seamfit.pattern.compare``), then the largest
landmark distance (cm). Scored alongside: the unchanged base pattern and proportional
scaling (``seamfit.pattern.scale``: widths by the girth ratio, lengths by the height
ratio). Also the ease error |ease on the target - ease of the base on the base body| at
bust / waist / hip (cm) and the seconds each method took.

Full run (repo root as the current directory, data under DATA):

    export PYTHONPATH=$PWD/native/python
    python tests/benchmarks/bench_accuracy.py run --data DATA --out bench_out/accuracy --jobs 8
    python tests/benchmarks/bench_accuracy.py report bench_out/accuracy/results.json

Methods: ``--methods adjoint,two-phase,fixed-point`` (a method this build lacks is recorded
as an error for each case). A subset: ``--garments gc_pencil_skirt --bodies size14``, with
coarse settings ``--edge-length 4 --sdf-spacing 0.005 --max-iterations 32``.

``run`` starts one process per case (at most ``--jobs`` at once, each with
``--threads`` OpenMP threads, default cores / jobs), so a crash or a timeout loses one
case only; each case's JSON and graded patterns are kept under OUT/cases/ and ``--resume``
skips cases already there. OUT/results.json collects them. ``report`` turns one or more
results.json (later files win for the same case) into docs/accuracy_results.md and
docs/img/accuracy_*.png.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import queue
import shlex
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from datetime import datetime, timezone
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
from bench_cli import Commands, add_sweep, threads_per_job  # noqa: E402

BASELINES = ("unchanged", "scaled")


# ----------------------------------------------------------------------------- cases

def discover(data: Path, base: str, garments: list[str] | None, bodies: list[str] | None) -> list[tuple[str, str]]:
    """(garment, body) pairs from patterns/index.json (or the folders), base body excluded."""
    pdir = data / "patterns"
    index = pdir / "index.json"
    if index.is_file():
        table = {g: sorted(b) for g, b in json.loads(index.read_text())["garments"].items()}
    else:
        table = {g.name: sorted(b.name for b in g.iterdir() if (b / "pattern.json").is_file())
                 for g in sorted(pdir.iterdir()) if g.is_dir()}
    pairs = []
    for g, bs in sorted(table.items()):
        if base not in bs or (garments and g not in garments):
            continue
        pairs += [(g, b) for b in bs if b != base and (not bodies or b in bodies)]
    return pairs


def preset_for(garment: str) -> str:
    """The preset seamfit's "auto" picks for this garment (its id names its kind)."""
    from seamfit.opt.presets import preset_for_garment
    return preset_for_garment(garment)


def grade_kwargs(args, garment: str) -> dict:
    kw = {"preset": args.preset if args.preset != "auto" else preset_for(garment)}
    for opt, field in (("edge_length", "edge_length_cm"), ("sdf_spacing", "sdf_spacing"),
                       ("max_iterations", "max_outer_iterations"), ("checkpoint_every", "checkpoint_every"),
                       ("inner_iterations", "inner_iterations"), ("time_budget", "time_budget_s"),
                       ("device", "device"), ("coarse_edge_length", "coarse_edge_length_cm"),
                       ("fine_iterations", "fine_outer_iterations")):
        v = getattr(args, opt, None)
        if v is not None:
            kw[field] = v
    if getattr(args, "start", None) is not None:
        kw["start"] = args.start
    over = dict(item.split("=", 1) for item in getattr(args, "strength", []) or [])
    if getattr(args, "seam", None) is not None:
        over["seam"] = args.seam
    if over:
        from dataclasses import asdict

        from seamfit.opt.presets import preset
        kw["strengths"] = {**asdict(preset(kw["preset"]).strengths), **{k: float(v) for k, v in over.items()}}
    return kw


def case_dir(out: Path, garment: str, body: str) -> Path:
    return out / "cases" / garment / body


def run_one(spec: dict, out: Path, threads: int, timeout: float | None, gpu: int | None = None) -> dict:
    """Run one case in a child process (on GPU ``gpu`` of the host, if given); a crash or
    timeout becomes that case's error."""
    from seamfit.fileio import atomic_write_text
    d = case_dir(out, spec["garment"], spec["body"])
    d.mkdir(parents=True, exist_ok=True)
    spec_path, result_path = d / "spec.json", d / "case.json"
    atomic_write_text(spec_path, json.dumps(spec, indent=1) + "\n")
    result_path.unlink(missing_ok=True)
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    if gpu is not None:
        env["CUDA_VISIBLE_DEVICES"] = str(gpu)
    cmd = [sys.executable, str(Path(__file__).resolve()), "case", str(spec_path), str(result_path)]
    t0 = time.perf_counter()
    with open(d / "log.txt", "w") as log:
        try:
            rc = subprocess.run(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            rc = "timeout"
    if result_path.is_file():
        return json.loads(result_path.read_text())
    why = f"timed out after {timeout:.0f} s" if rc == "timeout" else f"case process exited with {rc}"
    return {"garment": spec["garment"], "body": spec["body"], "base": spec["base"], "methods": {},
            "error": {"ok": False, "error": f"{why}; see {d / 'log.txt'}"},
            "seconds": time.perf_counter() - t0}


def cmd_case(args) -> int:
    from accuracy_case import run_case
    from seamfit.fileio import atomic_write_text, json_default
    spec = json.loads(Path(args.spec).read_text())
    res = run_case(Path(spec["data"]), spec["garment"], spec["body"], spec["base"], spec["methods"],
                   spec["grade"], save_dir=Path(args.result).parent, baseline_ease=spec["baseline_ease"])
    res["grade_settings"] = spec["grade"]
    atomic_write_text(Path(args.result), json.dumps(res, indent=1, default=json_default) + "\n")
    return 0




def machine() -> dict:
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"host": platform.node(), "cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "platform": platform.platform(), "blas": blas_kernels()}


def blas_kernels() -> dict:
    """The OpenBLAS kernel set numpy's and SciPy's libraries run (their own choice for the
    CPU, or OPENBLAS_CORETYPE's): results move by up to 0.3 cm between kernel sets
    (docs/method.md, "The drafts' own ease, and the CPU's BLAS kernels"), so a run records them."""
    import ctypes
    import numpy  # noqa: F401 - loads its OpenBLAS
    import scipy.linalg  # noqa: F401 - loads SciPy's
    out = {"OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE")}
    try:
        mapped = {line.split()[-1] for line in Path("/proc/self/maps").read_text().splitlines()}
    except OSError:
        return out
    for path in sorted(p for p in mapped if p.startswith("/") and "openblas" in p.lower()):
        # numpy 2's library is called scipy_openblas too: the folder says whose it is
        parts = Path(path).parts
        owner = next((n for n in ("numpy", "scipy") if n in parts or f"{n}.libs" in parts), Path(path).name)
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for name in ("openblas_get_corename64_", "openblas_get_corename",
                     "scipy_openblas_get_corename64_", "scipy_openblas_get_corename"):
            fn = getattr(lib, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                out[owner] = fn().decode()
                break
    return out


def git_commit() -> str | None:
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=10).stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        return None


def source_digest() -> str:
    """SHA-256 over the seamfit sources a grading runs (native/: Python, C++, CUDA), path and
    bytes in path order: ties a result to its code where the checkout's commit cannot (a
    copied tree, uncommitted changes)."""
    import hashlib
    h = hashlib.sha256()
    for f in sorted((ROOT / "native").rglob("*")):
        if f.is_file() and f.suffix in {".py", ".cpp", ".hpp", ".h", ".cu", ".cuh", ".txt"} \
                and "__pycache__" not in f.parts:
            h.update(str(f.relative_to(ROOT)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def git_dirty() -> bool | None:
    """Whether the checkout's native/ differs from its commit (None: not a git checkout)."""
    try:
        r = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--", "native"],
                           capture_output=True, text=True, timeout=20)
        return bool(r.stdout.strip()) if r.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        return None


def cmd_run(args) -> int:
    from accuracy_report import console_table, load_results
    from seamfit.fileio import atomic_write_text
    data, out = args.data.resolve(), args.out.resolve()
    if not (data / "patterns").is_dir() or not (data / "bodies").is_dir():
        print(f"{data}: needs patterns/ and bodies/", file=sys.stderr)
        return 2
    split = lambda s: [x.strip() for x in s.split(",") if x.strip()] if s else None  # noqa: E731
    methods = split(args.methods) or ["adjoint"]
    pairs = discover(data, args.base, split(args.garments), split(args.bodies))
    if not pairs:
        print("no (garment, body) pair matches", file=sys.stderr)
        return 2
    jobs = max(1, args.jobs)
    threads = threads_per_job(args.threads, jobs)
    out.mkdir(parents=True, exist_ok=True)
    meta = {"command": " ".join(shlex.quote(a) for a in sys.argv), "data": str(data), "base": args.base,
            "methods": methods, "jobs": jobs, "threads_per_job": threads, "machine": machine(),
            "commit": git_commit(), "native_modified": git_dirty(), "source_digest": source_digest(),
            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "subset": bool(args.garments or args.bodies), "baseline_ease": not args.no_baseline_ease}
    specs = [{"data": str(data), "garment": g, "body": b, "base": args.base, "methods": methods,
              "grade": grade_kwargs(args, g), "baseline_ease": not args.no_baseline_ease} for g, b in pairs]
    results: dict[tuple[str, str], dict] = {}
    todo = []
    for s in specs:
        done = case_dir(out, s["garment"], s["body"]) / "case.json"
        if args.resume and done.is_file():
            results[(s["garment"], s["body"])] = json.loads(done.read_text())
        else:
            todo.append(s)
    print(f"{len(specs)} cases ({len(specs) - len(todo)} kept from an earlier run), methods {','.join(methods)}, "
          f"{jobs} at once x {threads} threads", file=sys.stderr)

    def save():
        rows = [results[(s["garment"], s["body"])] for s in specs if (s["garment"], s["body"]) in results]
        meta["finished"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
        atomic_write_text(out / "results.json", json.dumps({"meta": meta, "cases": rows}, indent=1) + "\n")

    # Each of the ``jobs`` slots keeps one GPU (slot k uses GPU k mod gpus).
    slots: queue.Queue = queue.Queue()
    for k in range(jobs):
        slots.put(k)

    def run_in_slot(s):
        k = slots.get()
        try:
            return run_one(s, out, threads, args.case_timeout, k % args.gpus if args.gpus > 1 else None)
        finally:
            slots.put(k)

    if args.gpus > 1:
        meta["gpus"] = args.gpus
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        futs = {pool.submit(run_in_slot, s): s for s in todo}
        for fut in as_completed(futs):
            s = futs[fut]
            res = fut.result()
            results[(s["garment"], s["body"])] = res
            save()
            adj = res.get("methods", {}).get(methods[0], {})
            state = (f"max {adj['max_cm']:.2f} cm" if adj.get("ok") else
                     (adj.get("error") or res.get("error", {}).get("error", "?")))
            print(f"[{time.perf_counter() - t0:7.0f}s] {s['garment']}/{s['body']}: {methods[0]} {state} "
                  f"({res.get('seconds', 0):.0f} s)", file=sys.stderr, flush=True)
    save()
    meta["wall_seconds"] = time.perf_counter() - t0
    save()
    print("\n".join(console_table(load_results([out / "results.json"]))))
    print(f"wrote {out / 'results.json'}", file=sys.stderr)
    return 0


def cmd_report(args) -> int:
    from accuracy_report import console_table, load_results, write_report
    merged = load_results(args.results)
    print("\n".join(console_table(merged)))
    notes = args.notes.read_text() if args.notes else None
    for p in write_report(merged, args.docs, title_note=args.note, notes=notes):
        print(f"wrote {p}", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    cli = Commands(__doc__.splitlines()[0], epilog=__doc__)
    r = cli.add_run(cmd_run, help="grade and score every (garment, body) case")
    add_sweep(r, jobs_help="cases at once (default 1)")
    r.add_argument("--threads", type=int, default=0, help="OpenMP threads per case (default cores / jobs)")
    r.add_argument("--methods", default="adjoint", help="comma list of grading methods (default adjoint)")
    r.add_argument("--base", default="size06", help="base body id (default size06)")
    r.add_argument("--preset", default="auto", help="strength preset; auto: seamfit's choice for the garment kind")
    r.add_argument("--edge-length", type=float, default=None, help="mesh edge cm (default: GradeSettings)")
    r.add_argument("--sdf-spacing", type=float, default=None, help="SDF spacing m (default: GradeSettings)")
    r.add_argument("--max-iterations", type=int, default=None, help="outer iterations (default: GradeSettings)")
    r.add_argument("--checkpoint-every", type=int, default=None)
    r.add_argument("--coarse-edge-length", type=float, default=None,
                   help="coarse-to-fine: grade a finer mesh at this edge (cm) first; 0 off (default: GradeSettings)")
    r.add_argument("--fine-iterations", type=int, default=None,
                   help="coarse-to-fine: outer iterations on the finer mesh (default: GradeSettings)")
    r.add_argument("--inner-iterations", type=int, default=None)
    r.add_argument("--seam", type=float, default=None, help="seam-length strength (default: the preset's)")
    r.add_argument("--start", default=None, help="theta^(0) and anchor: base | level (default: GradeSettings)")
    r.add_argument("--strength", action="append", default=[], metavar="NAME=DELTA",
                   help="override one strength of the preset (repeatable), e.g. --strength pos=0")
    r.add_argument("--device", default=None, help="cpu | cuda | auto (default: GradeSettings)")
    r.add_argument("--gpus", type=int, default=1, help="spread the cases over this many GPUs of the host")
    r.add_argument("--time-budget", type=float, default=None, help="seconds per grading (default none)")
    r.add_argument("--case-timeout", type=float, default=None, help="kill a case after this many seconds")
    r.add_argument("--no-baseline-ease", action="store_true", help="skip draping the two baselines")
    r.add_argument("--resume", action="store_true", help="keep cases already finished under OUT/cases")
    c = cli.add("case", cmd_case, help=argparse.SUPPRESS)
    c.add_argument("spec")
    c.add_argument("result")
    p = cli.add_report(cmd_report, notes="markdown file appended as 'Notes on this run'",
                       help="results.json files -> docs/accuracy_results.md and docs/img/accuracy_*.png")
    p.add_argument("--note", default=None, help="a sentence put under the title (e.g. 'subset run')")
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
