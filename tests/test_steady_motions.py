"""Steady motions (constant lean, spin and heading rates) and the lean model's Jacobians, against facts derived by
hand from the paper's printed equations and against nonlinear simulation."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import rolling_disk_env as rd

PARAMS = rd.DiskParams(mass=3.0, radius=0.7, gravity=9.81)
"""Not the default disk, so that a g/r or an m confused with another constant shows."""


def _is_stable(eigenvalues: np.ndarray) -> bool:
    # The disk conserves energy: stable steady motions have purely imaginary (or zero) eigenvalues, so "stable" is
    # "no real part above round-off".
    return bool(np.max(eigenvalues.real) <= 1e-7 * max(1.0, np.max(np.abs(eigenvalues))))


def _squared_nonzero_pair(theta: float, dpsi: float, p: rd.DiskParams) -> float:
    """k, the nonzero eigenvalues being +-sqrt(k): the characteristic polynomial lambda^2 (lambda^2 - k), worked out
    by hand from the paper's printed ddphi, ddtheta, ddpsi linearized at dtheta = 0 and its circle condition."""
    g, r, c, s = p.gravity, p.radius, math.cos(theta), math.sin(theta)
    numerator = -5 * dpsi**4 * r**2 * c**2 * (1 + 2 * c**2) + 12 * dpsi**2 * g * r * c * math.cos(2 * theta)
    numerator -= 16 * g**2 * s**2
    return numerator / (15 * dpsi**2 * r**2 * c**2)


def _assert_characteristic_polynomial(eigenvalues: np.ndarray, k: float) -> None:
    """The eigenvalues are the roots of lambda^2 (lambda^2 - k): 0, 0, +-sqrt(k)."""
    coefficients = np.poly(eigenvalues)
    np.testing.assert_allclose(coefficients.imag, 0.0, atol=1e-9 * max(1.0, abs(k)))
    np.testing.assert_allclose(coefficients.real, [1.0, 0.0, -k, 0.0, 0.0], rtol=1e-9, atol=1e-9 * max(1.0, abs(k)))


@pytest.mark.parametrize(
    ("lean_state", "torque"),
    [((0.0, 1.0, 0.0, 0.0), None), ((0.2, 2.1, 0.3, 0.5), (0.7, -1.3)), ((-0.6, -1.0, 1.2, -2.0), (-2.0, 4.0))],
)
def test_lean_jacobians_match_finite_differences_of_state_derivative(lean_state, torque):
    a, b = rd.lean_jacobians(lean_state, torque, PARAMS)
    u0 = np.zeros(2) if torque is None else np.array(torque)
    x0 = np.array([0.0, 0.0, 0.0, lean_state[0], 0.0, *lean_state[1:]])
    rows, columns, step = [3, 5, 6, 7], [3, 5, 6, 7], 1e-6
    for j, column in enumerate(columns):
        e = np.zeros(8)
        e[column] = step
        slope = (rd.state_derivative(x0 + e, u0, PARAMS) - rd.state_derivative(x0 - e, u0, PARAMS)) / (2 * step)
        np.testing.assert_allclose(a[:, j], slope[rows], atol=1e-6)
    for j in range(2):
        e = np.zeros(2)
        e[j] = step
        slope = (rd.state_derivative(x0, u0 + e, PARAMS) - rd.state_derivative(x0, u0 - e, PARAMS)) / (2 * step)
        np.testing.assert_allclose(b[:, j], slope[rows], atol=1e-6)


