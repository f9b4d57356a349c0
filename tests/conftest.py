"""Test-wide settings: headless rendering, a quiet matplotlib, and at most :data:`MAX_WORKERS` pytest-xdist workers
for ``-n auto`` (the README's test command), which keep the tests of one ``xdist_group`` in one worker."""

import os

os.environ.setdefault("SYMPY_CACHE_SIZE", "100000")  # the derivation's simplification revisits subexpressions

import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

MAX_WORKERS = 8
"""A worker holds numba, SymPy and torch: the largest process of the suite took 963 MB (2 workers, ``ru_maxrss`` of
pytest's children), and a container can see more CPUs than it may use. A few tests take about a minute each alone
(the SymPy derivation that ``test_codegen`` checks, 70 s cold), which more workers do not shorten."""


@pytest.hookimpl(optionalhook=True, wrapper=True)
def pytest_xdist_auto_num_workers(config):
    """pytest-xdist's count of CPUs for ``-n auto``, at most :data:`MAX_WORKERS` unless the user sets the count
    (``PYTEST_XDIST_AUTO_NUM_WORKERS``)."""
    workers = yield
    return workers if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS") else min(workers, MAX_WORKERS)


def pytest_configure(config):
    """Under pytest-xdist (``-n``), its ``loadgroup`` scheduling instead of ``load``: the tests marked with the same
    ``xdist_group`` run in one worker. So the three files that need the SymPy derivation derive it once, a module
    fixture that several tests share (the zoo's trainings) runs once, and the tests that compile the same costly
    kernels (the contact steps) do not meet in two workers, one of them idle while the other compiles (the compile
    lock of ``rolling_disk_env.envs.batch``). pytest-xdist hands out the groups with the most tests first, one
    to each worker.
    Set here rather than in ``addopts``, which would be an error where pytest-xdist is not installed: the controller
    schedules by group, and each worker (told so in :func:`pytest_configure_node`) names its tests' groups."""
    if getattr(config.option, "dist", "no") == "load":
        config.option.dist = "loadgroup"
    if getattr(config, "workerinput", {}).get("loadgroup"):
        config.option.loadgroup = True
    config.addinivalue_line("markers", "xdist_group(name): run in the same pytest-xdist worker as the group's others")


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """pytest-xdist's controller, for each worker it starts: whether the worker's tests are scheduled by group."""
    node.workerinput["loadgroup"] = node.config.option.dist == "loadgroup"
