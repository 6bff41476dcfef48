"""A small sample of the stress suite (tests/benchmarks/stress.py; the full run's table is
docs/stress_results.md): a drape started inside a distorted body and a grading with extreme
strengths, each in its own process under a time limit, end ok or with a one-line refusal;
never NaN, a crash, a hang or an accepted checkpoint above the one before."""
import sys

import pytest
from common import BENCHMARKS

sys.path.insert(0, str(BENCHMARKS))
import stress  # noqa: E402


def _cheap(spec):
    spec = {**spec, "edge_length_cm": 6.0, "sdf_spacing": 0.01}
    if spec["kind"] == "grade":
        spec.update(max_outer_iterations=4, checkpoint_every=2)
    return spec


@pytest.mark.parametrize("kind", ["drape", "grade"])
def test_a_randomized_run_ends_ok_or_refused(kind, tmp_path, monkeypatch):
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path))
    seed = next(s for s in range(1000) if stress.draw(s)["kind"] == kind)
    spec = _cheap(stress.draw(seed))
    row = stress.run_one(spec, timeout_s=240.0)
    assert row["outcome"] in ("ok", "refused"), row


def test_the_summary_counts_every_outcome():
    rows = [{"kind": "drape", "outcome": "ok", "seconds": 1.0}, {"kind": "grade", "outcome": "hang", "seconds": 9.0}]
    text = "\n".join(stress.summary(rows))
    assert "| drape | 1 | 1 | 0 | 0 | 0 | 0 | 0 | 0 | - | 1.0 | 1.0 |" in text
    assert "| grade | 1 | 0 | 0 | 0 | 0 | 1 | 0 | 0 | - | 9.0 | 9.0 |" in text
