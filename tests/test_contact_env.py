"""The env under the "sliding" and "coulomb" contacts, against computations that do not use its step: the rigid
body's energy, torque power and contact-point velocity rebuilt with numpy (tests/reference.py), Newton's law for the
centre on finite differences of the env's own trajectory, the rolling env, and the model API's event-driven
``simulate_contact`` (the same switching, ``engine.contact_segment``, which the env's vectorized loops hand the disks
that slide or slip: the two must give the same steps)."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import rolling_disk_env as rd
from rolling_disk_env.dynamics import ROLLING_INDICES, steady_motion
from rolling_disk_env.integrators import simulate_contact
from tests import reference

# The file's tests compile each task's contact step (20 to 40 s each, with a cold cache): in one pytest-xdist worker
# (with test_goto's contact test), so that the other does not wait for the same kernels (batch.py's compile lock) but
# runs other tests meanwhile.
pytestmark = pytest.mark.xdist_group("contact steps")

PARAMS = rd.DiskParams()
CIRCLE = np.array([2, 0, 0, 0.5, 0, steady_motion(0.5, 1.0), 0, 1.0])
"""The paper's steady circle (scenario 2): its contact needs a friction coefficient of 0.356."""
CONTACTS = [
    pytest.param({"contact": "sliding"}, id="frozen lake"),
    pytest.param({"contact": "sliding", "friction_coefficient": 0.3}, id="sliding mu=0.3"),
    pytest.param({"contact": "coulomb", "friction_coefficient": 0.2}, id="coulomb mu=0.2"),
]
ROLLING = list(ROLLING_INDICES)
CONTACT_STEPS = ("circle", "goto", "upright")
"""The tasks whose contact steps the tests below compile and check under every contact: their generated steps share
the templates with every task's (``rolling_disk_env.codegen``); ``waypoints`` adds a task with progress to the
comparison with the rolling env, and ``ice`` its own contact, Coulomb's (test_ice checks its steps)."""


def _make(**kwargs):
    """An env of the task ``circle``, whose disks may lean up to 0.8 rad (the paper's circle leans 0.5)."""
    return gym.make(rd.ENV_ID, **{"task": "circle", "max_episode_steps": None, **kwargs}).unwrapped


def _passive(contact: str, mu: float | None, **kwargs):
    """A disk without torques that ends its episode only where it leaves the model's domain or its contact."""
    return _make(contact=contact, friction_coefficient=mu, actuators=(), task_options={"fall_lean": 1.5}, **kwargs)


def _run(env, steps: int, action=None, state=None) -> list[dict]:
    """The infos of the reset and of up to ``steps`` steps (fewer if the episode ends)."""
    _, info = env.reset(seed=0, options=None if state is None else {"state": state})
    infos = [info]
    action = np.zeros(env.action_space.shape, np.float32) if action is None else np.asarray(action, np.float32)
    for _ in range(steps):
        _, _, terminated, _, info = env.step(action)
        infos.append(info)
        if terminated:
            break
    return infos


def _sliding_start(extra_velocity) -> np.ndarray:
    """The paper's steady circle as a 10-state, its centre pushed by ``extra_velocity`` (m/s): it slips."""
    x = rd.sliding_state(CIRCLE)
    x[5:7] += extra_velocity
    return x


@pytest.mark.parametrize(
    ("task", "contact"),
    [
        *(
            pytest.param(task, *contact.values, id=f"{contact.id}-{task}")
            for task in CONTACT_STEPS
            for contact in CONTACTS
        ),
        pytest.param("ice", {}, id="coulomb mu=0.1-ice"),
    ],
)
def test_gymnasium_and_sb3_checkers_pass_under_each_contact(task, contact):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(rd.ENV_ID, task=task, **contact).unwrapped, skip_render_check=True)
        sb3_check_env(gym.make(rd.ENV_ID, task=task, **contact).unwrapped, warn=True)


