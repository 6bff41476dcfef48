"""The accuracy report lists where each method came out tighter than the base garment, by
the rule `seamfit grade` warns with (seamfit.opt.fit.ease_losses)."""
from __future__ import annotations

import sys
from common import BENCHMARKS

sys.path.insert(0, str(BENCHMARKS))
from accuracy_report import ease_flags  # noqa: E402


def _case(body, graded, scaled, draft=None):
    c = {"garment": "gc_tshirt", "body": body, "base_ease_cm": {"bust": 3.1, "waist": 24.3, "hip": None},
         "methods": {"adjoint": {"ok": True, "max_cm": 1.0, "ease_cm": graded},
                     "scaled": {"ok": True, "max_cm": 2.0, "ease_cm": scaled}}}
    if draft is not None:
        c["draft"] = {"ease_cm": draft}
    return c


def test_each_method_and_the_drafts_get_their_flagged_cases():
    res = {"metas": [{"methods": ["adjoint"]}], "cases": [
        _case("size16", {"bust": 0.4, "waist": 24.7, "hip": None}, {"bust": 2.9, "waist": 20.0, "hip": None},
              draft={"bust": 4.7, "waist": 23.0, "hip": None}),
        _case("size10", {"bust": 2.6, "waist": 24.0, "hip": None}, {"bust": 0.2, "waist": 9.0, "hip": None})]}
    rows = {r.split(" | ")[0].strip("| "): r for r in ease_flags(res) if r.startswith("| ") and " of " in r}
    assert rows["adjoint"] == "| adjoint | 1 of 2 | gc_tshirt size16 (bust) |"
    assert rows["scaled"] == "| scaled | 1 of 2 | gc_tshirt size10 (bust, waist) |"
    assert rows["the drafts themselves"] == "| the drafts themselves | 0 of 1 | - |"
