#!/usr/bin/env python3
"""Generate oracle test vectors with filterpy for bayestrack-kalman.

Run from the repository root:

    pip install filterpy numpy scipy
    python3 tools/filterpy_vectors.py > tests/data/filterpy_vectors.txt

The output is plain text, one record per line: a keyword followed by numbers
(matrices row-major). `tests/filterpy_oracle.rs` replays every case with our
filters and requires agreement to 1e-9. CI does not need Python: the vectors
are committed.

Cases:
  kf_cv       4-state constant velocity, positions measured, three missing
              measurements, then filterpy.kalman.rts_smoother.
  kf_control  position/velocity with a known acceleration input (B u).
  ekf_radar   filterpy's radar example: state [x, vx, alt], slant range.
  ukf_ct      coordinated-turn-like model, range/bearing measurement,
              MerweScaledSigmaPoints(alpha=0.3, beta=2, kappa=3-n) (W0 < 0),
              then UnscentedKalmanFilter.rts_smoother.
  ukf_pend    the pendulum of the speed anchor with alpha=1e-2 (W0 = -9999);
              at the anchor's alpha=1e-3 (W0 = -1e6) cancellation leaves two
              correct implementations about 1e-9 apart after 20 steps.
  imm_cv      IMMEstimator over two KalmanFilters (constant velocity, quiet
              and manoeuvring process noise), a target that turns half way;
              replayed by crates/kalman/tests/filterpy_imm.rs.
  ckf_ct      CubatureKalmanFilter on the ukf_ct model (its update reuses the
              predicted cubature points: our Ckf::step).
  srkf_cv     SquareRootKalmanFilter on a constant-velocity model.
"""
import numpy as np
from numpy.random import default_rng
from scipy.stats import multivariate_normal
from filterpy.kalman import (KalmanFilter, ExtendedKalmanFilter,
                             UnscentedKalmanFilter, MerweScaledSigmaPoints,
                             rts_smoother, IMMEstimator, CubatureKalmanFilter,
                             SquareRootKalmanFilter)
from filterpy.common import Q_continuous_white_noise, Q_discrete_white_noise
from scipy.linalg import block_diag

out = []


def emit(key, arr):
    a = np.atleast_1d(np.asarray(arr, dtype=float)).ravel()
    out.append(key + " " + " ".join(repr(float(v)) for v in a))


def emit_update(z, prior_x, prior_P, x, P, y=None, S=None):
    if z is None:
        out.append("z none")
    else:
        emit("z", z)
    emit("prior_x", prior_x)
    emit("prior_P", prior_P)
    emit("post_x", x)
    emit("post_P", P)
    if z is not None:
        emit("y", y)
        emit("S", S)
        emit("loglik", multivariate_normal.logpdf(np.ravel(y), cov=S))


def kf_cv():
    rng = default_rng(11)
    dt = 0.1
    kf = KalmanFilter(dim_x=4, dim_z=2)
    f1 = np.array([[1.0, dt], [0.0, 1.0]])
    kf.F = block_diag(f1, f1)  # state [x, vx, y, vy]
    q1 = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=0.1)
    kf.Q = block_diag(q1, q1)
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    kf.R = np.eye(2) * 0.25
    kf.x = np.array([[0.0], [1.0], [0.0], [0.5]])
    kf.P = np.diag([1.0, 0.5, 1.0, 0.5])
    out.append("case kf_cv")
    emit("F", kf.F); emit("Q", kf.Q); emit("H", kf.H); emit("R", kf.R)
    emit("x0", kf.x); emit("P0", kf.P)
    truth = np.array([0.0, 1.0, 0.0, 0.5])
    xs, ps = [], []
    for k in range(40):
        truth = kf.F @ truth + rng.multivariate_normal(np.zeros(4), kf.Q)
        z = kf.H @ truth + rng.normal(0, 0.5, 2)
        if k in (10, 11, 25):
            z = None
        kf.predict()
        px, pP = kf.x.copy(), kf.P.copy()
        kf.update(None if z is None else z.reshape(2, 1))
        out.append(f"step {k}")
        emit_update(z, px, pP, kf.x, kf.P, kf.y, kf.S)
        xs.append(kf.x.copy()); ps.append(kf.P.copy())
    xs_s, ps_s, _, _ = rts_smoother(np.array(xs), np.array(ps),
                                    [kf.F] * 40, [kf.Q] * 40)
    for k in range(40):
        out.append(f"smoothed {k}")
        emit("x", xs_s[k]); emit("P", ps_s[k])