def test_lean_jacobians_reject_bad_input():
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        rd.lean_jacobians(np.zeros((3, 4)))
    with pytest.raises(rd.OutOfDomainError):
        rd.lean_jacobians((1.57, 0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="torque"):
        rd.lean_jacobians((0.1, 0.0, 0.0, 0.0), torque=(1.0, 2.0, 3.0))


@pytest.mark.parametrize(("theta", "dpsi"), [(0.5, 1.0), (-0.4, 2.0), (0.9, -1.3), (0.0, 3.0), (1.4, 0.2)])
def test_steady_motion_is_an_equilibrium_of_the_lean_model(theta, dpsi):
    dphi = rd.steady_motion(theta, dpsi, PARAMS)
    rates = rd.lean_derivative((theta, dphi, 0.0, dpsi), params=PARAMS)
    np.testing.assert_allclose(rates, 0.0, atol=1e-12)


def test_steady_motion_errors_name_the_case():
    with pytest.raises(ValueError, match="leaning disk is steady only if it turns"):
        rd.steady_motion(0.3, 0.0)
    with pytest.raises(ValueError, match="every spin rate"):
        rd.steady_motion(0.0, 0.0)
    with pytest.raises(rd.OutOfDomainError, match="domain"):
        rd.steady_motion(-rd.LEAN_LIMIT, 1.0)
    with pytest.raises(ValueError, match="finite"):
        rd.steady_motion(math.nan, 1.0)
    with pytest.raises(ValueError, match="pass its dphi"):
        rd.steady_motion_eigenvalues(0.0, 0.0)
    with pytest.raises(ValueError, match="only for straight vertical rolling"):
        rd.steady_motion_eigenvalues(0.2, 1.0, dphi=3.0)


@pytest.mark.parametrize("ratio", [0.5, 0.9, 0.99, 1.01, 1.1, 2.0])
def test_straight_vertical_rolling_is_stable_iff_spin_squared_exceeds_g_over_3r(ratio):
    dphi = ratio * math.sqrt(PARAMS.gravity / (3 * PARAMS.radius))
    eigenvalues = rd.steady_motion_eigenvalues(0.0, 0.0, PARAMS, dphi=dphi)
    assert _is_stable(eigenvalues) == (ratio > 1)
    # Linearized by hand: ddtheta = (4 g / (5 r) - 12/5 dphi^2) theta once dpsi = 2 dphi (theta - theta0) is used.
    k = 4 * PARAMS.gravity / (5 * PARAMS.radius) - 12 / 5 * dphi**2
    _assert_characteristic_polynomial(eigenvalues, k)


@pytest.mark.parametrize("ratio", [0.5, 0.9, 1.1, 3.0])
def test_pivoting_vertical_disk_is_stable_iff_heading_rate_squared_exceeds_4g_over_5r(ratio):
    # theta = 0 and dpsi != 0: the steady spin rate is zero, the disk turns about its vertical diameter.
    dpsi = ratio * math.sqrt(4 * PARAMS.gravity / (5 * PARAMS.radius))
    assert rd.steady_motion(0.0, dpsi, PARAMS) == 0.0
    assert _is_stable(rd.steady_motion_eigenvalues(0.0, dpsi, PARAMS)) == (ratio > 1)


@pytest.mark.parametrize("theta", [-1.2, -0.5, -0.1, 0.05, 0.3, 0.5, 0.8, 1.3])
@pytest.mark.parametrize("dpsi", [-4.0, -1.0, -0.3, 0.2, 1.0, 2.5, 6.0])
def test_eigenvalues_equal_the_hand_derived_characteristic_polynomial(theta, dpsi):
    eigenvalues = rd.steady_motion_eigenvalues(theta, dpsi, PARAMS)
    k = _squared_nonzero_pair(theta, dpsi, PARAMS)
    _assert_characteristic_polynomial(eigenvalues, k)
    assert _is_stable(eigenvalues) == (k < 0)


@pytest.mark.parametrize("theta", [0.05, 0.4, 0.8, 1.2, 1.5])
def test_rolling_in_place_is_the_euler_disk_relation_and_is_stable(theta):
    # Centre at rest: r (dphi - dpsi sin(theta)) = 0. Solve the steady spin rate for it, then compare with
    # dpsi^2 cos(theta) = 4 g / r.
    def centre_speed(dpsi):
        return PARAMS.radius * (rd.steady_motion(theta, dpsi, PARAMS) - dpsi * math.sin(theta))

    dpsi = brentq(centre_speed, 0.1, 100.0, xtol=1e-14)
    assert dpsi**2 * math.cos(theta) == pytest.approx(4 * PARAMS.gravity / PARAMS.radius, rel=1e-10)
    x = np.array([0.0, 0.0, 0.0, theta, 0.0, rd.steady_motion(theta, dpsi, PARAMS), 0.0, dpsi])
    np.testing.assert_allclose(rd.state_derivative(x, params=PARAMS)[:2], 0.0, atol=1e-10)
    assert _is_stable(rd.steady_motion_eigenvalues(theta, dpsi, PARAMS))


@pytest.mark.parametrize(
    ("theta", "dpsi", "stable"),
    [(0.5, 1.0, True), (0.1, 0.2, True), (0.1, 3.5, True), (0.1, 1.5, False), (0.2, 1.0, False)],
)
def test_linear_stability_predicts_the_nonlinear_motion_over_20_s(theta, dpsi, stable):
    assert _is_stable(rd.steady_motion_eigenvalues(theta, dpsi)) == stable
    steady = np.array([0.0, 0.0, 0.0, theta, 0.0, rd.steady_motion(theta, dpsi), 0.0, dpsi])
    perturbed = steady + 1e-3 * np.array([0, 0, 0, 1, 0, 1, 1, 1])
    _, states = rd.simulate(perturbed, 20.0, 0.05, method="dop853")
    lean_departure = np.max(np.abs(states[:, 3] - theta))
    if stable:
        assert lean_departure < 0.02
    else:
        assert lean_departure > 0.1
