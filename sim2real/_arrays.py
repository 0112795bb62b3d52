"""Type aliases of the numpy arrays that sim2real's modules pass around.

Examples
--------
>>> import numpy as np
>>> from sim2real._arrays import FloatArray
>>> x: FloatArray = np.zeros(3)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoolArray", "FloatArray", "IntArray"]

#: An array of float64 (SI units; the name of the variable holding it says which).
FloatArray = NDArray[np.float64]
#: An array of int64 (e.g. nanosecond time stamps, indices).
IntArray = NDArray[np.int64]
#: A mask.
BoolArray = NDArray[np.bool_]
