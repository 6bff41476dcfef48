"""What the batch keeps in --out besides the jobs' own folders: each job's record (its
settings hash, exit, seconds, attempts and results), the summary table and status.json.

A job is done when its record says so under the settings hash the manifest asks for now
and its folder holds the result's report: then a rerun skips it. The record is written
after the job's folder is in place, so a job killed in between is simply done again.
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

from ..fileio import atomic_write_text, json_default
from . import settings as job_settings

LEVELS = ("bust", "waist", "hip")
RESULT_FILE = {"grade": "report.json", "grade-run": "summary.json"}


def file_digest(path: Path, _memo: dict = {}) -> str:
    """sha256 of a file's bytes ("missing" when it cannot be read: the job says why)."""
    path = Path(path)
    try:
        st = path.stat()
        key = (str(path), st.st_size, st.st_mtime_ns)
        if key not in _memo:
            h = hashlib.sha256()
            with open(path, "rb") as f:
                for chunk in iter(lambda: f.read(1 << 20), b""):
                    h.update(chunk)
            _memo[key] = h.hexdigest()
        return _memo[key]
    except OSError:
        return "missing"


def settings_hash(job) -> str:
    """What the job's result depends on: its kind, target, settings, the inputs' contents
    and the seamfit version."""
    from .. import __version__
    spec = {"kind": job.kind, "size": job.target.get("size"), "options": job_settings.to_argv(job.settings),
            "inputs": [file_digest(p) for p in job.inputs()], "seamfit": __version__}
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:24]


def record_path(out: Path, job_id: str) -> Path:
    return Path(out) / "jobs" / f"{job_id}.json"


def read_record(out: Path, job_id: str) -> dict | None:
    try:
        return json.loads(record_path(out, job_id).read_text())
    except (OSError, ValueError):
        return None


def is_done(out: Path, job, digest: str) -> dict | None:
    """The job's record when its result is in place under this settings hash, else None."""
    rec = read_record(out, job.id)
    if not rec or rec.get("state") != "done" or rec.get("hash") != digest:
        return None
    if not (Path(out) / job.id / RESULT_FILE[job.kind]).is_file():
        return None
    return rec


def write_record(out: Path, record: dict) -> None:
    atomic_write_text(record_path(out, record["id"]), json.dumps(record, indent=1, default=json_default) + "\n")


# ------------------------------------------------------------------ results of a job

def _ease_errors(report: dict) -> dict:
    """Result ease minus base ease per level (cm): how far the graded garment's ease is
    from the base's; None where the garment does not reach that level."""
    ease = report.get("ease_cm") or {}
    base, res = ease.get("base") or {}, ease.get("result") or {}
    return {lv: (None if base.get(lv) is None or res.get(lv) is None else round(res[lv] - base[lv], 3))
            for lv in LEVELS}


def _one(report: dict) -> dict:
    from ..opt.size_run import summary_row
    row = summary_row("", report, warm_from=None, seconds=0.0, folder="")
    return {"ease_error_cm": _ease_errors(report), "seam_mismatch_max_mm": row["seam_mismatch_mm"]["max"],
            "converged": row["converged"], "outer_iterations": row["outer_iterations"]}


def results_of(folder: Path, kind: str) -> dict:
    """The summary numbers of a finished job, read back from what it wrote. A size run
    gives, per level, the ease error of largest size, the largest seam mismatch, and
    converged when every size did."""
    folder = Path(folder)
    if kind == "grade":
        return _one(json.loads((folder / "report.json").read_text()))
    summary = json.loads((folder / "summary.json").read_text())
    rows = [_one(json.loads((folder / r["folder"] / "report.json").read_text()))
            for r in summary["sizes"] if not r.get("base")]
    ease = {}
    for lv in LEVELS:
        vals = [r["ease_error_cm"][lv] for r in rows if r["ease_error_cm"][lv] is not None]
        ease[lv] = max(vals, key=abs) if vals else None
    seams = [r["seam_mismatch_max_mm"] for r in rows if r["seam_mismatch_max_mm"] is not None]
    return {"ease_error_cm": ease, "seam_mismatch_max_mm": max(seams) if seams else None,
            "converged": all(r["converged"] for r in rows), "sizes": len(rows),
            "outer_iterations": sum(r["outer_iterations"] or 0 for r in rows)}


# ------------------------------------------------------------------ summary and status

