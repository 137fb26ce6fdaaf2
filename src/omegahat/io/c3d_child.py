"""The part of the C3D reader that runs in a child process (:func:`omegahat.io.c3d.open_c3d` says why): ezc3d's
reading of one file, reduced to what the reader uses and written pickled to standard output.

This file imports nothing of omegahat, so that the child starts without the package's imports (SciPy, Numba: most
of a reader's start-up); the parent loads it by its path (:data:`RUN`), not through the package.
"""

from __future__ import annotations

import pickle
import sys

import numpy as np

#: the child's program: this file loaded by its path (``argv[1]``), then :func:`main` on the C3D file (``argv[2]``)
RUN = (
    "import importlib.util, sys\n"
    "spec = importlib.util.spec_from_file_location('omegahat_c3d_child', sys.argv[1])\n"
    "module = importlib.util.module_from_spec(spec)\n"
    "spec.loader.exec_module(module)\n"
    "module.main(sys.argv[2])\n"
)


def load(path: str) -> dict:
    """The ``ROTATION`` and ``POINT`` parameters, the rotations' data and header of the C3D file ``path``."""
    import ezc3d

    c = ezc3d.c3d(path)
    params = c["parameters"]
    keep = {
        group: {
            name: {"value": entry["value"]}
            for name, entry in params.get(group, {}).items()
            if isinstance(entry, dict) and "value" in entry
        }
        for group in ("ROTATION", "POINT")
        if group in params
    }
    return {
        "parameters": keep,
        "data": {"rotations": np.asarray(c["data"].get("rotations", np.zeros((4, 4, 0, 0))))},
        "header": {"rotations": dict(c["header"].get("rotations", {}))},
    }


def main(path: str) -> None:
    """:func:`load` of ``path``, or ``{'error': message}`` where ezc3d raises, pickled to standard output."""
    try:
        out = load(path)
    except Exception as exc:  # ezc3d raises plain RuntimeError/IOError for unreadable files
        out = {"error": str(exc)}
    sys.stdout.buffer.write(pickle.dumps(out))
