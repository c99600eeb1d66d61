"""The motion library: every motion the studio or the CLI makes, edits or imports, kept in the workspace.

- :mod:`engine.library.workspace`: where (``--workspace``, $MOATTN_WORKSPACE, the user-data folder) and how big
  (``--library-mb``, $MOATTN_LIBRARY_MB, the stored setting).
- :mod:`engine.library.index`: the SQLite index (listing, search, the size bound), safe across processes.
- :mod:`engine.library.store`: :class:`MotionLibrary` (add, list, load, pin, remove, export's reads), atomic
  writes, damaged or foreign entries reported and skipped.
- :mod:`engine.library.cli_support`: the flags and the one call a motion-making command adds to keep its motions.

Torch-free: nothing here imports the model.
"""
from engine.library.index import Entry
from engine.library.store import Added, LibraryError, MotionLibrary, Problem, jsonable
from engine.library.workspace import DEFAULT_LIMIT_MB, LIMIT_ENV, WORKSPACE_ENV, library_dir, workspace_dir

KINDS = ("generate", "edit", "transfer", "compose", "control", "duet", "import")  # what the front ends write

__all__ = ["Added", "DEFAULT_LIMIT_MB", "Entry", "KINDS", "LIMIT_ENV", "LibraryError", "MotionLibrary", "Problem",
           "WORKSPACE_ENV", "jsonable", "library_dir", "workspace_dir"]
