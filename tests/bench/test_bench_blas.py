"""The accuracy benchmark records which OpenBLAS kernels numpy and SciPy ran: graded results
move with the kernel set (docs/method.md, "The drafts' own ease, and the CPU's BLAS kernels"),
so two runs are comparable only when their kernels are known."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from common import BENCHMARKS

sys.path.insert(0, str(BENCHMARKS))
from accuracy_report import _blas  # noqa: E402


def _kernels(coretype: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if coretype:
        env["OPENBLAS_CORETYPE"] = coretype
    code = "import json, bench_accuracy; print(json.dumps(bench_accuracy.blas_kernels()))"
    out = subprocess.run([sys.executable, "-c", code], cwd=BENCHMARKS, env=env, capture_output=True, text=True,
                         timeout=120, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_run_records_the_kernels_each_library_chose():
    own = _kernels(None)
    assert own["OPENBLAS_CORETYPE"] is None
    assert own.get("numpy") and own.get("scipy")      # both wheels bring an OpenBLAS


def test_a_forced_kernel_set_is_recorded_as_run():
    # Nehalem (SSE4.2) runs on any x86-64 CPU of the last fifteen years; the libraries report
    # the kernels they took.
    forced = _kernels("Nehalem")
    assert forced["OPENBLAS_CORETYPE"] == "Nehalem"
    assert forced["numpy"] == "Nehalem" and forced["scipy"] == "Nehalem"


def test_the_report_names_the_kernels_only_when_recorded():
    assert _blas({"blas": {"numpy": "Haswell", "scipy": "Haswell"}}) == \
        ", OpenBLAS kernels numpy Haswell / SciPy Haswell"
    assert _blas({"cpu": "x"}) == ""
