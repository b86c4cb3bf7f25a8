"""shscale from Python: spherical harmonics scaling and shadow fields for deformable objects.

NumPy arrays in and out, with the conventions of the ``shscale`` command line (real SH, index
``l² + l + m``, docs/conventions.md). Bad input raises ``ValueError`` with the message the CLI
prints; long calls release the GIL.

>>> import shscale
>>> shscale.sh_eval(2, [[0, 0, 1]]).shape
(1, 4)
"""

from ._api import (
    sh_eval,
    sh_cap,
    sh_rotate,
    scaling_matrix,
    ktable,
    visibility,
    inspect,
    probe,
    run,
    load_results,
    plot,
    kinds,
)
from ._native import __version__

__all__ = [
    "__version__",
    "sh_eval",
    "sh_cap",
    "sh_rotate",
    "scaling_matrix",
    "ktable",
    "visibility",
    "inspect",
    "probe",
    "run",
    "load_results",
    "plot",
    "kinds",
]
