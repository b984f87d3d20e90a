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
    "SensorSpec", "MPU6500", "LSM6DSL", "SENSORS", "sensor_for_phone",
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


@dataclass(frozen=True)
class SensorSpec:
    """Error figures of one IMU, in SI.

    Attributes
    ----------
    name : str
        IMU model.
    phone : str
        Dataset phone folder (``"s6"`` or ``"s8"``).
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
    """

    name: str
    phone: str
    gyro_bias: float
    gyro_noise: float
    accel_bias: float
    accel_noise: float
    rate_hz: float = 100.0


#: Samsung Galaxy S6 IMU: 6 deg/s, 0.01 deg/s/sqrt(Hz), 60 mg, 300 ug/sqrt(Hz).
MPU6500 = SensorSpec("MPU-6500", "s6", 6 * DEG_S, 0.01 * DEG_S_SQRT_HZ, 60 * MG, 300 * UG_SQRT_HZ)
#: Samsung Galaxy S8 IMU: 3 deg/s, 0.004 deg/s/sqrt(Hz), 40 mg, 130 ug/sqrt(Hz).
LSM6DSL = SensorSpec("LSM6DSL", "s8", 3 * DEG_S, 0.004 * DEG_S_SQRT_HZ, 40 * MG, 130 * UG_SQRT_HZ)
#: The paper's IMUs by phone folder.
SENSORS = {"s6": MPU6500, "s8": LSM6DSL}


def sensor_for_phone(phone: str) -> SensorSpec:
    """Return the datasheet spec of a dataset phone (``"s6"`` or ``"s8"``)."""
    from .errors import MorpiError

    try:
        return SENSORS[phone]
    except KeyError:
        raise MorpiError(f"phone {phone!r}: expected one of {sorted(SENSORS)}") from None
