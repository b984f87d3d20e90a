"""Old names kept working for one release: renamed keywords, attributes and JSON keys.

The package names each concept once, with its unit where it has one
(``speed_mps``, ``p2p_m``, ``dt_s``, ``calibration``; ``CHANGELOG.md`` lists
every rename). A name replaced in a release stays usable until the next one:

* a keyword parameter of a public function (or a dataclass constructor)
  accepts its old name, with a :class:`DeprecationWarning` naming the new
  one (:func:`renamed_keywords`);
* a public attribute reads under its old name, with the same warning
  (:func:`renamed_attribute`);
* a JSON object carries its old key beside the new one, with the same value
  (:func:`with_aliases`); a file the package reads takes an old key as the new
  one, with the warning (:func:`renamed_keys`).
"""
from __future__ import annotations

import functools
import warnings

from .errors import ParameterError

__all__ = ["renamed_keywords", "renamed_attribute", "with_aliases", "renamed_keys"]


def renamed_keywords(**old_to_new):
    """Decorator: the function also takes each old keyword name, as its new name, with a DeprecationWarning.

    Parameters
    ----------
    **old_to_new : str
        Old keyword name -> new keyword name.

    Returns
    -------
    callable
        A decorator; the wrapped function keeps its name, docstring and
        signature (``inspect.signature`` shows the new names only).

    Raises
    ------
    ParameterError
        (from the wrapped function) when a call gives both the old and the new
        name of one parameter.

    Examples
    --------
    >>> import warnings
    >>> @renamed_keywords(speed="speed_mps")
    ... def travel(seconds, *, speed_mps=1.0):
    ...     return seconds * speed_mps
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     travel(2.0, speed=3.0)
    6.0
    >>> str(caught[0].message)
    'travel: the keyword speed= is deprecated; use speed_mps='
    """
    def wrap(func):
        name = func.__qualname__.replace(".__init__", "")

        @functools.wraps(func)
        def inner(*args, **kwargs):
            for old, new in old_to_new.items():
                if old in kwargs:
                    if new in kwargs:
                        raise ParameterError(f"{name}: both {old}= and {new}= given; expected {new}= only")
                    warnings.warn(f"{name}: the keyword {old}= is deprecated; use {new}=", DeprecationWarning,
                                  stacklevel=2)
                    kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        inner.renamed_keywords = dict(getattr(func, "renamed_keywords", {}), **old_to_new)
        return inner
    return wrap


def renamed_attribute(owner: str, old: str, new: str) -> property:
    """A read-only property under the old name `old` returning attribute `new`, with a DeprecationWarning.

    Parameters
    ----------
    owner : str
        Class name shown in the warning.
    old, new : str
        Old and new attribute names.

    Returns
    -------
    property
        To assign in the class body (``period = renamed_attribute("Trajectory", "period", "p2p_m")``);
        on a dataclass, assign it after the class is made, so it is not taken for a field.

    Examples
    --------
    >>> import warnings
    >>> class Walk:
    ...     speed_mps = 1.5
    ...     speed = renamed_attribute("Walk", "speed", "speed_mps")
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     Walk().speed
    1.5
    >>> str(caught[0].message)
    'Walk.speed is deprecated; use Walk.speed_mps'
    """
    def get(self):
        warnings.warn(f"{owner}.{old} is deprecated; use {owner}.{new}", DeprecationWarning, stacklevel=2)
        return getattr(self, new)

    return property(get, doc=f"Deprecated name of :attr:`{new}`.")


def with_aliases(obj: dict, aliases: dict) -> dict:
    """A copy of JSON object `obj` with each old key of `aliases` (old -> new) beside its new key, same value.

    The old key follows its new key; a new key absent from `obj` adds nothing.

    Parameters
    ----------
    obj : dict
        A JSON object written with the new keys.
    aliases : dict
        Old key -> new key.

    Returns
    -------
    dict
        The object with the old keys added.

    Examples
    --------
    >>> with_aliases({"speed_mps": 0.5, "runs": 3}, {"speed_m_s": "speed_mps"})
    {'speed_mps': 0.5, 'speed_m_s': 0.5, 'runs': 3}
    """
    back = {new: old for old, new in aliases.items()}
    out = {}
    for key, value in obj.items():
        out[key] = value
        if key in back:
            out[back[key]] = value
    return out


def renamed_keys(obj: dict, aliases: dict, where: str) -> dict:
    """A copy of input mapping `obj` with each old key of `aliases` (old -> new) read as its new key, with a warning.

    Parameters
    ----------
    obj : dict
        A mapping read from a file (a parameter file, a manifest table).
    aliases : dict
        Old key -> new key.
    where : str
        The file (or table) shown in the warning and the error.

    Returns
    -------
    dict
        The mapping with the old keys renamed in place (order kept); `obj` itself when it has none.

    Raises
    ------
    ParameterError
        When `obj` holds both the old and the new name of one key.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     renamed_keys({"bg_radps": [0.0] * 3, "g_mps2": 9.8}, {"bg_radps": "gyro_bias_radps"}, "p.json")
    {'gyro_bias_radps': [0.0, 0.0, 0.0], 'g_mps2': 9.8}
    >>> str(caught[0].message)
    "p.json: the key 'bg_radps' is deprecated; use 'gyro_bias_radps'"
    """
    old_keys = [k for k in obj if k in aliases]
    if not old_keys:
        return obj
    for old in old_keys:
        new = aliases[old]
        if new in obj:
            raise ParameterError(f"{where}: both keys {old!r} and {new!r} given; expected {new!r} only")
        warnings.warn(f"{where}: the key {old!r} is deprecated; use {new!r}", DeprecationWarning, stacklevel=3)
    return {aliases.get(k, k): v for k, v in obj.items()}
