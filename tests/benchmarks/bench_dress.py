"""Every shared pattern dresses its own body: `seamfit drape` on each pattern of the data
(each garment in every size and shape, on the body it was drafted for), judged by the
simulator's limits: seams closed (largest sewing gap <= 2 mm), nothing inside the body
(smallest phi >= -1 mm) and the relative residual under the drape's tolerance.

    export PYTHONPATH=$PWD/native/python
    python tests/benchmarks/bench_dress.py run --data DATA --out OUT --jobs 16
    python tests/benchmarks/bench_dress.py report OUT/results.json

``run`` starts one `seamfit drape` process per pattern (at most --jobs at once, each with
--threads OpenMP threads, default cores / jobs) and collects their report.json files into
OUT/results.json (rewritten after every case). ``report`` writes docs/dress_results.md from
the runs' results and the reading of them in tests/benchmarks/dress_notes.md (--notes): the
notes' first paragraph is the page's summary, in bold under its title, the rest follows the
table. The committed page is rewritten by (one line)

    python tests/benchmarks/bench_dress.py report docs/results/data/dress_results.json
        docs/results/data/dress_results_rerun.json
"""
from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "native" / "python"))

from accuracy_case import body_file  # noqa: E402
from seamfit.fileio import atomic_write_text  # noqa: E402
from bench_cli import Commands, add_sweep, threads_per_job  # noqa: E402

MAX_GAP_MM = 2.0        # seams closed
MIN_PHI_MM = -1.0       # nothing inside the body


def cases(data: Path, garments: list[str] | None, only: list[str] | None = None) -> list[tuple[str, str]]:
    table = json.loads((data / "patterns" / "index.json").read_text())["garments"]
    # Circle skirts (the largest meshes, the slowest to settle) first, so a pool ends evenly.
    order = sorted(table, key=lambda g: ("circle" not in g, g))
    return [(g, b) for g in order if not garments or g in garments for b in sorted(table[g])
            if not only or f"{g}/{b}" in only]


def drape_one(data: Path, out: Path, garment: str, body: str, args) -> dict:
    folder = out / "cases" / f"{garment}__{body}"
    folder.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "seamfit", "drape", str(data / "patterns" / garment / body / "pattern.json"),
           str(body_file(data / "bodies", body)), "--out", str(folder), "--edge-length", str(args.edge_length),
           "--sdf-spacing", str(args.sdf_spacing), "--no-picture", "-q"]
    if args.max_seconds:
        cmd += ["--max-seconds", str(args.max_seconds)]
    env = dict(os.environ, OMP_NUM_THREADS=str(args.threads))
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    row = {"garment": garment, "body": body, "exit": proc.returncode, "wall_s": time.perf_counter() - t}
    rep = folder / "report.json"
    if rep.is_file():
        r = json.loads(rep.read_text())
        row.update({k: r.get(k) for k in ("converged", "residual", "iterations", "seconds", "max_sewing_gap_mm",
                                          "min_phi_mm", "vertices", "triangles", "message")})
        row["stages"] = [s.get("stage") for s in r.get("stages", [])]
    else:
        row["error"] = (proc.stderr or proc.stdout)[-600:]
    return row


def verdict(r: dict) -> bool:
    return bool(r.get("converged")) and r.get("max_sewing_gap_mm") is not None \
        and r["max_sewing_gap_mm"] <= MAX_GAP_MM and r["min_phi_mm"] >= MIN_PHI_MM


def cmd_run(args) -> int:
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    todo = cases(args.data, args.garments.split(",") if args.garments else None,
                 args.cases.split(",") if args.cases else None)
    args.threads = threads_per_job(args.threads, args.jobs)
    meta = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                       f"Python {platform.python_version()}",
            "command": " ".join(sys.argv), "edge_length_cm": args.edge_length, "sdf_spacing_m": args.sdf_spacing,
            "jobs": args.jobs, "threads": args.threads, "max_seconds": args.max_seconds}
    rows: list[dict] = []
    t0 = time.perf_counter()
    with ThreadPoolExecutor(args.jobs) as pool:
        futs = {pool.submit(drape_one, args.data, out, g, b, args): (g, b) for g, b in todo}
        for f in as_completed(futs):
            r = f.result()
            rows.append(r)
            meta["wall_s"] = time.perf_counter() - t0
            atomic_write_text(out / "results.json", json.dumps({"meta": meta, "cases": rows}, indent=1))
            ok = "ok  " if verdict(r) else "FAIL"
            print(f"[{time.perf_counter() - t0:7.0f}s] {ok} {r['garment']}/{r['body']}: "
                  f"gap {r.get('max_sewing_gap_mm')} mm, phi {r.get('min_phi_mm')} mm, "
                  f"residual {r.get('residual')}, {r.get('seconds')} s", flush=True)
    return 0


def _f(v, fmt=".2f"):
    return "-" if v is None else format(v, fmt)