def _fmt(v, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def table(records: list[dict]) -> str:
    """The per-job summary for the terminal."""
    lines = [f"{'job':<24} {'state':<8} {'exit':>4} {'s':>7} {'tries':>5} {'ease err b/w/h cm':>19} "
             f"{'seam mm':>8} converged"]
    for r in records:
        res = r.get("results") or {}
        ease = res.get("ease_error_cm") or {}
        e = "/".join(_fmt(ease.get(lv), ".2f") for lv in LEVELS) if ease else "-"
        conv = "-" if "converged" not in res else ("yes" if res["converged"] else "no")
        lines.append(f"{r['id']:<24} {r['state']:<8} {_fmt(r.get('exit'), 'd'):>4} {_fmt(r.get('seconds'), '.1f'):>7} "
                     f"{_fmt(r.get('attempts'), 'd'):>5} {e:>19} {_fmt(res.get('seam_mismatch_max_mm'), '.3f'):>8} "
                     f"{conv}")
    return "\n".join(lines)


def write_summary(out: Path, records: list[dict]) -> None:
    out = Path(out)
    atomic_write_text(out / "summary.json", json.dumps({"jobs": records}, indent=1, default=json_default) + "\n")
    head = ["job", "kind", "state", "exit", "seconds", "attempts", *(f"ease_error_{lv}_cm" for lv in LEVELS),
            "seam_mismatch_max_mm", "converged", "log"]
    rows = [",".join(head)]
    for r in records:
        res = r.get("results") or {}
        ease = res.get("ease_error_cm") or {}
        cells = [r["id"], r["kind"], r["state"], _fmt(r.get("exit"), "d").replace("-", ""),
                 _fmt(r.get("seconds"), ".2f").replace("-", "") if r.get("seconds") is not None else "",
                 str(r.get("attempts") or ""), *("" if ease.get(lv) is None else f"{ease[lv]:g}" for lv in LEVELS),
                 "" if res.get("seam_mismatch_max_mm") is None else f"{res['seam_mismatch_max_mm']:g}",
                 "" if "converged" not in res else ("yes" if res["converged"] else "no"), r.get("log") or ""]
        rows.append(",".join(cells))
    atomic_write_text(out / "summary.csv", "\n".join(rows) + "\n")


class Status:
    """Counts, throughput and time left, written to status.json (atomically) as they change."""

    def __init__(self, out: Path, manifest: Path, ids: list[str]):
        self.path = Path(out) / "status.json"
        self.manifest = str(manifest)
        self.t0 = time.time()
        self.state = {i: "queued" for i in ids}
        self.gradings = 0             # gradings finished in this run (a size run's sizes each count)
        self.ran = 0                  # jobs finished (done or failed) in this run

    def set(self, job_id: str, state: str, gradings: int = 0) -> None:
        if state in ("done", "failed") and self.state.get(job_id) not in ("done", "failed", "skipped"):
            self.ran += 1
            self.gradings += gradings
        self.state[job_id] = state

    def counts(self) -> dict:
        c = {k: 0 for k in ("done", "skipped", "failed", "running", "queued")}
        for s in self.state.values():
            c[s] += 1
        return c

    def snapshot(self) -> dict:
        c = self.counts()
        elapsed = time.time() - self.t0
        left_jobs = c["running"] + c["queued"]
        rate = self.ran / elapsed if self.ran and elapsed > 0 else None
        return {"manifest": self.manifest, "total": len(self.state), **c,
                "elapsed_s": round(elapsed, 1), "gradings": self.gradings,
                "jobs_per_hour": None if rate is None else round(3600 * rate, 1),
                "gradings_per_hour": None if rate is None else round(3600 * self.gradings / elapsed, 1),
                "seconds_left": None if rate is None else round(left_jobs / rate, 1),
                "running_jobs": sorted(i for i, s in self.state.items() if s == "running"),
                "failed_jobs": sorted(i for i, s in self.state.items() if s == "failed"),
                "finished": left_jobs == 0, "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z")}

    def write(self) -> dict:
        snap = self.snapshot()
        atomic_write_text(self.path, json.dumps(snap, indent=1) + "\n")
        return snap

    def line(self) -> str:
        s = self.snapshot()
        rate = "" if s["jobs_per_hour"] is None else f", {s['gradings_per_hour']:.0f} gradings/h"
        left = "" if s["seconds_left"] is None else f", about {_clock(s['seconds_left'])} left"
        return (f"[{_clock(s['elapsed_s']):>7}] {s['done'] + s['skipped']}/{s['total']} done "
                f"({s['skipped']} skipped), {s['failed']} failed, {s['running']} running{rate}{left}")


def _clock(seconds: float) -> str:
    m, s = divmod(int(round(seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"
