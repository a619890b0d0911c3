"""Range-bearing tracking of a turning target with
bayestrack.UnscentedKalmanFilter; fx and hx are vectorised over the sigma
points (one Python call per predict or update). Then the EKF and IEKF on a
radar (slant range) measurement with Jacobian callables."""

import numpy as np

import bayestrack as bt


def fx(xs, dt):  # all sigma points at once: (2n+1, 5)
    px, py, v, th, w = xs.T
    return np.stack([px + dt * v * np.cos(th), py + dt * v * np.sin(th), v, th + dt * w, w], axis=1)


def hx(xs):
    return np.stack([np.hypot(xs[:, 0], xs[:, 1]), np.arctan2(xs[:, 1], xs[:, 0])], axis=1)


rng = np.random.default_rng(2)
ukf = bt.UnscentedKalmanFilter(5, 2, dt=0.5, hx=hx, fx=fx, alpha=0.3, beta=2.0, kappa=-2.0, vectorized=True)
ukf.Q = np.diag([0.01, 0.01, 0.05, 0.001, 0.002])
ukf.R = np.diag([0.5**2, 0.01**2])
ukf.x = np.array([10.0, 5.0, 2.0, 0.3, 0.05])
ukf.P = np.diag([1.0, 1.0, 0.5, 0.05, 0.01])
truth = ukf.x.copy()
errs = []
for k in range(60):
    truth = fx(truth[None], 0.5)[0] + rng.multivariate_normal(np.zeros(5), ukf.Q)
    z = hx(truth[None])[0] + rng.normal(0, [0.5, 0.01])
    ukf.predict()
    ukf.update(z)
    errs.append(np.hypot(*(ukf.x[:2] - truth[:2])))
print(f"UKF position error: mean {np.mean(errs):.3f}, last {errs[-1]:.3f}")


def radar_h(x):  # filterpy's convention: x is a (3, 1) column
    return np.array([[np.hypot(x[0, 0], x[2, 0])]])


def radar_jac(x):
    d = np.hypot(x[0, 0], x[2, 0])
    return np.array([[x[0, 0] / d, 0.0, x[2, 0] / d]])


for cls in (bt.ExtendedKalmanFilter, bt.IteratedExtendedKalmanFilter):
    f = cls(3, 1)
    dt = 0.05
    f.F = np.eye(3) + np.array([[0, 1.0, 0], [0, 0, 0], [0, 0, 0]]) * dt
    f.Q = np.diag([1e-3, 1e-2, 1e-2])
    f.R = np.array([[25.0]])
    f.x = np.array([[-100.0], [100.0], [1000.0]])
    f.P = np.diag([50.0, 50.0, 50.0])
    pos, alt = 0.0, 1000.0
    for k in range(100):
        pos += 100 * dt
        f.predict()
        f.update([np.hypot(pos, alt) + rng.normal(0, 5.0)], radar_jac, radar_h)
    print(f"{cls.__name__}: position {f.x[0, 0]:.1f} (truth {pos:.1f}), iterations {f.iterations}")
