"""The committed generated code is what the derivation, the tableaus and the task modules give today."""

import subprocess
import sys

import pytest

from rolling_disk_env import codegen

# The SymPy derivation (about a minute, cached in the process) runs in one pytest-xdist worker for the three files
# that need it: test_codegen, test_derivation and test_paper (conftest.py's pytest_configure).
pytestmark = pytest.mark.xdist_group("derivation")


@pytest.fixture(scope="module")
def generated():
    return codegen.generated_files()


def test_every_generated_file_is_committed(generated):
    committed = {path.name for path in codegen.GENERATED_DIR.glob("*.py")} - {"__init__.py"}
    assert committed == set(generated)


@pytest.mark.parametrize("filename", sorted(path.name for path in codegen.GENERATED_DIR.glob("[!_]*.py")))
def test_generated_code_is_current(generated, filename):
    committed = (codegen.GENERATED_DIR / filename).read_text()
    assert committed == generated[filename], f"_generated/{filename} is stale: run `python -m rolling_disk_env.codegen`"


def test_import_loads_neither_sympy_nor_numba_nor_torch():
    code = "import sys, rolling_disk_env; print(*(name in sys.modules for name in ('sympy', 'numba', 'torch')))"
    loaded = subprocess.check_output([sys.executable, "-c", code], text=True).split()
    assert loaded == ["False", "False", "False"]
