"""Physics of the numeric model, checked against independent computations (tests/reference.py) and analytic
steady motions of the paper."""

import math

import numpy as np
import pytest

import rolling_disk_env as rd
from tests import reference

PARAMS = rd.DiskParams()
OTHER_DISK = rd.DiskParams(mass=2.0, radius=0.3, gravity=9.81)


@pytest.fixture(scope="module")
def states():
    return reference.random_states(np.random.default_rng(0), 40)


@pytest.mark.parametrize("params", [PARAMS, OTHER_DISK])
def test_energy_equals_translation_plus_rotation_plus_gravity(states, params):
    expected = [reference.energy(x, params) for x in states]
    np.testing.assert_allclose(rd.energy(states, params), expected, rtol=1e-8)


@pytest.mark.parametrize("params", [PARAMS, OTHER_DISK])
def test_contact_point_is_at_rest(states, params):
    # dc1, dc2 of the model against the velocity of a rigid disk whose contact point is at rest.
    derivative = rd.state_derivative(states, params=params)
    for x, dx in zip(states, derivative):
        centre_velocity = np.array([dx[0], dx[1], -params.radius * np.sin(x[3]) * dx[3]])
        contact_velocity = centre_velocity + np.cross(
            reference.angular_velocity_world(x), reference.contact_offset(x, params)
        )
        np.testing.assert_allclose(contact_velocity, 0.0, atol=1e-7)


@pytest.mark.parametrize("params", [PARAMS, OTHER_DISK])
def test_torque_free_motion_conserves_energy_instantaneously(states, params):
    # dE/dt = grad E . f, by a central difference of the independent energy along f.
    step = 1e-6
    for x in states:
        f = rd.state_derivative(x, params=params)
        rate = (reference.energy(x + step * f, params) - reference.energy(x - step * f, params)) / (2 * step)
        assert abs(rate) < 1e-5 * max(1.0, reference.energy(x, params))


@pytest.mark.parametrize("params", [PARAMS, OTHER_DISK])
def test_power_balance_with_torques(states, params):
    # dE/dt = tau_spin * (omega . axis) + tau_steer * omega_z, omega and the axis taken from R.
    rng = np.random.default_rng(1)
    step = 1e-6
    for x in states:
        torque = rng.uniform(-3, 3, 2)
        f = rd.state_derivative(x, torque, params)
        rate = (reference.energy(x + step * f, params) - reference.energy(x - step * f, params)) / (2 * step)
        omega = reference.angular_velocity_world(x)
        axis = reference.rotation(*x[2:5])[:, 0]
        power = torque[0] * omega @ axis + torque[1] * omega[2]
        assert rate == pytest.approx(power, abs=1e-5 * max(1.0, abs(power)))


def test_contact_force_is_mass_times_centre_acceleration(states):
    # lambda is the horizontal ground reaction: m * (d/dt of the centre velocity), by central differences in time.
    torque = np.array([1.5, -0.7])
    step = 1e-6
    for x in states[:10]:
        f = rd.state_derivative(x, torque)
        acceleration = (
            rd.state_derivative(x + step * f, torque)[:2] - rd.state_derivative(x - step * f, torque)[:2]
        ) / (2 * step)
        np.testing.assert_allclose(rd.contact_force(x, torque), PARAMS.mass * acceleration, atol=1e-5)


@pytest.mark.parametrize(("dphi", "dpsi"), [(0.0, 0.0), (3.0, 0.0), (-7.0, 0.0), (0.0, 2.0), (0.0, -5.0)])
def test_case1_vertical_rolling_or_spinning_in_place_is_an_equilibrium(dphi, dpsi):
    x = np.array([1.0, -2.0, 0.3, 0.0, 0.7, dphi, 0.0, dpsi])
    accelerations = rd.state_derivative(x)[5:]
    np.testing.assert_allclose(accelerations, 0.0, atol=1e-12)
    # Rolling straight: the centre moves at r * dphi along the heading's normal; spinning in place: it stays.
    _, trajectory = rd.simulate(x, 2.0, 0.01)
    np.testing.assert_allclose(trajectory[-1, 3], 0.0, atol=1e-12)
    travelled = np.hypot(*(trajectory[-1, :2] - x[:2]))
    assert travelled == pytest.approx(PARAMS.radius * abs(dphi) * 2.0, abs=1e-9)


