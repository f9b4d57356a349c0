"""Where rolling holds: the normal force and the friction the contact needs, against Newton's law; the env and
simulate stopping where the disk would slip or lift off; error-controlled integration where fixed steps fail."""

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.dynamics import steady_motion

SCENARIO_2 = np.array([2, 0, 0, 0.5, 0, steady_motion(0.5, 1.0), 0, 1.0])
"""The paper's steady circle: N = m g, and the contact needs |lambda| / (m g) = 0.356."""
HARD = {
    "near flat, slow": np.array([0, 0, 0, 1.2, 0, 0.5, 0, 0.0]),  # leans to 1.557 rad within 10 s
    "large lean": np.array([0, 0, 0, 0.9, 0, 1.0, 0, 0.0]),
}
PARAMS = rd.DiskParams(mass=3.0, radius=0.7, gravity=9.0)


def test_contact_forces_are_mass_times_the_centres_acceleration_along_a_driven_trajectory():
    # Newton's law for the centre, c = (c1, c2, r cos(theta)): m c'' = (lambda1, lambda2, N - m g), with c'' from
    # finite differences of a trajectory under torques.
    torque = np.array([1.5, -2.0])
    h = 1e-3
    x0 = np.array([0.3, -0.2, 0.1, 0.4, 0.5, 3.0, 0.7, -0.8])
    _, states = rd.simulate(x0, 0.5, h, method="dop853", torque=torque, params=PARAMS, rtol=1e-13, atol=1e-13)
    centres = np.column_stack([states[:, 0], states[:, 1], PARAMS.radius * np.cos(states[:, 3])])
    # Fourth-order central differences.
    stencil = -centres[4:] + 16 * centres[3:-1] - 30 * centres[2:-2] + 16 * centres[1:-3] - centres[:-4]
    acceleration = stencil / (12 * h * h)
    inner = states[2:-2]
    lambdas = rd.contact_force(inner, np.tile(torque, (len(inner), 1)), PARAMS)
    normal = rd.normal_force(inner, np.tile(torque, (len(inner), 1)), PARAMS)
    expected = np.column_stack([lambdas, normal - PARAMS.mass * PARAMS.gravity])
    np.testing.assert_allclose(PARAMS.mass * acceleration, expected, rtol=0, atol=1e-5 * np.abs(expected).max())
    required = rd.required_friction(inner, np.tile(torque, (len(inner), 1)), PARAMS)
    np.testing.assert_allclose(required, np.hypot(*lambdas.T) / normal, rtol=1e-12)


def test_the_papers_steady_circle_needs_a_friction_coefficient_of_0_356():
    params = rd.DiskParams()
    assert rd.normal_force(SCENARIO_2) == pytest.approx(params.mass * params.gravity, rel=1e-12)
    # The contact force is the centripetal force of the centre's circle: v dpsi / g of the weight.
    speed = params.radius * (SCENARIO_2[5] - SCENARIO_2[7] * np.sin(SCENARIO_2[3]))
    assert rd.required_friction(SCENARIO_2) == pytest.approx(speed * SCENARIO_2[7] / params.gravity, rel=1e-12)
    assert rd.required_friction(SCENARIO_2) == pytest.approx(0.356, abs=5e-4)


@pytest.mark.parametrize(("factor", "slips"), [(0.999, True), (1.001, False)])
def test_the_env_terminates_with_slipped_exactly_when_friction_falls_short(factor, slips):
    need = rd.required_friction(SCENARIO_2)
    env = gym.make("RollingDisk-v0", task="circle", actuators=(), friction_coefficient=factor * need)
    env.reset(seed=0, options={"state": SCENARIO_2})
    for _ in range(100):
        _, _, terminated, _, info = env.step(np.zeros(0, dtype=np.float32))
        if terminated:
            break
    assert terminated == slips
    assert info["termination"] == (rd.Termination.SLIPPED if slips else rd.Termination.NONE)
    assert info["required_friction"] == pytest.approx(need, rel=1e-6)


@pytest.mark.parametrize(("factor", "slips"), [(0.999, True), (1.001, False)])
def test_simulate_raises_where_friction_falls_short(factor, slips):
    need = rd.required_friction(SCENARIO_2)
    if not slips:
        rd.simulate(SCENARIO_2, 3.0, 0.01, friction_coefficient=factor * need)
        return
    with pytest.raises(rd.RollingContactError, match="friction") as error:
        rd.simulate(SCENARIO_2, 3.0, 0.01, friction_coefficient=factor * need)
    assert error.value.reason == "slipped" and error.value.time == 0.0
    assert error.value.required_friction == pytest.approx(need) and error.value.normal_force == pytest.approx(49.05)


def test_a_disk_whose_normal_force_vanishes_lifts_off():
    # Upright with a lean rate above sqrt(g / r): N = m (g - r dtheta^2) < 0.
    state = np.array([0, 0, 0, 0, 0, 1.0, 4.0, 0])
    assert rd.normal_force(state) < 0 and rd.required_friction(state) == np.inf
    env = gym.make("RollingDisk-v0")  # no friction coefficient: lift-off ends the episode all the same
    env.reset(seed=0, options={"state": state})
    _, _, terminated, _, info = env.step(np.zeros(2, dtype=np.float32))
    assert terminated and info["termination"] == rd.Termination.LIFTED_OFF
    with pytest.raises(rd.RollingContactError, match="lifted off") as error:
        rd.simulate(state, 1.0, 0.01)
    assert error.value.reason == "lifted_off" and error.value.normal_force < 0


@pytest.mark.parametrize("state", HARD.values(), ids=HARD.keys())
def test_dopri5_error_follows_its_tolerance_where_fixed_steps_fail(state):
    _, reference = rd.simulate(state, 2.0, 0.02, method="dop853", rtol=1e-12, atol=1e-12)
    errors = []
    for tolerance in (1e-6, 1e-8, 1e-10):
        _, states = rd.simulate(state, 2.0, 0.02, method="dopri5", rtol=tolerance, atol=tolerance)
        errors.append(np.abs(states - reference).max())
    assert errors[0] > 10 * errors[1] > 100 * errors[2]
    assert errors[2] < 1e-4
    with pytest.raises(rd.OutOfDomainError):  # the stiffest state: RK4 at the env's step diverges
        rd.simulate(HARD["near flat, slow"], 2.0, 0.02, method="rk4")


def test_the_env_with_dopri5_keeps_a_disk_leaning_to_1_557_rad_in_the_domain():
    env = gym.make(
        "RollingDisk-v0", integrator="dopri5", actuators=(), rtol=1e-9, atol=1e-9, task_options={"fall_lean": 1.5605}
    )
    _, info = env.reset(seed=0, options={"state": HARD["near flat, slow"]})
    energy, drift, lean = info["energy"], 0.0, 0.0
    for _ in range(500):
        _, _, terminated, truncated, info = env.step(np.zeros(0, dtype=np.float32))
        assert not terminated
        drift = max(drift, abs(info["energy"] - energy) / energy)
        lean = max(lean, abs(info["state"][3]))
    assert drift < 1e-6 and lean > 1.55 and truncated
