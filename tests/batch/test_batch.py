"""seamfit batch on a real local Ray instance (2 CPUs) at a coarse setting: a manifest's
problems named by job and field before any work; a run whose good jobs write their results
while a job with a bad input fails alone with its log; a rerun that skips what is done; a
worker killed mid-job whose job is retried and finishes; a cluster started on its own with
`ray start --head`, joined with --address, and an address where no cluster answers."""
from __future__ import annotations

import csv
import hashlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from seamfit.cli import main
from common import SAMPLES

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B10 = SAMPLES / "bodies/women_size10.obj"
ME = SAMPLES / "measurements/me.json"
# a coarse grading peaks at about 130 MB: half a GB each lets 2 run at once on a small CI machine
SMALL = ["--memory-per-job", "0.5"]
COARSE = {"edge_length": 5, "sdf_spacing": 0.01, "max_iterations": 2, "checkpoint_every": 1, "no_picture": True}


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _write(path: Path, data) -> Path:
    path.write_text(json.dumps(data, indent=1))
    return path


def _seamfit_env(**extra) -> dict:
    """The environment of a process (a batch, a Ray node) that imports the seamfit these tests
    import: the development tree's, or the installed one in CI, where the tree has no compiled
    core (a batch of the tree's seamfit there runs jobs that cannot grade). No Ray address or
    authentication setting of this process's own Ray leaks in: each test gives its own."""
    import seamfit
    root = str(Path(seamfit.__file__).resolve().parents[1])
    env = {k: v for k, v in os.environ.items()
           if k not in ("RAY_ADDRESS", "RAY_AUTH_MODE", "RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH")}
    env["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [os.environ.get("PYTHONPATH")])])
    return {**env, **extra}


# ----------------------------------------------------------------------- manifest checks

def test_manifest_problems_name_the_job_and_the_field(tmp_path, capsys):
    manifest = _write(tmp_path / "m.json", {"defaults": {"pattern": str(PATTERN), "base_body": str(B0)}, "jobs": [
        {"id": "ok", "target_body": str(B10)},
        {"id": "typo", "target_body": str(B10), "edge_lenght": 3},
        {"id": "nan", "target_body": str(B10), "edge_length": "abc"},
        {"id": "neg", "target_body": str(B10), "max_iterations": -1},
        {"id": "preset", "target_body": str(B10), "preset": "ballgown"},
        {"id": "two", "target_body": str(B10), "measurements": str(ME)},
        {"target_body": str(B10)},
        {"id": "ok", "target_body": str(B10)},
        {"id": "../up", "target_body": str(B10)},
    ]})
    out = tmp_path / "out"
    assert main(["batch", str(manifest), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert all(ln.startswith("seamfit batch: error: ") for ln in lines), err
    assert "Traceback" not in err
    for expected in ("job 'typo': edge_lenght: unknown field",
                     "job 'nan': edge_length: 'abc' is not a number",
                     "job 'neg': max_iterations: --max-iterations -1: must be >= 0",
                     "job 'preset': preset: 'ballgown' is not one of",
                     "job 'two': measurements: give one target, not both target_body and measurements",
                     "job 7: id: missing",
                     "job 'ok': id: 'ok' is also the id of job 'ok'",
                     "job '../up': id: '../up' cannot name a folder"):
        assert any(expected in ln for ln in lines), (expected, err)
    assert not out.exists(), "nothing is written for a bad manifest"
    # a bad default is named once, as the defaults' field, not once per job
    bad_default = _write(tmp_path / "d.json", {"defaults": {"max_iterations": "many"},
                                               "jobs": [{"id": f"j{k}"} for k in range(20)]})
    assert main(["batch", str(bad_default), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [f"seamfit batch: error: {bad_default}: defaults: max_iterations: "
                                        "'many' is not a whole number"]


def test_many_manifest_problems_are_capped_without_pointing_at_validate(tmp_path, capsys):
    from seamfit import cli
    jobs = [{"id": f"j{k}", "target_body": str(B10), "edge_lenght": 3} for k in range(cli.MAX_ERROR_LINES + 3)]
    manifest = _write(tmp_path / "m.json", {"defaults": {"pattern": str(PATTERN), "base_body": str(B0)},
                                            "jobs": jobs})
    assert main(["batch", str(manifest), "--out", str(tmp_path / "out")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == cli.MAX_ERROR_LINES + 1
    assert lines[-1] == "seamfit batch: error: ... and 3 more"   # validate does not read manifests


def test_csv_manifest_rows_are_checked_by_row_and_job(tmp_path, capsys):
    manifest = tmp_path / "m.csv"
    with open(manifest, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["id", "pattern", "base_body", "target_body", "edge_length", "fail_unconverged"])
        w.writerow(["a", str(PATTERN), str(B0), str(B10), "5", "yes"])
        w.writerow(["b", str(PATTERN), str(B0), "", "nan", "maybe"])
    assert main(["batch", str(manifest), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "row 3 (job 'b'): target_body: missing" in err
    assert "row 3 (job 'b'): fail_unconverged: 'maybe' is not true or false" in err
    assert "row 2" not in err


# ----------------------------------------------------------------------- runs on Ray

@pytest.fixture(scope="module")
def local_ray():
    """One local Ray instance (2 CPUs) for the in-process runs, which use it as they find it
    (its start costs about 8 s on 2 cores); the stopped batch starts its own."""
    import ray
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    yield ray
    ray.shutdown()


@pytest.fixture(scope="module")
def first_run(tmp_path_factory, local_ray):
    tmp = tmp_path_factory.mktemp("batch")
    broken = tmp / "broken.obj"
    broken.write_text("v 0 0 0\nthis is not a body\n")
    manifest = _write(tmp / "manifest.json", {
        "defaults": {"pattern": str(PATTERN), "base_body": str(B0), **COARSE},
        "jobs": [{"id": "size10", "target_body": str(B10)},
                 {"id": "me", "measurements": str(ME)},
                 {"id": "broken", "target_body": str(broken)}]})
    out, cache = tmp / "out", tmp / "cache"
    before = [_sha(p) for p in (PATTERN, B0, B10, ME, broken, manifest)]
    t0 = time.perf_counter()
    code = main(["batch", str(manifest), "--out", str(out), "--cache-dir", str(cache), "-q", *SMALL])
    seconds = time.perf_counter() - t0
    assert [_sha(p) for p in (PATTERN, B0, B10, ME, broken, manifest)] == before, "inputs are never modified"
    return manifest, out, cache, code, seconds


def test_good_jobs_write_their_results_and_a_bad_one_fails_alone_with_its_log(first_run):
    manifest, out, cache, code, _ = first_run
    assert code == 1, "a failed job makes the batch exit 1, the others' results written"
    for job in ("size10", "me"):
        rep = json.loads((out / job / "report.json").read_text())
        assert rep["outer_iterations"] >= 1 and (out / job / "pattern.json").stat().st_size > 0
        rec = json.loads((out / "jobs" / f"{job}.json").read_text())
        assert rec["state"] == "done" and rec["exit"] == 0 and rec["attempts"] == 1
        assert rec["results"]["converged"] == rep["converged"]
        assert rec["results"]["ease_error_cm"]["hip"] == pytest.approx(
            rep["ease_cm"]["result"]["hip"] - rep["ease_cm"]["base"]["hip"], abs=1e-3)
        # the base's shared work was done once, before its jobs: each found the drape cached
        assert rep["base_drape"]["cached"] is True, job
    assert "base ready" in (out / "logs" / "base-1.log").read_text()
    assert list((cache / "drape").glob("*.npz")), "the shared cache is the one given"
    # the body made from the measurements is the one graded to
    assert json.loads((out / "me/report.json").read_text())["inputs"]["target_body"] == str(out / "bodies/me.obj")
    bad = json.loads((out / "jobs/broken.json").read_text())
    assert bad["state"] == "failed" and bad["exit"] == 2 and bad["attempts"] == 1, "a bad input is not retried"
    log = (out / bad["log"]).read_text()
    assert "seamfit grade: error:" in log and "broken.obj" in log
    assert "broken.obj" in bad["reason"]
    assert not (out / "broken").exists()
    status = json.loads((out / "status.json").read_text())
    assert (status["total"], status["done"], status["failed"], status["finished"]) == (3, 2, 1, True)
    assert status["failed_jobs"] == ["broken"] and status["gradings"] == 2
    rows = list(csv.DictReader((out / "summary.csv").read_text().splitlines()))
    assert [(r["job"], r["state"]) for r in rows] == [("size10", "done"), ("me", "done"), ("broken", "failed")]
    assert not list(out.glob(".*seamfit-tmp*")), "no half-written set is left"


def test_a_rerun_skips_finished_jobs_and_redoes_a_changed_one(first_run, capsys):
    manifest, out, cache, _, _ = first_run
    stamp = {j: (out / j / "report.json").stat().st_mtime_ns for j in ("size10", "me")}
    data = json.loads(manifest.read_text())
    data["jobs"] = data["jobs"][:2]                     # the good jobs: nothing is left to run
    again = _write(manifest.parent / "again.json", data)
    assert main(["batch", str(again), "--out", str(out), "--cache-dir", str(cache)]) == 0
    err = capsys.readouterr().err
    assert "2 jobs, 2 already done (skipped), 0 to run" in err
    assert {j: (out / j / "report.json").stat().st_mtime_ns for j in stamp} == stamp, "done jobs are not redone"
    status = json.loads((out / "status.json").read_text())
    assert (status["skipped"], status["done"], status["finished"]) == (2, 0, True)
    # a changed setting or input changes the job's settings hash: that job is no longer done
    from seamfit.batch.manifest import read_manifest
    from seamfit.batch.records import is_done, settings_hash
    jobs = {j.id: j for j in read_manifest(again)}
    assert is_done(out, jobs["size10"], settings_hash(jobs["size10"])) is not None
    jobs["size10"].settings["max_iterations"] = 3
    assert is_done(out, jobs["size10"], settings_hash(jobs["size10"])) is None
    jobs["me"].target["measurements"] = SAMPLES / "measurements/ann.vit"
    assert is_done(out, jobs["me"], settings_hash(jobs["me"])) is None


def test_a_job_larger_than_any_node_is_refused_at_once(tmp_path, local_ray, capsys):
    manifest = _write(tmp_path / "m.json", [{"id": "a", "pattern": str(PATTERN), "base_body": str(B0),
                                             "target_body": str(B10), "device": "cuda"}])
    out = tmp_path / "out"
    t0 = time.perf_counter()
    assert main(["batch", str(manifest), "--out", str(out), "--memory-per-job", "100000"]) == 2
    assert main(["batch", str(manifest), "--out", str(out), *SMALL]) == 2
    assert time.perf_counter() - t0 < 30
    err = [ln for ln in capsys.readouterr().err.splitlines() if ": error: " in ln]
    assert len(err) == 2 and err[-2].startswith("seamfit batch: error: --memory-per-job 100000: no Ray node has that much memory")
    assert err[-1] == ("seamfit batch: error: jobs with device cuda need --gpus-per-job 1 of a GPU, and no Ray "
                       "node has a GPU")
    assert not list((out / "jobs").iterdir())


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:                                   # a zombie has ended; only its exit status is left
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return True


def _ends_within(pid: int, seconds: float) -> bool:
    """Whether process pid has ended, or ends within ``seconds``: SIGTERM reaches a grading
    busy in native code (a body field, a drape) when that call returns, seconds later on a
    loaded machine."""
    deadline = time.time() + seconds
    while _alive(pid) and time.time() < deadline:
        time.sleep(0.1)
    return not _alive(pid)


def test_a_killed_worker_is_retried_and_its_job_finishes(tmp_path, first_run):
    manifest = tmp_path / "m.csv"
    with open(manifest, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["id", "pattern", "base_body", "target_body", *COARSE])
        w.writerow(["size10", PATTERN, B0, B10, *COARSE.values()])
    out = tmp_path / "out"
    marker, log = out / "running/size10.json", out / "logs/size10.log"
    killed = {}

    def kill_the_worker_mid_grading():
        deadline = time.time() + 120
        while time.time() < deadline and not (marker.exists() and list(out.glob(".size10.seamfit-tmp-*"))):
            time.sleep(0.05)
        killed.update(json.loads(marker.read_text()))
        os.kill(killed["worker_pid"], signal.SIGKILL)

    killer = threading.Thread(target=kill_the_worker_mid_grading, daemon=True)
    killer.start()
    code = main(["batch", str(manifest), "--out", str(out), "--retries", "1", "--cache-dir", str(first_run[2]), "-q",
                 *SMALL])
    killer.join()
    assert code == 0 and killed["attempt"] == 1
    rec = json.loads((out / "jobs/size10.json").read_text())
    assert rec["state"] == "done" and rec["attempts"] == 2
    assert log.read_text().count("--- seamfit batch: attempt ") == 2
    assert (out / "size10/report.json").is_file() and (out / "size10/pattern.json").is_file()
    assert _ends_within(killed["pid"], 60), "the first attempt's grading died with its worker"
    assert not list(out.glob(".*seamfit-tmp*")), "the killed attempt left no half-written set"


def test_a_stopped_batch_ends_its_jobs_cleanly_and_keeps_what_is_done(tmp_path, first_run):
    manifest = _write(tmp_path / "m.json", {"defaults": {"pattern": str(PATTERN), "base_body": str(B0), **COARSE},
                                            "jobs": [{"id": "size10", "target_body": str(B10)}]})
    out = tmp_path / "out"
    env = _seamfit_env(SEAMFIT_CACHE_DIR=str(first_run[2]))
    proc = subprocess.Popen([sys.executable, "-m", "seamfit", "batch", str(manifest), "--out", str(out),
                             "--cpus", "1", *SMALL], env=env, stderr=subprocess.PIPE, text=True)
    marker = out / "running/size10.json"
    # Ray's start and the job's precompute can take minutes on a loaded 2-core machine
    deadline = time.time() + 600
    while (time.time() < deadline and proc.poll() is None
           and not (marker.exists() and list(out.glob(".size10.seamfit-tmp-*")))):
        time.sleep(0.05)
    if proc.poll() is not None or not marker.exists():
        proc.kill()
        raise AssertionError(f"the job never got under way (exit {proc.poll()}): {proc.communicate()[1]}")
    job_pid = json.loads(marker.read_text())["pid"]
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "seamfit batch: terminated (SIGTERM)" in err, err
    assert not _alive(job_pid), "the job's process ended with the batch"
    assert not list(out.glob(".*seamfit-tmp*")) and not (out / "size10").exists(), "no half-written set"
    rows = json.loads((out / "summary.json").read_text())["jobs"]
    assert [(r["id"], r["state"]) for r in rows] == [("size10", "not run")]
    status = json.loads((out / "status.json").read_text())
    assert not status["finished"] and status["running"] == 0 and status["running_jobs"] == []
    assert not list((out / "running").glob("*.json")), "no marker says a job still runs"


def test_the_example_manifest_runs_as_it_is(tmp_path, local_ray, first_run):
    # The repository's example: bodies, measurements, a size of a size chart and a size run.
    manifest = SAMPLES / "batch" / "manifest.json"
    out = tmp_path / "out"
    before = _sha(manifest)
    assert main(["batch", str(manifest), "--out", str(out), "--cache-dir", str(first_run[2]), "-q", *SMALL]) == 0
    rows = {r["id"]: r for r in json.loads((out / "summary.json").read_text())["jobs"]}
    assert set(rows) == {"pencil-size10", "pencil-apple", "pencil-me", "pencil-chart-42", "circle-size10", "pencil-run"}
    assert all(r["state"] == "done" and r["exit"] == 0 for r in rows.values()), rows
    for job in ("pencil-size10", "pencil-me", "pencil-chart-42", "circle-size10"):
        assert (out / job / "pattern.json").is_file(), job
    # the size run grades each body in turn, a folder per size
    graded = sorted(p.parent.name for p in (out / "pencil-run").rglob("pattern.json"))
    assert len(graded) >= 2, graded
    assert _sha(manifest) == before


# ----------------------------------------------------------------------- a running cluster (--address)

def _free_port() -> int:
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _group_members(pgid: int) -> list[int]:
    """The processes of a process group that have not ended (zombies excluded)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                pids.append(int(entry.name))
    return pids


@pytest.fixture
def ray_head(tmp_path_factory):
    """A one-node cluster started on its own, as `ray start --head` starts one on each machine
    of a cluster, from this Python with the seamfit these tests import, and a token of its own
    (Ray asks for one by default where ~/.ray/auth_token exists). Its temp folder is its own,
    so that its address file is never found by the local Ray instances of other tests; at the
    end its process group (ray start, the GCS, the raylet and its workers) is stopped and the
    folder removed."""
    import secrets
    import shutil
    import tempfile
    temp = tmp_path_factory.mktemp("rh")
    if len(str(temp)) > 40:                 # Ray's socket paths under it must fit in 107 characters
        temp = Path(tempfile.mkdtemp(prefix="rh", dir="/tmp"))
    port = _free_port()
    env = _seamfit_env(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(16))
    log = open(temp / "head.log", "w")
    head = subprocess.Popen([sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block", f"--port={port}",
                             "--num-cpus=1", "--object-store-memory=100000000", "--include-dashboard=false",
                             "--disable-usage-stats", f"--temp-dir={temp}"],
                            env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        import socket
        deadline = time.time() + 300
        up = False
        while not up and time.time() < deadline and head.poll() is None:
            time.sleep(0.5)
            if (temp / "ray_current_cluster").exists():       # written once the head is up
                try:
                    socket.create_connection(("127.0.0.1", port), timeout=2).close()
                    up = True
                except OSError:
                    pass
        assert up, f"the head node did not start (exit {head.poll()}): {(temp / 'head.log').read_text()[-2000:]}"
        yield {"address": f"127.0.0.1:{port}", "env": env, "head": head}
    finally:
        try:
            os.killpg(head.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        deadline = time.time() + 5
        while _group_members(head.pid) and time.time() < deadline:
            time.sleep(0.2)
        if _group_members(head.pid):        # the GCS takes its time over SIGTERM
            os.killpg(head.pid, signal.SIGKILL)
        head.wait(timeout=30)
        deadline = time.time() + 15
        while _group_members(head.pid) and time.time() < deadline:
            time.sleep(0.2)
        log.close()
        leftover = _group_members(head.pid)
        shutil.rmtree(temp, ignore_errors=True)
        assert not leftover, f"processes of the head node left running: {leftover}"


def test_a_running_cluster_is_joined_with_address(tmp_path, ray_head, first_run):
    # The batch starts no Ray of its own: its job runs on the cluster's worker, which imports
    # seamfit there, and the cluster outlives the batch. A driver without the cluster's
    # token is refused in one line naming the address.
    default_address_file = Path("/tmp/ray/ray_current_cluster")
    existed = default_address_file.exists()
    manifest = _write(tmp_path / "m.json", {"defaults": {"pattern": str(PATTERN), "base_body": str(B0), **COARSE},
                                            "jobs": [{"id": "size10", "target_body": str(B10)}]})
    address = ray_head["address"]
    argv = [sys.executable, "-m", "seamfit", "batch", str(manifest), "--address", address, *SMALL]

    # (Ray tries 20 times, a second apart, before it gives up; 2 here.)
    no_token = {k: v for k, v in ray_head["env"].items() if k != "RAY_AUTH_TOKEN"}
    no_token.update(RAY_AUTH_MODE="disabled", RAY_gcs_server_port_wait_time_s="2")
    t0 = time.perf_counter()
    proc = subprocess.run([*argv, "--out", str(tmp_path / "refused")], env=no_token, capture_output=True,
                          text=True, timeout=120)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and lines[-1].startswith(f"seamfit batch: error: cannot connect to the Ray cluster "
                                                         f"at {address}"), proc.stderr[-2000:]
    assert "RAY_AUTH_MODE=token" in lines[-1] and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert not [ln for ln in lines[:-1] if "gcs_client" in ln or "error" in ln], "Ray's own messages go to its log"
    assert time.perf_counter() - t0 < 60

    out = tmp_path / "out"
    proc = subprocess.run([*argv, "--out", str(out)], env={**ray_head["env"], "SEAMFIT_CACHE_DIR": str(first_run[2])},
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = json.loads((out / "summary.json").read_text())["jobs"]
    assert [(r["id"], r["state"], r["exit"]) for r in rows] == [("size10", "done", 0)], proc.stderr[-2000:]
    assert (out / "size10" / "pattern.json").is_file()
    assert ray_head["head"].poll() is None, "the cluster outlives the batch"
    assert existed or not default_address_file.exists(), "no address file is left where other tests' Ray looks"


def test_an_unreachable_cluster_is_named_in_one_line_at_once(tmp_path):
    manifest = _write(tmp_path / "m.json", [{"id": "a", "pattern": str(PATTERN), "base_body": str(B0),
                                             "target_body": str(B10)}])
    port = _free_port()                    # nothing listens there
    for address, expected in ((f"127.0.0.1:{port}", f"cannot reach the Ray cluster at 127.0.0.1:{port}"),
                              ("nohost", "--address nohost: not a Ray address")):
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "seamfit", "batch", str(manifest), "--out", str(tmp_path / "out"),
                               "--address", address, "-q"], env=_seamfit_env(), capture_output=True, text=True,
                              timeout=120)
        seconds = time.perf_counter() - t0
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2 and len(lines) == 1, proc.stderr[-2000:]
        assert lines[0].startswith(f"seamfit batch: error: {expected}"), lines
        assert seconds < 30, f"{address}: {seconds:.0f} s"
    assert not list((tmp_path / "out" / "jobs").iterdir())


def test_the_nodes_seamfit_is_checked_before_the_jobs(local_ray):
    # The check is sent by value, so a node without seamfit runs it too; here the local
    # instance's workers import this seamfit, and a node that imports none, one without its
    # compiled core, or another copy is named with what it needs.
    from seamfit.batch import cluster
    notes = []
    cluster.check_workers(local_ray, 1, notes.append)
    assert notes == []
    here = cluster._seamfit_check()()
    assert here["version"] and not here.get("core_error")
    assert cluster._compare(dict(here, host="n1"), here) is None
    missing = cluster._compare({"host": "n1", "error": "ModuleNotFoundError: No module named 'seamfit'"}, here)
    assert "cannot import seamfit (ModuleNotFoundError" in missing and here["where"] in missing
    no_core = cluster._compare(dict(here, core_error="ImportError: no _core"), here)
    assert "compiled core does not load" in no_core
    other = cluster._compare(dict(here, where="/elsewhere/seamfit", digest="0"), here)
    assert "another seamfit (/elsewhere/seamfit: its files differ" in other