def test_frozen_lake_keeps_the_centres_velocity_and_energy_changes_by_the_torques_work():
    # Frictionless: no horizontal force, so the centre's horizontal velocity never changes; the energy changes only by
    # the torques' work (trapezoid of their power, from numpy's angular velocity).
    env = _make(contact="sliding", dt=0.005)
    action = np.array([0.4, -0.2], np.float32)
    infos = _run(env, 60, action, _sliding_start([0.3, -0.2]))  # 0.3 s: on ice it falls (past 0.8 rad) at 0.36 s
    assert len(infos) == 61 and all(info["sliding"] for info in infos)
    states = np.array([info["state"] for info in infos])
    np.testing.assert_array_equal(states[:, 5:7], np.broadcast_to(states[0, 5:7], (len(states), 2)))
    np.testing.assert_allclose(np.array([info["contact_force"] for info in infos]), 0.0, atol=0)
    energy = np.array([info["energy"] for info in infos])
    np.testing.assert_allclose(energy, [reference.energy_sliding(x, PARAMS) for x in states], rtol=1e-12)
    torque = action * np.array([5.0, 10.0])
    power = np.array([reference.torque_power(x, torque) for x in states])
    work = np.cumsum((power[1:] + power[:-1]) / 2) * env.dt
    assert np.ptp(energy) > 0.1  # the torques do work
    np.testing.assert_allclose(energy[1:] - energy[0], work, atol=2e-4 * np.abs(work).max())


def test_sliding_energy_falls_by_the_friction_power_and_newtons_law_holds():
    # Sliding with kinetic friction mu: dE/dt = torque power - mu N |v| (v the contact point's velocity, rebuilt
    # with numpy), the centre accelerates by F / m horizontally and N = m (g + c3'') vertically (c3 = r cos theta).
    mu, dt = 0.3, 0.002
    env = _make(contact="sliding", friction_coefficient=mu, dt=dt)
    action = np.array([0.5, 0.3], np.float32)
    infos = _run(env, 100, action, _sliding_start([1.5, 1.0]))
    assert len(infos) == 101 and all(info["sliding"] for info in infos)
    states = np.array([info["state"] for info in infos])
    slips = np.array([info["slip_velocity"] for info in infos])
    np.testing.assert_allclose(slips, [reference.contact_point_velocity(x, PARAMS)[:2] for x in states], atol=1e-12)
    normal = np.array([info["normal_force"] for info in infos])
    force = np.array([info["contact_force"] for info in infos])
    np.testing.assert_allclose(np.hypot(*force.T), mu * normal, rtol=1e-12)
    np.testing.assert_allclose(np.array([info["required_friction"] for info in infos]), mu, rtol=1e-12)
    assert np.all(np.einsum("ij,ij->i", force, slips) < 0)  # friction opposes the slip
    torque = action * np.array([5.0, 10.0])
    power = np.array([reference.torque_power(x, torque) for x in states]) - mu * normal * np.hypot(*slips.T)
    energy = np.array([info["energy"] for info in infos])
    # The trapezoid's error, dt^2 / 12 of the power's second derivative, is below 1e-3 of the power here.
    np.testing.assert_allclose(np.diff(energy) / dt, (power[1:] + power[:-1]) / 2, rtol=0, atol=1e-3 * np.ptp(power))
    m, g, r = PARAMS.constants
    acceleration = (states[2:, 5:7] - states[:-2, 5:7]) / (2 * dt)
    # Central differences err by dt^2 / 6 of the third derivative: within 0.5% of the largest force here (a wrong
    # sign or coefficient of the friction would be off by its whole size).
    np.testing.assert_allclose(m * acceleration, force[1:-1], rtol=0, atol=5e-3 * np.abs(force).max())
    height = r * np.cos(states[:, 3])
    np.testing.assert_allclose(m * (g + np.diff(height, 2) / dt**2), normal[1:-1], rtol=0, atol=5e-3 * normal.max())


def test_coulomb_with_enough_friction_is_the_rolling_env_on_every_task():
    rng = np.random.default_rng(3)
    for task in (*CONTACT_STEPS, "waypoints"):
        rolling = gym.make(rd.ENV_ID, task=task)
        coulomb = gym.make(rd.ENV_ID, task=task, contact="coulomb", friction_coefficient=1.1)
        (a, info_a), (b, info_b) = rolling.reset(seed=4), coulomb.reset(seed=4)
        np.testing.assert_array_equal(a, b)
        for _ in range(200):
            action = rng.uniform(-0.5, 0.5, 2).astype(np.float32)
            a, reward_a, end_a, _, info_a = rolling.step(action)
            b, reward_b, end_b, _, info_b = coulomb.step(action)
            assert info_a["required_friction"] < 1.1 and not info_b["sliding"]
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)
            np.testing.assert_allclose(info_b["state"][ROLLING], info_a["state"], rtol=0, atol=1e-12)
            np.testing.assert_allclose(info_b["slip_velocity"], 0.0, atol=1e-12)
            assert reward_b == pytest.approx(reward_a, abs=1e-12) and end_a == end_b
            if end_a:
                break


