"""``seamfit batch MANIFEST --out DIR``: many gradings, spread over Ray's workers.

Runs every job of the manifest (JSON or CSV, seamfit.batch.manifest) as ``seamfit grade``
or ``seamfit grade-run`` would, each in its own folder DIR/<id>, on a local Ray instance
(or a cluster with --address). A job whose results are in place under the same settings
hash is skipped, so a rerun continues where a stopped one ended. Writes, besides the job
folders: logs/<id>.log, jobs/<id>.json (each job's record), bodies/<id>.obj (bodies made
from measurements), status.json (progress, while it runs), summary.json and summary.csv.
Exit code 0 when every job's results are written, 1 when a job failed (the others are
written; a job that exited 1 counts too), 2 on a bad manifest or option (nothing run), or a
cluster that cannot be joined or whose nodes do not import this seamfit.
See docs/batch.md.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import SeamfitError
from .parsing import add_command

EPILOG = ("Job fields and settings: docs/batch.md. A job's settings are the options of `seamfit grade`, "
          "by name (edge_length, max_iterations, preset, ...).")


def register(subparsers) -> None:
    from ..batch.run import Resources
    d = Resources()
    p = add_command(subparsers, "batch", EPILOG)
    p.add_argument("manifest", metavar="MANIFEST", type=Path, help="the jobs: a .json or .csv file")
    p.add_argument("--out", metavar="DIR", type=Path, required=True,
                   help="output folder: a folder per job, logs, records, status.json, summary")
    p.add_argument("--address", metavar="ADDR", default=None,
                   help="a running Ray cluster (host:6379 as `ray start --head` prints it, ray://host:10001 or "
                        "auto), whose nodes import this seamfit (checked before any job: docs/batch.md); default: "
                        "start Ray on this machine")
    p.add_argument("--cpus", metavar="N", type=int, default=None,
                   help="local Ray only: cores to use (default: all)")
    p.add_argument("--threads-per-job", metavar="N", type=int, default=d.threads,
                   help=f"CPU threads of each job, the cores it reserves (default {d.threads})")
    p.add_argument("--gpus-per-job", metavar="F", type=float, default=d.gpus,
                   help=f"share of a GPU that a job with device cuda reserves (default {d.gpus:g}; 0.25, four per GPU, gave the most gradings per hour on an H100)")
    p.add_argument("--memory-per-job", metavar="GB", type=float, default=d.memory_gb,
                   help=f"memory each job reserves, in GB (default {d.memory_gb:g})")
    p.add_argument("--retries", metavar="N", type=int, default=d.retries,
                   help=f"retries of a job whose process or worker died (default {d.retries})")
    p.add_argument("--cache-dir", metavar="DIR", type=Path, default=None,
                   help="the content-keyed cache the jobs share (body fields, base drapes); on a cluster a folder "
                        "every node sees (default: $SEAMFIT_CACHE_DIR or ~/.cache/seamfit)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..batch.manifest import read_manifest
    from ..batch.run import Resources, run_batch
    from .checks import number, whole

    whole("--threads-per-job", args.threads_per_job, 1)
    whole("--retries", args.retries, 0)
    if args.cpus is not None:
        whole("--cpus", args.cpus, 1)
        if args.address:
            raise SeamfitError("--cpus is for a local Ray instance; a cluster's nodes declare their own")
    number("--gpus-per-job", args.gpus_per_job)
    number("--memory-per-job", args.memory_per_job)
    jobs = read_manifest(args.manifest)        # every job checked before Ray starts
    # Ray's own SIGTERM handler (read when ray is imported) would abort the driver (exit 134)
    # after seamfit's has stopped the jobs: SIGTERM is seamfit's to handle (exit 143).
    os.environ.setdefault("RAY_DISABLE_FAILURE_SIGNAL_HANDLER", "1")
    try:
        import ray  # noqa: F401
    except ImportError:
        raise SeamfitError("seamfit batch runs on Ray, which is not installed (seamfit depends on it; a copy "
                           "installed without its dependencies lacks it): pip install 'seamfit[batch]' (or pip install ray)") from None
    res = Resources(threads=args.threads_per_job, gpus=args.gpus_per_job, memory_gb=args.memory_per_job,
                    retries=args.retries)
    return run_batch(args.manifest, jobs, args.out, address=args.address, cpus=args.cpus, res=res,
                     cache_dir=args.cache_dir, quiet=args.quiet)
