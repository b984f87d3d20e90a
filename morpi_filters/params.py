"""The error-parameter file shared by ``morpi assess`` and ``morpi curves``.

A JSON object with units in the key names::

    {
      "dv0_mps":         [dvx, dvy, dvz],   initial velocity error [m/s]
      "accel_bias_mps2": [bax, bay, baz],   accelerometer bias [m/s^2]
      "gyro_bias_radps": [bgx, bgy, bgz],   gyro bias [rad/s]
      "g_mps2":          9.81,              gravity magnitude [m/s^2], > 0
      "dG":              [0.05, 0.10],      Weinberg gain errors (fractions of the gain)
      "morpi_speed_mps": 1.0,               distance travelled per second along the path [m/s]
      "process_noise":   false              curves only: add the IMU white noise (see eskf)
    }

``morpi assess`` reads the values as one error realisation; ``morpi curves``
reads the same keys as 1-sigma values of zero-mean, independent errors.
Optional keys take the defaults of :data:`DEFAULTS`; ``"note"`` holds free
text. The keys of :data:`RENAMED_KEYS` (``ba_mps2``, ``bg_radps``: the names
before 0.2) are read as their new names for one release, with a
:class:`DeprecationWarning`. Any other key, a wrong type, a non-finite number or a value beyond its
physical bound (the constants below, each with its reason) raises
:class:`~morpi_filters.errors.ParameterError` naming the file and the key.
Time grids and run counts are not part of the file (they are command-line
options with their own limits).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .deprecation import renamed_keys
from .errors import ParameterError
from .resources import project_data
from .units import G0

__all__ = ["ErrorParams", "DEFAULTS", "REQUIRED", "RENAMED_KEYS", "load_params", "params_from_dict", "DEFAULT_PARAMS_FILE",
           "BA_MAX_MPS2", "BG_MAX_RADPS", "DV0_MAX_MPS", "SPEED_MAX_MPS", "G_MIN_MPS2", "G_MAX_MPS2", "DG_MAX"]

#: The committed parameter file of the analytical assessment.
DEFAULT_PARAMS_FILE = project_data() / "assessment_params.json"
#: Keys every parameter file must have: name -> vector length (None for a scalar).
REQUIRED = {"dv0_mps": 3, "accel_bias_mps2": 3, "gyro_bias_radps": 3, "g_mps2": None}
#: Optional keys and their defaults.
DEFAULTS = {"dG": [0.05, 0.10], "morpi_speed_mps": 1.0, "process_noise": False}
#: Keys renamed in 0.2 (old -> new), still read as the new ones for one release.
RENAMED_KEYS = {"ba_mps2": "accel_bias_mps2", "bg_radps": "gyro_bias_radps"}


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
        """The source as shown in reports: project-relative for the committed file.

        Examples
        --------
        >>> load_params().label
        'data/assessment_params.json'
        >>> params_from_dict({"dv0_mps": [0] * 3, "accel_bias_mps2": [0] * 3, "gyro_bias_radps": [0] * 3,
        ...                   "g_mps2": 9.8}, name="mine.json").label
        'mine.json'
        """
        try:
            if Path(self.source).resolve() == DEFAULT_PARAMS_FILE.resolve():
                return "data/" + DEFAULT_PARAMS_FILE.name
        except OSError:
            pass
        return self.source


#: Bounds of the values [SI units], each with its reason. The biases are bounded at about 17
#: times the larger datasheet offset of the two phones' IMUs (units.MPU6500: 60 mg zero-g
#: offset, 6 deg/s zero-rate offset): 1 g and 100 deg/s. A larger "bias" is a broken sensor or
#: a unit mistake (an accelerometer bias of 1 g flips the gravity it reads at rest).
BA_MAX_MPS2 = G0
BG_MAX_RADPS = 100 * math.pi / 180
#: Initial velocity error and travel speed: MoRPI is for slow platforms (robots and walkers,
#: the paper's robot moves at about 1 m/s); 10 m/s is twice a running pace.
DV0_MAX_MPS = 10.0
SPEED_MAX_MPS = 10.0
#: Gravity magnitude on the Earth's surface: 9.78 m/s^2 (equator) to 9.83 m/s^2 (poles), with margin.
G_MIN_MPS2, G_MAX_MPS2 = 9.7, 9.9
#: A gain error of 100 % or more makes the Weinberg gain zero or negative.
DG_MAX = 1.0
#: Most gain errors in the dG list (each one is a curve of the report).
DG_MAX_COUNT = 20
#: Largest parameter file read [bytes]; the committed one is under 1 kB.
MAX_FILE_BYTES = 64 * 1024
#: Free-text keys accepted and not read (a comment on the values).
TEXT_KEYS = ("note",)


def _number(name, key, v, bound=None, unit=""):
    """A finite JSON number (not a boolean) within +-bound."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ParameterError(f"{name}: key {key!r}: {_show(v)} is not a finite number")
    try:
        x = float(v)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise ParameterError(f"{name}: key {key!r}: {_show(v)} is not a finite number")
    if bound is not None and abs(x) > bound:
        raise ParameterError(f"{name}: key {key!r}: {_show(v)} is beyond the physical bound +-{bound:.4g} {unit}"
                             f" (see morpi_filters.params)")
    return x


