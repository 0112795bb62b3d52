"""robots.units: the one nanoseconds <-> seconds conversion, for numbers and arrays."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from robots.units import NS_PER_S, nanoseconds, seconds

# A duration of n ns round-trips exactly while the two roundings (n / 1e9 to seconds, then
# back times 1e9), each off by at most 2**-53 relative, stay under half a nanosecond:
# n * 2**-52 < 0.5, i.e. |n| < 2**51 ns (26 days). Near 2**53 ns a second's float is 2 ns
# coarse (8571962393883499 comes back ...498).
_DURATIONS = st.integers(min_value=-(2**51 - 1), max_value=2**51 - 1)


@given(_DURATIONS)
def test_nanoseconds_undo_seconds(t_ns: int) -> None:
    assert nanoseconds(seconds(t_ns)) == t_ns


@given(arrays(np.int64, st.integers(0, 20), elements=_DURATIONS))
def test_arrays_convert_as_their_elements(t_ns: np.ndarray) -> None:
    t_s = seconds(t_ns)
    assert t_s.dtype == np.float64
    assert t_s.tolist() == [seconds(int(n)) for n in t_ns]
    back = nanoseconds(t_s)
    assert back.dtype == np.int64
    assert back.tolist() == t_ns.tolist()


def test_values() -> None:
    assert seconds(NS_PER_S) == 1.0
    assert seconds(1_700_000_000_123_456_789) == 1_700_000_000_123_456_789 / 1e9
    assert nanoseconds(1.5) == 1_500_000_000 and isinstance(nanoseconds(1.5), int)
    assert nanoseconds(-0.25) == -250_000_000
    # halves of a nanosecond round to even, numbers and arrays alike
    assert nanoseconds(2.5e-9) == 2 and nanoseconds(3.5e-9) == 4
    assert nanoseconds(np.array([2.5e-9, 3.5e-9])).tolist() == [2, 4]