def kf_control():
    rng = default_rng(12)
    dt = 0.2
    kf = KalmanFilter(dim_x=2, dim_z=1, dim_u=1)
    kf.F = np.array([[1.0, dt], [0.0, 1.0]])
    kf.B = np.array([[0.5 * dt * dt], [dt]])
    kf.Q = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=0.05)
    kf.H = np.array([[1.0, 0.0]])
    kf.R = np.array([[0.5]])
    kf.x = np.array([[0.0], [0.0]])
    kf.P = np.eye(2) * 2.0
    out.append("case kf_control")
    emit("F", kf.F); emit("B", kf.B); emit("Q", kf.Q); emit("H", kf.H); emit("R", kf.R)
    emit("x0", kf.x); emit("P0", kf.P)
    truth = np.zeros(2)
    for k in range(30):
        u = np.sin(0.3 * k)
        truth = kf.F @ truth + kf.B.ravel() * u + rng.multivariate_normal(np.zeros(2), kf.Q)
        z = kf.H @ truth + rng.normal(0, np.sqrt(0.5), 1)
        kf.predict(u=np.array([[u]]))
        px, pP = kf.x.copy(), kf.P.copy()
        kf.update(z.reshape(1, 1))
        out.append(f"step {k}")
        emit("u", [u])
        emit_update(z, px, pP, kf.x, kf.P, kf.y, kf.S)


def radar_h(x):
    return np.array([[np.sqrt(x[0, 0] ** 2 + x[2, 0] ** 2)]])


def radar_jac(x):
    d = np.sqrt(x[0, 0] ** 2 + x[2, 0] ** 2)
    return np.array([[x[0, 0] / d, 0.0, x[2, 0] / d]])


def ekf_radar():
    rng = default_rng(13)
    dt = 0.05
    ekf = ExtendedKalmanFilter(dim_x=3, dim_z=1)
    ekf.F = np.eye(3) + np.array([[0, 1.0, 0], [0, 0, 0], [0, 0, 0]]) * dt
    ekf.Q = block_diag(Q_continuous_white_noise(2, dt, 0.1), [[0.1 * dt]])
    ekf.R = np.array([[25.0]])
    ekf.x = np.array([[-100.0], [100.0], [1000.0]])
    ekf.P = np.diag([50.0, 50.0, 50.0])
    out.append("case ekf_radar")
    emit("F", ekf.F); emit("Q", ekf.Q); emit("R", ekf.R)
    emit("x0", ekf.x); emit("P0", ekf.P)
    pos, vel, alt = 0.0, 100.0, 1000.0
    for k in range(40):
        pos += vel * dt + rng.normal(0, 0.5)
        alt += rng.normal(0, 0.5)
        z = np.array([np.sqrt(pos ** 2 + alt ** 2) + rng.normal(0, 5.0)])
        ekf.predict()
        px, pP = ekf.x.copy(), ekf.P.copy()
        ekf.update(z.reshape(1, 1), radar_jac, radar_h)
        out.append(f"step {k}")
        emit_update(z, px, pP, ekf.x, ekf.P, ekf.y, ekf.S)


def ct_f(x, dt):
    # state [px, py, speed, heading, turn rate]: constant turn rate and velocity
    px, py, v, th, w = x
    return np.array([px + dt * v * np.cos(th), py + dt * v * np.sin(th),
                     v, th + dt * w, w])


def rb_h(x):
    return np.array([np.hypot(x[0], x[1]), np.arctan2(x[1], x[0])])


