"""exp_kernel, the kernels' exponential, against 40-digit decimal arithmetic and libm, over its whole domain."""

import math
from decimal import Decimal, getcontext

import numba
import numpy as np
import pytest

from omegahat.kernels.expfn import exp_kernel


@numba.njit
def _exp_all(x):
    # a loop LLVM vectorises: the SIMD code path, which must give the scalar path's bits
    out = np.empty_like(x)
    for i in range(x.size):
        out[i] = exp_kernel(x[i])
    return out


def _ulps(got, want):
    return np.abs(got - want) / np.spacing(np.maximum(np.abs(want), np.finfo(float).tiny))


def test_within_one_ulp_of_the_correctly_rounded_value():
    getcontext().prec = 40
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-745.0, 709.0, 1500), rng.uniform(-1.0, 1.0, 500), [-708.3964, -0.5, 0.5]])
    exact = np.array([float(Decimal(float(v)).exp()) for v in x])  # e^x of the exact binary x, rounded
    assert _ulps(_exp_all(x), exact).max() <= 1.0


def test_agrees_with_libm_on_a_dense_sample_and_vectorised_equals_scalar():
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.uniform(-745.0, 709.0, 200_000), rng.uniform(-40.0, 0.0, 200_000)])
    got = _exp_all(x)
    assert _ulps(got, np.exp(x)).max() <= 1.0
    scalar = np.array([exp_kernel(v) for v in x[:2000]])  # the dispatcher's own (scalar) compilation
    np.testing.assert_array_equal(scalar, got[:2000])


def test_special_values():
    x = np.array([0.0, -0.0, -1e-300, 1e-300, -745.13, -745.2, -746.0, -1e300, -np.inf, np.nan])
    got = _exp_all(x)
    assert got[0] == 1.0 and got[1] == 1.0 and got[2] == 1.0 and got[3] == 1.0
    assert got[4] == 5e-324  # the smallest subnormal, as libm gives
    assert np.all(got[5:9] == 0.0)
    assert math.isnan(got[9])


@pytest.mark.parametrize("x", [-708.0, -709.5, -720.0, -740.0])
def test_subnormal_results(x):
    # two power-of-two factors keep the scaling exact down to the subnormals; libm is the reference there
    assert abs(exp_kernel(x) - math.exp(x)) <= 5e-324
