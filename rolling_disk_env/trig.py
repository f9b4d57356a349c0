"""Sine and cosine of one angle at once, in arithmetic that the compiler vectorizes over a batch of disks.

A call to libm's ``sin`` or ``cos`` keeps LLVM from vectorizing a loop, and an RK4 step of the model needs sixteen of
them. :func:`sincos` is plain arithmetic instead: a reduction to ``r`` in ``[-pi/4, pi/4]``, two polynomials, and a
branch-free choice by quadrant, so a loop over disks computes 8 of them per AVX-512 instruction (measured in
``benchmarks/bench_dynamics.py``). Every kernel of the package uses it, compiled or interpreted, for one disk or N,
so results agree to the last bit everywhere.

Accuracy: within 1 ulp of the correctly rounded value for ``|x| <= MAX_ANGLE`` (``tests/test_trig.py`` checks it
against ``math``). The reduction subtracts ``k pi/2`` in four parts (Cody and Waite), exact while ``|k| < 2^20``.
The model's angles stay far below that: psi changes by ``dpsi`` rad/s, theta stays within pi/2.

The polynomial coefficients are the minimax fits of ``sin(r)`` and ``cos(r)`` on ``[-pi/4, pi/4]`` that fdlibm
publishes (Sun Microsystems, 1993, ``__kernel_sin`` and ``__kernel_cos``): mathematical constants; the code is ours.
"""

from __future__ import annotations

from rolling_disk_env.jit import inline_kernel

MAX_ANGLE = 1.0e6
"""rad. Largest |x| for which the 1-ulp accuracy holds."""

_TWO_OVER_PI = 6.36619772367581382433e-01
# pi/2 in four parts; the first three have 33 significant bits, so k * part is exact for |k| < 2^20.
_PI_OVER_2 = (
    1.57079632673412561417e00,
    6.07710050630396597660e-11,
    2.02226624871116645580e-21,
    8.47842766036889956997e-32,
)
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


_ROUND = 6755399441055744.0
"""1.5 * 2^52: ``(y + _ROUND) - _ROUND`` rounds a double of magnitude below 2^51 to the nearest integer."""


@inline_kernel
def nearest(y):
    """The integer nearest to ``y``, ties to even (``np.rint(y)``) for ``|y| < 2^51``: two IEEE additions, which
    compile for the CPU and the GPU (numba-cuda has no lowering of ``np.rint`` or ``np.floor``) and vectorize on AVX2 as
    on AVX-512. Beyond 2^51, where :func:`sincos` promises no accuracy (:data:`MAX_ANGLE`), it returns an integer within
    ``1 + ulp(y)`` of ``y``; inf and NaN as they are. The JAX reading calls ``jnp.rint``, which is exact in float32 too
    (:mod:`rolling_disk_env.jax.reading`)."""
    return (y + _ROUND) - _ROUND


@inline_kernel
def sincos(x):
    """``(sin(x), cos(x))`` for an angle ``x`` in rad (see the module docstring for the accuracy)."""
    k = nearest(x * _TWO_OVER_PI)
    r = (((x - k * _PI_OVER_2[0]) - k * _PI_OVER_2[1]) - k * _PI_OVER_2[2]) - k * _PI_OVER_2[3]
    z = r * r
    sine = r + r * z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    # cos(r) = 1 - z/2 + z^2 p(z), summed so that the rounding of 1 - z/2 is recovered.
    half = 0.5 * z
    w = 1.0 - half
    cosine = w + (((1.0 - w) - half) + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6))))))
    # x = k pi/2 + r: turn (sin r, cos r) by the quadrant, k mod 4, here q = k - 4 nearest(k / 4) in -2..2 (-2 and 2
    # are the same quadrant: a tie of k / 4 rounds either way).
    q = k - 4.0 * nearest(0.25 * k)
    odd = abs(q) == 1.0
    half_turn = abs(q) == 2.0
    s = cosine if odd else sine
    c = sine if odd else cosine
    return (-s if half_turn | (q == -1.0) else s), (-c if half_turn | (q == 1.0) else c)
