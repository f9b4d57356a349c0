"""The batched path's sine and cosine: within one ulp of the C library's, whatever the array's size and layout."""

import math

import numpy as np
import pytest

from rolling_disk_env import trig


@pytest.mark.parametrize("size", [1, trig.TORCH_FROM - 1, trig.TORCH_FROM, 4096])
@pytest.mark.parametrize("name", ["sin", "cos"])
def test_within_one_ulp_of_math(name, size):
    rng = np.random.default_rng(size)
    angles = np.concatenate([rng.uniform(-4, 4, size), rng.uniform(-1e3, 1e3, size)])
    exact = np.array([getattr(math, name)(a) for a in angles])
    values = getattr(trig, name)(angles)
    assert values.shape == angles.shape and values.dtype == np.float64
    assert np.all(np.abs(values - exact) <= np.spacing(np.abs(exact)))


def test_read_only_and_reversed_arrays_and_floats():
    angles = np.linspace(-3, 3, 2 * trig.TORCH_FROM)
    read_only = angles.copy()
    read_only.flags.writeable = False
    np.testing.assert_allclose(trig.sin(read_only), np.sin(angles), rtol=0, atol=4e-16)
    np.testing.assert_allclose(trig.cos(angles[::-1]), np.cos(angles[::-1]), rtol=0, atol=4e-16)
    strided = np.stack([angles, -angles])[:, ::2]
    np.testing.assert_allclose(trig.cos(strided), np.cos(strided), rtol=0, atol=4e-16)
    assert trig.sin(0.5) == pytest.approx(math.sin(0.5), rel=1e-16)
