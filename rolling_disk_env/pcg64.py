"""numpy's PCG64 generator inside compiled code, so that N disks draw their episodes where they are stepped.

Gymnasium seeds an env with ``np.random.Generator(np.random.PCG64(seed))`` (``gymnasium.utils.seeding.np_random``) and
an episode draws ``generator.random(n)``. The vector env keeps each sub-environment's PCG64 state as four 64-bit words
and advances it with :func:`random` below, which returns the same doubles as ``generator.random()``, to the last
bit (``tests/test_pcg64.py``): a sub-environment seeded ``seed + i`` draws exactly the episodes of a single env with
that seed.

PCG64 (O'Neill 2014, as numpy implements it): a 128-bit linear congruential state ``s <- s * MULTIPLIER + increment``
(mod 2^128), output ``rotr64(high(s) ^ low(s), high(s) >> 58)`` of the new state; a double is its top 53 bits over
2^53. The 128-bit arithmetic is done on 64-bit halves.

Seeding: ``np.random.PCG64(seed)`` takes its state from ``np.random.SeedSequence(seed)``, which hashes the seed's
32-bit words (least significant first) into a pool of four 32-bit words and draws four uint64 from it
(``generate_state(4, np.uint64)``); PCG64 starts from those (numpy's ``pcg64_set_seed``). :func:`seed_state` does
both in compiled code, for seeds below :data:`SEED_LIMIT` = 2^128: a sub-environment's state from the batch's seed and
its index, in a loop over the disks (:func:`seed_states`) or in a GPU thread. All of it is integer arithmetic on
uint64, the 32-bit words held in the low halves, so that numba-cuda compiles it as it is.
"""

from __future__ import annotations

import numpy as np

from rolling_disk_env.jit import kernel, parallel_kernel, prange

MULTIPLIER_HIGH = np.uint64(0x2360ED051FC65DA4)
MULTIPLIER_LOW = np.uint64(0x4385DF649FCCF645)
SEED_LIMIT = 2**128
"""The seeds :func:`seed_state` takes are below this: four 32-bit words at most, SeedSequence's pool. SeedSequence mixes
the further words of a larger seed in a round of its own, left out here (the vector env seeds those through numpy)."""
# SeedSequence's hash constants (numpy/random/bit_generator.pyx): 32-bit words.
INIT_A = np.uint64(0x43B0D7E5)
MULT_A = np.uint64(0x931E8875)
INIT_B = np.uint64(0x8B51F9DD)
MULT_B = np.uint64(0x58F38DED)
MIX_MULT_L = np.uint64(0xCA01F9DD)
MIX_MULT_R = np.uint64(0x4973F715)
XSHIFT = np.uint64(16)
_LOW_32 = np.uint64(0xFFFFFFFF)
_32 = np.uint64(32)
_11 = np.uint64(11)
_58 = np.uint64(58)
_63 = np.uint64(63)
_1 = np.uint64(1)
_0 = np.uint64(0)
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
def _add(high, low, other_high, other_low):
    """``(high, low) + (other_high, other_low)`` mod 2^128, each number as its 64-bit halves (uint64)."""
    low = low + other_low
    return high + other_high + (_1 if low < other_low else _0), low


@kernel
def _advance(words):
    """Advances the generator whose state ``words`` holds by one step: ``s <- s * MULTIPLIER + increment``."""
    high, low = words[0], words[1]
    product_high = high * MULTIPLIER_LOW + low * MULTIPLIER_HIGH + _multiply_high(low, MULTIPLIER_LOW)
    words[0], words[1] = _add(product_high, low * MULTIPLIER_LOW, words[2], words[3])


@kernel
def random(words):
    """The next double in [0, 1) of the generator whose state ``words`` (uint64, shape (4,)) holds; advances it."""
    _advance(words)
    high, low = words[0], words[1]
    mixed = high ^ low
    rotation = high >> _58
    output = (mixed >> rotation) | (mixed << ((_63 - rotation + _1) & _63))
    return (output >> _11) * _TWO_TO_MINUS_53


