"""The numpy array types sim2real's signatures name, from their one home :mod:`robots.arrays`.

Examples
--------
>>> import numpy as np
>>> from sim2real._arrays import FloatArray
>>> x: FloatArray = np.zeros(3)
"""

from __future__ import annotations

from robots.arrays import BoolArray, FloatArray, IntArray

__all__ = ["BoolArray", "FloatArray", "IntArray"]
