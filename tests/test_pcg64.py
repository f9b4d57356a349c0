"""PCG64 in compiled code against numpy's own: the doubles a state draws, and the state that seeding starts from
(``np.random.PCG64(np.random.SeedSequence(seed))``, what ``gymnasium.utils.seeding.np_random`` seeds with)."""

import numpy as np
import pytest
from gymnasium.utils import seeding
from hypothesis import given, settings
from hypothesis import strategies as st

from rolling_disk_env import pcg64

EDGE_SEEDS = [0, 1, 2**32 - 1, 2**32, 2**32 + 1, 2**63, 2**64 - 1, 2**64, 2**96 - 1, 2**96, 2**127, 2**128 - 1]
"""Seeds whose 32-bit words SeedSequence counts differently (1 to 4 words), and the largest :func:`seed_state`
takes."""


def numpys_words(seed: int) -> np.ndarray:
    """The state of numpy's PCG64 seeded through SeedSequence, as :func:`pcg64.state_words` gives it."""
    return pcg64.state_words(np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed))))


def seed_state(seed: int, offset: int = 0) -> np.ndarray:
    words = np.zeros(4, dtype=np.uint64)
    pcg64.seed_state(np.uint64(seed >> 64), np.uint64(seed & (2**64 - 1)), np.uint64(offset), words)
    return words


@pytest.mark.parametrize("seed", [0, 1, 2**40 + 7])
def test_pcg64_draws_numpys_stream(seed):
    generator = seeding.np_random(seed)[0]
    words = pcg64.state_words(generator)
    ours = [pcg64.random(words) for _ in range(500)]
    np.testing.assert_array_equal(ours, generator.random(500))
    np.testing.assert_array_equal(words, pcg64.state_words(generator))


@pytest.mark.parametrize("seed", [0, 2**64 - 1, 2**64 + 5])
def test_gymnasium_seeds_pcg64_through_a_seed_sequence(seed):
    np.testing.assert_array_equal(pcg64.state_words(seeding.np_random(seed)[0]), numpys_words(seed))


@pytest.mark.parametrize("seed", EDGE_SEEDS)
def test_seed_state_gives_numpys_state(seed):
    np.testing.assert_array_equal(seed_state(seed), numpys_words(seed))


@settings(max_examples=300, deadline=None)
@given(
    seed=st.one_of(st.integers(0, 2**32), st.integers(0, 2**64), st.integers(0, 2**96), st.integers(0, 2**128 - 1)),
    offset=st.one_of(st.integers(0, 2**20), st.integers(0, 2**64 - 1)),
)
def test_seed_state_gives_numpys_state_for_any_seed_and_offset(seed, offset):
    seed = min(seed, 2**128 - 1 - offset)
    np.testing.assert_array_equal(seed_state(seed, offset), numpys_words(seed + offset))


def test_seed_states_seed_the_rows_of_the_mask_across_two_to_the_64():
    n, seed = 8, 2**64 - 3  # seed + k carries into the high word from k = 3: SeedSequence takes a third word
    words = np.full((n, 4), 7, dtype=np.uint64)
    mask = np.array([True, True, False, True, True, True, False, True])
    highs, lows = np.full(n, seed >> 64, dtype=np.uint64), np.full(n, seed & (2**64 - 1), dtype=np.uint64)
    pcg64.seed_states(highs, lows, np.arange(n, dtype=np.uint64), mask, words)
    for k in range(n):
        np.testing.assert_array_equal(words[k], numpys_words(seed + k) if mask[k] else [7, 7, 7, 7], err_msg=str(k))
