"""The installed wheel as a user meets it: run by .ci/run from an empty directory, in a venv that holds only the wheel
and its dependencies. The package imports from site-packages, declares gymnasium, numpy and numba as its only core
dependencies, and builds every id, steps, renders and batches with nothing more installed; the SB3 adapter names the
extra it needs."""

import importlib.metadata
import re
import sys
from importlib.util import find_spec
from pathlib import Path

import gymnasium as gym
import numpy as np

import rolling_disk_env as rd

location = Path(rd.__file__).resolve()
assert "site-packages" in location.parts, f"imported from {location}, not from the installed wheel"
core = sorted(
    re.match(r"[\w.-]+", requirement).group().lower()
    for requirement in importlib.metadata.requires("rolling-disk-env")
    if "extra ==" not in requirement
)
assert core == ["gymnasium", "numba", "numpy"], f"core dependencies {core}"
training = [name for name in ("torch", "stable_baselines3", "sympy", "scipy", "tensorboard") if find_spec(name)]
assert not training, f"installed with the core only, yet {training} are there"

for env_id in [rd.ENV_ID, *rd.TASK_IDS.values()]:
    assert gym.make(env_id).unwrapped.task.name in rd.TASK_IDS
# One task stepped (each compiles its own kernels, cold here: the others are the same machinery, tested from source).
env = gym.make(rd.ENV_ID, render_mode="rgb_array")
env.reset(seed=0)
observation, reward, _, _, info = env.step(env.action_space.sample())
assert np.all(np.isfinite(observation)) and np.isfinite(reward) and info["termination"] == rd.Termination.NONE
assert env.render().shape == (400, 600, 3)
envs = gym.make_vec(rd.ENV_ID, num_envs=16, vectorization_mode="vector_entry_point")
envs.reset(seed=0)
observations, *_ = envs.step(envs.action_space.sample())
assert observations.shape == (16, 4) and np.all(np.isfinite(observations))
try:
    rd.sb3  # noqa: B018 (the attribute's import is what is checked)
    raise AssertionError("rolling_disk_env.sb3 imported without Stable-Baselines3")
except ImportError as error:
    assert "rolling-disk-env[train]" in str(error), error

print(f"wheel: {location.parent} on Python {sys.version.split()[0]}: imports, builds every id, steps, renders, batches")
