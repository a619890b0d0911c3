"""Constant-velocity tracking with bayestrack.KalmanFilter (filterpy's names):
a whole sequence through batch_filter (no GIL, no Python per step), then the
RTS smoother; prints RMS position errors of the filter and the smoother."""

import numpy as np

from bayestrack import KalmanFilter

dt, steps = 0.1, 500
rng = np.random.default_rng(1)
kf = KalmanFilter(dim_x=4, dim_z=2)  # state [x, vx, y, vy]
kf.F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1.0]])
kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
kf.Q = np.kron(np.eye(2), [[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]) * 0.5
kf.R = np.eye(2) * 0.25
kf.P *= 10.0

truth = np.zeros((steps, 4))
x = np.array([0.0, 1.0, 0.0, 0.5])
for k in range(steps):
    x = kf.F @ x + rng.multivariate_normal(np.zeros(4), kf.Q)
    truth[k] = x
zs = truth[:, [0, 2]] + rng.normal(0, 0.5, (steps, 2))
zs_missing = list(zs)
zs_missing[100:110] = [None] * 10  # a gap: predictions only

means, covs, _, _ = kf.batch_filter(zs_missing)
smoothed, _ = kf.rts_smoother(means, covs)
pos = truth[:, [0, 2]]
rms = lambda est: np.sqrt(np.mean((est[:, [0, 2], 0] - pos) ** 2))  # noqa: E731
print(f"measurement RMS {np.sqrt(np.mean((zs - pos) ** 2)):.3f}")
print(f"filter RMS      {rms(means):.3f}")
print(f"smoother RMS    {rms(smoothed):.3f}")
print(f"last log-likelihood {kf.log_likelihood:.3f}")
