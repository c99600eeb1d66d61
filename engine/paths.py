"""Where shipped assets live (resolved from this file, never from the working directory)."""
from __future__ import annotations

import os
from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parents[1]
ASSETS = Path(os.environ.get("MOATTN_ASSETS", PROJECT_ROOT / "assets"))
MODEL_DIR = ASSETS / "model"
EVALUATOR_DIR = ASSETS / "evaluator"
CONTROL_DIR = ASSETS / "control"  # one fine-tuned model folder per control: root, left_wrist, right_wrist
# the base model the shipped control models were fine-tuned on (vocabulary and feature statistics): control runs on
# it when MODEL_DIR has moved on to another vocabulary (issue #32); a controls folder's own copy is its PRIOR sub-folder
CONTROL_PRIOR_DIR = CONTROL_DIR / "prior"
DUET_DIR = ASSETS / "duet"  # the ComMDM block (and new word rows) trained on MODEL_DIR
# the shared reference motions (real BVH and HumanML3D files, read in place, never copied into the project):
# the inversion benchmark inverts every motion file there, the tests read them (tests/conftest.py)
REAL_DATA_DIR = PROJECT_ROOT.parent / "shared" / "data" / "real"


def shown_default(value):
    """A default as help texts say it: an absolute path (str or Path) through :func:`shown_folder`, anything else
    as it is."""
    return shown_folder(value) if isinstance(value, (str, Path)) and Path(value).is_absolute() else value


def shown_folder(folder) -> str:
    """A path as messages and help texts name it: relative to the project when inside it (no machine's absolute
    path in what a user reads or a shipped file keeps)."""
    path = Path(folder).resolve()
    try:
        return str(path.relative_to(PROJECT_ROOT))
    except ValueError:
        return str(path)
