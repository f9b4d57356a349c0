"""Where methods fail and where the default must hold (benchmarks/results/stability.md maps it in full)."""

import numpy as np
import pytest

import rolling_disk_env as rd

ENV_DT = 0.02
EPISODE = 10.0
DRIFT_BOUND = 1e-3
FASTEST_SPIN = 40.0
"""rad/s, beyond what the tasks reach: spin torque 5 N m accelerates dphi by at most 2/3 rad/s^2 for 10 s."""


def _drift(states) -> float:
    energies = rd.energy(states)
    return float(np.max(np.abs(energies - energies[0])) / energies[0])


def test_explicit_euler_at_the_env_dt_breaks_the_energy_bound():
    _, states = rd.simulate(np.array([2, 0, 0, 0.1, 0, 2.5, 0, 0]), EPISODE, ENV_DT, method="euler")
    assert _drift(states) > 10 * DRIFT_BOUND  # measured 2.3%


def test_explicit_euler_at_the_env_dt_makes_a_fast_disk_fall_that_does_not():
    x0 = np.array([0, 0, 0, 0.3, 0, 10.0, 0, 0])
    _, exact = rd.simulate(x0, EPISODE, 0.1, method="dop853")
    assert np.max(np.abs(exact[:, 3])) < 0.5
    with pytest.raises(rd.OutOfDomainError):
        rd.simulate(x0, EPISODE, ENV_DT, method="euler")


@pytest.mark.parametrize("dphi", [1.0, 10.0, FASTEST_SPIN])
@pytest.mark.parametrize("theta", [0.05, 0.6])
def test_rk4_at_the_env_dt_holds_the_energy_bound_over_an_episode(dphi, theta):
    _, states = rd.simulate(np.array([0, 0, 0, theta, 0, dphi, 0, 0]), EPISODE, ENV_DT, method="rk4")
    assert _drift(states) < DRIFT_BOUND


def test_the_env_terminates_cleanly_next_to_the_singularity():
    # A fall threshold just inside the model's domain: the falling disk ends the episode, never a NaN.
    env = rd.RollingDiskEnv(actuators=(), task_options={"fall_lean": rd.LEAN_LIMIT - 1e-3})
    observation, _ = env.reset(seed=0, options={"state": [0, 0, 0, 1.2, 0, 0.0, 0.5, 0.0]})
    terminated = False
    for _ in range(100):
        observation, reward, terminated, _, info = env.step(np.zeros(0, dtype=np.float32))
        assert np.all(np.isfinite(observation)) and np.isfinite(reward)
        if terminated:
            break
    assert terminated and info["termination"] in (rd.Termination.FALLEN, rd.Termination.OUT_OF_DOMAIN)
    assert abs(info["state"][3]) < rd.LEAN_LIMIT
