"""bayestrack against filterpy on the same loops (issue 29's speed goals).

    python bench.py [--steps N]

KF: 4-state constant velocity, 2 positions measured; filterpy's
predict()/update() loop against bayestrack's batch_filter (no GIL, no Python
per step) and against bayestrack's own predict()/update() loop.
UKF: the 5-state coordinated-turn model of the oracle tests; filterpy's loop
against bayestrack's loop with per-point and vectorised fx/hx.
PF: one bootstrap step of paper 000's scalar model (the hikpf model,
10,000 particles): the built-in Rust model, the same model as a vectorised
Python model in bayestrack's ParticleFilter, and a pure-numpy bootstrap PF
(systematic resampling) written the usual way.
Prints the median of 5 repeats per variant and the speed-ups.
"""

import argparse
import os
import sys
import statistics
import time

import numpy as np

# python/ holds the package sources without the compiled module: import the
# installed wheel, not ./bayestrack
sys.path = [p for p in sys.path if os.path.abspath(p or ".") != os.path.dirname(os.path.abspath(__file__))]
import bayestrack as bt  # noqa: E402

try:
    import filterpy.kalman as fpk
except ImportError:  # pragma: no cover
    fpk = None


def timed(fn, repeats=5, clock=time.perf_counter):
    ts = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        ts.append(clock() - t0)
    return statistics.median(ts)


def setup_kf(kf, dt=0.1):
    kf.F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1.0]])
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    kf.Q = np.eye(4) * 1e-3
    kf.R = np.eye(2) * 0.25
    kf.x = np.zeros((4, 1))
    kf.P = np.eye(4)
    return kf


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


def setup_ukf(u):
    u.Q = np.diag([0.01, 0.01, 0.05, 0.001, 0.002])
    u.R = np.diag([0.5 ** 2, 0.01 ** 2])
    u.x = np.array([10.0, 5.0, 2.0, 0.3, 0.05])
    u.P = np.diag([1.0, 1.0, 0.5, 0.05, 0.01])
    return u


# ------------------------------------------------------------------ PF

SIN_FREQ, SIGMA = 0.04, 1e-5


def hikpf_sample(p, k, rng):
    t = k + 1
    return (1.0 + np.sin(SIN_FREQ * np.pi * t) + 0.5 * p
            + rng.gamma(3.0, 0.5, size=p.shape))


def hikpf_ll(p, z, k):
    x = p[:, 0]
    h = 0.2 * x * x if k + 1 <= 30 else 0.5 * x - 2.0
    e = z - h
    return -0.5 * e * e / SIGMA - 0.5 * np.log(SIGMA)


def numpy_pf(n, zs, seed=0):
    """A pure-numpy bootstrap PF on the same model (systematic resampling)."""
    rng = np.random.default_rng(seed)
    x = np.ones((n, 1))
    for k, z in enumerate(zs, start=1):
        x = hikpf_sample(x, k, rng)
        lw = hikpf_ll(x, z, k)
        w = np.exp(lw - lw.max())
        w /= w.sum()
        _ = w @ x
        u = (rng.random() + np.arange(n)) / n
        idx = np.minimum(np.searchsorted(np.cumsum(w), u), n - 1)
        x = x[idx]
    return x


def hikpf_measurements(steps, seed=1):
    rng = np.random.default_rng(seed)
    x, zs = 1.0, []
    for k in range(1, steps + 1):
        x = hikpf_sample(np.array([[x]]), k, rng)[0, 0]
        t = k + 1
        h = 0.2 * x * x if t <= 30 else 0.5 * x - 2.0
        zs.append(h + np.sqrt(SIGMA) * rng.normal())
    return zs


