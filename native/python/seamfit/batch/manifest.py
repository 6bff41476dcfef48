"""A batch manifest, read and checked before any work.

JSON: ``{"defaults": {...}, "jobs": [{...}, ...]}`` (or just the list of jobs); CSV: one job
per row, a column per field, an empty cell for a field not given. Each job has an ``id``
(its output folder's name), ``pattern``, ``base_body`` and one target:

  target_body                 one body mesh                         -> seamfit grade
  measurements                a measurement file of one body        -> a body made, then grade
  size_chart + size           one size of a size chart              -> a body made, then grade
  target_bodies               several body meshes, smallest first   -> seamfit grade-run
  size_chart (no size)        every size of a chart                 -> seamfit grade-run

``truth`` (grade jobs) is grade's ``--truth``. Every other field is a setting of
``seamfit grade`` by its option's name (``edge_length``, ``max_iterations``, ...;
``seamfit.batch.settings``). ``defaults`` give any field but ``id`` to every job. Paths are
relative to the manifest's folder. Every problem is one line naming the manifest, the job
and the field; the file contents are the job's own checks (a bad body fails its job alone).
"""
from __future__ import annotations

import csv
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ProblemsError, SeamfitError
from ..limits import read_text_file
from . import settings as job_settings

PATH_FIELDS = ("pattern", "base_body", "target_body", "measurements", "size_chart", "truth")
TARGETS = ("target_body", "measurements", "size_chart", "target_bodies")
ID_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,99}$")
# Names the batch itself writes in --out.
RESERVED_IDS = {"logs", "jobs", "bodies", "running", "status.json", "summary.json", "summary.csv"}


class ManifestError(ProblemsError):
    pass


@dataclass
class Job:
    id: str
    kind: str                          # "grade" or "grade-run"
    pattern: Path
    base_body: Path
    target: dict                       # the target's fields: paths absolute, size as given
    truth: Path | None = None
    settings: dict = field(default_factory=dict)   # setting name -> value, as given (checked)

    def inputs(self) -> list[Path]:
        """Every file the job reads."""
        files = [self.pattern, self.base_body, self.truth]
        for k in ("target_body", "measurements", "size_chart"):
            files.append(self.target.get(k))
        files += self.target.get("target_bodies", [])
        return [Path(p) for p in files if p is not None]


def read_manifest(path) -> list[Job]:
    path = Path(path)
    text = read_text_file(path, "manifest")
    if path.suffix.lower() == ".csv":
        rows = _csv_rows(path, text)
    else:
        rows = _json_rows(path, text)
    problems: list[str] = []
    jobs, seen = [], {}
    for where, row in rows:
        job = _job(path, where, row, problems)
        if job is None:
            continue
        if job.id in seen:
            problems.append(f"{path}: {where}: id: {job.id!r} is also the id of {seen[job.id]}; give each job its own")
            continue
        seen[job.id] = where
        jobs.append(job)
    if not rows:
        problems.append(f"{path}: holds no jobs")
    if problems:
        raise ManifestError(problems)
    return jobs


def _json_rows(path: Path, text: str) -> list[tuple[str, dict]]:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SeamfitError(f"{path}: not valid JSON: {exc}") from None
    defaults = {}
    if isinstance(data, dict):
        unknown = sorted(set(data) - {"defaults", "jobs"})
        if unknown:
            raise SeamfitError(f"{path}: unknown top-level field {unknown[0]!r} (a manifest holds defaults and jobs)")
        defaults = data.get("defaults") or {}
        if not isinstance(defaults, dict):
            raise SeamfitError(f"{path}: defaults: must be an object of fields")
        if "id" in defaults:
            raise SeamfitError(f"{path}: defaults: id: every job needs its own id")
        _check_default_settings(path, defaults)
        data = data.get("jobs")
    if not isinstance(data, list):
        raise SeamfitError(f"{path}: jobs: must be a list of jobs")
    rows = []
    for k, job in enumerate(data, 1):
        where = f"job {k}"
        if not isinstance(job, dict):
            raise SeamfitError(f"{path}: {where}: must be an object of fields")
        if isinstance(job.get("id"), str):
            where = f"job {job['id']!r}"
        rows.append((where, {**defaults, **job}))
    return rows


