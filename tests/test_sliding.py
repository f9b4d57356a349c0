"""The sliding disk (the paper's frozen lake, with dry friction) and Coulomb's hybrid of rolling and sliding, against
computations that do not use the model: the rigid body's energy, power and contact-point velocity rebuilt with numpy
(tests/reference.py), Newton's law for the centre on finite differences of trajectories, and a spun-up wheel worked
out by hand."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.dynamics import ROLLING_INDICES, steady_motion
from rolling_disk_env.integrators import simulate_contact
from tests import reference

PARAMS = rd.DiskParams(mass=3.0, radius=0.7, gravity=9.0)
SCENARIO_1 = np.array([2, 0, 0, 0.1, 0, 2.5, 0, 0.0])
SCENARIO_2 = np.array([2, 0, 0, 0.5, 0, steady_motion(0.5, 1.0), 0, 1.0])
"""The paper's steady circle: its contact needs a friction coefficient of 0.356."""
ROLLING = list(ROLLING_INDICES)
ROOT = Path(__file__).resolve().parents[1]


def _sliding_states(count: int, seed: int = 0) -> np.ndarray:
    """Random 10-states: the rolling ones of tests/reference.py with a centre velocity of up to 3 m/s."""
    rng = np.random.default_rng(seed)
    states = np.empty((count, 10))
    states[:, ROLLING] = reference.random_states(rng, count)
    states[:, 5:7] = rng.uniform(-3, 3, (count, 2))
    return states


def _rate(function, state: np.ndarray, derivative: np.ndarray, step: float = 1e-6) -> float:
    """d/dt of ``function(state)`` along dx/dt = ``derivative``, by central differences."""
    return (function(state + step * derivative) - function(state - step * derivative)) / (2 * step)


def test_names_and_rolling_states_as_sliding_states():
    assert rd.SLIDING_STATE_NAMES == ("c1", "c2", "phi", "theta", "psi", "dc1", "dc2", "dphi", "dtheta", "dpsi")
    rolling = reference.random_states(np.random.default_rng(1), 5)
    sliding = rd.sliding_state(rolling, PARAMS)
    np.testing.assert_array_equal(sliding[:, ROLLING], rolling)
    for x8, x10 in zip(rolling, sliding):
        np.testing.assert_allclose(x10[5:7], reference.centre_velocity_rolling(x8, PARAMS)[:2], atol=1e-12)
    np.testing.assert_allclose(rd.slip_velocity(sliding, PARAMS), 0.0, atol=1e-13)


def test_slip_velocity_is_the_velocity_of_the_material_contact_point():
    states = _sliding_states(20)
    for state, slip in zip(states, rd.slip_velocity(states, PARAMS)):
        velocity = reference.contact_point_velocity(state, PARAMS)
        assert abs(velocity[2]) < 1e-12  # the lowest point of the rim moves horizontally
        np.testing.assert_allclose(slip, velocity[:2], rtol=0, atol=1e-12)


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_energy_changes_by_the_torques_power_and_the_friction_power(mu):
    # dE/dt = tau_spin (R e1 . omega) + tau_steer omega_z - mu N |v|, everything but dx/dt from the rigid body: the
    # energy and the power from numpy, N from Newton's law along z, m (g + c3''), c3' = -r sin(theta) dtheta.
    states = _sliding_states(20, seed=2)
    torques = np.random.default_rng(3).uniform(-2, 2, (20, 2))
    derivatives = rd.sliding_derivative(states, torques, mu, PARAMS)
    for state, torque, derivative in zip(states, torques, derivatives):
        rate = _rate(lambda x: reference.energy_sliding(x, PARAMS), state, derivative)
        height_acceleration = _rate(lambda x: -PARAMS.radius * np.sin(x[3]) * x[8], state, derivative)
        normal = PARAMS.mass * (PARAMS.gravity + height_acceleration)
        slip = np.linalg.norm(reference.contact_point_velocity(state, PARAMS))
        expected = reference.torque_power(state, torque) - mu * normal * slip
        assert rate == pytest.approx(expected, abs=1e-6 * (1 + abs(expected)))
        if mu > 0:
            assert normal == pytest.approx(rd.sliding_normal_force(state, torque, mu, PARAMS), rel=1e-7)
            np.testing.assert_allclose(
                rd.friction_force(state, torque, mu, PARAMS),
                -mu * normal * reference.contact_point_velocity(state, PARAMS)[:2] / slip,
                rtol=1e-7,
            )


