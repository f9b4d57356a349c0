"""The engine's sine and cosine: within an ulp or two of libm's, on the angles the model meets and beyond."""

import math

import numpy as np
import pytest

from rolling_disk_env.jit import kernel
from rolling_disk_env.trig import MAX_ANGLE, nearest, sincos


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
def _nearest_many(values, out):
    for i in range(values.shape[0]):
        out[i] = nearest(values[i])


def test_nearest_is_numpys_rint_below_2_to_51():
    rng = np.random.default_rng(2)
    values = np.concatenate(
        [
            rng.uniform(-1e6, 1e6, 100_000),
            rng.uniform(-3, 3, 10_000),
            np.arange(-1000, 1000) * 0.5,  # integers and halves: ties go to the even neighbour
            np.nextafter(np.arange(-50.0, 50.0) + 0.5, np.inf),
            np.nextafter(np.arange(-50.0, 50.0) + 0.5, -np.inf),
            [0.0, -0.0, 5e-324, -5e-324, 2.0**51 - 0.5, 2.0**51 - 1.5, -(2.0**51) + 0.5, 2.0**50 + 0.5],
        ]
    )
    out = np.empty_like(values)
    _nearest_many(values, out)
    np.testing.assert_array_equal(out, np.rint(values))
    np.testing.assert_array_equal(np.array([nearest.py_func(v) for v in values[::97]]), out[::97])


def test_nearest_beyond_2_to_51_is_an_integer_near_y():
    rng = np.random.default_rng(3)
    magnitudes = 2.0 ** rng.uniform(51, 1000, 2000)
    values = np.concatenate([rng.choice([-1.0, 1.0], 2000) * magnitudes, [2.0**51, 2.0**52 + 1]])
    out = np.empty_like(values)
    _nearest_many(values, out)
    assert np.all(out == np.rint(out))
    assert np.all(np.abs(out - values) <= 1.0 + np.spacing(np.abs(values)))
    special, out = np.array([np.inf, -np.inf, np.nan]), np.empty(3)
    _nearest_many(special, out)
    np.testing.assert_array_equal(out, special)


def test_sincos_of_inf_and_nan_is_nan():
    angles = np.array([np.inf, -np.inf, np.nan])
    sines, cosines = np.empty(3), np.empty(3)
    _sincos_many(angles, sines, cosines)
    assert np.isnan(sines).all() and np.isnan(cosines).all()
