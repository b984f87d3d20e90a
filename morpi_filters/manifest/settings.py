"""How a dataset is evaluated: the manifest's ``[evaluation]`` table as one object (:class:`Settings`)."""
from __future__ import annotations

from dataclasses import dataclass, fields

from ..errors import ParameterError

#: How the step-rule search holds a train run out: ``"recording"`` scores each run with the mean gain of its
#: group's other train runs, ``"group"`` with the mean gain of the other groups' runs, ``"auto"`` takes
#: ``"group"`` when the train recordings form two groups or more, else ``"recording"``.
HELD_OUT_CHOICES = ("auto", "recording", "group")
#: What the INS integrates: its motion window (from the end of the initial rest to the robot's stop; a
#: recording started from the truth is integrated from its first sample either way), or the full recording
#: (the values of :class:`morpi_filters.field.FieldData`'s ``ins_span``).
INS_SPANS = ("motion", "full")
#: Which MoRPI steps drive the aided filter: ``"chosen"``, the method of least train error per group and
#: calibration (one filter); ``"each"``, one filter per MoRPI method.
AIDED_METHODS = ("chosen", "each")


@dataclass(frozen=True)
class Settings:
    """The choices of a dataset's evaluation that are the dataset's to make (the manifest's ``[evaluation]``).

    Each recording's ``train_group`` (a manifest label) says which train
    group sets its gains and the aided filter's tuning; these settings say
    how the rest is evaluated. The defaults are the general pipeline's; the
    shipped MoRPI manifest sets what the paper's tables do.

    Attributes
    ----------
    held_out : {"auto", "recording", "group"}
        How the step-rule search scores a train run (:data:`HELD_OUT_CHOICES`).
    ins_span : {"full", "motion"}
        What the INS integrates (:data:`INS_SPANS`).
    aided_methods : {"chosen", "each"}
        Which MoRPI steps drive the aided filter (:data:`AIDED_METHODS`).

    Examples
    --------
    >>> Settings(ins_span="motion").to_json()
    {'held_out': 'auto', 'ins_span': 'motion', 'aided_methods': 'chosen'}
    >>> Settings(held_out="run")
    Traceback (most recent call last):
    ...
    morpi_filters.errors.ParameterError: evaluation.held_out: 'run', expected one of 'auto', 'recording', 'group'
    """

    held_out: str = "auto"
    ins_span: str = "full"
    aided_methods: str = "chosen"

    def __post_init__(self):
        for f in fields(self):
            check = SETTING_CHOICES[f.name]
            v = getattr(self, f.name)
            if not isinstance(v, str) or v not in check:
                raise ParameterError(f"evaluation.{f.name}: {v!r}, expected one of "
                                     f"{', '.join(repr(c) for c in check)}")

    def to_json(self) -> dict:
        """The settings as the JSON's ``choices.settings``."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


#: The choices of each setting, by key.
SETTING_CHOICES = {"held_out": HELD_OUT_CHOICES, "ins_span": INS_SPANS, "aided_methods": AIDED_METHODS}
