"""Type stubs of the compiled module ``bayestrack._bayestrack``."""

from typing import Any, Callable, Optional, Sequence, Tuple, Union
from typing import Dict, Iterator, List  # --- trackers (pytrack) ---
import os  # --- trackers (pytrack) ---

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Array = npt.NDArray[np.float64]

MAX_DIM_X: int
MAX_DIM_Z: int

class KalmanFilter:
    """Linear Kalman filter with filterpy's attributes and methods."""

    dim_x: int
    dim_z: int
    dim_u: int
    x: Array
    P: Array
    Q: Array
    R: Array
    F: Array
    H: Array
    B: Optional[Array]
    y: Array
    S: Array
    log_likelihood: float
    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0, joseph: bool = True) -> None: ...
    def predict(self, u: Optional[ArrayLike] = None) -> None: ...
    def update(
        self, z: Optional[ArrayLike], R: Optional[ArrayLike] = None, H: Optional[ArrayLike] = None
    ) -> None: ...
    def batch_filter(
        self, zs: Union[ArrayLike, Sequence[Optional[ArrayLike]]], us: Optional[ArrayLike] = None
    ) -> Tuple[Array, Array, Array, Array]: ...
    def rts_smoother(
        self,
        Xs: ArrayLike,
        Ps: ArrayLike,
        Fs: Optional[Sequence[ArrayLike]] = None,
        Qs: Optional[Sequence[ArrayLike]] = None,
    ) -> Tuple[Array, Array]: ...

class ExtendedKalmanFilter:
    """Extended Kalman filter with filterpy's interface."""

    dim_x: int
    dim_z: int
    dim_u: int
    x: Array
    P: Array
    Q: Array
    R: Array
    F: Array
    B: Optional[Array]
    y: Array
    S: Array
    log_likelihood: float
    iterations: int
    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0, joseph: bool = True) -> None: ...
    def predict(
        self,
        u: Optional[ArrayLike] = None,
        fx: Optional[Callable[[Array], ArrayLike]] = None,
        FJacobian: Optional[Callable[[Array], ArrayLike]] = None,
    ) -> None: ...
    def update(
        self,
        z: Optional[ArrayLike],
        HJacobian: Callable[..., ArrayLike],
        Hx: Callable[..., ArrayLike],
        R: Optional[ArrayLike] = None,
        args: Any = (),
        hx_args: Any = (),
    ) -> None: ...

class IteratedExtendedKalmanFilter(ExtendedKalmanFilter):
    """Iterated EKF: the update relinearises ``Hx`` about its iterate."""

    def __init__(
        self,
        dim_x: int,
        dim_z: int,
        max_iterations: int = 5,
        tolerance: float = 1e-12,
        dim_u: int = 0,
        joseph: bool = True,
    ) -> None: ...

class UnscentedKalmanFilter:
    """Unscented Kalman filter with filterpy's interface."""

    dim_x: int
    dim_z: int
    dt: float
    fx: Callable[..., ArrayLike]
    hx: Callable[..., ArrayLike]
    vectorized: bool
    sigma_parameters: Tuple[float, float, float]
    x: Array
    P: Array
    Q: Array
    R: Array
    y: Array
    S: Array
    log_likelihood: float
    def __init__(
        self,
        dim_x: int,
        dim_z: int,
        dt: float,
        hx: Callable[..., ArrayLike],
        fx: Callable[..., ArrayLike],
        points: Any = None,
        *,
        alpha: Optional[float] = None,
        beta: Optional[float] = None,
        kappa: Optional[float] = None,
        vectorized: bool = False,
    ) -> None: ...
    def predict(
        self, dt: Optional[float] = None, fx: Optional[Callable[..., ArrayLike]] = None, **fx_args: Any
    ) -> None: ...
    def update(
        self,
        z: Optional[ArrayLike],
        R: Optional[ArrayLike] = None,
        hx: Optional[Callable[..., ArrayLike]] = None,
        **hx_args: Any,
    ) -> None: ...
    def batch_filter(
        self, zs: Union[ArrayLike, Sequence[Optional[ArrayLike]]]
    ) -> Tuple[Array, Array]: ...
    def rts_smoother(self, Xs: ArrayLike, Ps: ArrayLike) -> Tuple[Array, Array]: ...

# --- filters (pypf) ---

def stream_seed(key: Sequence[int]) -> int:
    """The seed the filters mix from a key of integers (``[seed, k]``)."""
    ...

