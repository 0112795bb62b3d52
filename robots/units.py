"""The one time conversion, integer nanoseconds (log stamps) <-> seconds (models), and the
one value of gravity every package uses.

Logs stamp messages in integer nanoseconds (ROS 2 ``builtin_interfaces/Time``, MCAP); the
models and fits work in seconds. :func:`seconds` and :func:`nanoseconds` are the conversion
both ways, for numbers and numpy arrays; :data:`NS_PER_S` splits a stamp into whole seconds
and nanoseconds. :data:`GRAVITY_MPS2` is standard gravity rounded as the simulators take it.

Examples
--------
>>> import numpy as np
>>> seconds(1_500_000_000)
1.5
>>> nanoseconds(np.array([0.0, 0.1, 2.5]))
array([         0,  100000000, 2500000000])
>>> divmod(nanoseconds(3.25), NS_PER_S)
(3, 250000000)
"""

from __future__ import annotations

from typing import Any, overload

import numpy as np
from numpy.typing import NDArray

__all__ = ["GRAVITY_MPS2", "NS_PER_S", "nanoseconds", "seconds"]

#: Nanoseconds in a second.
NS_PER_S = 1_000_000_000

#: Gravitational acceleration, m/s^2: weights, friction priors as a fraction of the weight, and
#: the gravity pybullet and MuJoCo simulate.
GRAVITY_MPS2 = 9.81


@overload
def seconds(t_ns: float) -> float: ...


@overload
def seconds(t_ns: NDArray[Any]) -> NDArray[np.float64]: ...


def seconds(t_ns: float | NDArray[Any]) -> float | NDArray[np.float64]:
    """Nanoseconds -> seconds (a float, or a float64 array of an array).

    Parameters
    ----------
    t_ns : int, float or ndarray
        A time or a duration in nanoseconds.

    Returns
    -------
    float or ndarray
        The same in seconds, ``t_ns / 1e9``.

    Examples
    --------
    >>> seconds(250_000_000)
    0.25
    """
    return t_ns / 1e9


@overload
def nanoseconds(t_s: float) -> int: ...


@overload
def nanoseconds(t_s: NDArray[Any]) -> NDArray[np.int64]: ...


def nanoseconds(t_s: float | NDArray[Any]) -> int | NDArray[np.int64]:
    """Seconds -> integer nanoseconds, rounded to the nearest (ties to even).

    Parameters
    ----------
    t_s : float or ndarray
        A time or a duration in seconds.

    Returns
    -------
    int or ndarray
        The same in nanoseconds (an int64 array of an array).

    Examples
    --------
    >>> nanoseconds(0.25)
    250000000
    """
    if isinstance(t_s, np.ndarray):
        return np.rint(t_s * 1e9).astype(np.int64)
    return round(t_s * 1e9)
