"""Writing outputs safely: atomic files, staged folders, owned outputs.

Every output file is written in a staging folder beside its destination and
renamed into place, so an interrupted run never leaves half a file. A report
section is built in a staging folder beside its destination and swapped in
only when it is complete, so an interrupted run leaves the previous complete
section in place. All outputs of one command (its folders and its ``--json``
file) are staged by one :class:`Outputs` and swapped in together at the end.

A command writes only what it owns. Every folder a command writes holds the
marker file :data:`MARKER`: a JSON object naming the command, the kind of
output (a report section such as ``"tables"``, ``"report"`` for a report
folder, ``"dataset"`` for a synthetic dataset) and every file and folder the
command wrote there. An output folder is replaced only when it does not exist,
is empty, or holds a marker of the same kind and nothing its marker does not
list. Anything else is refused with one line before anything is computed: a
folder without the marker, another command's kind of output (never mixed
with it, never replaced), or a file the user added to a morpi folder (named;
move it out and run again). A report folder itself is never replaced, only
the entries its marker lists (``index.md``; each section folder under the rule
above); the other entries stay. A marker of an earlier version (plain text,
no list) vouches for nothing but itself. The current directory, a folder
holding it and a mount point are never replaced.

Every JSON file a command writes (a section's ``result.json`` and its
``--json`` copy) begins with the key :data:`JSON_KEY`, an object naming the
format, the command and the section (:func:`stamp_json`); an existing
``--json`` file is overwritten only when it begins so (:func:`is_morpi_json`),
unless the caller forces it.

Staging folders carry the proof that a morpi run made them, so a later run
removes what a killed one left and nothing else (:mod:`morpi_filters.outputs.claims`). Folders and
files get the permissions the user's umask gives, not the private ones of
temporary files.

What a result is and when two are the same (JSON precision, the same-result rule):
:mod:`morpi_filters.results`.
"""
from __future__ import annotations

from .claims import JSON_KEY, MARKER, OUTPUT_FORMAT, foreign_entry, new_stage_dir, remove_stale, swap_in
from .atomic import atomic_path, new_temp_file, user_umask, write_json, write_text
from .checks import check_output_dir, check_output_file, is_morpi_json, stamp_json
from .session import Outputs, staged_dir

__all__ = [
    "atomic_path", "write_text", "write_json", "staged_dir", "MARKER", "JSON_KEY", "OUTPUT_FORMAT", "Outputs",
    "check_output_dir", "check_output_file", "remove_stale", "swap_in", "foreign_entry", "user_umask", "new_stage_dir",
    "new_temp_file", "stamp_json", "is_morpi_json",
]

