"""The evidence's linear algebra (services.learners.gp_evidence): LAPACK called directly must give, to the bit,
what scipy's cholesky, its solve_triangular and a matrix product gave (the same LAPACK), numpy's cholesky within
rounding, and refuse a gram that is not positive definite as they did; the evidence's gradient must be the
gradient of its value."""
import numpy as np
import pytest
from scipy.linalg import cholesky, solve_triangular

from services.learners.gp_evidence import factor_and_invert, kernel_shapes, negative_log_posterior


def gram_of(n: int, seed: int) -> np.ndarray:
    z = np.random.default_rng(seed).standard_normal((n, 17)) / 3.0
    smooth, linear = kernel_shapes(z)
    gram = 0.8 * smooth + 0.2 * linear
    gram.flat[::n + 1] += 1e-4
    return gram


@pytest.mark.parametrize("n", [1, 19, 64, 127, 256])
def test_the_factor_and_inverse_are_numpys_and_scipys_to_the_bit(n):
    gram = gram_of(n, n)
    assert np.array_equal(gram, gram.T)  # kernel_shapes' symmetry, which lets the transpose stand in
    chol = cholesky(gram, lower=True)
    inverse_chol = solve_triangular(chol, np.eye(n), lower=True)
    expected = inverse_chol.T @ inverse_chol
    got_chol, got_inverse = factor_and_invert(gram.copy().T)
    assert np.array_equal(np.tril(got_chol), chol)
    assert np.array_equal(got_inverse, expected)
    # numpy ships an OpenBLAS of its own (0.3.31 beside scipy's 0.3.30 here), whose kernels for the CPU found at
    # run time can round otherwise: on an AVX-512 machine (2026-12-02) numpy's factor differed from scipy's by up
    # to 9.1e-16 at n=256; on the machines before, by nothing
    np.testing.assert_allclose(np.tril(got_chol), np.linalg.cholesky(gram), rtol=0, atol=1e-12)


def test_a_gram_that_is_not_positive_definite_is_refused():
    gram = gram_of(30, 1)
    gram[4, 4] = -1.0
    assert factor_and_invert(gram.T.copy(order="F")) is None
    xs = np.zeros((5, 3))  # five samples at one place, no noise: a singular gram
    value, grad = negative_log_posterior(np.r_[np.zeros(3), 0.0, -50.0, -12.0], xs, np.ones((5, 1)), 0.0, 1.0, -50.0)
    assert value == 1e12 and not grad.any()  # the climb is told to go elsewhere


@pytest.mark.parametrize("k", [1, 3])
def test_the_gradient_is_the_values_derivative(k):
    rng = np.random.default_rng(k)
    xs, ys = rng.standard_normal((40, 4)), rng.standard_normal((40, k))
    theta = np.r_[rng.uniform(-0.5, 1.0, 4), 0.1, -1.0, 0.3]
    value, grad = negative_log_posterior(theta, xs, ys, 1.0, 1.0, -4.0)
    step = 1e-6
    for i in range(len(theta)):
        up, down = theta.copy(), theta.copy()
        up[i] += step
        down[i] -= step
        numeric = (negative_log_posterior(up, xs, ys, 1.0, 1.0, -4.0)[0]
                   - negative_log_posterior(down, xs, ys, 1.0, 1.0, -4.0)[0]) / (2 * step)
        assert grad[i] == pytest.approx(numeric, rel=1e-4, abs=1e-5), i
    assert np.isfinite(value)
