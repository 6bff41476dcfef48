"""Every input the coverage-guided fuzzing of the readers (tests/benchmarks/fuzz_readers.py)
found crashing is kept in tests/fuzz/regressions/ and must now give seamfit's own one-line
error or read cleanly: never another exception."""
from __future__ import annotations


import pytest

from seamfit.body import load_body, validate_body
from seamfit.errors import SeamfitError
from seamfit.pattern import validate_pattern
from seamfit.pattern.io import read_pattern_file
from common import TESTS

KEPT = sorted((TESTS / "fuzz" / "regressions").iterdir())


def test_the_kept_inputs_are_there():
    assert KEPT, "tests/fuzz/regressions holds the crashing inputs the fuzzing found"


@pytest.mark.parametrize("path", KEPT, ids=lambda p: p.name)
def test_a_kept_crash_reads_or_fails_with_one_line(path):
    try:
        if path.suffix == ".json":
            validate_pattern(read_pattern_file(path)[0])
        else:
            validate_body(load_body(path))
    except SeamfitError as exc:
        assert str(path) in str(exc) and "\n" not in str(exc)