def ukf_ct():
    rng = default_rng(14)
    dt = 0.5
    n = 5
    pts = MerweScaledSigmaPoints(n, alpha=0.3, beta=2.0, kappa=3.0 - n)
    ukf = UnscentedKalmanFilter(dim_x=n, dim_z=2, dt=dt, fx=ct_f, hx=rb_h, points=pts)
    ukf.Q = np.diag([0.01, 0.01, 0.05, 0.001, 0.002])
    ukf.R = np.diag([0.5 ** 2, 0.01 ** 2])
    ukf.x = np.array([10.0, 5.0, 2.0, 0.3, 0.05])
    ukf.P = np.diag([1.0, 1.0, 0.5, 0.05, 0.01])
    out.append("case ukf_ct")
    emit("ut", [0.3, 2.0, 3.0 - n]); emit("dt", [dt])
    emit("Q", ukf.Q); emit("R", ukf.R); emit("x0", ukf.x); emit("P0", ukf.P)
    truth = ukf.x.copy()
    xs, ps = [], []
    for k in range(30):
        truth = ct_f(truth, dt) + rng.multivariate_normal(np.zeros(n), ukf.Q)
        z = rb_h(truth) + rng.normal(0, [0.5, 0.01])
        if k == 17:
            z = None
        ukf.predict()
        px, pP = ukf.x.copy(), ukf.P.copy()
        ukf.update(z)
        out.append(f"step {k}")
        emit_update(z, px, pP, ukf.x, ukf.P, ukf.y, ukf.S)
        xs.append(ukf.x.copy()); ps.append(ukf.P.copy())
    xs_s, ps_s, _ = ukf.rts_smoother(np.array(xs), np.array(ps))
    for k in range(30):
        out.append(f"smoothed {k}")
        emit("x", xs_s[k]); emit("P", ps_s[k])


def pend_f(x, dt):
    return np.array([x[0] + dt * x[1], x[1] - dt * 9.81 * np.sin(x[0])])


def pend_h(x):
    return np.array([np.sin(x[0])])


def ukf_pend():
    rng = default_rng(15)
    dt = 0.01
    pts = MerweScaledSigmaPoints(2, alpha=1e-2, beta=2.0, kappa=0.0)
    ukf = UnscentedKalmanFilter(dim_x=2, dim_z=1, dt=dt, fx=pend_f, hx=pend_h, points=pts)
    ukf.Q = np.diag([1e-8, 1e-6])
    ukf.R = np.array([[0.0025]])
    ukf.x = np.array([0.5, 0.0])
    ukf.P = np.diag([0.1, 0.1])
    out.append("case ukf_pend")
    emit("ut", [1e-2, 2.0, 0.0]); emit("dt", [dt])
    emit("Q", ukf.Q); emit("R", ukf.R); emit("x0", ukf.x); emit("P0", ukf.P)
    truth = np.array([0.6, 0.0])
    for k in range(50):
        truth = pend_f(truth, dt)
        z = pend_h(truth) + rng.normal(0, 0.05, 1)
        ukf.predict()
        px, pP = ukf.x.copy(), ukf.P.copy()
        ukf.update(z)
        out.append(f"step {k}")
        emit_update(z, px, pP, ukf.x, ukf.P, ukf.y, ukf.S)


def cv_matrices(dt, var):
    f1 = np.array([[1.0, dt], [0.0, 1.0]])
    q1 = Q_discrete_white_noise(dim=2, dt=dt, var=var)
    return block_diag(f1, f1), block_diag(q1, q1)