def _merge_runs(paths: list[Path]) -> tuple[list[dict], list[dict]]:
    """Cases of several runs, a later run's case replacing an earlier one's (a rerun of
    some cases with other settings), and each run's meta with the cases it supplied."""
    by_case: dict[tuple[str, str], dict] = {}
    runs = []
    for i, path in enumerate(paths):
        data = json.loads(path.read_text())
        runs.append(dict(data["meta"]))
        for r in data["cases"]:
            by_case[(r["garment"], r["body"])] = dict(r, run=i)
    for i, meta in enumerate(runs):
        meta["supplied"] = sorted(f"{g}/{b}" for (g, b), r in by_case.items() if r["run"] == i)
    return sorted(by_case.values(), key=lambda r: (r["garment"], r["body"])), runs


def _run_line(meta: dict, i: int, n_cases: int) -> str:
    budget = meta.get("max_seconds")
    if budget is None:  # runs written before max_seconds was recorded: read it off the command
        words = meta["command"].split()
        budget = float(words[words.index("--max-seconds") + 1]) if "--max-seconds" in words else 0.0
    k = len(meta["supplied"])
    which = ("all cases" if k == n_cases else ", ".join(meta["supplied"]) if k <= 12
             else f"{k} cases, all but those of the other runs")
    return (f"* Run {i + 1} ({which}): {meta['machine']}; {meta['jobs']} drapes at once, {meta['threads']} "
            f"thread(s) each; {meta['edge_length_cm']} cm mesh, {meta['sdf_spacing_m'] * 1000:g} mm SDF; "
            f"{'a budget of %g s per stage' % budget if budget else 'no time budget (the default)'}; "
            f"wall {meta.get('wall_s', 0):.0f} s. Command: `{meta['command']}`")


def split_notes(text: str) -> tuple[str, str]:
    """The notes file's summary (its first paragraph, joined into one line) and the rest; no
    summary when the file starts with a heading."""
    text = text.strip()
    if text.startswith("#"):
        return "", text
    head, _, rest = text.partition("\n\n")
    return " ".join(head.split()), rest.strip()


def cmd_report(args) -> int:
    rows, runs = _merge_runs(args.results)
    summary, discussion = split_notes(args.notes.read_text()) if args.notes else ("", "")
    lines = ["# Every shared pattern dresses its own body", ""]
    if summary:
        lines += [f"**{summary}**", ""]
    lines += ["Generated by `tests/benchmarks/bench_dress.py report` from:", ""]
    lines += [_run_line(m, i, len(rows)) for i, m in enumerate(runs) if m["supplied"]]
    lines += [
        "",
        "Each pattern of the data "
        "is draped by `seamfit drape` on the body it was drafted for (sew with gravity off, settle; where the "
        "settle stagnates, a restart from the drape at twice the edge length and a Newton polish; see "
        "[simulator.md](simulator.md)). Limits: largest sewing gap "
        f"<= {MAX_GAP_MM:g} mm, smallest phi >= {MIN_PHI_MM:g} mm, relative residual under the tolerance "
        "(converged). Multi-layer garments (waistbands over skirts and trousers) ignore self-collision, as the "
        "paper does.", ""]
    good = [r for r in rows if verdict(r)]
    lines += [
        f"**{len(good)} of {len(rows)} patterns dress their body within the limits.**", "",
        "| garment | body | vertices | triangles | converged | residual | largest seam gap mm | smallest phi mm "
        "| iterations | seconds | stages |",
        "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        lines.append(
            f"| {r['garment']} | {r['body']} | {_f(r.get('vertices'), 'd')} | {_f(r.get('triangles'), 'd')} | "
            f"{'yes' if r.get('converged') else '**no**'} | {_f(r.get('residual'), '.2e')} | "
            f"{_f(r.get('max_sewing_gap_mm'))} | {_f(r.get('min_phi_mm'))} | {_f(r.get('iterations'), 'd')} | "
            f"{_f(r.get('seconds'), '.1f')} | {', '.join(r.get('stages') or []) or r.get('error', '')[:80]} |")
    bad = [r for r in rows if not verdict(r)]
    if bad:
        lines += ["", "## Outside the limits", ""]
        for r in bad:
            lines.append(f"* {r['garment']}/{r['body']}: {r.get('message') or r.get('error', '')[:300]}")
    if discussion:
        lines += ["", discussion]
    atomic_write_text(args.docs / "dress_results.md", "\n".join(lines) + "\n")
    print(f"{len(good)} / {len(rows)} within the limits; wrote {args.docs / 'dress_results.md'}")
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__)
    r = cli.add_run(cmd_run)
    add_sweep(r, bodies=False)
    r.add_argument("--threads", type=int, default=0, help="OpenMP threads per drape (default cores / jobs)")
    r.add_argument("--cases", default=None, help="comma list of garment/body (default all)")
    r.add_argument("--edge-length", type=float, default=1.5, help="mesh edge cm (default 1.5, the drape default)")
    r.add_argument("--sdf-spacing", type=float, default=0.0025, help="SDF spacing m (default 0.0025)")
    r.add_argument("--max-seconds", type=float, default=0.0, help="time budget per drape stage (default none)")
    q = cli.add_report(cmd_report)
    q.add_argument("--notes", type=Path, default=HERE / "dress_notes.md",
                   help="the reading of the results: its first paragraph the page's summary, the rest "
                        "appended after the table (default tests/benchmarks/dress_notes.md)")
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
