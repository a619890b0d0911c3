"""Agreement with filterpy to 1e-9 on the models of tests/filterpy_oracle.rs
(tools/filterpy_vectors.py): each case runs filterpy and bayestrack side by
side, step by step, on the same measurements."""

import numpy as np
import pytest
from numpy.random import default_rng

import bayestrack as bt

fp = pytest.importorskip("filterpy", reason="filterpy is not installed: pip install filterpy")
# filterpy depends on scipy; imported after the skip so that a machine
# without either skips this module instead of failing its collection
from scipy.linalg import block_diag  # noqa: E402
from filterpy.common import Q_continuous_white_noise  # noqa: E402
from filterpy.kalman import (  # noqa: E402
    ExtendedKalmanFilter,
    KalmanFilter,
    MerweScaledSigmaPoints,
    UnscentedKalmanFilter,
    rts_smoother,
)

TOL = 1e-9


def close(a, b, what, k):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, f"{what} step {k}: shape {a.shape} vs {b.shape}"
    err = np.max(np.abs(a - b)) if a.size else 0.0
    assert err <= TOL * max(1.0, np.max(np.abs(b))), f"{what} step {k}: |diff| = {err:e}"


def kf_pair():
    dt = 0.1
    f1 = np.array([[1.0, dt], [0.0, 1.0]])
    q1 = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=0.1)
    out = []
    for cls in (KalmanFilter, bt.KalmanFilter):
        kf = cls(dim_x=4, dim_z=2)
        kf.F = block_diag(f1, f1)
        kf.Q = block_diag(q1, q1)
        kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
        kf.R = np.eye(2) * 0.25
        kf.x = np.array([[0.0], [1.0], [0.0], [0.5]])
        kf.P = np.diag([1.0, 0.5, 1.0, 0.5])
        out.append(kf)
    return out


def kf_measurements():
    rng = default_rng(11)
    ref, _ = kf_pair()
    truth = np.array([0.0, 1.0, 0.0, 0.5])
    zs = []
    for k in range(40):
        truth = ref.F @ truth + rng.multivariate_normal(np.zeros(4), ref.Q)
        z = ref.H @ truth + rng.normal(0, 0.5, 2)
        zs.append(None if k in (10, 11, 25) else z)
    return zs


def test_kf_cv_steps_and_rts():
    ref, ours = kf_pair()
    xs, ps = [], []
    for k, z in enumerate(kf_measurements()):
        ref.predict()
        ours.predict()
        close(ours.x, ref.x, "prior x", k)
        close(ours.P, ref.P, "prior P", k)
        ref.update(None if z is None else z.reshape(2, 1))
        ours.update(z)
        close(ours.x, ref.x, "x", k)
        close(ours.P, ref.P, "P", k)
        if z is not None:
            close(ours.y, ref.y, "y", k)
            close(ours.S, ref.S, "S", k)
            close(ours.log_likelihood, ref.log_likelihood, "log_likelihood", k)
        xs.append(ref.x.copy())
        ps.append(ref.P.copy())
    xs, ps = np.array(xs), np.array(ps)
    want_x, want_p, _, _ = rts_smoother(xs, ps, [ref.F] * 40, [ref.Q] * 40)
    got_x, got_p = ours.rts_smoother(xs, ps)
    close(got_x, want_x, "smoothed x", "all")
    close(got_p, want_p, "smoothed P", "all")


def test_kf_batch_filter_matches_filterpy():
    ref, ours = kf_pair()
    zs = kf_measurements()
    want = ref.batch_filter([None if z is None else z.reshape(2, 1) for z in zs])
    got = ours.batch_filter(zs)
    for name, a, b in zip(("means", "covs", "means_p", "covs_p"), got, want):
        close(a, b, name, "all")
    close(ours.x, ref.x, "final x", "last")


def test_kf_control():
    rng = default_rng(12)
    dt = 0.2
    filters = []
    for cls in (KalmanFilter, bt.KalmanFilter):
        kf = cls(dim_x=2, dim_z=1, dim_u=1)
        kf.F = np.array([[1.0, dt], [0.0, 1.0]])
        kf.B = np.array([[0.5 * dt * dt], [dt]])
        kf.Q = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=0.05)
        kf.H = np.array([[1.0, 0.0]])
        kf.R = np.array([[0.5]])
        kf.x = np.array([[0.0], [0.0]])
        kf.P = np.eye(2) * 2.0
        filters.append(kf)
    ref, ours = filters
    truth = np.zeros(2)
    for k in range(30):
        u = np.sin(0.3 * k)
        truth = ref.F @ truth + ref.B.ravel() * u + rng.multivariate_normal(np.zeros(2), ref.Q)
        z = ref.H @ truth + rng.normal(0, np.sqrt(0.5), 1)
        ref.predict(u=np.array([[u]]))
        ours.predict(u=u)
        close(ours.x, ref.x, "prior x", k)
        ref.update(z.reshape(1, 1))
        ours.update(z)
        close(ours.x, ref.x, "x", k)
        close(ours.P, ref.P, "P", k)
        close(ours.log_likelihood, ref.log_likelihood, "log_likelihood", k)


def radar_h(x):
    return np.array([[np.sqrt(x[0, 0] ** 2 + x[2, 0] ** 2)]])


def radar_jac(x):
    d = np.sqrt(x[0, 0] ** 2 + x[2, 0] ** 2)
    return np.array([[x[0, 0] / d, 0.0, x[2, 0] / d]])