def imm_cv():
    rng = default_rng(16)
    dt = 1.0
    h = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    r = np.eye(2) * 1.0
    filters = []
    qs = []
    for var in (0.01, 2.0):
        kf = KalmanFilter(dim_x=4, dim_z=2)
        kf.F, kf.Q = cv_matrices(dt, var)
        kf.H, kf.R = h, r
        kf.x = np.array([[0.0], [1.0], [0.0], [0.0]])
        kf.P = np.diag([4.0, 1.0, 4.0, 1.0])
        filters.append(kf)
        qs.append(kf.Q)
    mu = np.array([0.7, 0.3])
    trans = np.array([[0.95, 0.05], [0.10, 0.90]])
    imm = IMMEstimator(filters, mu, trans)
    out.append("case imm_cv")
    emit("F", filters[0].F); emit("Q0", qs[0]); emit("Q1", qs[1])
    emit("H", h); emit("R", r); emit("x0", filters[0].x); emit("P0", filters[0].P)
    emit("mu0", mu); emit("M", trans)
    truth = np.array([0.0, 1.0, 0.0, 0.0])
    for k in range(40):
        if 15 <= k < 22:
            truth[3] += 0.6  # a turn: y velocity builds up
            truth[1] -= 0.1
        truth[0] += dt * truth[1]
        truth[2] += dt * truth[3]
        z = h @ truth + rng.normal(0, 1.0, 2)
        imm.predict()
        imm.update(z.reshape(2, 1))
        out.append(f"step {k}")
        emit("z", z); emit("mu", imm.mu); emit("x", imm.x); emit("P", imm.P)
        for i, f in enumerate(imm.filters):
            emit(f"x{i}", f.x); emit(f"P{i}", f.P)


def ckf_ct():
    rng = default_rng(17)
    dt = 0.5
    n = 5
    ckf = CubatureKalmanFilter(dim_x=n, dim_z=2, dt=dt, hx=rb_h, fx=ct_f)
    ckf.Q = np.diag([0.01, 0.01, 0.05, 0.001, 0.002])
    ckf.R = np.diag([0.5 ** 2, 0.01 ** 2])
    ckf.x = np.array([10.0, 5.0, 2.0, 0.3, 0.05])
    ckf.P = np.diag([1.0, 1.0, 0.5, 0.05, 0.01])
    out.append("case ckf_ct")
    emit("dt", [dt]); emit("Q", ckf.Q); emit("R", ckf.R)
    emit("x0", ckf.x); emit("P0", ckf.P)
    truth = ckf.x.copy()
    for k in range(30):
        truth = ct_f(truth, dt) + rng.multivariate_normal(np.zeros(n), ckf.Q)
        z = rb_h(truth) + rng.normal(0, [0.5, 0.01])
        ckf.predict()
        px, pP = ckf.x.copy(), ckf.P.copy()
        ckf.update(z.reshape(2, 1))  # a 1-d z broadcasts against the (2, 1) prediction in filterpy 2.0.0
        out.append(f"step {k}")
        emit_update(z, px, pP, ckf.x, ckf.P, ckf.y, ckf.S)


def srkf_cv():
    rng = default_rng(18)
    dt = 0.1
    f, q = cv_matrices(dt, 0.5)
    h = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    r = np.array([[0.25, 0.05], [0.05, 0.5]])
    kf = SquareRootKalmanFilter(dim_x=4, dim_z=2)
    kf.F, kf.H = f, h
    kf.Q, kf.R = q, r
    kf.x = np.array([[0.0], [1.0], [0.0], [0.5]])
    kf.P = np.diag([1.0, 0.5, 1.0, 0.5])
    out.append("case srkf_cv")
    emit("F", f); emit("Q", q); emit("H", h); emit("R", r)
    emit("x0", kf.x); emit("P0", kf.P)
    truth = np.array([0.0, 1.0, 0.0, 0.5])
    for k in range(30):
        truth = f @ truth + rng.multivariate_normal(np.zeros(4), q)
        z = h @ truth + rng.multivariate_normal(np.zeros(2), r)
        kf.predict()
        px, pP = kf.x.copy(), kf.P.copy()
        kf.update(z.reshape(2, 1))
        out.append(f"step {k}")
        emit_update(z, px, pP, kf.x, kf.P, kf.y, kf.S)


if __name__ == "__main__":
    import filterpy
    out.append(f"# generated by tools/filterpy_vectors.py with filterpy {filterpy.__version__}, numpy {np.__version__}")
    kf_cv()
    kf_control()
    ekf_radar()
    ukf_ct()
    ukf_pend()
    imm_cv()
    ckf_ct()
    srkf_cv()
    print("\n".join(out))
