"""``seamfit batch``: many gradings from one manifest, spread over the cores, GPUs and nodes
of a Ray cluster (docs/batch.md).

manifest   reads and checks a JSON or CSV manifest into jobs
settings   a job's settings, checked and turned into ``seamfit grade`` options
records    settings hashes, per-job records, the summary table and status.json
tasks      the Ray tasks: a base's shared work, one job (in its own process)
cluster    joining a running cluster (--address), checking its nodes' seamfit
job        the job's process: makes a body from measurements, then runs grade / grade-run
run        the driver: skips finished jobs, submits the rest, follows their progress
"""
