"""Hypothesis: any initial state in the documented ranges and any action sequence keep everything finite.

``FUZZ_EXAMPLES=2000 python -m pytest tests/test_fuzz.py`` searches longer than the suite's 100 examples.
"""

import os

import gymnasium as gym
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rolling_disk_env as rd
from rolling_disk_env.tasks import TASKS

FUZZ = settings(
    max_examples=int(os.environ.get("FUZZ_EXAMPLES", 100)), deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


@st.composite
def scenarios(draw):
    """A task, an exact initial state drawn inside its documented ranges (as degenerate ranges), a disk."""
    task = draw(st.sampled_from(sorted(TASKS)))
    defaults = TASKS[task].default_initial_ranges
    point = {key: draw(st.floats(low, high)) for key, (low, high) in defaults.items()}
    params_ranges = {"mass": (draw(st.floats(1.0, 10.0)),) * 2, "radius": (draw(st.floats(0.3, 2.0)),) * 2}
    return task, {key: (value, value) for key, value in point.items()}, params_ranges


actions = st.lists(st.lists(st.floats(-10.0, 10.0), min_size=2, max_size=2), min_size=1, max_size=150)


@FUZZ
@given(scenario=scenarios(), sequence=actions, seed=st.integers(0, 2**16))
def test_single_env_never_returns_a_non_finite_value(scenario, sequence, seed):
    task, initial_ranges, params_ranges = scenario
    env = gym.make(rd.ENV_ID, task=task, initial_ranges=initial_ranges, params_ranges=params_ranges)
    observation, info = env.reset(seed=seed)
    assert np.all(np.isfinite(observation))
    for action in sequence:
        observation, reward, terminated, truncated, info = env.step(np.array(action, dtype=np.float32))
        assert np.all(np.isfinite(observation)) and np.isfinite(reward)
        assert np.all(np.isfinite(info["state"])) and np.isfinite(info["energy"])
        assert observation in env.observation_space
        if terminated or truncated:
            break


@FUZZ
@given(scenario=scenarios(), sequence=actions, seed=st.integers(0, 2**16))
def test_vector_env_never_returns_a_non_finite_value(scenario, sequence, seed):
    task, initial_ranges, params_ranges = scenario
    vector = rd.RollingDiskVectorEnv(
        num_envs=3, max_episode_steps=40, task=task, initial_ranges=initial_ranges, params_ranges=params_ranges
    )
    observations, _ = vector.reset(seed=seed)
    for action in sequence:
        batch = np.array([action, action[::-1], [-a for a in action]], dtype=np.float32)
        observations, rewards, _, _, infos = vector.step(batch)
        assert np.all(np.isfinite(observations)) and np.all(np.isfinite(rewards))
        assert np.all(np.isfinite(infos["state"]))
        assert observations in vector.observation_space
