"""Task waypoints: the waypoints lie on legs of the drawn lengths and turns; a waypoint counts only in its order (one
passed out of order changes nothing); the observation and reward terms against computations from the states."""

import math

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.tasks import WaypointsTask

PARAMS = rd.DiskParams()
WEIGHTS = WaypointsTask.default_reward_weights


def make(**kwargs):
    return gym.make(rd.TASK_IDS["waypoints"], **kwargs)


def waypoints(env) -> np.ndarray:
    goal = env.unwrapped.goal
    return np.array([[goal[f"x{j}"], goal[f"y{j}"]] for j in range(4)])


def at(point, psi=0.0, dphi=2.0) -> list[float]:
    """An upright disk rolling at ``dphi`` with its centre at ``point`` (m), heading ``psi``."""
    return [point[0], point[1], 0.0, 0.0, psi, dphi, 0.0, 0.0]


def test_the_waypoints_are_legs_of_the_drawn_lengths_and_turns():
    env = make()
    for seed in range(20):
        _, info = env.reset(seed=seed)
        points = np.vstack([info["state"][:2], waypoints(env)])
        legs = np.diff(points, axis=0)
        lengths = np.hypot(*legs.T)
        assert np.all((3.0 <= lengths) & (lengths <= 6.0))
        headings = np.arctan2(legs[:, 1], legs[:, 0])
        turns = np.angle(np.exp(1j * np.diff(headings)))
        assert np.all(np.abs(turns) <= 2.0 + 1e-12)


def test_a_waypoint_passed_out_of_order_does_not_count():
    env = make()
    env.reset(seed=0)
    points = waypoints(env)
    for later in (1, 2, 3):  # on waypoint 1, 2 or 3 first: the next is still waypoint 0
        env.reset(seed=0, options={"state": at(points[later])})
        _, _, terminated, _, info = env.step(np.zeros(2, np.float32))
        assert env.unwrapped.goal["next"] == 0 and info["reward_waypoint"] == 0.0 and not terminated


def test_the_waypoints_count_in_order_and_the_last_ends_the_episode_as_a_success():
    env = make()
    env.reset(seed=1)
    points = waypoints(env)
    batch = env.unwrapped._batch
    for j in range(4):
        # The disk put on waypoint j (its state written into the engine's lanes, the progress kept).
        batch.lanes[:8, 0] = at(points[j])
        _, _, terminated, _, info = env.step(np.zeros(2, np.float32))
        assert env.unwrapped.goal["next"] == j + 1 and info["reward_waypoint"] == 1.0
        assert terminated == (j == 3) and info["is_success"] == (j == 3)
        assert info["reward_reached"] == float(j == 3)
    assert info["termination"] == rd.Termination.REACHED


def towards(x, forward, point):
    """The distance (m) from the centre of the disk in state ``x`` to ``point``, the sine and cosine of its bearing
    from the rolling direction ``forward``, and the unit vector towards it."""
    offset = point - x[:2]
    distance = np.hypot(*offset)
    u = offset / distance
    return distance, forward[0] * u[1] - forward[1] * u[0], forward @ u, u


def test_the_observation_and_the_reward_terms_are_the_states():
    env = make(max_episode_steps=200)
    _, info = env.reset(seed=4)
    points = waypoints(env)
    rng = np.random.default_rng(0)
    for _ in range(150):
        previous = env.unwrapped.goal["next"]
        observation, _, terminated, truncated, info = env.step(rng.uniform(-0.3, 0.3, 2).astype(np.float32))
        x = info["state"]
        nxt = int(env.unwrapped.goal["next"])
        forward = np.array([math.sin(x[4]), -math.cos(x[4])])
        d, sin_b, cos_b, u = towards(x, forward, points[min(nxt, 3)])
        d2, sin2, cos2, _ = towards(x, forward, points[min(nxt + 1, 3)])
        dphi_target = 2.0 / PARAMS.radius
        expected = [d, sin_b, cos_b, d2, sin2, cos2, x[3], x[6], x[5] - dphi_target, x[7], (4 - nxt) / 4]
        np.testing.assert_allclose(observation, np.float32(expected), rtol=1e-5, atol=1e-5)
        # The rolling constraint's centre velocity: r (dphi - dpsi sin theta) f + r cos theta dtheta (cos psi, sin psi).
        r = PARAMS.radius
        velocity = r * (x[5] - x[7] * math.sin(x[3])) * forward + r * math.cos(x[3]) * x[6] * np.array(
            [math.cos(x[4]), math.sin(x[4])]
        )
        miss = d * abs(sin_b) if cos_b > 0 else d
        terms = {
            "progress": float(np.clip(velocity @ u / 2.0, -1, 1)),
            "aim": -min(miss**2, 1),
            "speed": -min(((x[5] - dphi_target) / dphi_target) ** 2, 1),
            "upright": -min((x[3] / 0.8) ** 2, 1),
            "waypoint": float(nxt > previous),
        }
        for term, value in terms.items():
            assert info[f"reward_{term}"] == pytest.approx(value, abs=1e-9), term
        if terminated or truncated:
            break


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"leg_range": (0.4, 5.0)}, "leg_range must satisfy"),
        ({"turn_range": (-4.0, 1.0)}, "turn_range must satisfy"),
        ({"cruise_speed": 0}, "cruise_speed must be a finite number > 0"),
        ({"reach_radius": -0.1}, "reach_radius must be a finite number > 0"),
    ],
)
def test_bad_options_are_refused_with_their_message(options, message):
    with pytest.raises(ValueError, match=message):
        make(task_options=options)
