"""Sensor specifications from datasheet units."""
from __future__ import annotations

import math

import pytest

from morpi_filters import units
from morpi_filters.errors import ParameterError


@pytest.mark.parametrize("spec,sheet", [
    # the paper's table "Sensors Errors according to manufacturer", in its own units
    (units.MPU6500, dict(gyro_bias_deg_s=6, gyro_noise_deg_s_sqrt_hz=0.01, accel_bias_mg=60, accel_noise_ug_sqrt_hz=300)),
    (units.LSM6DSL, dict(gyro_bias_deg_s=3, gyro_noise_deg_s_sqrt_hz=0.004, accel_bias_mg=40, accel_noise_ug_sqrt_hz=130)),
])
def test_datasheet_units_give_the_paper_specs(spec, sheet):
    s = units.SensorSpec.from_datasheet(spec.name, **sheet)
    assert s == spec
    # independent arithmetic: deg -> rad by pi/180, mg -> m/s^2 by 9.80665e-3, ug by 9.80665e-6
    assert math.isclose(s.gyro_bias, sheet["gyro_bias_deg_s"] * math.pi / 180, rel_tol=1e-15)
    assert math.isclose(s.accel_noise, sheet["accel_noise_ug_sqrt_hz"] * 9.80665e-6, rel_tol=1e-15)


def test_a_users_imu_needs_no_dataset_phone():
    s = units.SensorSpec.from_datasheet("BMI270", gyro_bias_deg_s=0.5, gyro_noise_deg_s_sqrt_hz=0.007,
                                        accel_bias_mg=20, accel_noise_ug_sqrt_hz=160, rate_hz=200)
    assert not hasattr(s, "phone") and s.rate_hz == 200.0              # an IMU is not a dataset folder


@pytest.mark.parametrize("key,value", [("gyro_bias_deg_s", -1.0), ("accel_bias_mg", float("nan")),
                                       ("accel_noise_ug_sqrt_hz", float("inf")), ("rate_hz", 0.0),
                                       ("gyro_noise_deg_s_sqrt_hz", "a lot")])
def test_impossible_datasheet_values_are_refused_by_name(key, value):
    sheet = dict(gyro_bias_deg_s=3, gyro_noise_deg_s_sqrt_hz=0.004, accel_bias_mg=40, accel_noise_ug_sqrt_hz=130)
    sheet[key] = value
    with pytest.raises(ParameterError, match=key):
        units.SensorSpec.from_datasheet("x", **sheet)


@pytest.mark.parametrize("field, value", [
    ("gyro_bias", -1e-3), ("gyro_noise", math.nan), ("accel_bias", math.inf), ("accel_noise", -0.1),
    ("rate_hz", 0.0), ("rate_hz", -100.0), ("gyro_noise", "loud"),
])
def test_a_plain_spec_refuses_impossible_figures(field, value):
    good = dict(name="X", gyro_bias=1e-3, gyro_noise=1e-4, accel_bias=0.1, accel_noise=1e-3, rate_hz=100.0)
    units.SensorSpec(**good)                                          # the same spec with good figures is fine
    with pytest.raises(ParameterError, match=f"SensorSpec 'X': {field}="):
        units.SensorSpec(**{**good, field: value})
