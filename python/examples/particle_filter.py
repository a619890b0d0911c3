"""A bootstrap particle filter with a model written in numpy, and the same
model built into the wheel.

    python examples/particle_filter.py

The model is paper 000's scalar benchmark (the hikpf experiment):
x_t = 1 + sin(0.04 pi t) + 0.5 x_{t-1} + Gamma(3, rate 2),
z_t = x_t^2 / 5 (t <= 30) or x_t / 2 - 2 (after) plus N(0, 1e-5).
`sample` and `log_likelihood` are called once per step on the whole
(n, 1) particle array; `rng` is a numpy Generator seeded from the filter's
seed and the step, so a run is reproducible.
"""

import numpy as np

import bayestrack as bt

SIGMA = 1e-5


def sample(particles, k, rng):
    t = k + 1  # step k is time t = k + 1; the particles start at x_1
    return (1.0 + np.sin(0.04 * np.pi * t) + 0.5 * particles
            + rng.gamma(3.0, 0.5, size=particles.shape))


def log_likelihood(particles, z, k):
    x = particles[:, 0]
    h = 0.2 * x * x if k + 1 <= 30 else 0.5 * x - 2.0
    return -0.5 * (z - h) ** 2 / SIGMA - 0.5 * np.log(SIGMA)


def main():
    rng = np.random.default_rng(0)
    x, xs, zs = 1.0, [], []
    for k in range(1, 60):
        x = sample(np.array([[x]]), k, rng)[0, 0]
        h = 0.2 * x * x if k + 1 <= 30 else 0.5 * x - 2.0
        xs.append(x)
        zs.append(h + np.sqrt(SIGMA) * rng.normal())

    n = 2000
    python_model = bt.ParticleFilter(n, 1, sample, log_likelihood,
                                     particles=np.ones((n, 1)), seed=7)
    rust_model = bt.ParticleFilter.hikpf(n, seed=7)
    err_py, err_rust = [], []
    for x, z in zip(xs, zs):
        err_py.append(python_model.step(z)[0] - x)
        err_rust.append(rust_model.step(z)[0] - x)
    rmse = lambda e: float(np.sqrt(np.mean(np.square(e))))  # noqa: E731
    print(f"RMSE, numpy model:    {rmse(err_py):.4f}  log evidence {python_model.log_evidence:.1f}")
    print(f"RMSE, built-in model: {rmse(err_rust):.4f}  log evidence {rust_model.log_evidence:.1f}")
    print(f"last ESS {python_model.ess:.0f} of {n}; covariance {python_model.covariance[0, 0]:.3g}")


if __name__ == "__main__":
    main()
