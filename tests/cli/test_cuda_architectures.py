"""The CUDA targets of the build (cmake/SeamfitCudaArchitectures.cmake), run by CMake itself:
native code from Turing to the newest GPUs the compiler knows, PTX of the newest."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from common import REPO



def _cmake() -> str:
    here = Path(sys.executable).parent / "cmake"
    found = str(here) if here.exists() else shutil.which("cmake")
    assert found, "cmake is needed (scripts/setup.sh installs it)"
    return found


def _targets(version: str, tmp_path) -> list[str]:
    script = tmp_path / "t.cmake"
    script.write_text(f'include("{REPO}/cmake/SeamfitCudaArchitectures.cmake")\n'
                      f'seamfit_cuda_architectures(out {version})\nmessage(STATUS "${{out}}")\n')
    proc = subprocess.run([_cmake(), "-P", str(script)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split("-- ", 1)[1].strip().split(";")


@pytest.mark.parametrize("version, newest", [("12.4", "90"), ("12.8", "120"), ("13.0.48", "120")])
def test_turing_to_the_newest_with_ptx(version, newest, tmp_path):
    targets = _targets(version, tmp_path)
    real = [t.split("-")[0] for t in targets if t.endswith("-real")]
    assert real[:5] == ["75", "80", "86", "89", "90"]          # Turing, Ampere, Ada, Hopper
    assert ("100" in real and "120" in real) == (newest == "120")     # Blackwell where nvcc has it
    assert [t for t in targets if not t.endswith("-real")] == [f"{newest}-virtual"]

