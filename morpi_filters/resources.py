"""Files the project ships beside its code: the route catalogue, the
manifest of the MoRPI dataset, the assessment parameters and the dataset
checksums.

They live in the top-level ``data/`` folder of the source tree; the build maps
that folder into the package as ``morpi_filters/data`` (see ``pyproject.toml``),
so an installed wheel carries them. :func:`project_data` finds the folder in
either layout through :mod:`importlib.resources`.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

__all__ = ["project_data", "MORPI_MANIFEST", "morpi_manifest"]

#: The file name of the MoRPI dataset's manifest in :func:`project_data`.
MORPI_MANIFEST = "morpi.toml"


@lru_cache(maxsize=None)
def project_data() -> Path:
    """Folder holding ``routes.json``, ``morpi.toml``, ``assessment_params.json`` and ``dataset_checksums.txt``.

    Returns
    -------
    Path
        ``morpi_filters/data`` inside an installed package, else the
        ``data/`` folder next to the package in a source checkout.
        The result is cached: every call returns the same object.

    Examples
    --------
    >>> folder = project_data()
    >>> {"routes.json", "morpi.toml", "assessment_params.json", "dataset_checksums.txt"} <= {p.name for p in folder.iterdir()}
    True
    >>> project_data() is folder
    True
    """
    packaged = resources.files(__package__) / "data"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parent.parent / "data"


def morpi_manifest() -> Path:
    """The manifest of the MoRPI dataset (``data/morpi.toml``), its files relative to a dataset root.

    Applied to a root (``load_dataset(morpi_manifest(), root=DIR)``, or
    ``FieldData(DIR)``) it describes the recordings of the MoRPI layout found
    there: one ``[[recording]]`` per folder ``<phone>/<route>[/<split>]`` of
    ``routes.json``'s layout, its CSV files by a glob, its group the folder
    ``<phone>/<route>``, the route's truth and the phone's IMU. Written by
    ``analysis/morpi_manifest.py``.

    Returns
    -------
    Path

    Examples
    --------
    >>> morpi_manifest().name
    'morpi.toml'
    """
    return project_data() / MORPI_MANIFEST
