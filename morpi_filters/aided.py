"""MoRPI-aided inertial navigation: one closed-loop error-state filter pass per recording.

The 3D strapdown runs sample by sample on the real, irregular time steps
(attitude by the rotation vector of the trapezoid gyro increment, velocity and
position by the trapezoid rule). An error-state Kalman filter runs beside it
with the states

``[dp, dv, eps, ba, bg]`` (the slices of :mod:`morpi_filters.error_model`),
``dc`` (:data:`CLONE`: the horizontal position error at the last step
boundary), ``k`` (:data:`GAIN`: the relative error of the MoRPI step gain) and
``e`` (:data:`TURN`: the heading error of given step directions, which grows
by a share of every turn they read: :attr:`AidTuning.turn_sigma`).

Conventions (those of :mod:`morpi_filters.error_model`): ``dp = p_hat - p``,
``dv = v_hat - v``, ``C_hat = exp([eps x]) C``, ``ba = b_a - b_a_hat``,
``bg = b_g - b_g_hat``. After every update the estimate is fed back into the
nominal state (position, velocity, attitude, biases, clone) and those error
states return to zero; the gain error and the step directions' heading error stay states. It is either estimated
or only considered (:attr:`AidTuning.gain_estimated`: the estimate is the one
of the filter that takes the trained gain as exact, the covariance carries the
gain's spread).

The covariance is propagated on an epoch grid (every ``dt_s`` seconds of
samples, 0.1 s by default, and every step boundary's own sample) with the
transition ``I + F T + (F T)^2 / 2`` of the interval's mean specific force and
attitude; the nominal state is integrated at every sample. Updates happen at
the epochs:

* the step displacement: the MoRPI step, ``L (cos psi, sin psi)`` (length
  ``L`` from the trained gain; heading ``psi`` of the filter's attitude averaged
  over the step, which turns the measured vector with the filter's heading
  error, or a given step vector) equals ``(1 + k)`` times the displacement
  since the clone;
* zero velocity and zero rate: the still stretches the caller
  names (``AidedInput.rest``), and the zero-velocity update alone where the
  robot stands while its phone may hum with the motors (``AidedInput.standing``);
  while the robot stands, the process noise is the still phone's own
  (``AidTuning.rest_accel_noise``, ``rest_gyro_noise``), not the motion's;
* non-holonomic: the robot's lateral and vertical velocity are zero
  (phone-to-robot tilt from the rest specific force, mounting yaw zero).

The accelerometer bias may step when the robot starts or stops moving
(``AidTuning.accel_jump``): the phone's apparent specific force shifts under way.

Every measurement has its nonlinear model ``h``, Jacobian ``H`` and noise
``R`` (``step_model``, ``zero_velocity_model``, ``zero_rate_model``,
``nhc_model`` of :mod:`morpi_filters._aided_kernel`). One update serves them
all: filterpy's ``KalmanFilter`` equations in Joseph form (``kf_update``,
with the considered gain error: the gain of the filter that takes it as
known), and the smoother is filterpy's Rauch-Tung-Striebel recursion written
for the fed-back filter (``smooth_member``). :func:`run_batch` runs many
recordings (or one recording under many tunings): each member's forward pass
and smoother are loops over its samples and epochs, compiled by numba. The
tests hold every piece to numpy reference forms (``tests/oracles/aided.py``:
``kf_predict``, ``kf_update``, ``rts_smooth`` and the measurement classes
``StepDisplacement``, ``ZeroVelocity``, ``ZeroRate``, ``NonHolonomic``), and
those to filterpy and to finite differences.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from . import _aided_kernel, _jit
from .error_model import BA, BG, DP, DV, EPS, N_STATES
from .deprecation import renamed_keywords
from .errors import ParameterError
from .parallel import available_cores, chunk_ranges, execute

#: Clone of the horizontal position error at the last step boundary.
CLONE = slice(N_STATES, N_STATES + 2)
#: Relative error of the step gain.
GAIN = N_STATES + 2
#: Heading error of given step directions (``step_heading="gyro"``): the turns they read, each off by a
#: share of its angle (:attr:`AidTuning.turn_sigma`).
TURN = N_STATES + 3
#: Dimension of the aided error state.
N_AIDED = N_STATES + 4
#: Sources of the MoRPI step direction (:attr:`AidTuning.step_heading`).
STEP_HEADINGS = ("attitude", "gyro")
#: 95 % point of the chi-square distribution with 2 degrees of freedom (the horizontal ellipse).
CHI2_95_2DOF = 5.991464547107979


# --------------------------------------------------------------------------- inputs and tunables

@dataclass(frozen=True)
class AidTuning:
    """Tunables of the aided filter (1 sigma, SI).

    Attributes
    ----------
    accel_noise, gyro_noise : float
        White-noise densities of the motion [m/s^2/sqrt(Hz)], [rad/s/sqrt(Hz)]
        (while the robot stands: `rest_accel_noise`, `rest_gyro_noise`).
    accel_walk, gyro_walk : float
        Bias random walks [m/s^2/sqrt(s)], [rad/s/sqrt(s)].
    rest_gyro_noise, rest_accel_noise : float
        Gyro and accelerometer white-noise densities while the robot stands
        (``AidedInput.rest`` and ``standing``): the process noise of the
        intervals that end there, and the gyro's for the zero-rate update
        [rad/s/sqrt(Hz)], [m/s^2/sqrt(Hz)] (0: `gyro_noise`, `accel_noise`).
    turn_sigma : float
        Error of a turn that given step directions (``step_heading="gyro"``)
        read, relative to its angle: their heading error (:data:`TURN`)
        gains ``(turn_sigma * turn)^2`` of variance at each step whose
        direction turns from the previous one [-].
    accel_jump : float
        Change of the accelerometer's apparent bias when the robot starts or
        stops moving, 1 sigma per axis [m/s^2] (the phone tilts on its mount
        under way: its specific force shifts by a step, not a walk).
    step_sigma : float
        Step displacement noise per axis [m].
    nhc_sigma : float
        Non-holonomic velocity noise [m/s].
    zupt_sigma : float
        Rest velocity noise [m/s].
    gain_sigma : float
        Prior relative gain error (0: the gain is taken as exact).
    gain_estimated : bool
        Whether the updates estimate the gain error (True) or only consider
        it (False: a considered state; the estimate is that of the
        filter taking the trained gain as exact, its covariance carries the
        gain's uncertainty).
    tilt0, ba0, bg0 : float
        Initial roll/pitch [rad], accelerometer bias [m/s^2] and gyro bias [rad/s] uncertainty.
    steps, nhc, rest : bool
        Which aids run.
    step_heading : str
        Direction of the MoRPI step displacement: ``"attitude"`` (the filter's
        attitude averaged over the step, the paper's heading equation) or
        ``"gyro"`` (MoRPI's own z-gyro heading reading, :attr:`AidedInput.step_vector`).
    """

    accel_noise: float = 1e-2
    gyro_noise: float = 1e-3
    accel_walk: float = 1e-4
    gyro_walk: float = 1e-5
    rest_gyro_noise: float = 0.0
    rest_accel_noise: float = 0.0
    turn_sigma: float = 0.0
    accel_jump: float = 0.0
    step_sigma: float = 0.05
    nhc_sigma: float = 0.05
    zupt_sigma: float = 0.01
    gain_sigma: float = 0.05
    gain_estimated: bool = True
    tilt0: float = 0.02
    ba0: float = 0.2
    bg0: float = 0.05
    steps: bool = True
    nhc: bool = True
    rest: bool = True
    step_heading: str = "attitude"

    def __post_init__(self):
        if self.step_heading not in STEP_HEADINGS:
            raise ParameterError(f"AidTuning.step_heading={self.step_heading!r}: expected one of {STEP_HEADINGS}")
        for k in _TUNING_FIELDS:
            v = getattr(self, k)
            if isinstance(v, (bool, str)):
                continue
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"AidTuning.{k}={v!r}: expected a finite value >= 0")
        for k in ("step_sigma", "nhc_sigma", "zupt_sigma"):
            if getattr(self, k) <= 0:
                raise ParameterError(f"AidTuning.{k}={getattr(self, k)!r}: expected a value > 0")

    def with_(self, **kw) -> "AidTuning":
        """A copy with some fields changed.

        Examples
        --------
        >>> t = AidTuning(step_sigma=0.02).with_(nhc=False)
        >>> t.step_sigma, t.nhc
        (0.02, False)
        """
        from dataclasses import replace

        return replace(self, **kw)


_TUNING_FIELDS = tuple(f.name for f in fields(AidTuning))


@dataclass(frozen=True, eq=False)
class AidedInput:
    """One recording prepared for the aided filter.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s], increasing.
    f, omega : ndarray, shape (n, 3)
        Specific force [m/s^2] and angular rate [rad/s] (calibrated as wished).
    C0 : ndarray, shape (3, 3)
        Initial attitude (roll and pitch from rest, yaw zero: the frame's x
        axis is the initial heading, whose variance the filter starts near
        zero; the non-holonomic constraint takes `C0` as the phone-to-robot
        tilt, so a yaw in it would turn the robot's axes as well).
    g : float
        Gravity magnitude [m/s^2].
    step_start, step_end, step_length : ndarray, shape (k,)
        MoRPI steps: boundaries [s] and lengths [m] (empty: no steps).
    rest : tuple of (float, float)
        Rest windows [s]: zero velocity and zero angular rate.
    standing : tuple of (float, float)
        Stretches where the robot stands but the phone may vibrate (the motors
        running before the motion) [s]: zero velocity only.
    step_vector : ndarray, shape (k, 2), optional
        MoRPI's own step displacements (its heading reading) [m], for
        ``step_heading="gyro"``.
    sample_dt : float, optional
        The sample interval that sets the epoch grid [s] (default: the
        median interval of `time`; :meth:`until` keeps the whole recording's).
    v0 : ndarray, shape (3,)
        Velocity at the first sample, in the navigation frame [m/s] (default
        zero: a recording that starts at rest). The nominal velocity starts
        there, so a recording that starts under way can be followed when its
        initial velocity is known (from an earlier pass, a wheel odometer, a
        commanded speed).
    v0_sigma : float or ndarray, shape (3,)
        Its 1-sigma uncertainty per axis [m/s] (one value for the three, or
        one per axis; default 1 mm/s): the initial velocity covariance is
        ``diag(v0_sigma^2)``. Too small a sigma around a wrong `v0` leaves the
        filter confident of a wrong velocity, which the step lengths correct
        only slowly.
    """

    time: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    C0: np.ndarray
    g: float
    step_start: np.ndarray = field(default_factory=lambda: np.zeros(0))
    step_end: np.ndarray = field(default_factory=lambda: np.zeros(0))
    step_length: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rest: tuple = ()
    standing: tuple = ()
    step_vector: np.ndarray | None = None
    sample_dt: float | None = None
    v0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    v0_sigma: float | np.ndarray = 1e-3

    def __post_init__(self):
        t = np.asarray(self.time, float)
        n = t.shape[0] if t.ndim == 1 else -1
        if n < 2 or np.asarray(self.f).shape != (n, 3) or np.asarray(self.omega).shape != (n, 3):
            raise ParameterError(f"AidedInput: expected time (n,) with n >= 2 and f, omega (n, 3); got "
                                 f"{t.shape}, {np.shape(self.f)}, {np.shape(self.omega)}")
        if not np.all(np.diff(t) > 0):
            raise ParameterError("AidedInput: time must increase strictly")
        k = np.shape(self.step_length)
        if np.shape(self.step_start) != k or np.shape(self.step_end) != k:
            raise ParameterError("AidedInput: step_start, step_end and step_length must have one shape")
        if self.step_vector is not None and np.shape(self.step_vector) != k + (2,):
            raise ParameterError(f"AidedInput: step_vector must have shape {k + (2,)}")
        v0 = np.asarray(self.v0, float)
        if v0.shape != (3,) or not np.all(np.isfinite(v0)):
            raise ParameterError(f"AidedInput.v0={self.v0!r}: expected three finite velocities [m/s]")
        sig = np.asarray(self.v0_sigma, float)
        if sig.shape not in ((), (3,)) or not np.all(np.isfinite(sig) & (sig >= 0)):
            raise ParameterError(f"AidedInput.v0_sigma={self.v0_sigma!r}: expected one or three finite "
                                 f"values >= 0 [m/s]")

    @property
    def nominal_dt(self) -> float:
        """The sample interval that sets the epoch grid [s]."""
        return float(self.sample_dt) if self.sample_dt is not None else float(np.median(np.diff(self.time)))

    def until(self, t: float) -> "AidedInput":
        """The recording up to the sample nearest to `t`, its last (and the steps that end by then).

        The forward filter is causal: its estimate at `t` is the same on this
        shorter input, at a fraction of the cost (the smoother is not).

        Examples
        --------
        >>> t = np.arange(11) * 0.1
        >>> inp = AidedInput(time=t, f=np.zeros((11, 3)), omega=np.zeros((11, 3)), C0=np.eye(3), g=9.8,
        ...                  step_start=np.array([0.0, 0.5]), step_end=np.array([0.5, 0.9]),
        ...                  step_length=np.array([1.0, 1.0]))
        >>> cut = inp.until(0.52)
        >>> cut.time.size, cut.step_end.tolist()
        (6, [0.5])
        """
        from dataclasses import replace

        time = np.asarray(self.time, float)
        j = int(np.clip(np.searchsorted(time, t), 1, time.size - 1))
        last = j if abs(time[j] - t) < abs(time[j - 1] - t) else j - 1
        n = min(time.size, max(last + 1, 2))
        keep = np.asarray(self.step_end, float) <= max(float(t), time[n - 1])
        return replace(self, sample_dt=self.nominal_dt, time=time[:n], f=np.asarray(self.f)[:n], omega=np.asarray(self.omega)[:n],
                       step_start=np.asarray(self.step_start)[keep], step_end=np.asarray(self.step_end)[keep],
                       step_length=np.asarray(self.step_length)[keep],
                       step_vector=None if self.step_vector is None else np.asarray(self.step_vector)[keep])

    def since(self, t: float) -> "AidedInput":
        """The recording from the last sample at or before `t` on, the filter started there.

        The steps that start before that sample are dropped, the rest and
        standing stretches are cut to start there (those that end before are
        dropped); the initial attitude :attr:`C0`, the initial velocity
        :attr:`v0` with its :attr:`v0_sigma` (set them with
        :func:`dataclasses.replace` when the cut starts under way) and the
        epoch grid's sample interval are kept. The filter started on it knows
        nothing of what came before.

        Examples
        --------
        >>> t = np.arange(11) * 0.1
        >>> inp = AidedInput(time=t, f=np.zeros((11, 3)), omega=np.zeros((11, 3)), C0=np.eye(3), g=9.8,
        ...                  step_start=np.array([0.2, 0.5]), step_end=np.array([0.5, 0.9]),
        ...                  step_length=np.array([1.0, 1.0]), rest=((0.0, 0.3), (0.9, 1.0)), standing=((0.3, 0.5),))
        >>> late = inp.since(0.48)
        >>> float(late.time[0].round(12)), late.step_start.tolist(), late.rest, late.standing
        (0.4, [0.5], ((0.9, 1.0),), ((0.4, 0.5),))
        """
        from dataclasses import replace

        time = np.asarray(self.time, float)
        first = int(np.clip(np.searchsorted(time, t, side="right") - 1, 0, time.size - 2))
        t0 = float(time[first])
        keep = np.asarray(self.step_start, float) >= t0

        def cut(spans):
            return tuple((max(float(a), t0), float(b)) for a, b in spans if b >= t0)

        return replace(self, sample_dt=self.nominal_dt, time=time[first:], f=np.asarray(self.f)[first:],
                       omega=np.asarray(self.omega)[first:], step_start=np.asarray(self.step_start)[keep],
                       step_end=np.asarray(self.step_end)[keep], step_length=np.asarray(self.step_length)[keep],
                       step_vector=None if self.step_vector is None else np.asarray(self.step_vector)[keep],
                       rest=cut(self.rest), standing=cut(self.standing))


@dataclass(frozen=True)
class Innovations:
    """The updates of one kind of measurement over one recording, in time order.

    Attributes
    ----------
    time : ndarray, shape (u,)
        Update times (their epochs' samples) [s].
    z : ndarray, shape (u, m)
        The measurements (for the step: the measured displacement [m]).
    y : ndarray, shape (u, m)
        The innovations ``z - h(x)``: measured minus predicted.
    S : ndarray, shape (u, m, m)
        Their covariances ``H P H^T + R`` (the normalized innovation squared
        is ``y^T S^-1 y``).
    """

    time: np.ndarray
    z: np.ndarray
    y: np.ndarray
    S: np.ndarray


def step_innovation_components(inn: Innovations):
    """The step innovations along and across the measured step, and the filter's sigma along it.

    With ``u`` the measured step's direction, the along-track part ``y . u``
    is the measured step length minus the predicted one (``1 + k`` times the
    INS's displacement since the last boundary; positive: the INS fell
    short), the cross-track part
    ``u x y`` (positive: the measured step lies to the left of the INS's),
    and ``sqrt(u^T S u)`` the spread the filter expected along the step.

    Parameters
    ----------
    inn : Innovations
        The ``"step"`` innovations of a result (2-D measurements).

    Returns
    -------
    along, cross, sigma_along : ndarray, shape (u,)
        [m]; zero-length steps give NaN.

    Examples
    --------
    A step of 0.5 m along x that the INS ran 0.2 m too far and 0.1 m to its right:

    >>> inn = Innovations(time=np.array([1.0]), z=np.array([[0.5, 0.0]]), y=np.array([[-0.2, 0.1]]),
    ...                   S=np.array([np.diag([0.09, 0.01])]))
    >>> [v.round(6).tolist() for v in step_innovation_components(inn)]
    [[-0.2], [0.1], [0.3]]
    """
    z, y, S = np.asarray(inn.z, float), np.asarray(inn.y, float), np.asarray(inn.S, float)
    if z.ndim != 2 or z.shape[1] != 2 or y.shape != z.shape or S.shape != z.shape + (2,):
        raise ParameterError(f"step_innovation_components: expected 2-D step innovations; got z {z.shape}, "
                             f"y {y.shape}, S {S.shape}")
    norm = np.linalg.norm(z, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = z / norm[:, None]
    along = np.einsum("bi,bi->b", y, u)
    cross = u[:, 0] * y[:, 1] - u[:, 1] * y[:, 0]
    sigma = np.sqrt(np.einsum("bi,bij,bj->b", u, S, u))
    return along, cross, sigma


@dataclass(frozen=True)
class AidedResult:
    """The aided filter over one recording.

    Attributes
    ----------
    time : ndarray, shape (m,)
        Epoch times [s].
    position : ndarray, shape (m, 3)
        Forward filter position at the epochs [m].
    P_xy : ndarray, shape (m, 2, 2)
        Its horizontal covariance [m^2].
    smoothed : ndarray or None, shape (m, 3)
        Smoothed position at the epochs [m] (when asked).
    P_xy_smoothed : ndarray or None, shape (m, 2, 2)
        Its horizontal covariance [m^2] (when asked, with ``smoothed_covariance``).
    nis : dict
        Measurement name -> (sum of NIS, number of updates, dof).
    gain_error : float
        Estimated relative gain error ``k``.
    gain_sigma : float
    bias_a, bias_g : ndarray, shape (3,)
        Final bias estimates [m/s^2], [rad/s].
    bias_a_sigma, bias_g_sigma : ndarray, shape (3,)
    innovations : dict
        Measurement name -> :class:`Innovations` of every update of that kind
        (when asked: ``run_batch(innovations=True)``; empty without).
    """

    time: np.ndarray
    position: np.ndarray
    P_xy: np.ndarray
    smoothed: np.ndarray | None
    P_xy_smoothed: np.ndarray | None
    nis: dict
    gain_error: float
    gain_sigma: float
    bias_a: np.ndarray
    bias_g: np.ndarray
    bias_a_sigma: np.ndarray
    bias_g_sigma: np.ndarray
    innovations: dict = field(default_factory=dict)

    def index_at(self, t: float) -> int:
        """Index of the epoch nearest to time `t` (a step boundary is an epoch: its own sample)."""
        return int(np.argmin(np.abs(self.time - t)))

    @property
    def end_point(self) -> np.ndarray:
        """Last horizontal position, shape (2,) [m]."""
        return self.position[-1, :2]

    @property
    def end_cov(self) -> np.ndarray:
        """Its covariance, shape (2, 2) [m^2]."""
        return self.P_xy[-1]


# --------------------------------------------------------------------------- the horizontal error ellipse

@dataclass(frozen=True)
class ErrorEllipse:
    """The region ``d^T P^-1 d <= chi2_2(level)`` of a horizontal position covariance ``P``.

    Attributes
    ----------
    semi_major, semi_minor : float
        Semi-axes [m] (``sqrt(chi2 * lambda)`` of the eigenvalues of ``P``).
    orientation : float
        Angle of the major axis from the x axis, counter-clockwise, in ``(-pi/2, pi/2]`` [rad].
    level : float
        Probability inside the ellipse for a Gaussian error of covariance ``P``.
    points : ndarray, shape (k, 2)
        Points on the ellipse around its centre [m], the first repeated last (a closed curve to plot).
    """

    semi_major: float
    semi_minor: float
    orientation: float
    level: float
    points: np.ndarray


def error_ellipse(P_xy, *, level: float = 0.95, center=(0.0, 0.0), n_points: int = 65) -> ErrorEllipse:
    """The horizontal error ellipse of a 2 x 2 position covariance (95 % by default).

    A Gaussian horizontal error ``d`` of covariance ``P`` has ``d^T P^-1 d``
    chi-square distributed with 2 degrees of freedom, so the ellipse
    ``d^T P^-1 d <= q`` with ``q`` that distribution's `level` quantile
    (scipy's ``chi2.ppf``; 5.991 for 95 %) holds it with probability
    `level`. Its semi-axes are ``sqrt(q lambda)`` for the eigenvalues
    ``lambda`` of ``P``, along their eigenvectors.

    Parameters
    ----------
    P_xy : array_like, shape (2, 2)
        Symmetric positive semi-definite covariance [m^2] (e.g. :attr:`AidedResult.end_cov`).
    level : float
        Probability inside, in (0, 1).
    center : array_like, shape (2,)
        Centre of the returned points [m] (e.g. the estimate).
    n_points : int
        Points on the curve (at least 3; the first is repeated last).

    Returns
    -------
    ErrorEllipse
        Semi-axes, orientation and points.

    Raises
    ------
    ParameterError
        A covariance that is not a finite symmetric positive semi-definite
        2 x 2 matrix, a `level` outside (0, 1), fewer than 3 points.

    Examples
    --------
    >>> e = error_ellipse(np.diag([4.0, 1.0]))          # sigma 2 m along x, 1 m along y
    >>> round(e.semi_major, 4), round(e.semi_minor, 4), e.orientation, e.points.shape
    (4.8955, 2.4477, 0.0, (65, 2))
    """
    P = np.asarray(P_xy, float)
    if P.shape != (2, 2) or not np.all(np.isfinite(P)):
        raise ParameterError(f"error_ellipse: P_xy must be a finite 2 x 2 covariance; got shape {P.shape}")
    scale = float(np.abs(P).max())
    if abs(P[0, 1] - P[1, 0]) > 1e-9 * scale:
        raise ParameterError(f"error_ellipse: P_xy must be symmetric; got off-diagonals {P[0, 1]!r}, {P[1, 0]!r}")
    if not (isinstance(level, (float, int)) and 0.0 < level < 1.0):
        raise ParameterError(f"error_ellipse: level={level!r}: expected a probability in (0, 1)")
    if isinstance(n_points, bool) or not (isinstance(n_points, (int, np.integer)) and n_points >= 3):
        raise ParameterError(f"error_ellipse: n_points={n_points!r}: expected a whole number >= 3")
    c = np.asarray(center, float)
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise ParameterError(f"error_ellipse: center={center!r}: expected two finite coordinates [m]")
    from scipy.stats import chi2

    q = float(chi2.ppf(level, 2))
    a, b, d = P[0, 0], 0.5 * (P[0, 1] + P[1, 0]), P[1, 1]
    # eigenvalues of a symmetric 2 x 2 matrix: mean -/+ the radius of its Mohr circle
    mean, radius = 0.5 * (a + d), math.hypot(0.5 * (a - d), b)
    big, small = mean + radius, mean - radius
    if small < -1e-12 * scale or a < 0 or d < 0:
        raise ParameterError(f"error_ellipse: P_xy must be positive semi-definite; its eigenvalues are {big!r}, "
                             f"{small!r}")
    theta = 0.5 * math.atan2(2.0 * b, a - d)          # the major axis (in (-pi/2, pi/2])
    if theta == -0.5 * math.pi:
        theta = 0.5 * math.pi
    major, minor = math.sqrt(q * big), math.sqrt(q * max(small, 0.0))
    s = np.linspace(0.0, 2.0 * math.pi, int(n_points))
    s[-1] = 0.0                                         # the curve closes on its first point exactly
    u, w = major * np.cos(s), minor * np.sin(s)
    ct, st = math.cos(theta), math.sin(theta)
    pts = np.stack([c[0] + ct * u - st * w, c[1] + st * u + ct * w], axis=1)
    return ErrorEllipse(semi_major=major, semi_minor=minor, orientation=theta, level=float(level), points=pts)


# --------------------------------------------------------------------------- the pass over many members

def _step_samples(inp: AidedInput):
    """The steps the filter updates with, in the order it runs them (by end sample, then by step), and the
    samples nearest to every step's start and end (the earlier one on a tie)."""
    t = np.asarray(inp.time, float)
    n = t.size
    k = np.shape(inp.step_length)[0]
    x = np.concatenate([np.asarray(inp.step_start, float), np.asarray(inp.step_end, float)])
    j = np.searchsorted(t, x)
    np.clip(j, 1, n - 1, out=j)
    near = j - (np.abs(t[j - 1] - x) <= np.abs(t[j] - x))
    a, b = near[:k], near[k:]
    end_j = np.flatnonzero((b > a) & np.isfinite(inp.step_length))
    return end_j[np.argsort(b[end_j], kind="stable")], a, b


def applied_steps(inp: AidedInput) -> np.ndarray:
    """Indices of the steps the filter updates with, in the order it runs them.

    A step whose start and end fall on the same sample, or whose length is
    not finite, gives no update.

    Parameters
    ----------
    inp : AidedInput
        The recording and its steps.

    Returns
    -------
    ndarray of int, shape (u,)
        Step indices, by end sample (then by index).

    Examples
    --------
    >>> t = np.arange(11) * 0.1
    >>> inp = AidedInput(time=t, f=np.zeros((11, 3)), omega=np.zeros((11, 3)), C0=np.eye(3), g=9.8,
    ...                  step_start=np.array([0.0, 0.5, 0.51, 0.6]), step_end=np.array([0.5, 0.9, 0.52, 0.8]),
    ...                  step_length=np.array([1.0, 1.0, 0.1, np.nan]))
    >>> applied_steps(inp).tolist()          # the third starts and ends on one sample, the fourth has no length
    [0, 1]
    """
    if not np.shape(inp.step_length)[0]:
        return np.zeros(0, np.int64)
    return _step_samples(inp)[0].astype(np.int64)


def _epochs(inp: AidedInput, tun: AidTuning, epoch_s: float):
    """A member's epoch samples, its step events and rest flags.

    Epochs fall every ``epoch_s`` (in whole samples) and on the sample nearest
    to each step boundary, so a step update compares the MoRPI length with the
    displacement over the same samples.

    Returns
    -------
    (epochs, end_k, end_a, end_j, starts, rest, standing) : the epoch samples (sorted); the step
        updates in the order they run (end sample, start sample, step index: by end sample, then by
        step); the start samples; rest and standing flags per sample
    """
    t = inp.time
    n = t.size
    m = max(1, int(round(epoch_s / inp.nominal_dt)))
    on = np.zeros(n, bool)                  # the epoch samples, as a mask
    on[::m] = True
    on[-1] = True
    none = np.zeros(0, np.int64)
    end_k, end_a, end_j, starts = none, none, none, none
    if tun.steps and inp.step_length.size:
        end_j, a, b = _step_samples(inp)
        end_k, end_a = b[end_j].astype(np.int64), a[end_j].astype(np.int64)
        on[end_a] = True
        on[end_k] = True
        starts = np.unique(end_a)
    rest = np.zeros(n, bool)
    standing = np.zeros(n, bool)
    if tun.rest:
        for t0, t1 in inp.rest:
            rest[np.searchsorted(t, t0, "left"):np.searchsorted(t, t1, "right")] = True
        for t0, t1 in inp.standing:
            standing[np.searchsorted(t, t0, "left"):np.searchsorted(t, t1, "right")] = True
    return np.flatnonzero(on), end_k, end_a, end_j.astype(np.int64), starts, rest, standing & ~rest


@renamed_keywords(epoch_s="dt_s")
def run_batch(inputs, tunings, *, dt_s: float = 0.1, smooth=False, smoothed_covariance: bool = True,
              nis: bool = True, innovations=False, workers: int | None = None):
    """Run the aided filter on many members (one compiled forward pass each, then the smoother where asked).

    The members are independent: with more than one worker, threads run them
    side by side (the compiled loops release the GIL) and the results are the
    same bits as on one thread.

    Parameters
    ----------
    inputs : sequence of AidedInput
    tunings : AidTuning or sequence of AidTuning
        One for all members, or one per member.
    dt_s : float
        Time step of the covariance and update epochs [s] (rounded to whole samples per member).
    smooth : bool or sequence of bool
        Also run the Rauch-Tung-Striebel smoother, for every member or for
        those flagged (keeps the covariance of every epoch: about
        ``8 * 19^2`` bytes per epoch and smoothed member).
    smoothed_covariance : bool
        Also compute the smoothed covariances (``AidedResult.P_xy_smoothed``;
        None without); the smoothed positions do not need them.
    nis : bool
        Also sum the normalized innovations squared (``AidedResult.nis``; empty
        without).
    innovations : bool or sequence of bool
        Also keep every update's measurement, innovation and its covariance,
        for every member or for those flagged (``AidedResult.innovations``;
        empty without).
    workers : int, optional
        Threads that run the members (default: the CPU cores this process may
        use, :func:`morpi_filters.parallel.available_cores`; 1: the calling
        thread only).

    Returns
    -------
    list of AidedResult
        One per input, in order (empty for no input).

    Raises
    ------
    ParameterError
        A tuning count that differs from the inputs', a non-positive `dt_s`
        or `workers`.

    Examples
    --------
    >>> t = np.arange(301) * 0.01                     # three seconds standing still
    >>> still = AidedInput(time=t, f=np.tile([0.0, 0.0, 9.8], (301, 1)), omega=np.zeros((301, 3)), C0=np.eye(3),
    ...                    g=9.8, rest=((0.0, 3.0),))
    >>> (r,) = run_batch([still], AidTuning())
    >>> r.end_point.tolist(), sorted(r.nis)
    ([0.0, 0.0], ['zero rate', 'zero velocity'])
    """
    inputs = list(inputs)
    B = len(inputs)
    if B == 0:
        return []
    tunings = [tunings] * B if isinstance(tunings, AidTuning) else list(tunings)
    if len(tunings) != B:
        raise ParameterError(f"run_batch: {len(tunings)} tunings for {B} inputs")
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ParameterError(f"dt_s={dt_s!r}: expected a positive time step [s]")
    epoch_s = dt_s
    keep_hist = np.asarray(smooth, bool)
    if keep_hist.ndim > 1 or keep_hist.size not in (1, B):
        raise ParameterError(f"run_batch: smooth must be a bool or {B} bools")
    keep_hist = np.broadcast_to(keep_hist.ravel(), (B,)).copy()
    keep_inn = np.asarray(innovations, bool)
    if keep_inn.ndim > 1 or keep_inn.size not in (1, B):
        raise ParameterError(f"run_batch: innovations must be a bool or {B} bools")
    keep_inn = np.broadcast_to(keep_inn.ravel(), (B,)).copy()
    for b, (t, inp) in enumerate(zip(tunings, inputs)):
        if t.step_heading == "gyro" and t.steps and inp.step_vector is None:
            raise ParameterError(f"member {b}: step_heading='gyro' needs AidedInput.step_vector")
    if workers is None:
        workers = available_cores()
    if isinstance(workers, bool) or not (isinstance(workers, (int, np.integer)) and workers >= 1):
        raise ParameterError(f"run_batch: workers={workers!r}: expected a whole number >= 1")
    kern = _aided_kernel.compiled()
    # what depends on a member's input alone, laid out once per input (a tuning search runs each input under
    # many tunings)
    keys = [(id(inp), tun.steps, tun.rest) for inp, tun in zip(inputs, tunings)]
    layouts = {}
    for i, key in enumerate(keys):
        if key not in layouts:
            layouts[key] = _layout(inputs[i], tunings[i], epoch_s)

    def members(_, a, b):
        return [_run_member(kern, inputs[i], tunings[i], epoch_s, bool(keep_hist[i]), smoothed_covariance, nis,
                            bool(keep_inn[i]), layouts[keys[i]]) for i in range(a, b)]

    # ranges of at most 8 members, about 4 or more per thread when the members allow: a thread lays out
    # a member's arguments (Python, under the GIL) while the others run compiled passes
    chunk = max(1, min(8, B // (4 * int(workers))))
    out = []
    execute(members, None, chunk_ranges(B, chunk), workers=int(workers), reduce=out.extend)
    return out


def _run_member(kern, inp: AidedInput, tun: AidTuning, epoch_s, smooth, smoothed_covariance, nis, keep_inn,
                layout=None):
    """One member of :func:`run_batch`: the compiled forward pass, the smoother where asked, the result.

    `kern` holds the compiled functions (:func:`_aided_kernel.compiled`); `layout` is the member's
    :func:`_layout`.
    """
    K = _aided_kernel
    a = _kernel_args(inp, tun, epoch_s, smooth, keep_inn, layout)
    kern["forward_member"](*a.values())
    time, ep_p, x, P, bias, nis_arr = a["t"], a["ep_p"], a["x"], a["P"], a["bias"], a["nis"]
    sm = Psm = None
    if smooth:
        # the smoothed error states (filterpy's recursion) correct the forward positions
        xs, Ps_xy = np.zeros((ep_p.shape[0], N_AIDED)), np.zeros((ep_p.shape[0], 2, 2))
        kern["smooth_member"](a["hist_P"], a["hist_rec"], tun.accel_walk ** 2, tun.gyro_walk ** 2, a["fj"],
                              bool(smoothed_covariance), xs, Ps_xy)
        sm = ep_p - xs[:, DP]
        Psm = Ps_xy if smoothed_covariance else None
    # the kinds in the order of their first update
    kinds = sorted((i for i in range(len(K.KINDS)) if nis_arr[i, 1] > 0), key=lambda i: (nis_arr[i, 2], i))
    nis_of = {K.KINDS[i]: (float(nis_arr[i, 0]), int(nis_arr[i, 1]), K.KIND_DOF[i]) for i in kinds} if nis else {}
    inn_of = {}
    if keep_inn:
        for i in kinds:
            u, dof = a["inn_n"][i], K.KIND_DOF[i]
            inn_of[K.KINDS[i]] = Innovations(time=time[a["inn_k"][i, :u]], z=a["inn_z"][i, :u, :dof].copy(),
                                             y=a["inn_y"][i, :u, :dof].copy(), S=a["inn_S"][i, :u, :dof, :dof].copy())
    return AidedResult(
        time=time[a["ep_k"]], position=ep_p, P_xy=a["ep_P"], smoothed=sm, P_xy_smoothed=Psm, nis=nis_of,
        gain_error=float(x[GAIN]), gain_sigma=float(np.sqrt(max(P[GAIN, GAIN], 0.0))),
        bias_a=bias[:3].copy(), bias_g=bias[3:].copy(),
        bias_a_sigma=np.sqrt(np.maximum(np.diag(P[BA, BA]), 0.0)),
        bias_g_sigma=np.sqrt(np.maximum(np.diag(P[BG, BG]), 0.0)), innovations=inn_of)


def _layout(inp: AidedInput, tun: AidTuning, epoch_s) -> dict:
    """What a member's pass takes from its input alone (and from whether it uses steps and rest): its samples
    and steps read-only, the epochs and step events, the per-sample flags. Members of one batch that share
    an input and those two switches share it."""
    K = _aided_kernel
    ro = _jit.read_only                   # inputs read-only: one compiled pass, frozen inputs or not
    time = ro(inp.time)
    epochs, end_k, end_a, end_j, starts, rest, standing = _epochs(inp, tun, epoch_s)
    flags = np.zeros(time.size, np.int64)
    flags[epochs] |= K.EPOCH
    flags[rest] |= K.REST
    flags[standing] |= K.STAND
    flags[starts] |= K.START
    nk = np.shape(inp.step_length)[0]
    step_vec = np.zeros((nk, 2)) if inp.step_vector is None else np.ascontiguousarray(inp.step_vector, float)
    return dict(t=time, f=ro(inp.f), w=ro(inp.omega), flags=ro(flags, np.int64), end_k=ro(end_k, np.int64),
                end_a=ro(end_a, np.int64), end_j=ro(end_j, np.int64), step_len=ro(inp.step_length),
                epochs=epochs.size, step_vec=ro(step_vec), turn_q={})


def _kernel_args(inp: AidedInput, tun: AidTuning, epoch_s, smooth, keep_inn, layout=None):
    """The arguments of :func:`_aided_kernel.forward_member` for one member, by name and in order: its
    events and tunables, and zeroed outputs sized for it. `layout` is the member's :func:`_layout`, made
    here when not given."""
    K = _aided_kernel
    if layout is None:
        layout = _layout(inp, tun, epoch_s)
    n, end_k, end_j = layout["t"].size, layout["end_k"], layout["end_j"]
    gyro = tun.step_heading == "gyro"
    step_vec = layout["step_vec"]
    turn_q = _NO_TURNS
    if gyro and tun.turn_sigma > 0 and inp.step_vector is not None and end_j.size:
        # the given directions' heading error grows by a share of each turn they take (from the previous
        # step's direction; the first step's from the frame's zero heading), added where the step ends; the
        # layout keeps it per turn sigma (members of a batch share their input's)
        turn_q = layout["turn_q"].get(tun.turn_sigma)
        if turn_q is None:
            psi = np.arctan2(step_vec[:, 1], step_vec[:, 0])
            turn = np.angle(np.exp(1j * np.diff(np.r_[0.0, psi])))
            turn_q = np.zeros(n)
            np.add.at(turn_q, end_k, (tun.turn_sigma * turn[end_j]) ** 2)
            turn_q = layout["turn_q"][tun.turn_sigma] = _jit.read_only(turn_q)
    gyro_rest = tun.rest_gyro_noise or tun.gyro_noise
    named = {"q_a": tun.accel_noise ** 2, "q_a_rest": (tun.rest_accel_noise or tun.accel_noise) ** 2,
             "q_g": tun.gyro_noise ** 2, "q_g_rest": gyro_rest ** 2, "q_ba": tun.accel_walk ** 2,
             "q_bg": tun.gyro_walk ** 2, "jump2": tun.accel_jump ** 2, "step_sigma": tun.step_sigma,
             "nhc_sigma": tun.nhc_sigma, "zupt_sigma": tun.zupt_sigma, "gyro_sigma_rest": gyro_rest,
             "nhc": float(tun.nhc), "g": float(inp.g), "gyro_heading": float(gyro)}
    par = np.array([named[k] for k in K.PAR])
    I3 = np.eye(3)
    P0 = np.zeros((N_AIDED, N_AIDED))
    P0[DV, DV] = np.diag(np.broadcast_to(np.square(np.asarray(inp.v0_sigma, float)), (3,)))
    P0[EPS, EPS] = I3 * tun.tilt0 ** 2
    P0[EPS.stop - 1, EPS.stop - 1] = 1e-10        # the heading is zero by definition of the frame
    P0[BA, BA] = I3 * tun.ba0 ** 2
    P0[BG, BG] = I3 * tun.bg0 ** 2
    P0[GAIN, GAIN] = tun.gain_sigma ** 2 if tun.steps else 0.0
    m, kinds = layout["epochs"], len(K.KINDS)
    cap = (m + end_k.size) if keep_inn else 0
    rows = m if smooth else 0
    ro = _jit.read_only
    return dict(
        t=layout["t"], f=layout["f"], w=layout["w"], flags=layout["flags"], end_k=end_k, end_a=layout["end_a"],
        end_j=end_j, step_len=layout["step_len"], step_vec=step_vec, turn_q=turn_q, par=ro(par),
        C0=ro(inp.C0), v0=ro(inp.v0), P0=ro(P0),
        fj=-1 if tun.gain_estimated else GAIN, keep_inn=bool(keep_inn), keep_hist=bool(smooth),
        ep_k=np.zeros(m, np.int64), ep_p=np.zeros((m, 3)), ep_P=np.zeros((m, 2, 2)), nis=np.zeros((kinds, 3)),
        inn_k=np.zeros((kinds, cap), np.int64), inn_z=np.zeros((kinds, cap, 3)), inn_y=np.zeros((kinds, cap, 3)),
        inn_S=np.zeros((kinds, cap, 3, 3)), inn_n=np.zeros(kinds, np.int64),
        hist_P=np.zeros((rows, N_AIDED, N_AIDED)), hist_rec=np.zeros((rows, _HIST_WIDTH)),
        x=np.zeros(N_AIDED), P=np.zeros((N_AIDED, N_AIDED)), bias=np.zeros(6))


#: The turn variances of a member without given step directions (read-only, shared).
_NO_TURNS = _jit.read_only(np.zeros(0))

#: Columns of the smoother's epoch record besides the covariance: name -> (columns, shape of one row).
_HIST = {"x": (slice(0, N_AIDED), (N_AIDED,)), "fed": (slice(N_AIDED, 2 * N_AIDED), (N_AIDED,)),
         "d": (2 * N_AIDED, ()), "fn": (slice(2 * N_AIDED + 1, 2 * N_AIDED + 4), (3,)),
         "Cm": (slice(2 * N_AIDED + 4, 2 * N_AIDED + 13), (3, 3)), "jq": (2 * N_AIDED + 13, ()),
         "qa": (2 * N_AIDED + 14, ()), "qg": (2 * N_AIDED + 15, ()), "tq": (2 * N_AIDED + 16, ())}
_HIST_WIDTH = 2 * N_AIDED + 17
