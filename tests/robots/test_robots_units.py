"""robots.units: the one nanoseconds <-> seconds conversion, for numbers and arrays."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from robots.units import NS_PER_S, nanoseconds, seconds

# within 2**53 ns (104 days) a duration in seconds keeps every nanosecond
_DURATIONS = st.integers(min_value=-(2**53), max_value=2**53)


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
