"""What every test folder shares: the repository's paths and the devices a test can run on.

Importable from any folder under tests/ (tests/conftest.py puts tests/ on sys.path).
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
SAMPLES = REPO / "sample_files"
DATA = TESTS / "data"
BENCHMARKS = TESTS / "benchmarks"
# the shared data sits beside the clone (../shared), as in CI; SEAMFIT_SHARED_DATA names another place
SHARED_DATA = Path(os.environ.get("SEAMFIT_SHARED_DATA", REPO.parent / "shared" / "data"))


def _cuda_usable() -> bool:
    from seamfit.device import cuda_available
    return cuda_available()[0]


# A GPU test exists where a GPU is present: elsewhere it is not collected (rather than
# reported as skipped). GPU is True where this seamfit build has CUDA and a GPU is present.
GPU = _cuda_usable()
DEVICES = ["cpu"] + (["cuda"] if GPU else [])


def run_cli(capsys, *argv):
    """(exit code, stdout, stderr) of ``seamfit ARGV``, run in this process."""
    from seamfit import cli
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def command_runner(monkeypatch, capsys, command: str):
    """``run(*argv)``: run_cli of ``seamfit COMMAND ARGV`` with that subcommand alone
    registered, so that the test does not depend on the others being importable."""
    from seamfit import cli
    monkeypatch.setattr(cli, "COMMANDS", (command,))
    return lambda *argv: run_cli(capsys, command, *argv)


def file_sha256(path) -> str:
    """The file's SHA-256 (hex): to show that an input was not modified."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
