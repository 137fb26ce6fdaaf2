r"""The generators of many campaign runs at once: ``SeedSequence(seed, spawn_key=(j,))`` for every run j.

A campaign's run j draws from ``numpy.random.default_rng(SeedSequence(seed, spawn_key=(j,)))``. Building that
SeedSequence and hashing it into PCG64's state costs, in NumPy, as much as all the run's draws together (its
mixing loops run one word at a time). :func:`seed_words` computes the same 128-bit state and increment words for all
runs at once, with NumPy's element-wise integer arithmetic over the runs, and :func:`generators` hands them to PCG64
through a seed sequence that returns them. ``tests/test_seeds.py`` checks the
words against ``SeedSequence.generate_state(4, numpy.uint64)`` itself.

NumPy's SeedSequence (``numpy/random/bit_generator.pyx``, O'Neill's seed_seq_fe with a pool of four 32-bit
words), for an entropy ``seed`` and a one-word spawn key ``j < 2³²``:

* the entropy words: ``seed`` in little-endian 32-bit words, padded with zeros to the pool size (4), then ``j``;
* the pool: ``pool[i] = hashmix(entropy[i])`` for i < 4, then ``pool[d] = mix(pool[d], hashmix(pool[s]))`` for
  every ordered pair s ≠ d, then each further entropy word w mixed in as ``pool[d] = mix(pool[d], hashmix(w))``
  for d = 0..3; ``hashmix(v) = f(v ⊕ h)·h'`` with the multiplier h advanced by ``MULT_A`` at every call and
  ``f(v) = v ⊕ (v ≫ 16)``, ``mix(x, y) = f(MIX_L x − MIX_R y)``, all modulo 2³²;
* the output: 8 words cycling over the pool, ``f((pool ⊕ h)·h')`` with h advanced by ``MULT_B``, paired into 4
  little-endian 64-bit words (PCG64's state and increment).

The hash multipliers advance the same way for every run; only the last entropy word differs, so the words of
all runs are computed column by column. Spawn keys of 2³² and more take two words: they are computed by NumPy's
own SeedSequence, one at a time.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.random import PCG64, Generator, SeedSequence
from numpy.random.bit_generator import ISeedSequence
from numpy.typing import ArrayLike

__all__ = ["generators", "seed_words"]

_MASK = 0xFFFFFFFF
_INIT_A, _MULT_A = 0x43B0D7E5, 0x931E8875
_INIT_B, _MULT_B = 0x8B51F9DD, 0x58F38DED
_MIX_L, _MIX_R = 0xCA01F9DD, 0x4973F715
_POOL = 4


def _f(v):
    return v ^ (v >> np.uint64(16))


class _HashMix:
    """hashmix with its multiplier advancing at every call; values are uint64 arrays (or scalars) below 2³²."""

    def __init__(self, init: int, mult: int):
        self.h = init
        self.mult = mult

    def __call__(self, v):
        v = v ^ np.uint64(self.h)
        self.h = (self.h * self.mult) & _MASK
        return _f((v * np.uint64(self.h)) & np.uint64(_MASK))


def _mix(x, y):
    return _f((np.uint64(_MIX_L) * x - np.uint64(_MIX_R) * y) & np.uint64(_MASK))


def _words32(value: int) -> list:
    """A non-negative integer's little-endian 32-bit words (0 is one word)."""
    words = []
    while True:
        words.append(value & _MASK)
        value >>= 32
        if value == 0:
            return words


def seed_words(seed: int, indices: ArrayLike) -> np.ndarray:
    """``SeedSequence(seed, spawn_key=(j,)).generate_state(4, numpy.uint64)`` for every j of ``indices``:
    ``(N, 4)`` uint64."""
    seed = int(seed)
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer; got {seed}")
    indices = np.asarray(indices, dtype=np.int64).reshape(-1)
    if indices.size and indices.min() < 0:
        raise ValueError(f"run indices must be non-negative; got {int(indices.min())}")
    out = np.empty((indices.size, 4), dtype=np.uint64)
    wide = indices >= 2**32
    for row in np.flatnonzero(wide):  # two-word spawn keys: NumPy's own SeedSequence
        out[row] = SeedSequence(seed, spawn_key=(int(indices[row]),)).generate_state(4, np.uint64)
    j = indices[~wide].astype(np.uint64)
    run = _words32(seed)
    entropy = [np.full(j.shape, w, dtype=np.uint64) for w in run + [0] * max(0, _POOL - len(run))] + [j]
    hashmix = _HashMix(_INIT_A, _MULT_A)
    pool = [hashmix(entropy[i]) for i in range(_POOL)]
    for s in range(_POOL):
        for d in range(_POOL):
            if s != d:
                pool[d] = _mix(pool[d], hashmix(pool[s]))
    for w in entropy[_POOL:]:
        for d in range(_POOL):
            pool[d] = _mix(pool[d], hashmix(w))
    out_hash = _HashMix(_INIT_B, _MULT_B)
    state = [out_hash(pool[k % _POOL]) for k in range(8)]
    for m in range(4):
        out[~wide, m] = state[2 * m] | (state[2 * m + 1] << np.uint64(32))
    return out


class _Words(ISeedSequence):
    """A seed sequence that hands PCG64 precomputed state words."""

    __slots__ = ("words",)

    def __init__(self, words):
        self.words = words

    def generate_state(self, n_words, dtype=np.uint32):
        if n_words != 4 or np.dtype(dtype) != np.uint64:  # pragma: no cover - PCG64 asks for exactly this
            raise ValueError("precomputed words serve PCG64 only")
        return self.words


def generators(seed: int, indices: ArrayLike) -> Iterator[Generator]:
    """``numpy.random.default_rng(SeedSequence(seed, spawn_key=(j,)))`` for every j of ``indices``, the same
    generators (same PCG64 state), built from :func:`seed_words`."""
    words = seed_words(seed, indices)
    for row in range(words.shape[0]):
        yield Generator(PCG64(_Words(words[row])))  # type: ignore[arg-type]  # numpy's stubs omit ISeedSequence
