"""seed_words and generators against NumPy's own SeedSequence and default_rng."""

import numpy as np
import pytest
from numpy.random import SeedSequence, default_rng

from omegahat.lab.campaigns.seeds import generators, seed_words


@pytest.mark.parametrize("seed", [0, 1, 123, 20250101, 2**32 - 1, 2**32, 2**64 + 9, 2**127 + 3, 2**128 + 7, 2**200 + 1])
def test_words_are_seed_sequence_states(seed):
    # one-word spawn keys (vectorised), the largest one-word key and two-word keys (NumPy's SeedSequence)
    indices = np.array([0, 1, 2, 3, 99, 1000, 65535, 2**31, 2**32 - 1, 2**32, 2**45 + 3])
    want = np.array([SeedSequence(seed, spawn_key=(int(j),)).generate_state(4, np.uint64) for j in indices])
    got = seed_words(seed, indices)
    assert got.dtype == np.uint64 and got.shape == (indices.size, 4)
    np.testing.assert_array_equal(got, want)


def test_generators_draw_the_seed_sequences_streams():
    indices = [5, 0, 17, 4096]
    for j, rng in zip(indices, generators(777, indices), strict=True):
        ref = default_rng(SeedSequence(777, spawn_key=(j,)))
        np.testing.assert_array_equal(rng.standard_normal(50), ref.standard_normal(50))
        np.testing.assert_array_equal(rng.random(50), ref.random(50))


def test_bad_seeds_and_indices_are_named():
    with pytest.raises(ValueError, match="seed must be a non-negative integer; got -1"):
        seed_words(-1, [0])
    with pytest.raises(ValueError, match="run indices must be non-negative; got -3"):
        seed_words(1, [2, -3])
    assert seed_words(1, []).shape == (0, 4)
