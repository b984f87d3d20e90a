"""The error-parameter file shared by ``morpi assess`` and ``morpi curves``.

A JSON object with units in the key names::

    {
      "dv0_mps":   [dvx, dvy, dvz],   initial velocity error [m/s]
      "ba_mps2":   [bax, bay, baz],   accelerometer bias [m/s^2]
      "bg_radps":  [bgx, bgy, bgz],   gyro bias [rad/s]
      "g_mps2":    9.81,              gravity magnitude [m/s^2], > 0
      "dG":        [0.05, 0.10],      Weinberg gain errors (fractions of the gain)
      "morpi_speed_mps": 1.0,         distance travelled per second along the path [m/s]
      "process_noise": false          curves only: add the IMU white noise (see eskf)
    }

``morpi assess`` reads the values as one error realisation; ``morpi curves``
reads the same keys as 1-sigma values of zero-mean, independent errors.
Optional keys take the defaults of :data:`DEFAULTS`. Any problem raises
:class:`MorpiError` naming the file and the key.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import MorpiError
from .resources import project_data

__all__ = ["ErrorParams", "DEFAULTS", "REQUIRED", "load_params", "params_from_dict", "DEFAULT_PARAMS_FILE"]

#: The committed parameter file of the analytical assessment.
DEFAULT_PARAMS_FILE = project_data() / "assessment_params.json"
#: Keys every parameter file must have: name -> vector length (None for a scalar).
REQUIRED = {"dv0_mps": 3, "ba_mps2": 3, "bg_radps": 3, "g_mps2": None}
#: Optional keys and their defaults.
DEFAULTS = {"dG": [0.05, 0.10], "morpi_speed_mps": 1.0, "process_noise": False}


@dataclass(frozen=True)
class ErrorParams:
    """Error parameters of the analytical assessment (SI units).

    Attributes
    ----------
    dv0 : ndarray, shape (3,)
        Initial velocity error [m/s].
    ba : ndarray, shape (3,)
        Accelerometer bias [m/s^2].
    bg : ndarray, shape (3,)
        Gyro bias [rad/s].
    g : float
        Gravity magnitude [m/s^2].
    dG : tuple of float
        Weinberg gain errors as fractions of the gain.
    morpi_speed_mps : float
        Distance travelled per second along the periodic path [m/s].
    process_noise : bool
        Whether covariance curves add IMU white noise.
    source : str
        The file the values came from.
    """

    dv0: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    g: float
    dG: tuple = (0.05, 0.10)
    morpi_speed_mps: float = 1.0
    process_noise: bool = False
    source: str = "<dict>"

    @property
    def label(self) -> str:
        """The source as shown in reports: project-relative for the committed file."""
        try:
            if Path(self.source).resolve() == DEFAULT_PARAMS_FILE.resolve():
                return "data/" + DEFAULT_PARAMS_FILE.name
        except OSError:
            pass
        return self.source


def _number(name, key, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise MorpiError(f"{name}: key {key!r}: {v!r} is not a finite number")
    return float(v)


def _vector(name, key, v, n):
    if not isinstance(v, list) or len(v) != n:
        got = f"length {len(v)}" if isinstance(v, list) else type(v).__name__
        raise MorpiError(f"{name}: key {key!r}: expected a list of {n} numbers, got {got}")
    return np.array([_number(name, f"{key}[{i}]", x) for i, x in enumerate(v)])


def params_from_dict(d: dict, name: str = "<dict>") -> ErrorParams:
    """Validate a parameter mapping (see the module docstring)."""
    if not isinstance(d, dict):
        raise MorpiError(f"{name}: expected a JSON object with keys {sorted(REQUIRED)}")
    missing = [k for k in REQUIRED if k not in d]
    if missing:
        raise MorpiError(f"{name}: missing key(s) {', '.join(missing)}; expected {sorted(REQUIRED)}")
    dv0 = _vector(name, "dv0_mps", d["dv0_mps"], 3)
    ba = _vector(name, "ba_mps2", d["ba_mps2"], 3)
    bg = _vector(name, "bg_radps", d["bg_radps"], 3)
    g = _number(name, "g_mps2", d["g_mps2"])
    if g <= 0:
        raise MorpiError(f"{name}: key 'g_mps2': {g} must be a positive gravity magnitude [m/s^2]")
    dG = d.get("dG", DEFAULTS["dG"])
    if not isinstance(dG, list) or not dG:
        raise MorpiError(f"{name}: key 'dG': expected a non-empty list of gain-error fractions")
    dG = tuple(_number(name, f"dG[{i}]", x) for i, x in enumerate(dG))
    speed = _number(name, "morpi_speed_mps", d.get("morpi_speed_mps", DEFAULTS["morpi_speed_mps"]))
    if speed <= 0:
        raise MorpiError(f"{name}: key 'morpi_speed_mps': {speed} must be positive [m/s]")
    noise = d.get("process_noise", DEFAULTS["process_noise"])
    if not isinstance(noise, bool):
        raise MorpiError(f"{name}: key 'process_noise': expected true or false, got {noise!r}")
    return ErrorParams(dv0=dv0, ba=ba, bg=bg, g=g, dG=dG, morpi_speed_mps=speed, process_noise=noise, source=name)


def load_params(path=None) -> ErrorParams:
    """Read and validate a parameter file (default: :data:`DEFAULT_PARAMS_FILE`)."""
    path = Path(path) if path is not None else DEFAULT_PARAMS_FILE
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise MorpiError(f"{path}: no such parameter file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise MorpiError(f"{path}: cannot read the parameter file ({exc})") from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MorpiError(f"{path}: line {exc.lineno}: not valid JSON ({exc.msg})") from None
    return params_from_dict(d, str(path))
