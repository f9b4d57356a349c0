"""Independent reference computations for the physics tests.

Nothing here uses the derivation or the generated code: rotation matrices are built from elementary rotations with
numpy, the angular velocity comes from dR/dt R^T with dR/dt by the product rule, and the contact point is the lowest
point of the rim found from the geometry of a disk on a plane.
"""

import numpy as np

from rolling_disk_env import DiskParams


def _elementary(angle: float, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Rotation by ``angle`` about world axis 0, 1 or 2, and its derivative with respect to the angle."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    matrix, derivative = np.eye(3), np.zeros((3, 3))
    matrix[i, i], matrix[i, j], matrix[j, i], matrix[j, j] = c, -s, s, c
    derivative[i, i], derivative[i, j], derivative[j, i], derivative[j, j] = -s, -c, c, -s
    return matrix, derivative


def rotation(phi: float, theta: float, psi: float) -> np.ndarray:
    """R = R_z(psi) R_y(theta) R_x(phi)."""
    return _elementary(psi, 2)[0] @ _elementary(theta, 1)[0] @ _elementary(phi, 0)[0]


def angular_velocity_world(state: np.ndarray) -> np.ndarray:
    """omega from the skew matrix dR/dt R^T, dR/dt by the product rule (rad/s)."""
    phi, theta, psi, dphi, dtheta, dpsi = state[2:8]
    (rz, drz), (ry, dry), (rx, drx) = _elementary(psi, 2), _elementary(theta, 1), _elementary(phi, 0)
    r_dot = dpsi * drz @ ry @ rx + dtheta * rz @ dry @ rx + dphi * rz @ ry @ drx
    skew = r_dot @ (rz @ ry @ rx).T
    return np.array([skew[2, 1], skew[0, 2], skew[1, 0]])


def centre(state: np.ndarray, params: DiskParams) -> np.ndarray:
    """The disk's centre, its height being that of a disk touching the plane z = 0 (m)."""
    axis = rotation(*state[2:5])[:, 0]
    up_in_plane = np.array([0.0, 0.0, 1.0]) - axis[2] * axis
    height = params.radius * np.linalg.norm(up_in_plane)
    return np.array([state[0], state[1], height])


def contact_offset(state: np.ndarray, params: DiskParams) -> np.ndarray:
    """Contact point minus centre: r times the unit vector of the disk's plane that points most downwards (m)."""
    axis = rotation(*state[2:5])[:, 0]
    down_in_plane = np.array([0.0, 0.0, -1.0]) + axis[2] * axis
    return params.radius * down_in_plane / np.linalg.norm(down_in_plane)


def centre_velocity_rolling(state: np.ndarray, params: DiskParams) -> np.ndarray:
    """Velocity of the centre of a rigid disk whose contact point is at rest: omega x (c - p) (m/s)."""
    return np.cross(angular_velocity_world(state), -contact_offset(state, params))


def energy(state: np.ndarray, params: DiskParams) -> float:
    """Kinetic + potential energy of a rolling thin disk (J): translation, rotation about the centre, gravity."""
    omega_body = rotation(*state[2:5]).T @ angular_velocity_world(state)
    inertia = np.diag([params.axial_inertia, params.diametral_inertia, params.diametral_inertia])
    velocity = centre_velocity_rolling(state, params)
    kinetic = 0.5 * params.mass * velocity @ velocity + 0.5 * omega_body @ inertia @ omega_body
    return kinetic + params.mass * params.gravity * centre(state, params)[2]


def random_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """States with |theta| <= 1 rad, angles in [-pi, pi], rates in [-4, 4] rad/s, centre in [-5, 5] m."""
    states = np.empty((count, 8))
    states[:, :2] = rng.uniform(-5, 5, (count, 2))
    states[:, [2, 4]] = rng.uniform(-np.pi, np.pi, (count, 2))
    states[:, 3] = rng.uniform(-1, 1, count)
    states[:, 5:] = rng.uniform(-4, 4, (count, 3))
    return states


# The sliding disk: the same rigid body with its centre's horizontal velocity (dc1, dc2) free, a 10-state
# (c1, c2, phi, theta, psi, dc1, dc2, dphi, dtheta, dpsi).


def rolling_layout(state: np.ndarray) -> np.ndarray:
    """The 8 components of a 10-state that the functions above read: (c1, c2, phi, theta, psi, dphi, dtheta, dpsi)."""
    return np.asarray(state)[[0, 1, 2, 3, 4, 7, 8, 9]]


def centre_velocity_sliding(state: np.ndarray, params: DiskParams) -> np.ndarray:
    """(dc1, dc2, d/dt of the centre's height), the height of a disk touching the plane being r cos(theta) (m/s)."""
    return np.array([state[5], state[6], -params.radius * np.sin(state[3]) * state[8]])


def contact_point_velocity(state: np.ndarray, params: DiskParams) -> np.ndarray:
    """Velocity of the disk's material point at the contact: c' + omega x (p - c) (m/s)."""
    rolling = rolling_layout(state)
    return centre_velocity_sliding(state, params) + np.cross(
        angular_velocity_world(rolling), contact_offset(rolling, params)
    )


def energy_sliding(state: np.ndarray, params: DiskParams) -> float:
    """Kinetic + potential energy of a sliding thin disk (J)."""
    rolling = rolling_layout(state)
    omega_body = rotation(*rolling[2:5]).T @ angular_velocity_world(rolling)
    inertia = np.diag([params.axial_inertia, params.diametral_inertia, params.diametral_inertia])
    velocity = centre_velocity_sliding(state, params)
    kinetic = 0.5 * params.mass * velocity @ velocity + 0.5 * omega_body @ inertia @ omega_body
    return kinetic + params.mass * params.gravity * centre(rolling, params)[2]


def torque_power(state: np.ndarray, torque: np.ndarray) -> float:
    """Power of tau_spin about the disk's axis R e1 and tau_steer about +z (W); any state layout of 8 or 10."""
    rolling = rolling_layout(state) if len(state) == 10 else state
    omega = angular_velocity_world(rolling)
    return torque[0] * rotation(*rolling[2:5])[:, 0] @ omega + torque[1] * omega[2]
