"""bayestrack: Bayesian filters in Rust with filterpy's interface.

Switch from filterpy by changing the import::

    from bayestrack import KalmanFilter, UnscentedKalmanFilter

The filters are compiled for ``1 <= dim_x <= MAX_DIM_X`` (6) and
``1 <= dim_z <= MAX_DIM_Z`` (4). Errors are Python exceptions carrying the
Rust message: ``numpy.linalg.LinAlgError`` for a covariance that is not
positive definite (as filterpy raises), ``ValueError`` for wrong shapes,
NaN or infinite inputs and invalid parameters; an exception raised by a
model callable propagates unchanged.
"""

from ._bayestrack import (
    MAX_DIM_X,
    MAX_DIM_Z,
    ExtendedKalmanFilter,
    IteratedExtendedKalmanFilter,
    KalmanFilter,
    UnscentedKalmanFilter,
)

# --- trackers (pytrack) ---
from ._bayestrack import Tracker, experiment_names, tracker_names, tracker_options
from . import otb
from ._experiments import reproduce_table


class MerweScaledSigmaPoints:
    """Van der Merwe's scaled sigma points, as filterpy names them.

    Only the parameters are used: pass it as ``points=`` to
    :class:`UnscentedKalmanFilter` (filterpy's own object works too).
    """

    def __init__(self, n, alpha, beta, kappa):
        self.n = n
        self.alpha = alpha
        self.beta = beta
        self.kappa = kappa

    def num_sigmas(self):
        """Number of sigma points, ``2 n + 1``."""
        return 2 * self.n + 1

    def __repr__(self):
        return (f"MerweScaledSigmaPoints(n={self.n}, alpha={self.alpha}, "
                f"beta={self.beta}, kappa={self.kappa})")


__all__ = [
    "KalmanFilter",
    "ExtendedKalmanFilter",
    "IteratedExtendedKalmanFilter",
    "UnscentedKalmanFilter",
    "MerweScaledSigmaPoints",
    "MAX_DIM_X",
    "MAX_DIM_Z",
    # --- trackers (pytrack) ---
    "Tracker",
    "tracker_names",
    "tracker_options",
    "otb",
    "reproduce_table",
    "experiment_names",
]

# --- filters (pypf) ---
from ._bayestrack import HybridUkfIekf, ParticleFilter, stream_seed  # noqa: E402

__all__ += ["ParticleFilter", "HybridUkfIekf", "stream_seed"]