def test_case1_vertical_disk_spinning_and_turning_starts_to_lean():
    # With theta = 0, ddtheta = -6/5 dphi dpsi: Case 1 needs dphi = 0 or dpsi = 0.
    x = np.array([0, 0, 0, 0.0, 0, 2.0, 0.0, 1.5])
    assert rd.state_derivative(x)[6] == pytest.approx(-6 / 5 * 2.0 * 1.5)


def test_case3_steady_circle_holds_lean_and_radius():
    theta, dpsi = 0.5, 1.0
    dphi = rd.steady_motion(theta, dpsi)
    x0 = np.array([2.0, 0.0, 0.0, theta, 0.0, dphi, 0.0, dpsi])
    times, trajectory = rd.simulate(x0, 6.0, 0.01, method="dop853", rtol=1e-12, atol=1e-12)
    # Centre speed r (dphi - dpsi sin(theta)) along (sin psi, -cos psi), turning at dpsi: a circle of radius
    # v / dpsi whose centre lies to the left of the motion.
    radius = PARAMS.radius * (dphi - dpsi * np.sin(theta)) / dpsi
    circle_centre = np.array([2.0 + radius, 0.0])
    distance = np.hypot(*(trajectory[:, :2] - circle_centre).T)
    np.testing.assert_allclose(distance, radius, atol=1e-6)
    np.testing.assert_allclose(trajectory[:, 3], theta, atol=1e-6)
    np.testing.assert_allclose(trajectory[:, 4], dpsi * times, atol=1e-6)


def test_the_engines_steady_circles_converge_within_its_newton_steps():
    """engine.steady_circle's Newton iteration (at most engine.NEWTON_STEPS steps) lands on the steady circle over
    five decades of radius and six of speed: the model's ddtheta, from the derivation, is zero there to round-off, and
    the centre path's radius is the one asked for."""
    from rolling_disk_env import engine

    rng = np.random.default_rng(7)
    radii = np.exp(rng.uniform(np.log(0.05), np.log(1e4), 4000))
    speeds = np.exp(rng.uniform(np.log(1e-3), np.log(1e3), 4000))
    solved = 0
    for radius, speed in zip(radii, speeds, strict=True):
        theta, dphi, dpsi = engine.steady_circle(radius, speed, 9.81, 1.0)
        if math.isnan(theta):
            continue
        solved += 1
        x = np.array([0, 0, 0, theta, 0, dphi, 0, dpsi])
        scale = dpsi * dpsi + abs(dphi * dpsi) + 9.81
        assert abs(rd.state_derivative(x)[6]) <= 1e-12 * scale, (radius, speed)
        assert PARAMS.radius * (dphi - dpsi * math.sin(theta)) / dpsi == pytest.approx(radius, rel=1e-12)
    assert solved > 1000


def test_circle_condition_is_the_zero_of_ddtheta():
    for theta, dpsi in [(0.2, 0.5), (-0.4, 2.0), (0.9, -1.3)]:
        dphi = rd.steady_motion(theta, dpsi)
        x = np.array([0, 0, 0, theta, 0, dphi, 0, dpsi])
        assert rd.state_derivative(x)[6] == pytest.approx(0.0, abs=1e-12)


def _upright_rolling_jacobian(dphi: float) -> np.ndarray:
    y = np.array([0.0, dphi, 0.0, 0.0])
    step = 1e-7
    columns = [(rd.lean_derivative(y + step * e) - rd.lean_derivative(y - step * e)) / (2 * step) for e in np.eye(4)]
    return np.array(columns).T


