"""SI conversions and the sensor specifications of the MoRPI paper.

Everything inside the package is SI and radians. Datasheet figures enter here,
once, through the constants below (``value * CONSTANT`` gives SI).

The two IMUs are the paper's table "Sensors Errors according to manufacturer":
MPU-6500 (Samsung Galaxy S6) and LSM6DSL (Samsung Galaxy S8).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "G0", "DEG", "DEG_S", "MG", "UG", "UG_SQRT_HZ", "DEG_S_SQRT_HZ",
    "SensorSpec", "MPU6500", "LSM6DSL", "IMUS",
]

#: Standard gravity [m/s^2] (also the magnitude used to convert mg).
G0 = 9.80665
#: One degree in radians.
DEG = math.pi / 180.0
#: One deg/s in rad/s.
DEG_S = DEG
#: One milli-g in m/s^2.
MG = 1e-3 * G0
#: One micro-g in m/s^2.
UG = 1e-6 * G0
#: One ug/sqrt(Hz) in m/s^2/sqrt(Hz) (accelerometer noise density).
UG_SQRT_HZ = UG
#: One deg/s/sqrt(Hz) in rad/s/sqrt(Hz) (gyro noise density).
DEG_S_SQRT_HZ = DEG


def _check_figures(owner: str, figures: dict) -> None:
    """Refuse an error figure that is negative or not finite, or a ``rate_hz`` that is not positive, naming it."""
    from .errors import ParameterError

    for key, v in figures.items():
        try:
            ok = math.isfinite(float(v)) and float(v) >= 0 and (key != "rate_hz" or float(v) > 0)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            what = "a positive rate [Hz]" if key == "rate_hz" else "a finite value >= 0"
            raise ParameterError(f"{owner}: {key}={v!r}, expected {what}")


@dataclass(frozen=True)
class SensorSpec:
    """Error figures of one IMU, in SI.

    Attributes
    ----------
    name : str
        IMU model.
    gyro_bias : float
        Turn-on gyro bias, 1 sigma per axis [rad/s].
    gyro_noise : float
        Gyro white-noise density (angle random walk) [rad/s/sqrt(Hz)].
    accel_bias : float
        Turn-on accelerometer bias, 1 sigma per axis [m/s^2].
    accel_noise : float
        Accelerometer white-noise density [m/s^2/sqrt(Hz)].
    rate_hz : float
        Nominal sampling rate [Hz].

    Raises
    ------
    ParameterError
        A negative or non-finite error figure, or a rate that is not positive, naming the field.
    """

    name: str
    gyro_bias: float
    gyro_noise: float
    accel_bias: float
    accel_noise: float
    rate_hz: float = 100.0

    def __post_init__(self):
        _check_figures(f"SensorSpec {self.name!r}", {k: getattr(self, k) for k in (
            "gyro_bias", "gyro_noise", "accel_bias", "accel_noise", "rate_hz")})

    @classmethod
    def from_datasheet(cls, name: str, *, gyro_bias_deg_s: float, accel_bias_mg: float,
                       accel_noise_ug_sqrt_hz: float, gyro_noise_deg_s_sqrt_hz: float | None = None,
                       gyro_noise_deg_h_sqrt_hz: float | None = None, rate_hz: float = 100.0) -> "SensorSpec":
        """A spec from the units a datasheet prints.

        Parameters
        ----------
        name : str
            IMU model.
        gyro_bias_deg_s : float
            Turn-on gyro bias [deg/s].
        gyro_noise_deg_s_sqrt_hz, gyro_noise_deg_h_sqrt_hz : float
            Gyro noise density [deg/s/sqrt(Hz)] or [deg/h/sqrt(Hz)]: exactly one of the two.
        accel_bias_mg : float
            Turn-on accelerometer bias [mg].
        accel_noise_ug_sqrt_hz : float
            Accelerometer noise density [ug/sqrt(Hz)].
        rate_hz : float
            Sampling rate [Hz].

        Returns
        -------
        SensorSpec
            In SI.

        Raises
        ------
        ParameterError
            A negative, zero-rate or non-finite value, naming it.

        Examples
        --------
        >>> s = SensorSpec.from_datasheet("LSM6DSL", gyro_bias_deg_s=3, gyro_noise_deg_s_sqrt_hz=0.004,
        ...                               accel_bias_mg=40, accel_noise_ug_sqrt_hz=130)
        >>> s.gyro_bias == LSM6DSL.gyro_bias and s.accel_noise == LSM6DSL.accel_noise
        True
        >>> round(s.gyro_bias, 5)      # 3 deg/s in rad/s
        0.05236
        >>> t = SensorSpec.from_datasheet("LSM6DSL", gyro_bias_deg_s=3, gyro_noise_deg_h_sqrt_hz=14.4,
        ...                               accel_bias_mg=40, accel_noise_ug_sqrt_hz=130)
        >>> bool(abs(t.gyro_noise - s.gyro_noise) < 1e-15)
        True
        """
        from .errors import ParameterError

        if (gyro_noise_deg_s_sqrt_hz is None) == (gyro_noise_deg_h_sqrt_hz is None):
            raise ParameterError("SensorSpec.from_datasheet: give exactly one of gyro_noise_deg_s_sqrt_hz and "
                                 "gyro_noise_deg_h_sqrt_hz")
        if gyro_noise_deg_s_sqrt_hz is None:
            try:
                gyro_noise_deg_s_sqrt_hz = float(gyro_noise_deg_h_sqrt_hz) / 3600.0
            except (TypeError, ValueError):
                raise ParameterError(f"SensorSpec.from_datasheet: gyro_noise_deg_h_sqrt_hz={gyro_noise_deg_h_sqrt_hz!r}, "
                                     "expected a finite value >= 0") from None
        given = {"gyro_bias_deg_s": gyro_bias_deg_s, "gyro_noise_deg_s_sqrt_hz": gyro_noise_deg_s_sqrt_hz,
                 "accel_bias_mg": accel_bias_mg, "accel_noise_ug_sqrt_hz": accel_noise_ug_sqrt_hz,
                 "rate_hz": rate_hz}
        _check_figures("SensorSpec.from_datasheet", given)
        return cls(name=str(name),
                   gyro_bias=float(gyro_bias_deg_s) * DEG_S, gyro_noise=float(gyro_noise_deg_s_sqrt_hz) * DEG_S_SQRT_HZ,
                   accel_bias=float(accel_bias_mg) * MG, accel_noise=float(accel_noise_ug_sqrt_hz) * UG_SQRT_HZ,
                   rate_hz=float(rate_hz))


#: Samsung Galaxy S6 IMU: 6 deg/s, 0.01 deg/s/sqrt(Hz), 60 mg, 300 ug/sqrt(Hz).
MPU6500 = SensorSpec("MPU-6500", 6 * DEG_S, 0.01 * DEG_S_SQRT_HZ, 60 * MG, 300 * UG_SQRT_HZ)
#: Samsung Galaxy S8 IMU: 3 deg/s, 0.004 deg/s/sqrt(Hz), 40 mg, 130 ug/sqrt(Hz).
LSM6DSL = SensorSpec("LSM6DSL", 3 * DEG_S, 0.004 * DEG_S_SQRT_HZ, 40 * MG, 130 * UG_SQRT_HZ)
#: The IMUs the package knows by name: a manifest's ``imu.spec`` may name one (which recordings carry
#: which IMU is the manifest's to say: the MoRPI phones' in ``data/morpi.toml``).
IMUS = {s.name: s for s in (MPU6500, LSM6DSL)}
