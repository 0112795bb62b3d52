"""The numpy array types the toolkit's signatures name: one home for the aliases.

Examples
--------
>>> import numpy as np
>>> t_s: FloatArray = np.linspace(0.0, 1.0, 3)
>>> active: BoolArray = t_s > 0.5
>>> index: IntArray = np.flatnonzero(active)
>>> index.dtype == np.int64
True
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoolArray", "FloatArray", "IntArray"]

#: An array of float64 (times in s, velocities, coordinates).
FloatArray = NDArray[np.float64]
#: An array of booleans (masks).
BoolArray = NDArray[np.bool_]
#: An array of int64 (indices, nanosecond stamps).
IntArray = NDArray[np.int64]
