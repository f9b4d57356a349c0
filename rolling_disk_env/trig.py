"""Sine and cosine of float64 arrays for the batched path, where numpy's took a third of a vector-env step.

numpy's float64 ``sin`` and ``cos`` are scalar loops over the C library (about 8 ns a value here, 33 us at
N = 4096), while torch's CPU kernels are vectorized (SLEEF, AVX2/AVX-512, at most 1 ulp from the exact value):
1.4x faster at a thousand values, 3.3x at 4096 (``python benchmarks/bench_dynamics.py`` times both). torch is
installed anyway, for Stable-Baselines3; it is imported on the first large array, not with the package.

Both functions take and return numpy arrays (or floats); smaller arrays stay with numpy, whose call costs less.
"""

from __future__ import annotations

import numpy as np

TORCH_FROM = 640
"""Arrays of at least this many values go to torch (below, numpy's cheaper call wins; the two cost the same at
about 550 values here, 5 us)."""


def _tensor(a: np.ndarray):
    """A float64 tensor sharing ``a``'s memory where torch can (it refuses read-only and negative strides)."""
    import torch

    if not a.flags.writeable or min(a.strides, default=0) < 0:
        a = a.copy()
    return torch.from_numpy(a)


def sin(a):
    """Elementwise sine, float64."""
    a = np.asarray(a, dtype=np.float64)
    return np.sin(a) if a.size < TORCH_FROM else _tensor(a).sin().numpy()


def cos(a):
    """Elementwise cosine, float64."""
    a = np.asarray(a, dtype=np.float64)
    return np.cos(a) if a.size < TORCH_FROM else _tensor(a).cos().numpy()