class ParticleFilter:
    """Bootstrap particle filter: a vectorised Python model or a built-in Rust one."""

    n: int
    dim: int
    seed: int
    k: int
    particles: Array
    weights: Array
    mean: Array
    covariance: Array
    ess: float
    log_evidence: float
    estimate: Optional[Array]
    def __init__(
        self,
        n: int,
        dim: int,
        sample: Callable[[Array, int, np.random.Generator], ArrayLike],
        log_likelihood: Callable[[Array, Any, int], ArrayLike],
        particles: Optional[ArrayLike] = None,
        *,
        resampling: str = "systematic",
        ess_threshold: Optional[float] = None,
        seed: int = 0,
        threads: Optional[int] = None,
    ) -> None: ...
    @staticmethod
    def hikpf(
        n: int,
        x0: float = 1.0,
        sin_freq: float = 0.04,
        *,
        resampling: str = "systematic",
        ess_threshold: Optional[float] = None,
        seed: int = 0,
        threads: Optional[int] = None,
    ) -> "ParticleFilter": ...
    @staticmethod
    def constant_velocity(
        n: int,
        axes: int = 2,
        dt: float = 1.0,
        q: float = 1.0,
        r: float = 1.0,
        particles: Optional[ArrayLike] = None,
        *,
        resampling: str = "systematic",
        ess_threshold: Optional[float] = None,
        seed: int = 0,
        threads: Optional[int] = None,
    ) -> "ParticleFilter": ...
    def predict(self) -> None: ...
    def update(self, z: Any) -> Array: ...
    def step(self, z: Any) -> Array: ...

class HybridUkfIekf:
    """Hybrid UKF -> IEKF step of paper 000 (sec. 3.3)."""

    dim_x: int
    dim_z: int
    dt: float
    x: Array
    P: Array
    Q: Array
    R: Array
    y: Array
    S: Array
    log_likelihood: float
    iterations: int
    x_ukf: Optional[Array]
    P_ukf: Optional[Array]
    fx: Callable[..., ArrayLike]
    hx: Callable[..., ArrayLike]
    HJacobian: Callable[..., ArrayLike]
    def __init__(
        self,
        dim_x: int,
        dim_z: int,
        dt: float,
        hx: Callable[..., ArrayLike],
        fx: Callable[..., ArrayLike],
        HJacobian: Callable[..., ArrayLike],
        *,
        alpha: float = 1e-3,
        beta: float = 2.0,
        kappa: float = 0.0,
        max_iterations: int = 5,
        tolerance: float = 1e-12,
        prior: str = "ukf_predicted",
    ) -> None: ...
    def step(self, z: Optional[ArrayLike], R: Optional[ArrayLike] = None) -> None: ...
    def batch_filter(
        self, zs: Union[ArrayLike, Sequence[Optional[ArrayLike]]]
    ) -> Tuple[Array, Array]: ...
# --- trackers (pytrack) ---

Box = Tuple[float, float, float, float]
Frame = npt.NDArray[np.uint8]

class Tracker:
    """A registered tracker with OpenCV's interface: ``init(frame, box)``,
    then ``ok, box = update(frame)`` per frame. Frames are uint8 ``(H, W, 3)``
    BGR (``bgr=False``: RGB) or ``(H, W)`` gray; boxes ``(x, y, w, h)`` with
    a 0-based corner (``one_based=True``: OTB's 1-based)."""

    name: str
    options: List[str]
    init_box: Optional[Box]
    copied: bool
    particles: int
    def __init__(
        self,
        name: str,
        *,
        seed: int = 0,
        bgr: bool = True,
        one_based: bool = False,
        **options: Union[bool, int, float, str],
    ) -> None: ...
    def init(self, frame: Frame, box: ArrayLike) -> None: ...
    def update(self, frame: Frame) -> Tuple[bool, Box]: ...

def tracker_names() -> List[str]: ...
def tracker_options(name: str) -> List[Dict[str, str]]: ...

class TrackingSequence:
    """A tracking sequence on disk; frames decoded one at a time."""

    name: str
    path: str
    files: List[str]
    groundtruth: Array
    labelled: npt.NDArray[np.bool_]
    init_box: Optional[Box]
    notes: List[str]
    def __len__(self) -> int: ...
    def __getitem__(self, index: int) -> Frame: ...
    def __iter__(self) -> Iterator[Frame]: ...

class FrameIter:
    def __iter__(self) -> FrameIter: ...
    def __next__(self) -> Frame: ...

def load_sequence(
    path: Union[str, "os.PathLike[str]"],
    *,
    bgr: bool = True,
    one_based: bool = False,
    require_groundtruth: bool = True,
) -> TrackingSequence: ...
def score(gt: Any, boxes: ArrayLike) -> Dict[str, Any]: ...
def format_box(box: ArrayLike) -> str: ...
def reproduce_rows(
    name: str, full: bool = False, *, out: Optional[str] = None, **options: Union[bool, int, float, str]
) -> List[Dict[str, Any]]: ...
def experiment_names() -> List[str]: ...