def _show(v) -> str:
    """A short, one-line rendering of a JSON value for a message."""
    text = repr(v) if not isinstance(v, int) or abs(v) < 10 ** 30 else f"an integer of {len(str(abs(v)))} digits"
    text = " ".join(text.split())
    return text if len(text) <= 60 else text[:57] + "..."


def _vector(name, key, v, n, bound, unit):
    if not isinstance(v, list) or len(v) != n:
        got = f"length {len(v)}" if isinstance(v, list) else type(v).__name__
        raise ParameterError(f"{name}: key {key!r}: expected a list of {n} numbers, got {got}")
    return np.array([_number(name, f"{key}[{i}]", x, bound, unit) for i, x in enumerate(v)])


def params_from_dict(d: dict, name: str = "<dict>") -> ErrorParams:
    """Validate a parameter mapping (see the module docstring).

    Parameters
    ----------
    d : dict
        The parsed JSON object: the keys of :data:`REQUIRED`, optionally those
        of :data:`DEFAULTS` and a ``"note"`` text; values in the SI units of
        their key names (``dv0_mps`` [m/s], ``accel_bias_mps2`` [m/s^2], ``gyro_bias_radps``
        [rad/s], ``g_mps2`` [m/s^2], ``morpi_speed_mps`` [m/s], ``dG`` as
        fractions of the gain).
    name : str, optional
        Where the mapping came from, used in error messages and kept as
        :attr:`ErrorParams.source` (default ``"<dict>"``).

    Returns
    -------
    ErrorParams
        The validated values, missing optional keys filled from :data:`DEFAULTS`.

    Raises
    ------
    ParameterError
        One line naming the key and what was expected, for: a missing or
        unknown key, a wrong type, a non-finite number, a value beyond its
        physical bound (:data:`BA_MAX_MPS2`, :data:`BG_MAX_RADPS`,
        :data:`DV0_MAX_MPS`, :data:`SPEED_MAX_MPS`, :data:`G_MIN_MPS2` ..
        :data:`G_MAX_MPS2`, :data:`DG_MAX`), or too many gain errors.

    Examples
    --------
    >>> p = params_from_dict({"dv0_mps": [0.03, 0.04, 0.0], "accel_bias_mps2": [0.0] * 3,
    ...                       "gyro_bias_radps": [0.0] * 3, "g_mps2": 9.81})
    >>> p.dv0.tolist(), p.dG, p.morpi_speed_mps, p.process_noise
    ([0.03, 0.04, 0.0], (0.05, 0.1), 1.0, False)
    >>> params_from_dict({"dv0_mps": [0.0] * 3, "accel_bias_mps2": [0.0] * 3, "gyro_bias_radps": [0.0] * 3, "g_mps2": 1.6})
    Traceback (most recent call last):
    ...
    morpi_filters.errors.ParameterError: <dict>: key 'g_mps2': 1.6 must be a positive gravity magnitude on the Earth's surface, between 9.7 and 9.9 m/s^2
    """
    if not isinstance(d, dict):
        raise ParameterError(f"{name}: expected a JSON object with keys {sorted(REQUIRED)}")
    d = renamed_keys(d, RENAMED_KEYS, name)
    known = set(REQUIRED) | set(DEFAULTS) | set(TEXT_KEYS)
    unknown = [k for k in d if k not in known]
    if unknown:
        raise ParameterError(f"{name}: unknown key(s) {', '.join(_show(k) for k in unknown)}; expected only "
                             f"{', '.join(sorted(known))} (time grids and run counts are command-line options)")
    missing = [k for k in REQUIRED if k not in d]
    if missing:
        raise ParameterError(f"{name}: missing key(s) {', '.join(missing)}; expected {sorted(REQUIRED)}")
    for k in TEXT_KEYS:
        if k in d and not isinstance(d[k], str):
            raise ParameterError(f"{name}: key {k!r}: expected a text string, got {type(d[k]).__name__}")
    dv0 = _vector(name, "dv0_mps", d["dv0_mps"], 3, DV0_MAX_MPS, "m/s")
    ba = _vector(name, "accel_bias_mps2", d["accel_bias_mps2"], 3, BA_MAX_MPS2, "m/s^2")
    bg = _vector(name, "gyro_bias_radps", d["gyro_bias_radps"], 3, BG_MAX_RADPS, "rad/s")
    g = _number(name, "g_mps2", d["g_mps2"])
    if not G_MIN_MPS2 <= g <= G_MAX_MPS2:
        raise ParameterError(f"{name}: key 'g_mps2': {g} must be a positive gravity magnitude on the Earth's "
                             f"surface, between {G_MIN_MPS2} and {G_MAX_MPS2} m/s^2")
    dG = d.get("dG", DEFAULTS["dG"])
    if not isinstance(dG, list) or not dG or len(dG) > DG_MAX_COUNT:
        raise ParameterError(f"{name}: key 'dG': expected a non-empty list of at most {DG_MAX_COUNT} "
                             "gain-error fractions")
    dG = tuple(_number(name, f"dG[{i}]", x, DG_MAX, "(fraction of the gain)") for i, x in enumerate(dG))
    speed = _number(name, "morpi_speed_mps", d.get("morpi_speed_mps", DEFAULTS["morpi_speed_mps"]))
    if not 0 < speed <= SPEED_MAX_MPS:
        raise ParameterError(f"{name}: key 'morpi_speed_mps': {speed} must be positive [m/s] and at most "
                             f"{SPEED_MAX_MPS:g} m/s")
    noise = d.get("process_noise", DEFAULTS["process_noise"])
    if not isinstance(noise, bool):
        raise ParameterError(f"{name}: key 'process_noise': expected true or false, got {_show(noise)}")
    return ErrorParams(dv0=dv0, ba=ba, bg=bg, g=g, dG=dG, morpi_speed_mps=speed, process_noise=noise, source=name)


