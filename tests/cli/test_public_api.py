"""seamfit's public face: the names a script uses, importable from ``seamfit`` itself, each
the object its module defines, and ``import seamfit`` light (nothing heavy until used)."""
import subprocess
import sys

import pytest

import seamfit
from common import SAMPLES



@pytest.mark.parametrize("name", [n for n in seamfit.__all__ if n != "__version__"])
def test_every_public_name_resolves_to_its_modules_object(name):
    value = getattr(seamfit, name)
    module = seamfit._API.get(name)
    if module is not None:
        import importlib
        assert value is getattr(importlib.import_module(module), name)


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'grade_everything'"):
        seamfit.grade_everything


def test_import_seamfit_loads_no_solver():
    code = ("import sys, seamfit; heavy = [m for m in ('numpy', 'scipy', 'seamfit.opt', 'seamfit.sim', "
            "'seamfit._core') if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""


def test_a_script_reads_meshes_and_writes_through_the_api(tmp_path):
    pattern = seamfit.load_pattern(SAMPLES / "patterns" / "gc_pencil_skirt" / "size06" / "pattern.json")
    body = seamfit.load_body(SAMPLES / "bodies" / "women_size06.obj")
    mesh = seamfit.build_sewn_mesh(pattern, 4.0)
    assert mesh.n_vertices > 0 and body.n_vertices > 0
    saved = seamfit.save_pattern(pattern, tmp_path / "copy.json")
    again = seamfit.load_pattern(saved)
    assert [p.name for p in again.panels] == [p.name for p in pattern.panels]
    assert seamfit.landmark_errors(again, pattern).to_dict()["max_cm"] == pytest.approx(0.0, abs=1e-9)