@pytest.mark.parametrize("mu", [0.3, 0.4])
def test_the_papers_steady_circle_slides_below_0_356_and_rolls_above_as_simulate_contact_says(mu):
    # simulate_contact runs each disk through the switching alone; the env's batch rolls it in vectorized loops until
    # it slips, then hands it to the same code: the same RK4 steps, the same results but for round-off (the steps'
    # lengths, 0.02 s against differences of simulate's output times, differ in the last bit).
    env = _passive("coulomb", mu)
    infos = _run(env, 100, state=CIRCLE)
    assert len(infos) == 101
    states = np.array([info["state"] for info in infos])
    trajectory = simulate_contact(CIRCLE, 2.0, 0.02, "rk4", friction_coefficient=mu)
    np.testing.assert_allclose(states, trajectory.states, rtol=0, atol=1e-12)
    sliding = np.array([info["sliding"] for info in infos])
    if mu < 0.356:
        # It slips at once, leans into the turn and sticks again when the slip dies out: where simulate_contact
        # says, within the step.
        assert [event.kind for event in trajectory.events] == ["slip", "stick"]
        stick = trajectory.events[1].time
        assert sliding[0] and not sliding[-1]
        first_rolling = np.flatnonzero(~sliding)[0]
        assert (first_rolling - 1) * 0.02 < stick <= first_rolling * 0.02
        energy = np.array([info["energy"] for info in infos])
        # Without input, sliding only loses energy (rolling keeps it, to RK4's error).
        assert np.all(np.diff(energy)[sliding[:-1] & sliding[1:]] < 0) and energy[-1] < energy[0] - 1.0
    else:
        assert trajectory.events == () and not sliding.any()


def test_a_sliding_disk_stops_where_friction_holds_it_only_under_coulomb():
    # Slipping with no input, kinetic friction dies the slip out. "coulomb" rolls on from there; "sliding" (the
    # kinetic law alone, no force at zero slip) ends the episode OUT_OF_DOMAIN.
    start = _sliding_start([0.4, 0.0])
    coulomb = _run(_passive("coulomb", 0.5), 60, state=start)
    assert coulomb[0]["sliding"] and not coulomb[-1]["sliding"] and len(coulomb) == 61
    sliding = _run(_passive("sliding", 0.5), 60, state=start)
    assert sliding[-1]["termination"] == rd.Termination.OUT_OF_DOMAIN and len(sliding) < 61


def test_reset_takes_8_or_10_numbers_under_the_sliding_contacts():
    env = _make(contact="coulomb", friction_coefficient=0.5)
    _, info = env.reset(seed=0, options={"state": CIRCLE})
    assert info["state"].shape == (10,) and not info["sliding"]
    np.testing.assert_allclose(info["state"], rd.sliding_state(CIRCLE), atol=1e-15)
    pushed = _sliding_start([0.2, 0.1])
    _, info = env.reset(seed=0, options={"state": pushed})
    np.testing.assert_array_equal(info["state"], pushed)
    assert info["sliding"] and np.hypot(*info["slip_velocity"]) == pytest.approx(np.hypot(0.2, 0.1))
    _, info = gym.make(rd.ENV_ID).reset(seed=0)
    assert info["state"].shape == (8,) and info["sliding"] is False
    np.testing.assert_array_equal(info["slip_velocity"], [0.0, 0.0])
    with pytest.raises(ValueError, match=r"shape \(8,\) or \(10,\)"):
        env.reset(options={"state": np.zeros(9)})
    with pytest.raises(ValueError, match="10-states need contact='sliding' or 'coulomb'"):
        gym.make(rd.ENV_ID).reset(options={"state": pushed})


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"contact": "ice"}, "contact must be one of"),
        ({"contact": "coulomb"}, "needs a friction_coefficient"),
        ({"contact": "coulomb", "friction_coefficient": -0.1}, "friction_coefficient"),
        ({"contact": "coulomb", "friction_coefficient": 1.2}, "sqrt"),
        ({"contact": "sliding", "integrator": "dopri5"}, "integrator='rk4'"),
    ],
)
def test_bad_contact_arguments_raise(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(rd.ENV_ID, **kwargs)