def _no_constant(token):
    raise ValueError(f"{token} is not a finite number")


def _unique_keys(pairs):
    seen = {}
    for k, v in pairs:
        if k in seen:
            raise ValueError(f"key {k!r} appears twice")
        seen[k] = v
    return seen


def load_params(path=None) -> ErrorParams:
    """Read and validate a parameter file.

    Parameters
    ----------
    path : path-like, optional
        The JSON parameter file; :data:`DEFAULT_PARAMS_FILE` (the committed
        ``data/assessment_params.json``) when None.

    Returns
    -------
    ErrorParams
        The validated values, with ``source`` set to the path.

    Raises
    ------
    ParameterError
        For a missing, unreadable, oversized or non-JSON file, NaN or
        Infinity, a repeated key, nesting or integers beyond what JSON parsing
        accepts, and every case of :func:`params_from_dict`.

    Examples
    --------
    >>> import json, os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "p.json")
    >>> with open(path, "w") as fh:
    ...     json.dump({"dv0_mps": [0.1, 0, 0], "accel_bias_mps2": [0, 0, 0], "gyro_bias_radps": [0, 0, 0],
    ...                "g_mps2": 9.8, "dG": [0.1]}, fh)
    >>> p = load_params(path)
    >>> p.dv0.tolist(), p.g, p.dG, p.source == path
    ([0.1, 0.0, 0.0], 9.8, (0.1,), True)
    >>> load_params().label
    'data/assessment_params.json'
    """
    path = Path(path) if path is not None else DEFAULT_PARAMS_FILE
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise ParameterError(f"{path}: no such parameter file") from None
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read the parameter file ({exc.strerror or exc})") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ParameterError(f"{path}: parameter file larger than {MAX_FILE_BYTES // 1024} kB; expected a small "
                             "JSON object")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: cannot read the parameter file (not UTF-8 text)") from None
    try:
        d = json.loads(text, parse_constant=_no_constant, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as exc:
        raise ParameterError(f"{path}: line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except RecursionError:
        raise ParameterError(f"{path}: nested too deeply; expected a flat JSON object") from None
    except ValueError as exc:   # NaN/Infinity, a repeated key, an integer of more than 4300 digits
        raise ParameterError(f"{path}: {' '.join(str(exc).split())[:120]}") from None
    return params_from_dict(d, str(path))
