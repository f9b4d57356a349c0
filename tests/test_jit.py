"""Where the compiled kernels are cached: NUMBA_CACHE_DIR, the package's folder, the user's cache, or nowhere (then in
memory, with one line of warning), tried on a copy of the package that imitates a read-only install."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "rolling_disk_env"
NOWHERE = "/proc/nonexistent"
"""A directory that no one, root included, can create."""


def read_only_install(site: Path) -> Path:
    """A copy of the package under ``site`` whose ``__pycache__`` folders cannot be created, as in a read-only
    site-packages (a file stands where each would be: that stops root too, whom file modes do not)."""
    shutil.copytree(PACKAGE, site / "rolling_disk_env", ignore=shutil.ignore_patterns("__pycache__"))
    for folder in [site / "rolling_disk_env", *(site / "rolling_disk_env").rglob("*")]:
        if folder.is_dir():
            (folder / "__pycache__").touch()
    return site


def run(site: Path, code: str, **environment: str) -> subprocess.CompletedProcess:
    """``python -c code`` importing the package from ``site``, with ``environment`` (None values unset)."""
    env = {**os.environ, "PYTHONPATH": str(site), "PYTHONDONTWRITEBYTECODE": "1", **environment}
    env = {key: value for key, value in env.items() if value != "unset"}
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=site, env=env, capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr
    return result


WHERE = "import rolling_disk_env.jit as jit; print(jit.__file__); print(jit.CACHE_DIRECTORY)"


def test_kernels_compile_in_memory_where_no_cache_directory_is_writable(tmp_path):
    site = read_only_install(tmp_path)
    code = (
        f"{WHERE}\n"
        "import gymnasium as gym, numpy as np\n"
        "env = gym.make('RollingDisk-v0')\n"
        "env.reset(seed=0)\n"
        "observation, reward, *_ = env.step(np.zeros(2, dtype=np.float32))\n"
        "print(np.all(np.isfinite(observation)) and reward > 0)\n"
    )
    # Unoptimized machine code (NUMBA_OPT=0): this checks where kernels go, not how fast they run; a step compiles
    # in half the time (10 s instead of 20, upright), and nothing it compiles is kept.
    nowhere = {"NUMBA_CACHE_DIR": NOWHERE, "HOME": NOWHERE, "XDG_CACHE_HOME": NOWHERE}
    result = run(site, code, NUMBA_OPT="0", **nowhere)
    module, directory, works = result.stdout.split()
    assert module.startswith(str(site)) and directory == "None" and works == "True"
    warning = result.stderr.splitlines()
    assert len(warning) == 1 and "no writable directory" in warning[0] and "NUMBA_CACHE_DIR" in warning[0]
    assert not any(path.is_dir() for path in site.rglob("__pycache__"))


@pytest.mark.parametrize("where", ["NUMBA_CACHE_DIR", "home"])
def test_a_read_only_install_caches_where_it_can_write(tmp_path, where):
    site = read_only_install(tmp_path / "site")
    writable = tmp_path / "writable"
    if where == "NUMBA_CACHE_DIR":
        environment = {"NUMBA_CACHE_DIR": str(writable), "HOME": NOWHERE, "XDG_CACHE_HOME": NOWHERE}
    else:  # numba's user-wide cache, ~/.cache/numba, as before
        environment = {"NUMBA_CACHE_DIR": "unset", "HOME": str(writable), "XDG_CACHE_HOME": "unset"}
    result = run(site, WHERE, **environment)
    _, directory = result.stdout.split()
    expected = writable if where == "NUMBA_CACHE_DIR" else writable / ".cache" / "numba"
    assert Path(directory).parent == expected and Path(directory).is_dir()
    assert result.stderr == ""


def test_a_writable_package_caches_beside_its_modules(tmp_path):
    site = tmp_path / "site"
    shutil.copytree(PACKAGE, site / "rolling_disk_env", ignore=shutil.ignore_patterns("__pycache__"))
    result = run(site, WHERE, NUMBA_CACHE_DIR="unset", HOME=NOWHERE, XDG_CACHE_HOME=NOWHERE)
    _, directory = result.stdout.split()
    assert Path(directory) == site / "rolling_disk_env" / "__pycache__"
