"""The aids the ablation removes in turn (:data:`ABLATIONS`), whether a filter uses one, and one row of it."""
from __future__ import annotations

from .. import aided
from ..errors import ParameterError


#: Aids removed in turn in the ablation (AidTuning fields set to these values; smoothing: the forward
#: filter read instead of the smoothed one). The rest updates are removed from a filter started at the
#: motion onset, and compared with the filter started there with them (:meth:`Prepared.onset_input`).
ABLATIONS = {"steps": {"steps": False}, "non-holonomic": {"nhc": False}, "rest updates": {"rest": False},
             "gain state": {"gain_sigma": 0.0}, "smoothing": {}}


def aid_used(name: str, tuning: aided.AidTuning) -> bool:
    """Whether a filter with `tuning` uses the aid of the ablation named `name` (:data:`ABLATIONS`).

    The steps, the non-holonomic and the rest updates where they run; the gain
    state where it is estimated (a considered gain changes the covariance,
    not the estimate); the smoother always (the cells read it).

    Parameters
    ----------
    name : str
        A key of :data:`ABLATIONS`.
    tuning : aided.AidTuning
        The chosen filter's tunables.

    Returns
    -------
    bool

    Raises
    ------
    ParameterError
        For a name that is not an ablation.

    Examples
    --------
    >>> t = aided.AidTuning(nhc=False, gain_estimated=False)
    >>> [n for n in ABLATIONS if aid_used(n, t)]
    ['steps', 'rest updates', 'smoothing']
    """
    if name not in ABLATIONS:
        raise ParameterError(f"aid_used: name={name!r}: expected one of {sorted(ABLATIONS)}")
    return {"steps": tuning.steps, "non-holonomic": tuning.nhc, "rest updates": tuning.rest,
            "gain state": tuning.gain_estimated and tuning.gain_sigma > 0, "smoothing": True}[name]


def ablation_row(label, name, used, full, without=None, start="rest window") -> dict:
    """One ablation row: the filter without the aid against the full filter, both read smoothed and forward.

    Parameters
    ----------
    label : str
        The cell.
    name : str
        The aid removed (a key of :data:`ABLATIONS`).
    used : bool
        Whether the full filter uses it (:func:`aid_used`).
    full, without : (float, float)
        Smoothed and forward mean end-point errors [%] of the full filter and of the filter without the
        aid; `without` None for an aid not used (not run: the full filter's values) and for the smoothing
        (both columns the full filter's forward read-out).
    start : str
        Where both filters start.

    Returns
    -------
    dict
        A row of :attr:`AidedStudy.ablation`.
    """
    sm, fw = full
    if without is None:
        if used and name != "smoothing":
            raise ParameterError(f"ablation of {label!r}: {name!r} is used but was not run")
        # not used: the same filter; without smoothing: the forward read-out for both columns
        without = (fw, fw) if name == "smoothing" else (sm, fw)
    return {"cell": label, "removed": name, "smoothed_percent": float(without[0]),
            "forward_percent": float(without[1]), "used": bool(used), "full_percent": float(sm),
            "full_forward_percent": float(fw), "start": start}
