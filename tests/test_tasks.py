"""The tasks' physics: controllability of upright rolling, the steady circle, and that a passive disk fails."""

import math

import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.dynamics import steady_circle
from rolling_disk_env.tasks import UprightTask


def _linearize(dphi: float):
    """A, B of the lean model about upright rolling at dphi, by central differences of lean_derivative."""
    y0, u0, step = np.array([0.0, dphi, 0.0, 0.0]), np.zeros(2), 1e-6
    a = np.array(
        [(rd.lean_derivative(y0 + step * e) - rd.lean_derivative(y0 - step * e)) / (2 * step) for e in np.eye(4)]
    ).T
    b = np.array(
        [
            (rd.lean_derivative(y0, u0 + step * e) - rd.lean_derivative(y0, u0 - step * e)) / (2 * step)
            for e in np.eye(2)
        ]
    ).T
    return a, b


def _controllability_rank(a, b) -> int:
    blocks = [b]
    for _ in range(3):
        blocks.append(a @ blocks[-1])
    return int(np.linalg.matrix_rank(np.hstack(blocks), tol=1e-8))


def test_upright_rolling_at_the_target_speed_is_controllable():
    task = UprightTask()
    dphi = task.target_spin_rate(rd.DiskParams().radius)
    assert dphi**2 < rd.DiskParams().critical_spin_rate ** 2  # unstable without control
    a, b = _linearize(dphi)
    assert _controllability_rank(a, b) == 4
    # Steer alone reaches theta, dtheta and dpsi through the gyroscopic term; the lean has no input of its own.
    assert _controllability_rank(a, b[:, 1:]) == 3
    np.testing.assert_allclose(b[2], 0.0, atol=1e-9)
    # Without rolling there is no coupling: the lean cannot be controlled.
    a0, b0 = _linearize(0.0)
    assert _controllability_rank(a0, b0) < 4


@pytest.mark.parametrize(("radius", "speed"), [(3.0, 2.0), (6.0, 2.0), (4.0, 2.5), (2.0, 3.0)])
def test_steady_circle_has_the_requested_radius_and_speed(radius, speed):
    theta, dphi, dpsi = steady_circle(radius, speed)
    x0 = np.array([radius, 0.0, 0.0, theta, math.pi, dphi, 0.0, dpsi])  # rolling along +y from (R, 0)
    times, states = rd.simulate(x0, math.pi / dpsi, 0.01, method="dop853", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.hypot(states[:, 0], states[:, 1]), radius, atol=1e-6)
    np.testing.assert_allclose(states[:, 3], theta, atol=1e-7)
    sample = states[len(times) // 3]
    velocity = rd.state_derivative(sample)[:2]
    assert np.hypot(*velocity) == pytest.approx(speed)
    assert sample[0] * velocity[1] - sample[1] * velocity[0] > 0  # counter-clockwise about the origin


def test_circle_observation_reads_the_sampled_offsets():
    offsets = {"radial_offset": (0.3, 0.3), "heading_error": (0.1, 0.1), "theta": (0.02, 0.02)}
    env = rd.RollingDiskEnv(task="circle", initial_ranges=offsets)
    observation, info = env.reset(seed=0)
    goal = env.goal
    assert np.hypot(*info["state"][:2]) == pytest.approx(goal["radius"] + 0.3)
    assert observation[0] == pytest.approx(0.3)
    assert observation[1] == pytest.approx(math.sin(0.1))
    assert observation[2] == pytest.approx(math.cos(0.1))
    assert observation[3] == pytest.approx(0.02 - goal["theta"])


def _heading(task: str, state: np.ndarray, goal: dict) -> tuple[float, float]:
    """The sine and cosine observed by ``task`` from ``state``, by plane geometry: circle's heading error, the angle
    from the circle's counter-clockwise tangent to the rolling direction (sin psi, -cos psi); goto's bearing, the
    angle from the rolling direction to the target."""
    c1, c2, psi = state[0], state[1], state[4]
    if task == "circle":
        around = math.atan2(c2 - goal["cy"], c1 - goal["cx"])  # the tangent points at around + pi/2
        delta = (psi - math.pi / 2) - (around + math.pi / 2)
        return math.sin(delta), math.cos(delta)
    beta = math.atan2(goal["y"] - c2, goal["x"] - c1) - (psi - math.pi / 2)
    return math.sin(beta), math.cos(beta)


@pytest.mark.parametrize("task", ["circle", "goto"])
def test_the_observed_heading_follows_the_state_step_by_step(task):
    """The fused step hands the task the sines and cosines of the new state's angles it keeps for the next step; a
    stale or swapped pair (theta's for psi's, or the last step's) would show here: psi moves by some 1e-3 rad a
    step under the random steer torques."""
    env = rd.RollingDiskEnv(task=task)
    observation, info = env.reset(seed=5)
    rng = np.random.default_rng(5)
    moved = 0.0
    for _ in range(200):
        expected = _heading(task, info["state"], env.goal)
        np.testing.assert_allclose(observation[1:3], expected, atol=2e-6)
        last_psi = info["state"][4]
        observation, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        moved = max(moved, abs(info["state"][4] - last_psi))
        if terminated or truncated:
            observation, info = env.reset()
    assert moved > 1e-3


@pytest.mark.parametrize("task", ["upright", "circle"])
def test_a_passive_disk_fails_the_task(task):
    # Close to none of 64 episodes: a passive circle episode can trace a circle near the target by chance.
    vector = rd.RollingDiskVectorEnv(num_envs=64, max_episode_steps=rd.MAX_EPISODE_STEPS, task=task, actuators=())
    vector.reset(seed=0)
    finished = np.zeros(64, dtype=bool)
    successes = 0
    while not finished.all():
        _, _, terminated, truncated, infos = vector.step(np.zeros((64, 0), dtype=np.float32))
        ending = (terminated | truncated) & ~finished
        successes += int(np.sum(infos["is_success"] & ending))
        finished |= ending
    assert successes <= 3
