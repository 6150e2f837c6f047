"""One OpenBLAS thread for the command, set before numpy loads OpenBLAS.

numpy's OpenBLAS (``scipy-openblas``) starts a pool of threads, one per core, the
first time numpy is imported, and reads ``OPENBLAS_NUM_THREADS`` only then. The
command parallelises by processes (a conversion's three, ``--jobs``) and multiplies
matrices a few columns wide, where the pool's threads only wait, spinning, beside
the work: 4 % of a 200 000-line conversion's CPU and 0.06 s of CPU at every start
(``docs/measurements.md``, "Start-up"). :mod:`prsxy_post.cli` imports this module
before numpy; a value the user set stays. The library itself never sets it: a
program that imports it keeps its own threads.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
