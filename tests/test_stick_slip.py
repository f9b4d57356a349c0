"""Coulomb's stick-slip never creates energy: the contact impulse that ends a slide, the stops' location, and the
energy of the paper's steady circle on surfaces with too little friction, in ``simulate`` and in the env.

Independent computations: the rigid body's energy, angular momentum and contact-point velocity rebuilt with numpy
(tests/reference.py); the rolling model's own RK4 (``rd.simulate``); scipy's DOP853 between the events."""

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env import engine
from rolling_disk_env._generated import sliding
from rolling_disk_env.dynamics import ROLLING_INDICES
from rolling_disk_env.integrators import MAX_SWITCHES, simulate_contact
from rolling_disk_env.paper import scenarios
from tests import reference

PARAMS = rd.DiskParams()
DISK = PARAMS.constants
SCENARIO_2 = np.array(scenarios()[1].state0)
"""The paper's steady circle: lean 0.5 rad, 89.28 J; its contact needs a friction coefficient of 0.356."""
FRICTIONS = (0.05, 0.1, 0.2, 0.3)
ROLLING = list(ROLLING_INDICES)


def _angular_momentum_about_contact(state: np.ndarray) -> np.ndarray:
    """m (c - p) x c' + R I R^T omega (kg m^2/s), p the contact point: an impulse there leaves it unchanged."""
    rolling = reference.rolling_layout(state)
    offset = reference.contact_offset(rolling, PARAMS)  # p - c
    rotation = reference.rotation(*rolling[2:5])
    body = np.diag([PARAMS.axial_inertia, PARAMS.diametral_inertia, PARAMS.diametral_inertia])
    spin = rotation @ body @ rotation.T @ reference.angular_velocity_world(rolling)
    return PARAMS.mass * np.cross(-offset, reference.centre_velocity_sliding(state, PARAMS)) + spin


def test_the_contact_impulse_zeroes_the_slip_at_the_contact_point_and_only_takes_energy():
    rng = np.random.default_rng(3)
    for _ in range(50):
        x = rd.sliding_state(reference.random_states(rng, 1)[0], PARAMS)
        x[5:7] += rng.uniform(-0.5, 0.5, 2)  # a slip of up to 0.7 m/s
        stuck = np.array(sliding.stick(tuple(x), PARAMS.radius))
        np.testing.assert_array_equal(stuck[:5], x[:5])  # an impulse changes velocities only
        slip = reference.contact_point_velocity(x, PARAMS)[:2]
        np.testing.assert_allclose(reference.contact_point_velocity(stuck, PARAMS), 0.0, atol=1e-12)
        # The impulse acts at the contact point: the angular momentum about it is kept, and the energy changes by
        # half the impulse (the centre's change of momentum) times the slip, which is never positive.
        before, after = _angular_momentum_about_contact(x), _angular_momentum_about_contact(stuck)
        np.testing.assert_allclose(after, before, rtol=0, atol=1e-12 * max(1.0, np.abs(before).max()))
        impulse = PARAMS.mass * (stuck[5:7] - x[5:7])
        change = reference.energy_sliding(stuck, PARAMS) - reference.energy_sliding(x, PARAMS)
        assert change == pytest.approx(0.5 * impulse @ slip, rel=1e-9, abs=1e-12)
        assert change < 0 and impulse @ slip < 0


def _energy_rises(states: np.ndarray) -> np.ndarray:
    """Each step's energy change over the start's energy, from the independent energy."""
    energy = np.array([reference.energy_sliding(x, PARAMS) for x in states])
    return np.diff(energy) / energy[0]


@pytest.mark.parametrize("mu", FRICTIONS)
def test_the_steady_circle_on_too_little_friction_never_gains_energy(mu):
    # 6 s at 0.001 s: RK4's own error on the fast leaning roll after a stick is 9e-13 of the energy a step there (at
    # 0.01 s it is 9e-8; the next test); the switching adds none.
    trajectory = simulate_contact(SCENARIO_2, 6.0, 0.001, "rk4", friction_coefficient=mu)
    assert trajectory.events[0].kind == "slip" and trajectory.events[0].time == 0.0
    assert _energy_rises(trajectory.states).max() < 1e-9
    for event in trajectory.events[1:]:
        if event.kind != "slip":
            assert 0 < event.slip < 1e-9 and event.energy_change <= 1e-12 * 89.28


@pytest.mark.parametrize("mu", FRICTIONS)
def test_at_0_01_s_the_only_energy_gains_are_rk4s_own_while_rolling(mu):
    # Every step whose energy rises by more than 1e-9 of the start holds no event, and the rolling model's own RK4
    # (rd.simulate, no contact code) takes the same step from its start: the gain is RK4's truncation error.
    dt = 0.01
    trajectory = simulate_contact(SCENARIO_2, 6.0, dt, "rk4", friction_coefficient=mu)
    rises = _energy_rises(trajectory.states)
    times = np.array([event.time for event in trajectory.events])
    for k in np.flatnonzero(rises > 1e-9):
        start, end = trajectory.times[k], trajectory.times[k + 1]
        assert not np.any((times > start) & (times <= end))
        assert np.hypot(*rd.slip_velocity(trajectory.states[k])) < 1e-12  # rolling
        _, rolled = rd.simulate(trajectory.states[k, ROLLING], dt, dt, method="rk4")
        np.testing.assert_allclose(trajectory.states[k + 1, ROLLING], rolled[-1], rtol=0, atol=1e-12)


