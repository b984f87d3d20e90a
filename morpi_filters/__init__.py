"""morpi_filters: error models for mobile-robot pure inertial navigation.

The package compares four views of the same drift, on the same axes: a symbolic
closed form of the 15-state INS error model, the covariance of an error-state
Kalman filter, Monte Carlo simulation through a nonlinear strapdown, and the
MoRPI field recordings (Etzion and Klein, "MoRPI: Mobile Robot Pure Inertial
Navigation", IEEE J-ISPIN, 2023).

Conventions (stated once, used everywhere)
------------------------------------------
Names
    Every module, the ``morpi`` command and the JSON files use the same
    names, as strings:

    * methods: ``"INS-3D"`` and ``"INS-2D"`` (3D and yaw-only strapdown),
      ``"MoRPI-A"`` (Weinberg steps on the y specific force) and ``"MoRPI-G"``
      (on the z angular rate), ``"MoRPI-aided INS"`` (the error-state filter
      with MoRPI step updates);
    * calibrations: ``"RD"`` (raw data), ``"GC"`` (gyro bias from the initial
      rest), ``"GAC"`` (gyro and accelerometer biases from the rest);
    * splits and routes: the dataset's folder names (``"train"``, ``"test"``;
      ``"short_distance"``, ``"L_shape"``, ... in ``data/routes.json``).

    Monte Carlo columns add the gain scenario: ``"MoRPI-A[dG = 5 %]"``.
    A quantity has one name, with its unit where it has one (``_m``, ``_s``,
    ``_mps``, ``_mps2``, ``_radps``, ``_hz``; datasheet units as
    :mod:`morpi_filters.units` names them, ``_deg_s``, ``_mg``): ``p2p_m`` the
    peak-to-peak distance of a periodic path, ``speed_mps``, ``dt_s`` a time
    step, ``calibration`` the name of a calibration. A renamed parameter,
    field, flag or key keeps its old name for one release
    (:mod:`morpi_filters.deprecation`; ``CHANGELOG.md``).
Frames
    ``b``: body = phone axes. x forward (direction of travel at the start),
    y to the left, z up (out of the screen). A level phone at rest reads
    ``f_z = +g``.
    ``n``: navigation frame, fixed at the start point. x towards the end point,
    y to the left, z up. Gravity is ``g^n = (0, 0, -g)``; the specific force of
    a body at rest is ``f^n = (0, 0, +g)``.
    The paper writes the body z axis down. The symbolic module takes the sign
    convention as a parameter (``"z_up"`` for this package, ``"z_down"`` for
    the paper's reading) so both can be derived and compared.
Units
    SI and radians inside the package: s, m, m/s, m/s^2, rad, rad/s. Datasheet
    units (deg/s, mg, ug/sqrt(Hz), deg/s/sqrt(Hz)) appear only at the edges and
    are converted by :mod:`morpi_filters.units`. White-noise intensities are
    root power spectral densities (e.g. m/s^2/sqrt(Hz)).
Arrays
    Time (or batch) on axis 0. Vectors over time are ``(n, 3)``; stacks of
    matrices are ``(n, k, k)``; Monte Carlo runs add one leading axis,
    ``(runs, n, ...)``.
Error state (15)
    ``[dp(3), dv(3), eps(3), b_a(3), b_g(3)]``: position error and velocity
    error in n, misalignment in n, accelerometer and gyro bias residuals in b.
    Index it through the named slices ``DP, DV, EPS, BA, BG`` of
    :mod:`morpi_filters.error_model`, never with bare numbers.
Matrices
    ``F, G, Q`` (continuous), ``Phi, Qd`` (discrete), ``H, R, P, x, z``
    (filter), as in filterpy and the INS literature.
Randomness
    Every random function takes ``rng`` (a :class:`numpy.random.Generator`),
    or a ``seed`` where a study spawns independent streams from one
    :class:`numpy.random.SeedSequence`; nothing touches NumPy's global random
    state, and a default seed is a named value in the signature.
Errors
    Problems a user can cause (a bad file, a bad parameter) raise a kind of
    :class:`morpi_filters.errors.MorpiError`, one per cause (a bad recording
    ``DataError``, a bad parameter ``ParameterError``), with a message that
    names the file, line or parameter and what was expected.

Dataset schema
--------------
One CSV per recording with the header ``time,f_x,f_y,f_z,g_x,g_y,g_z``:
time in s (strictly increasing, not starting at 0, NOT uniformly sampled),
specific force in m/s^2 and angular rate in rad/s, both in phone axes. The
field recordings are read from a directory given by ``--data`` or the
environment variable ``MORPI_DATA``; they are never part of this package.
"""
from __future__ import annotations

__version__ = "0.1.0"

from .errors import MorpiError

__all__ = ["MorpiError", "__version__"]
