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
  (:func:`with_aliases`).
"""
from __future__ import annotations

import functools
import warnings

from .errors import ParameterError

__all__ = ["renamed_keywords", "renamed_attribute", "with_aliases"]


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
