"""Task eight: the gates against the geometry of the two circles (numpy), in their order; a disk that rides one lobe
again, on that lobe's exact steady circle, strays off the course and never succeeds; one whole eight, ridden by the
classical controller, passes the eight gates in the order the geometry gives; the observation against the states."""

import math

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from agents.baselines import EightLQR
from rolling_disk_env.dynamics import steady_circle
from rolling_disk_env.tasks import EightTask

PARAMS = rd.DiskParams()


def make(**kwargs):
    return gym.make(rd.TASK_IDS["eight"], **kwargs)


def lobes(goal: dict) -> tuple[np.ndarray, np.ndarray, float]:
    """The centres of lobe A (counter-clockwise) and lobe B (clockwise), and their radius (m)."""
    crossing, normal = np.array([goal["cx"], goal["cy"]]), np.array([goal["nx"], goal["ny"]])
    return crossing + goal["radius"] * normal, crossing - goal["radius"] * normal, goal["radius"]


def turned(centre: np.ndarray, sense: float, track: np.ndarray) -> np.ndarray:
    """The angle (rad) the track has turned about ``centre`` in the ``sense`` of travel (+1 counter-clockwise), from
    its first point, unwrapped."""
    angles = np.unwrap(np.arctan2(track[:, 1] - centre[1], track[:, 0] - centre[0]))
    return sense * (angles - angles[0])


def test_a_disk_that_rides_one_lobe_again_strays_off_the_course():
    # The exact steady circle of lobe A, zero torque: it stays on lobe A. After the lobe's four gates the next is on
    # lobe B, whose circle it leaves: off the course once more than 1 m away from it, with no success.
    env = make(actuators=())
    env.reset(seed=0)
    goal = env.unwrapped.goal
    centre_a, centre_b, radius = lobes(goal)
    theta, dphi, dpsi = steady_circle(radius, 2.5, PARAMS)
    crossing = np.array([goal["cx"], goal["cy"]])
    # On lobe A at its crossing point, travelling counter-clockwise: the direction of travel (sin psi, -cos psi).
    outward = (crossing - centre_a) / radius
    travel = np.array([-outward[1], outward[0]])
    psi = math.atan2(travel[0], -travel[1])
    env.reset(seed=0, options={"state": [*crossing, 0.0, theta, psi, dphi, 0.0, dpsi]})
    assert env.unwrapped.goal["gate"] == goal["gate"]  # the drawn start gate is kept: set it to lobe A's first
    env.unwrapped._batch.goals[8:, 0] = (0.0, 0.0, 0.0)
    track, ended = [], None
    for _ in range(1250):
        _, _, terminated, truncated, info = env.step(np.zeros(0, np.float32))
        track.append(info["state"][:2])
        if terminated or truncated:
            ended = info
            break
    track = np.array(track)
    np.testing.assert_allclose(np.hypot(*(track - centre_a).T), radius, atol=0.05)  # it rode lobe A
    assert ended is not None and ended["termination"] == rd.Termination.OFF_COURSE and not ended["is_success"]
    assert env.unwrapped.goal["passed"] == 4  # lobe A's four gates, and none of B's
    assert abs(np.hypot(*(track[-1] - centre_b)) - radius) > 1.0


def test_one_whole_eight_passes_the_gates_in_the_order_of_the_geometry():
    # EightLQR rides an eight; the counts of gates passed after each step against the quarter turns about each lobe's
    # centre, from the track alone.
    env = make()
    agent = EightLQR(task="eight")
    observation, info = env.reset(seed=2)
    goal = env.unwrapped.goal
    centre_a, centre_b, _ = lobes(goal)
    start_gate = goal["gate"]
    track, passed = [info["state"][:2]], [0.0]
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = agent.predict(observation)
        observation, _, terminated, truncated, info = env.step(action)
        track.append(info["state"][:2])
        passed.append(env.unwrapped.goal["passed"])
    assert info["termination"] == rd.Termination.REACHED and info["is_success"] and passed[-1] == 8
    track, passed = np.array(track), np.array(passed)
    gate = int(start_gate)
    for count in range(1, 9):
        step = int(np.argmax(passed >= count))  # the step gate `count` counted
        lobe, sense = (centre_a, 1.0) if gate < 4 else (centre_b, -1.0)
        # The quarter turn of the gate: from the lobe's centre, past the gate's direction (the gate numbers start
        # at the crossing: gate j of a lobe is (j + 1) quarter turns from it).
        crossing = np.array([goal["cx"], goal["cy"]]) - lobe
        quarter = (gate % 4 + 1) * math.pi / 2
        angle = sense * (math.atan2(*(track[step] - lobe)[::-1]) - math.atan2(crossing[1], crossing[0]))
        before = sense * (math.atan2(*(track[step - 1] - lobe)[::-1]) - math.atan2(crossing[1], crossing[0]))
        wrapped = (np.array([before, angle]) - quarter + math.pi) % (2 * math.pi) - math.pi
        assert wrapped[0] < 0 <= wrapped[1], (count, gate, wrapped)
        gate = (gate + 1) % 8


def test_the_observation_is_the_states_against_the_next_gates_lobe():
    env = make()
    observation, info = env.reset(seed=5)
    rng = np.random.default_rng(1)
    steady = None
    for _ in range(100):
        goal = env.unwrapped.goal
        centre_a, centre_b, radius = lobes(goal)
        if steady is None:
            steady = steady_circle(radius, 2.5, PARAMS)
        sense = 1.0 if goal["gate"] < 4 else -1.0
        centre = centre_a if sense > 0 else centre_b
        x = info["state"]
        offset = x[:2] - centre
        out = offset / np.hypot(*offset)
        travel = sense * np.array([-out[1], out[0]])
        forward = np.array([math.sin(x[4]), -math.cos(x[4])])
        theta, dphi, dpsi = steady
        expected = [
            np.hypot(*offset) - radius,
            travel[0] * forward[1] - travel[1] * forward[0],
            travel @ forward,
            x[3] - sense * theta,
            x[6],
            x[5] - dphi,
            x[7] - sense * dpsi,
            sense * theta,
        ]
        np.testing.assert_allclose(observation[:8], np.float32(expected), rtol=1e-5, atol=1e-5)
        observation, _, terminated, truncated, info = env.step(rng.uniform(-0.2, 0.2, 2).astype(np.float32))
        if terminated or truncated:
            break


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"radius_range": (0, 3)}, "radius_range must satisfy"),
        ({"course_bound": 3.0}, "course_bound must be a number in"),
        ({"target_speed": -1}, "target_speed must be a finite number > 0"),
    ],
)
def test_bad_options_are_refused_with_their_message(options, message):
    with pytest.raises(ValueError, match=message):
        make(task_options=options)


def test_a_lobe_too_tight_for_a_steady_circle_is_refused():
    with pytest.raises(ValueError, match="no steady circle"):
        make(task_options={"radius_range": (0.3, 0.5), "target_speed": 2.5, "course_bound": 0.1})


def test_the_task_class_names_its_progress():
    assert EightTask.progress_names == ("gate", "passed", "just_passed")
