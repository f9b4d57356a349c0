"""The engine's sine and cosine: within an ulp or two of libm's, on the angles the model meets and beyond."""

import math

import numpy as np
import pytest

from rolling_disk_env.jit import kernel
from rolling_disk_env.trig import MAX_ANGLE, floor, sincos


@kernel
def _sincos_many(angles, sines, cosines):
    for i in range(angles.shape[0]):
        sines[i], cosines[i] = sincos(angles[i])


def _ulps(ours: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.abs(ours - reference) / np.spacing(np.abs(reference))


@pytest.mark.parametrize(("bound", "ulps"), [(math.pi, 1), (1e3, 1), (MAX_ANGLE, 2)])
def test_sincos_is_within_ulps_of_libm(bound, ulps):
    rng = np.random.default_rng(0)
    angles = np.concatenate(
        [
            rng.uniform(-bound, bound, 100_000),
            # Next to the multiples of pi/2, where the reduction cancels most digits.
            np.arange(-min(bound, 1e4) // 2, min(bound, 1e4) // 2) * (math.pi / 2) + rng.uniform(-1e-9, 1e-9),
            [0.0, -0.0, 1e-300, math.pi / 4],
        ]
    )
    sines, cosines = np.empty_like(angles), np.empty_like(angles)
    _sincos_many(angles, sines, cosines)
    assert _ulps(sines, np.array([math.sin(a) for a in angles])).max() <= ulps
    assert _ulps(cosines, np.array([math.cos(a) for a in angles])).max() <= ulps


def test_sincos_interpreted_is_sincos_compiled():
    angles = np.random.default_rng(1).uniform(-50, 50, 1000)
    sines, cosines = np.empty_like(angles), np.empty_like(angles)
    _sincos_many(angles, sines, cosines)
    interpreted = np.array([sincos.py_func(a) for a in angles])
    np.testing.assert_array_equal(interpreted[:, 0], sines)
    np.testing.assert_array_equal(interpreted[:, 1], cosines)


@kernel
def _floor_many(values, out):
    for i in range(values.shape[0]):
        out[i] = floor(values[i])


def test_floor_is_numpys_floor():
    rng = np.random.default_rng(2)
    values = np.concatenate(
        [
            rng.uniform(-1e6, 1e6, 100_000),
            rng.uniform(-3, 3, 10_000),
            np.arange(-1000, 1000) * 0.5,  # integers and halves
            np.nextafter(np.arange(-50.0, 50.0), np.inf),
            np.nextafter(np.arange(-50.0, 50.0), -np.inf),
            [0.0, -0.0, 2.0**51 - 0.5, 2.0**51 + 1, -(2.0**51) - 1, 2.0**60, 1e300, -1e300, np.inf, -np.inf, np.nan],
        ]
    )
    out = np.empty_like(values)
    _floor_many(values, out)
    np.testing.assert_array_equal(out, np.floor(values))