def _check_default_settings(path: Path, defaults: dict) -> None:
    """The defaults' settings, once (not once per job that inherits them)."""
    names = set(job_settings.setting_names())
    problems = []
    for k, v in defaults.items():
        if k in PATH_FIELDS or k in TARGETS or k == "size":
            continue
        name = k.replace("-", "_")
        if name not in names:
            problems.append(f"{path}: defaults: {k}: unknown field (the settings of seamfit grade: "
                            + ", ".join(sorted(names)) + ")")
            continue
        try:
            job_settings.convert(name, v)
        except ValueError as exc:
            problems.append(f"{path}: defaults: {k}: {exc}")
    if problems:
        raise ManifestError(problems)


def _csv_rows(path: Path, text: str) -> list[tuple[str, dict]]:
    reader = csv.DictReader(text.splitlines())
    if not reader.fieldnames:
        raise SeamfitError(f"{path}: the CSV has no header row")
    rows = []
    for row in reader:
        if None in row:
            raise SeamfitError(f"{path}: row {reader.line_num}: more cells than the header has columns")
        cells = {k.strip(): (v or "").strip() for k, v in row.items() if k is not None}
        cells = {k: v for k, v in cells.items() if v != ""}
        if not cells:
            continue
        if "target_bodies" in cells:
            cells["target_bodies"] = cells["target_bodies"].split(";")
        where = f"row {reader.line_num}" + (f" (job {cells['id']!r})" if "id" in cells else "")
        rows.append((where, cells))
    return rows


def _job(manifest: Path, where: str, row: dict, problems: list[str]) -> Job | None:
    n_before = len(problems)

    def bad(fieldname: str, message: str) -> None:
        problems.append(f"{manifest}: {where}: {fieldname}: {message}")

    base = manifest.parent

    def path_of(fieldname, value):
        if not isinstance(value, str) or not value.strip():
            bad(fieldname, "must be a file path")
            return None
        return Path(os.path.abspath(base / value))

    job_id = row.get("id")
    if job_id is None:
        bad("id", "missing (each job's output folder is named by its id)")
    elif not isinstance(job_id, str) or not ID_PATTERN.match(job_id) or job_id.lower() in RESERVED_IDS:
        bad("id", f"{job_id!r} cannot name a folder: letters, digits, '.', '_' and '-', starting with a letter or "
                  f"digit, at most 100, and not one of {', '.join(sorted(RESERVED_IDS))}")
    paths = {}
    for f in ("pattern", "base_body"):
        if f not in row:
            bad(f, "missing")
        else:
            paths[f] = path_of(f, row[f])
    given = [t for t in TARGETS if t in row]
    if not given:
        bad("target_body", "missing: give target_body, measurements, size_chart (with or without size) "
                           "or target_bodies")
    elif len(given) > 1:
        bad(given[1], f"give one target, not both {given[0]} and {given[1]}")
    target: dict = {}
    for t in given[:1]:
        if t == "target_bodies":
            v = row[t]
            if not isinstance(v, list) or not v:
                bad(t, "must be a list of body files, smallest first")
            else:
                target[t] = [path_of(t, p) for p in v]
        else:
            target[t] = path_of(t, row[t])
    if "size" in row:
        if "size_chart" not in row:
            bad("size", "a size needs its size_chart")
        elif not isinstance(row["size"], (str, int)) or isinstance(row["size"], bool) or str(row["size"]) == "":
            bad("size", "must name one of the chart's sizes")
        else:
            target["size"] = str(row["size"])
    kind = "grade-run" if ("target_bodies" in target or ("size_chart" in target and "size" not in target)) \
        else "grade"
    truth = None
    if "truth" in row:
        if kind != "grade":
            bad("truth", "only a job with one target has a truth pattern")
        else:
            truth = path_of("truth", row["truth"])
    names = set(job_settings.setting_names())
    values = {}
    for k, v in row.items():
        if k in PATH_FIELDS or k in ("id", "size", "target_bodies"):
            continue
        name = k.replace("-", "_")
        if name not in names:
            bad(k, "unknown field (a job's fields: id, " + ", ".join(PATH_FIELDS) + ", target_bodies, size, "
                   "and the settings of seamfit grade: " + ", ".join(sorted(names)) + ")")
            continue
        try:
            values[name] = job_settings.convert(name, v)
        except ValueError as exc:
            bad(k, str(exc))
    if len(problems) == n_before:
        try:
            job_settings.checked(values)
        except SeamfitError as exc:
            # grade's message names its option: say which field that is
            option = str(exc).split()[0]
            field_name = next((n for n in values if job_settings.option_of(n) == option), option.lstrip("-"))
            bad(field_name, str(exc))
    if len(problems) > n_before:
        return None
    return Job(id=job_id, kind=kind, pattern=paths["pattern"], base_body=paths["base_body"], target=target,
               truth=truth, settings=values)
