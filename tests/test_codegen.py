"""The committed generated code is what the derivation gives today."""

import subprocess
import sys

import pytest

from rolling_disk_env import codegen


@pytest.mark.parametrize(("batched", "filename"), [(False, "scalar.py"), (True, "batched.py")])
def test_generated_code_is_current(batched, filename):
    committed = (codegen.GENERATED_DIR / filename).read_text()
    assert committed == codegen.generate(batched), (
        f"_generated/{filename} is stale: run `python -m rolling_disk_env.codegen`"
    )


def test_import_does_not_run_the_derivation_nor_load_torch():
    code = (
        "import sys, time; t = time.perf_counter(); import rolling_disk_env; "
        "print(time.perf_counter() - t, 'sympy' in sys.modules, 'torch' in sys.modules)"
    )
    seconds, sympy_loaded, torch_loaded = subprocess.check_output([sys.executable, "-c", code], text=True).split()
    assert (sympy_loaded, torch_loaded) == ("False", "False")
    assert float(seconds) < 1.0