def pf_rows(n_particles=10_000, steps=59):
    zs = hikpf_measurements(steps)

    def run(pf):
        for z in zs:
            pf.step(z)

    # CPU time of this process (all threads): on a loaded machine wall time
    # mostly measures the other processes; the comparison is single-threaded
    cpu = time.process_time
    t_rust = timed(lambda: run(bt.ParticleFilter.hikpf(n_particles, seed=1, threads=1)), clock=cpu)
    t_rust_mt = timed(lambda: run(bt.ParticleFilter.hikpf(n_particles, seed=1)))
    t_py = timed(lambda: run(bt.ParticleFilter(n_particles, 1, hikpf_sample, hikpf_ll,
                                               particles=np.ones((n_particles, 1)), seed=1)),
                 clock=cpu)
    t_np = timed(lambda: numpy_pf(n_particles, zs), clock=cpu)
    rows = [
        (f"PF step, built-in Rust model, 1 thread, CPU ({n_particles} particles)", t_rust),
        (f"PF step, built-in Rust model, all threads, wall ({n_particles})", t_rust_mt),
        (f"PF step, vectorised Python model, CPU ({n_particles})", t_py),
        (f"PF step, pure-numpy bootstrap PF, CPU ({n_particles})", t_np),
    ]
    return rows, steps, t_rust, t_py, t_np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--only-pf", action="store_true", help="run the PF rows alone")
    args = ap.parse_args()
    n = args.steps
    pf, pf_steps, t_rust, t_py, t_np = pf_rows()
    if args.only_pf:
        print(f"{'variant':58s} {'total ms':>9s} {'us/step':>9s}")
        for name, t in pf:
            print(f"{name:58s} {t * 1e3:9.2f} {t / pf_steps * 1e6:9.2f}")
        print(f"\nPF Python model vs built-in Rust model (CPU, 1 thread): {t_py / t_rust:.2f}x (goal within 2x)")
        print(f"PF Python model vs pure numpy: {t_np / t_py:.2f}x faster")
        return
    rng = np.random.default_rng(0)
    zs = np.cumsum(rng.normal(size=(n, 2)), axis=0)
    rows = []

    def loop(kf):
        for z in zs:
            kf.predict()
            kf.update(z)

    t_bt_batch = timed(lambda: setup_kf(bt.KalmanFilter(4, 2)).batch_filter(zs))
    t_bt_loop = timed(lambda: loop(setup_kf(bt.KalmanFilter(4, 2))))
    rows.append(("KF batch_filter (bayestrack)", t_bt_batch))
    rows.append(("KF predict/update loop (bayestrack)", t_bt_loop))
    if fpk:
        t_fp = timed(lambda: loop(setup_kf(fpk.KalmanFilter(4, 2))))
        rows.append(("KF predict/update loop (filterpy)", t_fp))

    pts = (0.3, 2.0, -2.0)
    uzs = [rb_h(np.array([10.0 + 0.5 * k, 5.0, 2.0, 0.3, 0.05])) for k in range(n // 4)]

    def uloop(u):
        for z in uzs:
            u.predict()
            u.update(z)

    mk = lambda h, f, v: setup_ukf(  # noqa: E731
        bt.UnscentedKalmanFilter(5, 2, 0.5, h, f, alpha=pts[0], beta=pts[1], kappa=pts[2], vectorized=v))
    t_ukf = timed(lambda: uloop(mk(rb_h, ct_f, False)))
    t_ukf_v = timed(lambda: uloop(mk(rb_h_vec, ct_f_vec, True)))
    rows.append((f"UKF loop, per-point fx/hx (bayestrack, {len(uzs)} steps)", t_ukf))
    rows.append((f"UKF loop, vectorised fx/hx (bayestrack, {len(uzs)} steps)", t_ukf_v))
    if fpk:
        sp = fpk.MerweScaledSigmaPoints(5, *pts)
        t_ukf_fp = timed(lambda: uloop(setup_ukf(fpk.UnscentedKalmanFilter(5, 2, 0.5, rb_h, ct_f, sp))))
        rows.append((f"UKF loop (filterpy, {len(uzs)} steps)", t_ukf_fp))

    rows += pf
    print(f"{'variant':58s} {'total ms':>9s} {'us/step':>9s}")
    for name, t in rows:
        steps = len(uzs) if "UKF" in name else pf_steps if "PF" in name else n
        print(f"{name:58s} {t * 1e3:9.2f} {t / steps * 1e6:9.2f}")
    print(f"\nPF Python model vs built-in Rust model (CPU, 1 thread): {t_py / t_rust:.2f}x (goal within 2x)")
    print(f"PF Python model vs pure numpy: {t_np / t_py:.2f}x faster")
    if fpk:
        print(f"\nKF batch_filter vs filterpy loop: {t_fp / t_bt_batch:.1f}x (goal 20x)")
        print(f"KF loop vs filterpy loop: {t_fp / t_bt_loop:.1f}x")
        print(f"UKF vectorised vs filterpy: {t_ukf_fp / t_ukf_v:.1f}x (goal 10x)")
        print(f"UKF per-point vs filterpy: {t_ukf_fp / t_ukf:.1f}x")


if __name__ == "__main__":
    main()
