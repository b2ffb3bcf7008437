"""The paper's experiments (docs/METHOD.md §9), one module each, and ``reproduce``.

Run one alone with ``python -m experiments.e1_noise --quick --out DIR`` (from the
repository's root), all of them with ``python -m experiments.reproduce``. Shared helpers
live in :mod:`experiments._common`; no experiment imports another.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")   # before anything imports mujoco
