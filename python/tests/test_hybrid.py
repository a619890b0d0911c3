"""HybridUkfIekf: the hybrid UKF -> IEKF step of paper 000 sec. 3.3."""

import numpy as np
import pytest

import bayestrack as bt

DT = 0.1
F = np.array([[1.0, DT], [0.0, 1.0]])
H = np.array([[1.0, 0.0]])
Q = np.array([[1e-3, 0.0], [0.0, 1e-2]])


def linear_hybrid(prior="ukf_predicted", r=0.25):
    hy = bt.HybridUkfIekf(2, 1, DT, hx=lambda x: H @ x, fx=lambda x, dt: F @ x,
                          HJacobian=lambda x: H, prior=prior, alpha=0.5)
    hy.x = np.array([0.0, 1.0])
    hy.P = np.eye(2)
    hy.Q = Q
    hy.R = np.array([[r]])
    return hy


def kf(r):
    k = bt.KalmanFilter(2, 1)
    k.x = np.array([[0.0], [1.0]])
    k.P = np.eye(2)
    k.F, k.H, k.Q, k.R = F, H, Q, np.array([[r]])
    return k


def test_linear_model_equals_the_kalman_filter():
    # linear f and h: the UKF is exact and the IEKF update with the UKF's
    # predicted prior is the KF update, whatever its starting point
    hy, k = linear_hybrid(), kf(0.25)
    rng = np.random.default_rng(1)
    for t in range(30):
        z = np.array([0.1 * t + rng.normal(0, 0.5)])
        hy.step(z)
        k.predict()
        k.update(z)
        assert np.allclose(hy.x, k.x[:, 0], atol=1e-9, rtol=0)
        assert np.allclose(hy.P, k.P, atol=1e-9, rtol=0)
        assert hy.log_likelihood == pytest.approx(k.log_likelihood, abs=1e-9)
        # step (a) alone is the KF too on a linear model
        assert np.allclose(hy.x_ukf, k.x[:, 0], atol=1e-9, rtol=0)


def test_posterior_prior_uses_the_measurement_twice():
    # prior = UKF posterior: the same z applied twice, i.e. the KF with R / 2
    hy, k = linear_hybrid("ukf_posterior", r=0.25), kf(0.125)
    for z in [0.3, 0.1, -0.2, 0.5]:
        hy.step([z])
        k.predict()
        k.update([z])
        assert np.allclose(hy.x, k.x[:, 0], atol=1e-9, rtol=0)
        assert np.allclose(hy.P, k.P, atol=1e-9, rtol=0)


def test_nonlinear_update_is_the_iekf_fixed_point():
    # scalar hikpf-like measurement h(x) = x^2 / 5: after convergence the
    # posterior mean x satisfies the Gauss-Newton fixed point of the IEKF
    # from the UKF's predicted belief (xp, Pp):
    # x = xp + K (z - h(x) - H(x) (xp - x)), K = Pp H^T (H Pp H^T + R)^-1
    fx = lambda x, dt: 1.0 + 0.5 * x  # noqa: E731
    hx = lambda x: 0.2 * x * x  # noqa: E731
    hj = lambda x: np.array([[0.4 * x[0]]])  # noqa: E731
    hy = bt.HybridUkfIekf(1, 1, 1.0, hx=hx, fx=fx, HJacobian=hj,
                          max_iterations=100, tolerance=1e-14)
    ukf = bt.UnscentedKalmanFilter(1, 1, 1.0, hx=hx, fx=fx)
    for f in (hy, ukf):
        f.x = np.array([1.0])
        f.P = np.array([[0.75]])
        f.Q = np.array([[0.75]])
        f.R = np.array([[1e-3]])
    ukf.predict()
    xp, pp = ukf.x[0], ukf.P[0, 0]
    z = 2.0
    hy.step([z])
    x = hy.x[0]
    h = 0.4 * x
    k = pp * h / (h * pp * h + 1e-3)
    assert abs(x - (xp + k * (z - 0.2 * x * x - h * (xp - x)))) < 1e-9
    assert abs(hy.P[0, 0] - (1 - k * h) * pp) < 1e-9
    assert hy.iterations > 1
    # the refinement moved the estimate away from the UKF's
    assert abs(hy.x_ukf[0] - x) > 1e-3


def test_missing_measurement_is_the_ukf_prediction():
    hy = linear_hybrid()
    hy.step(None)
    assert np.allclose(hy.x, F @ np.array([0.0, 1.0]), atol=1e-12)
    means, covs = linear_hybrid().batch_filter([None, [0.2], None])
    assert means.shape == (3, 2) and covs.shape == (3, 2, 2)


def test_bad_input_raises():
    hy = linear_hybrid()
    with pytest.raises(ValueError, match="prior"):
        bt.HybridUkfIekf(2, 1, DT, hx=lambda x: x, fx=lambda x, dt: x,
                         HJacobian=lambda x: x, prior="other")
    with pytest.raises(TypeError, match="callable"):
        bt.HybridUkfIekf(2, 1, DT, hx=1, fx=lambda x, dt: x, HJacobian=lambda x: x)
    with pytest.raises(ValueError, match="max_iterations"):
        bt.HybridUkfIekf(2, 1, DT, hx=lambda x: x, fx=lambda x, dt: x,
                         HJacobian=lambda x: x, max_iterations=0)
    with pytest.raises(ValueError, match="NaN"):
        hy.step([np.nan])
    with pytest.raises(ValueError, match=r"z must have shape \(1,\)"):
        hy.step([1.0, 2.0])
    hy.HJacobian = lambda x: np.ones(3)
    with pytest.raises(ValueError, match="HJacobian"):
        hy.step([0.1])

    def boom(x):
        raise RuntimeError("jacobian failed")

    hy.HJacobian = boom
    with pytest.raises(RuntimeError, match="jacobian failed"):
        hy.step([0.1])
    hy.HJacobian = lambda x: H
    hy.step([0.1])
