"""Bad input raises a clear Python exception and never crashes the
interpreter; batch_filter releases the GIL."""

import threading
import time

import numpy as np
import pytest

import bayestrack as bt


def cv_filter():
    kf = bt.KalmanFilter(dim_x=4, dim_z=2)
    dt = 0.1
    kf.F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1.0]])
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    kf.Q = np.eye(4) * 1e-3
    kf.R = np.eye(2) * 0.25
    return kf


def test_wrong_shapes_raise_value_error():
    kf = cv_filter()
    with pytest.raises(ValueError, match=r"F must have shape \(4, 4\)"):
        kf.F = np.eye(3)
    with pytest.raises(ValueError, match=r"z must have shape \(2,\)"):
        kf.update([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"x must have shape"):
        kf.x = np.zeros(5)
    with pytest.raises(ValueError, match=r"zs must have shape \(T, 2\)"):
        kf.batch_filter(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="dim_x = 7 is not supported"):
        bt.KalmanFilter(7, 1)
    # a rejected assignment leaves the filter usable
    kf.predict()
    kf.update([0.1, 0.2])


def test_nan_is_refused():
    kf = cv_filter()
    with pytest.raises(ValueError, match="z contains NaN"):
        kf.update([np.nan, 1.0])
    with pytest.raises(ValueError, match="Q contains NaN"):
        kf.Q = np.full((4, 4), np.nan)
    with pytest.raises(ValueError, match=r"zs\[3\] contains NaN"):
        zs = np.zeros((5, 2))
        zs[3, 1] = np.inf
        kf.batch_filter(zs)
    # an in-place NaN written into the stored array is caught at the next step
    kf.P[0, 0] = np.nan
    with pytest.raises(ValueError, match="P contains NaN"):
        kf.predict()


def test_non_positive_definite_is_linalg_error():
    kf = cv_filter()
    kf.P = np.diag([1.0, -1.0, 1.0, 1.0])
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        kf.predict()
    kf = cv_filter()
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        kf.Q = np.diag([1.0, -1.0, 1.0, 1.0])
        kf.predict()
    # a singular S: R = 0 and the measured components known exactly
    kf = cv_filter()
    kf.R = np.zeros((2, 2))
    kf.P = np.diag([0.0, 1.0, 0.0, 1.0])
    with pytest.raises(np.linalg.LinAlgError, match="innovation covariance"):
        kf.update([1.0, 2.0])


def test_callable_that_raises_propagates():
    ekf = bt.ExtendedKalmanFilter(2, 1)

    def hx(x):
        raise KeyError("boom in Hx")

    with pytest.raises(KeyError, match="boom in Hx"):
        ekf.update([1.0], lambda x: np.array([[1.0, 0.0]]), hx)

    ukf = bt.UnscentedKalmanFilter(2, 1, 0.1, lambda x: x[:1], lambda x, dt: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        ukf.predict()
    ukf = bt.UnscentedKalmanFilter(2, 1, 0.1, lambda x: x[:1], lambda x, dt: x[:1])
    with pytest.raises(ValueError, match="fx returned shape"):
        ukf.predict()
    ukf = bt.UnscentedKalmanFilter(2, 1, 0.1, lambda x: x[:1], lambda x, dt: x * np.nan)
    with pytest.raises(ValueError, match="fx returned NaN"):
        ukf.predict()
    # vectorised: a callable that raises, and one that returns the wrong shape
    ukf = bt.UnscentedKalmanFilter(2, 1, 0.1, lambda x: x[:, :1], lambda x, dt: x[:3], vectorized=True)
    with pytest.raises(ValueError, match="fx returned shape"):
        ukf.predict()
    # the filter is still usable afterwards
    ukf.fx = lambda x, dt: x
    ukf.predict()
    ukf.update([0.0])
    assert np.all(np.isfinite(ukf.P))


def test_invalid_parameters():
    with pytest.raises(ValueError, match="alpha"):
        bt.UnscentedKalmanFilter(2, 1, 0.1, lambda x: x[:1], lambda x, dt: x, alpha=0.0)
    with pytest.raises(ValueError, match="max_iterations"):
        bt.IteratedExtendedKalmanFilter(2, 1, max_iterations=0)
    with pytest.raises(TypeError):
        bt.UnscentedKalmanFilter(2, 1, 0.1, "not callable", lambda x, dt: x)


def test_batch_filter_releases_the_gil():
    kf = cv_filter()
    zs = np.random.default_rng(0).normal(size=(400_000, 2))
    ticks = []
    stop = threading.Event()

    def counter():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0)

    t = threading.Thread(target=counter)
    t.start()
    time.sleep(0.05)
    before = len(ticks)
    kf.batch_filter(zs)
    during = len(ticks) - before
    stop.set()
    t.join()
    # with the GIL held the other thread could not run at all during the
    # batch (a few ticks at its edges at most)
    assert during > 100, f"the other thread advanced only {during} times"