@kernel
def _hashmix(value, hash_constant, multiplier):
    """SeedSequence's ``hashmix`` of the 32-bit word ``value`` (its ``generate_state`` applies it with ``MULT_B``):
    the hashed word and the next hash constant."""
    value ^= hash_constant
    hash_constant = (hash_constant * multiplier) & _LOW_32
    value = (value * hash_constant) & _LOW_32
    return value ^ (value >> XSHIFT), hash_constant


@kernel
def _mix(x, y):
    """SeedSequence's ``mix`` of two 32-bit words."""
    result = (MIX_MULT_L * x - MIX_MULT_R * y) & _LOW_32
    return result ^ (result >> XSHIFT)


@kernel
def _generated_word(first, second, hash_constant):
    """One uint64 of ``generate_state(4, np.uint64)``: the pool words ``first`` and ``second`` hashed into its low
    and high 32 bits; and the next hash constant."""
    low, hash_constant = _hashmix(first, hash_constant, MULT_B)
    high, hash_constant = _hashmix(second, hash_constant, MULT_B)
    return low | (high << _32), hash_constant


@kernel
def seed_state(seed_high, seed_low, offset, words):
    """Writes into ``words`` (uint64, shape (4,)) the state of ``np.random.PCG64(np.random.SeedSequence(seed +
    offset))``, as :func:`state_words` gives it, where ``seed = seed_high * 2^64 + seed_low``.

    Args:
        seed_high: the seed's high 64 bits (an unsigned integer).
        seed_low: its low 64 bits.
        offset: added to the seed (a non-negative integer): sub-environment k of a batch seeded ``seed`` takes ``k``.
        words: the generator's state to write, ``(state high, state low, increment high, increment low)``.

    ``seed + offset`` must be below :data:`SEED_LIMIT` (2^128); larger sums wrap around.
    """
    high, low = _add(np.uint64(seed_high), np.uint64(seed_low), _0, np.uint64(offset))
    # SeedSequence's pool, in words: the entropy's four 32-bit words, least significant first, each hashed (numpy
    # hashes a 0 for the words a smaller seed lacks: the same). Then every word is mixed into every other one.
    words[0], words[1], words[2], words[3] = low & _LOW_32, low >> _32, high & _LOW_32, high >> _32
    hash_constant = INIT_A
    for i in range(4):
        words[i], hash_constant = _hashmix(words[i], hash_constant, MULT_A)
    for source in range(4):
        for target in range(4):
            if source != target:
                hashed, hash_constant = _hashmix(words[source], hash_constant, MULT_A)
                words[target] = _mix(words[target], hashed)
    # generate_state(4, np.uint64): the pool's words in turn, two to a uint64, low half first.
    pool_0, pool_1, pool_2, pool_3 = words[0], words[1], words[2], words[3]
    state_high, hash_constant = _generated_word(pool_0, pool_1, INIT_B)
    state_low, hash_constant = _generated_word(pool_2, pool_3, hash_constant)
    sequence_high, hash_constant = _generated_word(pool_0, pool_1, hash_constant)
    sequence_low, hash_constant = _generated_word(pool_2, pool_3, hash_constant)
    # pcg64_set_seed: increment = (sequence << 1) | 1; the state starts at 0, steps, adds the seed's state, steps.
    words[2] = (sequence_high << _1) | (sequence_low >> _63)
    words[3] = (sequence_low << _1) | _1
    words[0], words[1] = _add(words[2], words[3], state_high, state_low)
    _advance(words)


@parallel_kernel
def seed_states(seed_highs, seed_lows, offsets, mask, words):
    """:func:`seed_state` for each disk k of ``mask``: ``words[k]`` from ``seed_highs[k]``, ``seed_lows[k]`` and
    ``offsets[k]`` (uint64 arrays of N; ``words`` (N, 4) uint64), on numba's threads. The other rows are left as
    they are."""
    for k in prange(words.shape[0]):
        if mask[k]:
            seed_state(seed_highs[k], seed_lows[k], offsets[k], words[k])
