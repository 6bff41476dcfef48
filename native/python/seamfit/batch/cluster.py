"""Joining a running Ray cluster (``seamfit batch --address``), and checking that its nodes
can run the jobs.

A cluster that cannot be joined stops the batch with one line naming the address: at once
when nothing answers there (a TCP check before Ray's own connection, which retries for
many minutes), or when Ray refuses this driver (the cluster's authentication token, its Ray
or Python version), or after CONNECT_TIMEOUT_S when the address answers but no Ray does.
Ray's own messages while it connects go to ``ray-connect.log`` in the output folder.

The jobs run the seamfit that each node's Ray workers import (the task's function is
found there by name), so before any job starts, every node that can take one is asked,
by a task that needs no seamfit to run, which seamfit its workers import: none, one whose
compiled core does not load, or one whose version or files differ from this one's stop
the batch with a line per problem.
"""
from __future__ import annotations

import os
import socket
import sys
import threading
from pathlib import Path

from ..errors import ProblemsError, SeamfitError

REACH_TIMEOUT_S = 5.0       # the TCP check of the address
CONNECT_TIMEOUT_S = 60.0    # ray.init against a cluster: about 2 s when it answers
CHECK_TIMEOUT_S = 120.0     # the check of the nodes' seamfit (a worker's start on each)
CONNECT_LOG = "ray-connect.log"


class ClusterError(ProblemsError):
    pass


def connect(ray, address: str, out: Path) -> None:
    """``ray.init`` against the running cluster at ``address``, or a SeamfitError of one
    line naming it."""
    dialed = dial_address(address)
    log = out / CONNECT_LOG
    sys.stderr.flush()
    saved = os.dup(2)
    late = (f"seamfit batch: error: cannot connect to the Ray cluster at {address}{_via(address, dialed)}: "
            f"no Ray answered within {CONNECT_TIMEOUT_S:g} s (Ray's messages: {log})\n")
    watchdog = threading.Timer(CONNECT_TIMEOUT_S, _give_up, (saved, late))
    watchdog.daemon = True
    try:
        # Ray's core logs each failed try of its connection on stderr (a line a second for
        # 20 s when the token is wrong): into the log, and one line here.
        with open(log, "wb") as f:
            os.dup2(f.fileno(), 2)
        watchdog.start()
        ray.init(address=address, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    except Exception as exc:
        try:
            ray.shutdown()
        except Exception:
            pass
        raise SeamfitError(f"cannot connect to the Ray cluster at {address}{_via(address, dialed)}: "
                           f"{_why(exc)} (Ray's messages: {log})") from None
    finally:
        watchdog.cancel()
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)
    try:
        if log.stat().st_size == 0:
            log.unlink()
    except OSError:
        pass


def _give_up(fd: int, line: str) -> None:
    """The connection hangs in Ray's native code, where no exception reaches it: the batch
    ends here (nothing has been submitted yet)."""
    try:
        os.write(fd, line.encode())
    finally:
        os._exit(2)


def _via(address: str, dialed: str | None) -> str:
    return f" ({dialed})" if dialed and dialed != address else ""


def dial_address(address: str) -> str | None:
    """The host:port that Ray dials for ``address`` (its own reading: ``auto``, a local
    host replaced by this machine's address), checked to accept a connection. None where
    it cannot be told (Ray judges it)."""
    if address.startswith("ray://"):
        dialed = address[len("ray://"):].split("/")[0]
    else:
        try:
            from ray._private.services import canonicalize_bootstrap_address
        except ImportError:             # another Ray's layout: the address as given
            dialed = address
        else:
            try:
                dialed = canonicalize_bootstrap_address(address)
            except ValueError:
                raise SeamfitError(f"--address {address}: not a Ray address (host:port, ray://host:port or auto)") from None
            except Exception:
                dialed = address
            if dialed is None:
                raise SeamfitError(f"--address {address}: no running Ray cluster found on this machine (start one with "
                                   "`ray start --head`, or give the head node's host:port)")
    host, sep, port = dialed.rpartition(":")
    if not sep or not port.isdigit():
        return None
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=REACH_TIMEOUT_S).close()
    except OSError as exc:
        why = exc.strerror or str(exc) or type(exc).__name__
        raise SeamfitError(f"cannot reach the Ray cluster at {address}{_via(address, dialed)}: {why} "
                           "(is its head node running? `ray start --head` prints the address to give)") from None
    return dialed