@pytest.mark.parametrize("ratio", [0.7, 0.95, 1.05, 1.5])
def test_upright_rolling_is_stable_iff_spin_squared_exceeds_g_over_3r(ratio):
    dphi = ratio * PARAMS.critical_spin_rate
    growth = np.max(np.linalg.eigvals(_upright_rolling_jacobian(dphi)).real)
    # Linearized: ddtheta = (4g/5r - 12/5 dphi^2) theta, an exponential rate sqrt of that when positive.
    expected = np.sqrt(max(0.0, 4 * PARAMS.gravity / 5 - 12 / 5 * dphi**2))
    assert growth == pytest.approx(expected, abs=1e-5)
    # Nonlinear check from a small lean theta0 (dtheta = dpsi = 0). Linearized, dpsi = 2 dphi (theta - theta0), so
    # theta oscillates about theta* = a theta0 / (a - b), a = 12/5 dphi^2, b = 4g/5r, reaching 2 theta* - theta0;
    # below the threshold the lean grows exponentially, far past the linear regime.
    theta0 = 1e-3
    x0 = np.array([0, 0, 0, theta0, 0, dphi, 0, 0])
    try:
        _, trajectory = rd.simulate(x0, 20.0, 0.01)
        peak = np.max(np.abs(trajectory[:, 3]))
    except rd.OutOfDomainError:
        peak = np.pi / 2
    if ratio > 1:
        a, b = 12 / 5 * dphi**2, 4 * PARAMS.gravity / (5 * PARAMS.radius)
        assert peak == pytest.approx(2 * a * theta0 / (a - b) - theta0, rel=0.05)
    else:
        assert peak > 100 * theta0


def test_lean_model_agrees_with_full_model():
    x0 = np.array([2, 0, 0, 0.1, 0, 2.5, 0, 0])
    torque = np.array([0.5, -0.3])
    _, full = rd.simulate(x0, 10.0, 0.01, torque=torque)
    _, lean = rd.simulate(rd.lean_state(x0), 10.0, 0.01, torque=torque, model="lean")
    np.testing.assert_allclose(lean, rd.lean_state(full), rtol=1e-12, atol=1e-12)


def test_batched_path_equals_scalar_path(states):
    torques = np.random.default_rng(2).uniform(-2, 2, (len(states), 2))
    batch = rd.state_derivative(states, torques)
    one_by_one = np.array([rd.state_derivative(x, u) for x, u in zip(states, torques)])
    np.testing.assert_allclose(batch, one_by_one, rtol=1e-14, atol=1e-14)
    forces = [rd.contact_force(x, u) for x, u in zip(states, torques)]
    np.testing.assert_allclose(rd.contact_force(states, torques), forces, rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: rd.state_derivative(np.zeros(7)), "shape"),
        (lambda: rd.state_derivative([0, 0, 0, np.nan, 0, 0, 0, 0]), "finite"),
        (lambda: rd.state_derivative(np.zeros(8), torque=[1.0]), "torque"),
        (lambda: rd.state_derivative(np.zeros(8), torque=[np.inf, 0]), "torque"),
        (lambda: rd.energy([0, 0, 0, 1.57, 0, 0, 0, 0]), "domain"),
        (lambda: rd.DiskParams(mass=-1.0), "mass"),
        (lambda: rd.DiskParams(radius=float("nan")), "radius"),
    ],
)
def test_bad_input_raises_a_clear_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_rotation_matrix_is_the_papers_r():
    rng = np.random.default_rng(3)
    for phi, theta, psi in rng.uniform(-np.pi, np.pi, (20, 3)):
        rotation = rd.dynamics.rotation_matrix(phi, theta, psi)
        np.testing.assert_allclose(rotation, reference.rotation(phi, theta, psi), atol=1e-15)
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-15)