def test_without_torques_friction_never_adds_energy():
    states = _sliding_states(100, seed=4)
    states = states[rd.sliding_normal_force(states, None, 0.5, PARAMS) > 0]  # on the plane (N < 0: lift-off)
    assert len(states) > 50
    derivatives = rd.sliding_derivative(states, None, 0.5, PARAMS)
    rates = [_rate(lambda x: reference.energy_sliding(x, PARAMS), s, d) for s, d in zip(states, derivatives)]
    assert max(rates) < 1e-6


def test_with_the_friction_the_rolling_contact_needs_the_slip_does_not_accelerate():
    # The sliding model given the rolling model's horizontal reaction lambda as its contact force has the rolling
    # model's accelerations: two solves of the one Lagrangian, with and without the constraint, agree.
    from rolling_disk_env._generated import sliding

    rolling = reference.random_states(np.random.default_rng(5), 10)
    torques = np.random.default_rng(6).uniform(-2, 2, (10, 2))
    lambdas = rd.contact_force(rolling, torques, PARAMS)
    normals = rd.normal_force(rolling, torques, PARAMS)
    expected = rd.state_derivative(rolling, torques, PARAMS)
    for x8, u, force, normal, rates in zip(rolling, torques, lambdas, normals, expected):
        x10 = rd.sliding_state(x8, PARAMS)
        f1, f2 = force / normal
        derivative = np.array(sliding.friction_derivative(tuple(x10), *u, f1, f2, *PARAMS.constants))
        np.testing.assert_allclose(derivative[ROLLING], rates, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(PARAMS.mass * derivative[5:7], force, rtol=1e-9, atol=1e-9)
        energy, normal_sliding, *_ = sliding.friction_diagnostics(tuple(x10), *u, f1, f2, *PARAMS.constants)
        assert normal_sliding == pytest.approx(normal, rel=1e-9)
        assert energy == pytest.approx(reference.energy(x8, PARAMS), rel=1e-12)


def test_at_zero_slip_the_kinetic_law_gives_no_force():
    x10 = rd.sliding_state(SCENARIO_2)
    np.testing.assert_array_equal(rd.sliding_derivative(x10, friction_coefficient=0.4), rd.sliding_derivative(x10))


def test_frictionless_sliding_keeps_the_centres_velocity_and_energy():
    # The paper's frozen lake: scenario 1 started as rolling, 10 s with dop853.
    times, states = rd.simulate(SCENARIO_1, 10.0, 0.01, method="dop853", contact="sliding", rtol=1e-12, atol=1e-12)
    assert states.shape == (len(times), 10)
    assert np.ptp(states[:, 5:7], axis=0).max() <= 1e-15 * np.abs(states[0, 5:7]).max()
    energy = np.array([reference.energy_sliding(x, rd.DiskParams()) for x in states])
    assert np.abs(energy - energy[0]).max() < 1e-9
    assert np.abs(rd.sliding_energy(states) - energy).max() < 1e-12
    assert np.ptp(states[:, 3]) > 0.5  # the lean changes: the test is not of a disk at rest


def test_frictionless_sliding_with_torques_gains_their_work():
    torque = np.array([1.5, -0.8])
    times, states = rd.simulate(SCENARIO_1, 3.0, 0.001, method="dop853", torque=torque, contact="sliding", rtol=1e-12)
    energy = np.array([reference.energy_sliding(x, rd.DiskParams()) for x in states])
    power = np.array([reference.torque_power(x, torque) for x in states])
    work = np.concatenate([[0.0], np.cumsum((power[1:] + power[:-1]) / 2 * np.diff(times))])  # trapezoidal
    assert np.abs(energy - energy[0] - work).max() < 1e-5
    assert np.abs(work).max() > 1.0


@pytest.mark.parametrize("method", ["rk4", "dop853"])
def test_coulomb_with_a_large_mu_never_slips_and_is_the_rolling_model(method):
    torque = np.array([0.7, -0.4])
    _, rolling = rd.simulate(SCENARIO_1, 5.0, 0.01, method=method, torque=torque)
    trajectory = simulate_contact(SCENARIO_1, 5.0, 0.01, method=method, torque=torque, friction_coefficient=10.0)
    assert trajectory.events == ()
    np.testing.assert_allclose(trajectory.states[:, ROLLING], rolling, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rd.slip_velocity(trajectory.states), 0.0, atol=1e-13)


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853"])
def test_the_papers_steady_circle_slides_below_0_356_and_rolls_above(method):
    assert rd.required_friction(SCENARIO_2) == pytest.approx(0.356, abs=5e-4)
    below = simulate_contact(SCENARIO_2, 1.0, 0.01, method=method, friction_coefficient=0.30)
    assert below.events[0].kind == "slip" and below.events[0].time == 0.0
    assert np.hypot(*rd.slip_velocity(below.states[-1])) > 0.5
    assert below.states[-1, 3] > 0.6  # without enough friction the disk leans into the turn
    above = simulate_contact(SCENARIO_2, 6.0, 0.01, method=method, friction_coefficient=0.40)
    assert above.events == ()
    _, rolling = rd.simulate(SCENARIO_2, 6.0, 0.01, method=method)
    # The same steps but for dopri5: scipy's RK45 here, the engine's own step control there.
    agreement = 1e-7 if method == "dopri5" else 1e-12
    np.testing.assert_allclose(above.states[:, ROLLING], rolling, rtol=0, atol=agreement)


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853"])
def test_a_wheel_spun_up_slips_and_sticks_at_the_times_newton_gives(method):
    # A vertical disk rolling straight (psi = 0: forward is -y), a spin torque tau for t_on, then none, on a contact
    # of friction mu. By hand, with u the forward speed of the centre, omega = dphi, slip s = r omega - u (the
    # contact point's velocity along y), N = m g, friction -mu N along y while s > 0:
    #   m u' = mu m g,  (m r^2 / 2) omega' = tau - r mu m g,  so  s' = 2 tau / (m r) - 3 mu g.
    # Rolling needs |lambda| / N = 2 tau / (3 m g r) > mu: it slips at once, s grows at that rate until t_on, then
    # falls at 3 mu g, and sticks at t_on + s(t_on) / (3 mu g).
    m, g, r = PARAMS.constants
    mu, tau, t_on = 0.2, 6.0, 0.5
    rate = 2 * tau / (m * r) - 3 * mu * g
    assert 2 * tau / (3 * m * g * r) > mu and rate > 0
    x0 = np.array([0, 0, 0, 0, 0, 2.0, 0, 0])
    spun = simulate_contact(x0, t_on, 0.01, method, torque=[tau, 0], params=PARAMS, friction_coefficient=mu)
    assert [(event.time, event.kind) for event in spun.events] == [(0.0, "slip")]
    np.testing.assert_allclose(rd.slip_velocity(spun.states[-1], PARAMS), [0, rate * t_on], atol=1e-9)
    coasting = simulate_contact(spun.states[-1], 1.0, 0.01, method, params=PARAMS, friction_coefficient=mu)
    (stick,) = coasting.events
    assert stick.kind == "stick"
    assert stick.time == pytest.approx(rate * t_on / (3 * mu * g), abs=1e-9)
    # Where it sticks the slip speed of the samples before it, a straight line in time, crosses zero.
    slips = rd.slip_velocity(coasting.states, PARAMS)[:, 1]
    before = coasting.times < stick.time
    slope, intercept = np.polyfit(coasting.times[before], slips[before], 1)
    assert -intercept / slope == pytest.approx(stick.time, abs=1e-9)
    np.testing.assert_allclose(slips[~before], 0.0, atol=1e-12)
    np.testing.assert_allclose(coasting.states[:, 3], 0.0, atol=1e-12)


def test_stick_events_land_where_the_slip_speed_reaches_zero():
    # The paper's steady circle on mu = 0.3: it slides, leans in, and sticks again, the slip turning as it dies out.
    trajectory = simulate_contact(SCENARIO_2, 2.0, 0.001, "dop853", friction_coefficient=0.3, rtol=1e-12, atol=1e-12)
    assert [event.kind for event in trajectory.events] == ["slip", "stick"]
    stick = trajectory.events[1].time
    # Sampled every 10 microseconds over its last millisecond of sliding, the slip speed falls to zero at the event
    # (found again within 2e-9 s: near zero slip the engine's steps run to the next output time): the parabola
    # through its last three samples reaches zero within 1e-8 s of it.
    before = np.flatnonzero(trajectory.times < stick)[-1]
    start = trajectory.times[before]
    close = simulate_contact(trajectory.states[before], 0.001, 1e-5, "dop853", friction_coefficient=0.3, rtol=1e-12)
    (event,) = close.events
    assert event.kind == "stick" and start + event.time == pytest.approx(stick, abs=2e-9)
    speeds = np.hypot(*rd.slip_velocity(close.states).T)
    sliding = np.flatnonzero(close.times < event.time)
    last = sliding[-3:]
    assert 0 < speeds[last[2]] < speeds[last[1]] < speeds[last[0]] < 2e-3
    roots = np.roots(np.polyfit(close.times[last] - close.times[last[2]], speeds[last], 2)).real
    crossing = close.times[last[2]] + roots[np.argmin(np.abs(roots))]
    assert crossing == pytest.approx(event.time, abs=1e-8)
    np.testing.assert_allclose(speeds[close.times > event.time], 0.0, atol=1e-12)
    # The other methods find it within their error.
    for method, tolerance in (("rk4", 1e-4), ("dopri5", 1e-6)):
        other = simulate_contact(SCENARIO_2, 2.0, 0.001, method, friction_coefficient=0.3)
        assert other.events[1].time == pytest.approx(stick, abs=tolerance)


def test_newtons_law_for_the_centre_holds_in_both_modes():
    # m c'' = (F1, F2, N - m g) with c = (c1, c2, r cos(theta)) and c'' from finite differences of a trajectory that
    # slides, then rolls: F and N from the sliding model while it slides, lambda and N from the rolling one after.
    mu, h = 0.3, 1e-3
    params = rd.DiskParams()
    trajectory = simulate_contact(SCENARIO_2, 3.0, h, "dop853", friction_coefficient=mu, rtol=1e-13, atol=1e-13)
    (_, stick) = [event.time for event in trajectory.events]
    times, states = trajectory.times, trajectory.states
    centres = np.column_stack([states[:, 0], states[:, 1], params.radius * np.cos(states[:, 3])])
    stencil = -centres[4:] + 16 * centres[3:-1] - 30 * centres[2:-2] + 16 * centres[1:-3] - centres[:-4]
    acceleration = stencil / (12 * h * h)
    inner, at = states[2:-2], times[2:-2]
    # The contact force jumps at the stick, and turns fast in the last milliseconds before it, with the slip direction
    # (see the test above): the differences need a smooth trajectory over their five samples.
    smooth = (at < stick - 0.01) | (at > stick + 3 * h)
    sliding, rolling = smooth & (at < stick), smooth & (at > stick)
    expected = np.empty((len(inner), 3))
    expected[sliding, :2] = rd.friction_force(inner[sliding], None, mu)
    expected[sliding, 2] = rd.sliding_normal_force(inner[sliding], None, mu)
    expected[rolling, :2] = rd.contact_force(inner[rolling][:, ROLLING])
    expected[rolling, 2] = rd.normal_force(inner[rolling][:, ROLLING])
    expected[:, 2] -= params.mass * params.gravity
    for mode in (sliding, rolling):
        assert mode.sum() > 500
        scale = np.abs(expected[mode]).max()
        np.testing.assert_allclose(params.mass * acceleration[mode], expected[mode], rtol=0, atol=1e-6 * scale)


def test_a_batch_is_its_disks_one_by_one():
    states = _sliding_states(4, seed=7)
    torques = np.random.default_rng(8).uniform(-1, 1, (4, 2))
    batch = rd.sliding_derivative(states, torques, 0.2, PARAMS)
    for state, torque, row in zip(states, torques, batch):
        np.testing.assert_array_equal(rd.sliding_derivative(state, torque, 0.2, PARAMS), row)
    starts = np.array([SCENARIO_1, SCENARIO_2])
    trajectory = simulate_contact(starts, 2.0, 0.01, "dop853", friction_coefficient=0.3)
    for i, start in enumerate(starts):
        alone = simulate_contact(start, 2.0, 0.01, "dop853", friction_coefficient=0.3)
        np.testing.assert_array_equal(trajectory.states[:, i], alone.states)
        assert [e.time for e in trajectory.events[i]] == [e.time for e in alone.events]


def test_a_disk_that_lifts_off_raises_under_every_contact():
    state = np.array([0, 0, 0, 0, 0, 1.0, 4.0, 0])  # N = m (g - r dtheta^2) < 0
    for contact in ("sliding", "coulomb"):
        with pytest.raises(rd.RollingContactError, match="lifted off") as error:
            rd.simulate(state, 1.0, 0.01, method="dop853", contact=contact, friction_coefficient=0.5)
        assert error.value.reason == "lifted_off"


def test_bad_arguments_are_named():
    x = rd.sliding_state(SCENARIO_1)
    with pytest.raises(ValueError, match=r"x must have shape \(10,\) or \(N, 10\)"):
        rd.sliding_derivative(SCENARIO_1)
    with pytest.raises(ValueError, match="x must be finite"):
        rd.sliding_derivative(np.full(10, np.nan))
    for mu in (-0.1, np.inf, True, "0.3"):
        with pytest.raises(ValueError, match="friction_coefficient must be a finite number >= 0"):
            rd.sliding_derivative(x, friction_coefficient=mu)
    with pytest.raises(ValueError, match="torque must have shape"):
        rd.sliding_derivative(x, torque=[1.0])
    with pytest.raises(ValueError, match="contact must be one of"):
        rd.simulate(SCENARIO_1, 1.0, 0.01, contact="ice")
    with pytest.raises(ValueError, match=r"one of \('rk4', 'dopri5', 'dop853'\) under contact='sliding'"):
        rd.simulate(SCENARIO_1, 1.0, 0.01, method="euler", contact="sliding")
    with pytest.raises(ValueError, match="model='full'"):
        rd.simulate(SCENARIO_1, 1.0, 0.01, model="lean", contact="sliding")
    with pytest.raises(ValueError, match="needs a friction_coefficient"):
        rd.simulate(SCENARIO_1, 1.0, 0.01, contact="coulomb")
    with pytest.raises(ValueError, match=r"shape \(8,\), \(10,\), \(N, 8\) or \(N, 10\)"):
        rd.simulate(np.zeros(9), 1.0, 0.01, contact="coulomb", friction_coefficient=0.3)
    with pytest.raises(ValueError, match="a callable torque needs one disk"):
        rd.simulate(np.array([SCENARIO_1] * 2), 1.0, 0.01, torque=lambda t, x: [0, 0], contact="sliding")
    # Kinetic friction only: a sliding disk at zero slip that friction could hold has no force law.
    with pytest.raises(rd.OutOfDomainError, match="contact='coulomb' rolls on"):
        rd.simulate(SCENARIO_1, 1.0, 0.01, contact="sliding", friction_coefficient=0.5)


_PROGRAM = """
import json, numpy as np, rolling_disk_env as rd
from rolling_disk_env import engine
from rolling_disk_env.dynamics import steady_motion
rng = np.random.default_rng(9)
x = rng.uniform(-2, 2, (20, 10))
x[:, 3] = rng.uniform(-1.3, 1.3, 20)
u = rng.uniform(-5, 5, (20, 2))
out = {"derivative": rd.sliding_derivative(x, u, 0.4).tolist(), "diagnostics": rd.friction_force(x, u, 0.4).tolist()}
row = np.empty(10)
disk = np.array([5.0, 9.81, 1.0])
engine.hybrid_derivative(x[0], u[0], 0.4, np.array([0.1, 0.2]), -x[0, 5:7], 1e-12, disk, row)
out["hybrid"] = row.tolist()
# The env's control period under "coulomb": the paper's circle slips at once on mu = 0.3, and sticks in 1.9 s.
circle = tuple(rd.sliding_state(np.array([2, 0, 0, 0.5, 0, steady_motion(0.5, 1.0), 0, 1.0])).tolist())
out["period"] = engine.advance_contact(circle, 2.0, 100, (0.0, 0.0), 0.3, True, (5.0, 9.81, 1.0))[0]
print(json.dumps(out))
"""


def test_compiled_sliding_kernels_give_the_interpreted_generated_code_to_the_last_bit():
    runs = []
    for disable in ("0", "1"):
        environment = {**os.environ, "NUMBA_DISABLE_JIT": disable}
        result = subprocess.run(
            [sys.executable, "-c", _PROGRAM], capture_output=True, text=True, env=environment, cwd=ROOT, timeout=600
        )
        assert result.returncode == 0, result.stderr[-3000:]
        runs.append(json.loads(result.stdout))
    assert runs[0] == runs[1]  # JSON keeps every float's exact value