def test_stops_of_rk4_and_dop853_agree():
    # Both with outputs every 0.001 s (near zero slip dop853 hands the slide to the engine's steps, up to the next
    # output; with outputs every 0.01 s they came within 8.4e-7 s).
    rk4 = simulate_contact(SCENARIO_2, 6.0, 0.001, "rk4", friction_coefficient=0.2)
    dop853 = simulate_contact(SCENARIO_2, 6.0, 0.001, "dop853", friction_coefficient=0.2, rtol=1e-12, atol=1e-12)
    kinds = [event.kind for event in rk4.events]
    assert kinds == [event.kind for event in dop853.events]
    assert kinds.count("stick") == 4 and kinds.count("slip") == 5  # slides, sticks and slips again
    times = np.array([[a.time, b.time] for a, b in zip(rk4.events, dop853.events)])
    np.testing.assert_allclose(times[:, 0], times[:, 1], rtol=0, atol=1e-6)


@pytest.mark.parametrize("torqued", [False, True], ids=["no torque", "random torques"])
def test_every_stop_of_random_starts_is_located_and_its_impulse_takes_energy(torqued):
    # 1000 random starts (lean up to 0.5 rad, rates up to 5 rad/s) on each friction coefficient, 5 s of the engine's
    # RK4 steps of 0.01 s (simulate_contact's rk4), torques drawn for each step (within the env's 5 and 10 N m).
    rng = np.random.default_rng(11 + torqued)
    times = np.linspace(0.0, 5.0, 501)
    states = np.empty((len(times), 10))
    events = np.empty((MAX_SWITCHES, engine.EVENT_SIZE))
    stops = 0
    for mu in FRICTIONS:
        for _ in range(250):
            x = np.zeros(8)
            x[[2, 4]] = rng.uniform(-np.pi, np.pi, 2)
            x[3] = rng.uniform(-0.5, 0.5)
            x[5:] = rng.uniform(-5, 5, 3)
            torques = rng.uniform(-1, 1, (len(times) - 1, 2)) * [5.0, 10.0] * torqued
            start = tuple(rd.sliding_state(x, PARAMS).tolist())
            _, _, _, switches, _ = engine.contact_run(start, times, torques, mu, True, DISK, True, states, events)
            for row in events[: min(switches, len(events))]:
                if row[1] in (engine.STICK, engine.RESLIP):
                    stops += 1
                    assert row[2] < 1e-9
                    # The energy's round-off: its terms reach 1e5 J on a disk that fell spinning at 400 rad/s.
                    rates = row[4:][[5, 6, 7, 8, 9]]
                    terms = 0.5 * PARAMS.mass * PARAMS.radius**2 * rates @ rates + abs(
                        reference.energy_sliding(row[4:], PARAMS)
                    )
                    assert row[3] <= 1e-12 * reference.energy_sliding(row[4:], PARAMS) + 1e-15 * terms
                    scale = max(1.0, np.abs(row[4:][5:]).max())  # m/s, or rad/s times r = 1 m
                    np.testing.assert_allclose(
                        reference.contact_point_velocity(row[4:], PARAMS), 0.0, atol=4e-14 * scale
                    )
    assert stops > 200


@pytest.mark.parametrize("mu", FRICTIONS)
def test_the_env_takes_the_same_steps_and_never_gains_energy(mu):
    # The env's control period of 0.01 s in 10 substeps of 0.001 s: the same RK4 steps as simulate_contact's at
    # 0.001 s (the env rolls its disks in vectorized loops and sends those that slide to the same switching code).
    env = gym.make(
        rd.ENV_ID, task="circle", contact="coulomb", friction_coefficient=mu, actuators=(), dt=0.01, substeps=10,
        task_options={"fall_lean": 1.5}, max_episode_steps=None,
    ).unwrapped  # fmt: skip
    _, info = env.reset(seed=0, options={"state": SCENARIO_2})
    states = [info["state"]]
    for _ in range(600):
        _, _, terminated, _, info = env.step(np.zeros(0, np.float32))
        states.append(info["state"])
        assert not terminated
    states = np.array(states)
    assert _energy_rises(states).max() < 1e-9
    # The same to round-off: the steps' lengths differ in the last bit (0.01 / 10 against differences of the output
    # times), which the slides amplify to 5e-9 by 6 s.
    trajectory = simulate_contact(SCENARIO_2, 6.0, 0.001, "rk4", friction_coefficient=mu)
    np.testing.assert_allclose(states, trajectory.states[::10], rtol=0, atol=1e-7)