def _why(exc: BaseException) -> str:
    texts, e = [], exc
    while e is not None and len(texts) < 6:
        texts.append(str(e))
        e = e.__cause__ or e.__context__
    text = " ".join(" ".join(texts).split())
    if "Authentication" in text or "Unauthenticated" in text or type(exc).__name__ == "AuthenticationError":
        return ("it refuses this process's authentication token, or its lack of one: set RAY_AUTH_MODE=token, "
                "with the cluster's token in RAY_AUTH_TOKEN, RAY_AUTH_TOKEN_PATH or ~/.ray/auth_token")
    if "Version mismatch" in text:
        return text[text.index("Version mismatch"):].split(" Traceback")[0]
    return " ".join(str(exc).split()) or type(exc).__name__


# ----------------------------------------------------------------------- the nodes' seamfit

def _seamfit_check():
    """The check run on each node, and here: a function made here, so that Ray sends it by
    value and a node without seamfit can still run it."""

    def seamfit_here() -> dict:
        import hashlib
        import os
        import socket
        info = {"host": socket.gethostname()}
        try:
            import seamfit
        except Exception as exc:
            return {**info, "error": f"{type(exc).__name__}: {exc}"}
        root = os.path.dirname(os.path.abspath(seamfit.__file__))
        digest = hashlib.sha256()
        for folder, dirs, files in os.walk(root):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            for name in sorted(files):
                if name.endswith((".so", ".pyd", ".pyc")):
                    continue          # the compiled core differs between a wheel and a developer build
                path = os.path.join(folder, name)
                digest.update(os.path.relpath(path, root).encode() + b"\0")
                with open(path, "rb") as f:
                    digest.update(f.read())
        info.update(version=getattr(seamfit, "__version__", "?"), where=root, digest=digest.hexdigest())
        try:
            import seamfit._core  # noqa: F401
        except Exception as exc:
            info["core_error"] = f"{type(exc).__name__}: {exc}"
        return info

    return seamfit_here


def check_workers(ray, threads: int, say) -> None:
    """Every alive node with ``threads`` CPUs or more (one that can take a job) runs the
    check; a ClusterError lists the nodes whose workers cannot run this seamfit's jobs."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    check = _seamfit_check()
    here = check()
    nodes = [n for n in ray.nodes() if n.get("Alive") and n.get("Resources", {}).get("CPU", 0) >= threads]
    if not nodes:
        return                    # no node can take a job: check_fits says so
    task = ray.remote(num_cpus=0, max_retries=0)(check)
    refs = {task.options(name="seamfit check", scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False))
            .remote(): n.get("NodeManagerAddress", n["NodeID"]) for n in nodes}
    ready, late = ray.wait(list(refs), num_returns=len(refs), timeout=CHECK_TIMEOUT_S)
    problems: dict[str, list[str]] = {}
    for ref in ready:
        node = refs[ref]
        try:
            info = ray.get(ref)
        except Exception as exc:
            last = next((ln for ln in reversed(str(exc).splitlines()) if ln.strip()), type(exc).__name__)
            problems.setdefault(f"cannot run a task: {' '.join(last.split())}", []).append(node)
            continue
        problem = _compare(info, here)
        if problem:
            problems.setdefault(problem, []).append(f"{node} ({info['host']})" if info.get("host") else node)
    for ref in late:
        ray.cancel(ref, force=True)
    if late:
        say(f"note    {len(late)} of {len(refs)} Ray nodes did not answer the check of their seamfit within "
            f"{CHECK_TIMEOUT_S:g} s: going on")
    if problems:
        raise ClusterError([f"Ray node{'s' if len(where) > 1 else ''} {_names(where)}: {problem}"
                            for problem, where in problems.items()])


def _compare(info: dict, here: dict) -> str | None:
    """What keeps a node's workers from running this seamfit's jobs, or None."""
    need = (f"start that node's Ray (`ray start`) where Python imports the same seamfit as here "
            f"(version {here['version']}, {here['where']})")
    if "error" in info:
        return f"its Ray workers cannot import seamfit ({info['error']}): {need}"
    if info.get("core_error"):
        return (f"its Ray workers import seamfit from {info['where']}, whose compiled core does not load "
                f"({info['core_error']}): {need}")
    if info["version"] != here["version"] or info["digest"] != here["digest"]:
        other = "its files differ from" if info["version"] == here["version"] else f"version {info['version']}, not"
        return f"its Ray workers run another seamfit ({info['where']}: {other} this one): {need}"
    return None


def _names(nodes: list[str]) -> str:
    return ", ".join(nodes[:3]) + (f" and {len(nodes) - 3} more" if len(nodes) > 3 else "")