@pytest.mark.parametrize("cls", [bt.ExtendedKalmanFilter, bt.IteratedExtendedKalmanFilter])
def test_ekf_radar(cls):
    rng = default_rng(13)
    dt = 0.05
    filters = []
    for c in (ExtendedKalmanFilter, cls):
        ekf = c(dim_x=3, dim_z=1) if c is not bt.IteratedExtendedKalmanFilter else c(3, 1, max_iterations=1)
        ekf.F = np.eye(3) + np.array([[0, 1.0, 0], [0, 0, 0], [0, 0, 0]]) * dt
        ekf.Q = block_diag(Q_continuous_white_noise(2, dt, 0.1), [[0.1 * dt]])
        ekf.R = np.array([[25.0]])
        ekf.x = np.array([[-100.0], [100.0], [1000.0]])
        ekf.P = np.diag([50.0, 50.0, 50.0])
        filters.append(ekf)
    ref, ours = filters
    pos, vel, alt = 0.0, 100.0, 1000.0
    for k in range(40):
        pos += vel * dt + rng.normal(0, 0.5)
        alt += rng.normal(0, 0.5)
        z = np.array([np.sqrt(pos ** 2 + alt ** 2) + rng.normal(0, 5.0)])
        ref.predict()
        ours.predict()
        ref.update(z.reshape(1, 1), radar_jac, radar_h)
        ours.update(z, radar_jac, radar_h)
        close(ours.x, ref.x, "x", k)
        close(ours.P, ref.P, "P", k)
        close(ours.y, ref.y, "y", k)
        close(ours.S, ref.S, "S", k)


def ct_f(x, dt):
    px, py, v, th, w = x
    return np.array([px + dt * v * np.cos(th), py + dt * v * np.sin(th), v, th + dt * w, w])


def ct_f_vec(xs, dt):
    px, py, v, th, w = xs.T
    return np.stack([px + dt * v * np.cos(th), py + dt * v * np.sin(th), v, th + dt * w, w], axis=1)


def rb_h(x):
    return np.array([np.hypot(x[0], x[1]), np.arctan2(x[1], x[0])])


def rb_h_vec(xs):
    return np.stack([np.hypot(xs[:, 0], xs[:, 1]), np.arctan2(xs[:, 1], xs[:, 0])], axis=1)


@pytest.mark.parametrize("vectorized", [False, True])
def test_ukf_ct_steps_and_rts(vectorized):
    rng = default_rng(14)
    dt, n = 0.5, 5
    pts = MerweScaledSigmaPoints(n, alpha=0.3, beta=2.0, kappa=3.0 - n)
    ref = UnscentedKalmanFilter(dim_x=n, dim_z=2, dt=dt, fx=ct_f, hx=rb_h, points=pts)
    if vectorized:
        ours = bt.UnscentedKalmanFilter(n, 2, dt, rb_h_vec, ct_f_vec, points=pts, vectorized=True)
    else:
        ours = bt.UnscentedKalmanFilter(n, 2, dt, rb_h, ct_f, points=pts)
    for f in (ref, ours):
        f.Q = np.diag([0.01, 0.01, 0.05, 0.001, 0.002])
        f.R = np.diag([0.5 ** 2, 0.01 ** 2])
        f.x = np.array([10.0, 5.0, 2.0, 0.3, 0.05])
        f.P = np.diag([1.0, 1.0, 0.5, 0.05, 0.01])
    truth = ref.x.copy()
    xs, ps = [], []
    for k in range(30):
        truth = ct_f(truth, dt) + rng.multivariate_normal(np.zeros(n), ref.Q)
        z = rb_h(truth) + rng.normal(0, [0.5, 0.01])
        if k == 17:
            z = None
        ref.predict()
        ours.predict()
        close(ours.x, ref.x, "prior x", k)
        close(ours.P, ref.P, "prior P", k)
        ref.update(z)
        ours.update(z)
        close(ours.x, ref.x, "x", k)
        close(ours.P, ref.P, "P", k)
        if z is not None:
            close(ours.y, ref.y, "y", k)
            close(ours.S, ref.S, "S", k)
        xs.append(ref.x.copy())
        ps.append(ref.P.copy())
    want_x, want_p, _ = ref.rts_smoother(np.array(xs), np.array(ps))
    got_x, got_p = ours.rts_smoother(np.array(xs), np.array(ps))
    close(got_x, want_x, "smoothed x", "all")
    close(got_p, want_p, "smoothed P", "all")


def pend_f(x, dt):
    return np.array([x[0] + dt * x[1], x[1] - dt * 9.81 * np.sin(x[0])])


def pend_h(x):
    return np.array([np.sin(x[0])])


def test_ukf_pendulum_batch_filter():
    rng = default_rng(15)
    dt = 0.01
    pts = MerweScaledSigmaPoints(2, alpha=1e-2, beta=2.0, kappa=0.0)
    ref = UnscentedKalmanFilter(dim_x=2, dim_z=1, dt=dt, fx=pend_f, hx=pend_h, points=pts)
    ours = bt.UnscentedKalmanFilter(2, 1, dt, pend_h, pend_f, alpha=1e-2, beta=2.0, kappa=0.0)
    for f in (ref, ours):
        f.Q = np.diag([1e-8, 1e-6])
        f.R = np.array([[0.0025]])
        f.x = np.array([0.5, 0.0])
        f.P = np.diag([0.1, 0.1])
    truth = np.array([0.6, 0.0])
    zs = []
    for _ in range(50):
        truth = pend_f(truth, dt)
        zs.append(pend_h(truth) + rng.normal(0, 0.05, 1))
    want_m, want_c = ref.batch_filter(zs)
    got_m, got_c = ours.batch_filter(np.array(zs))
    close(got_m, want_m, "means", "all")
    close(got_c, want_c, "covs", "all")
