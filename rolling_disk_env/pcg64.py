"""numpy's PCG64 generator inside compiled code, so that N disks draw their episodes where they are stepped.

Gymnasium seeds an env with ``np.random.Generator(np.random.PCG64(seed))`` (``gymnasium.utils.seeding.np_random``) and
an episode draws ``generator.random(n)``. The vector env keeps each sub-environment's PCG64 state as four 64-bit words
and advances it with :func:`random` below, which returns the same doubles as ``generator.random()``, to the last
bit (``tests/test_pcg64.py``): a sub-environment seeded ``seed + i`` draws exactly the episodes of a single env with
that seed.

PCG64 (O'Neill 2014, as numpy implements it): a 128-bit linear congruential state ``s <- s * MULTIPLIER + increment``
(mod 2^128), output ``rotr64(high(s) ^ low(s), high(s) >> 58)`` of the new state; a double is its top 53 bits over
2^53. The 128-bit arithmetic is done on 64-bit halves.
"""

from __future__ import annotations

import numpy as np

from rolling_disk_env.jit import kernel

MULTIPLIER_HIGH = np.uint64(0x2360ED051FC65DA4)
MULTIPLIER_LOW = np.uint64(0x4385DF649FCCF645)
_LOW_32 = np.uint64(0xFFFFFFFF)
_32 = np.uint64(32)
_11 = np.uint64(11)
_58 = np.uint64(58)
_63 = np.uint64(63)
_1 = np.uint64(1)
_TWO_TO_MINUS_53 = 1.0 / 9007199254740992.0


def state_words(generator: np.random.Generator) -> np.ndarray:
    """The state of a PCG64 ``generator`` as ``(state high, state low, increment high, increment low)``, uint64."""
    state = generator.bit_generator.state
    if state["bit_generator"] != "PCG64":
        raise TypeError(f"expected a PCG64 generator (Gymnasium's), got {state['bit_generator']}")
    mask = (1 << 64) - 1
    value, increment = state["state"]["state"], state["state"]["inc"]
    return np.array([value >> 64, value & mask, increment >> 64, increment & mask], dtype=np.uint64)


@kernel
def _multiply_high(a, b):
    """The high 64 bits of the 128-bit product of two uint64."""
    a0, a1 = a & _LOW_32, a >> _32
    b0, b1 = b & _LOW_32, b >> _32
    middle = ((a0 * b0) >> _32) + ((a0 * b1) & _LOW_32) + ((a1 * b0) & _LOW_32)
    return a1 * b1 + ((a0 * b1) >> _32) + ((a1 * b0) >> _32) + (middle >> _32)


@kernel
def random(words):
    """The next double in [0, 1) of the generator whose state ``words`` (uint64, shape (4,)) holds; advances it."""
    high, low = words[0], words[1]
    new_low = low * MULTIPLIER_LOW
    new_high = high * MULTIPLIER_LOW + low * MULTIPLIER_HIGH + _multiply_high(low, MULTIPLIER_LOW)
    low = new_low + words[3]
    high = new_high + words[2] + (_1 if low < new_low else np.uint64(0))
    words[0], words[1] = high, low
    mixed = high ^ low
    rotation = high >> _58
    output = (mixed >> rotation) | (mixed << ((_63 - rotation + _1) & _63))
    return (output >> _11) * _TWO_TO_MINUS_53
