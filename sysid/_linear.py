r"""Classical step and frequency figures of the identified first-order-plus-dead-time axis.

The linear part of each fitted axis is :math:`G(s) = g\,e^{-ds}/(T s + 1)`, whose figures have
closed forms (e.g. Astrom & Murray, *Feedback Systems*, 2nd ed., sec. 5.3 and 9.1): the step
response is :math:`g(1 - e^{-(t-d)/T})` for :math:`t \ge d`, so the 10-90 % rise time is
:math:`T\ln 9` (the dead time only shifts it), the 2 % settling time :math:`d + T\ln 50`, and
the -3 dB bandwidth :math:`\sqrt{10^{3/10}-1}/T` (a pure delay has unit gain). A few lines of
arithmetic instead of an LTI toolbox: exact (no Pade approximant of the delay, whose
non-minimum-phase undershoot would lengthen the rise time of slow-delay axes), and no
multi-second toolbox import.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["first_order_stats"]

#: -3 dB: the frequency where :math:`|G(j\omega)| = g\,10^{-3/20}`.
_BW_FACTOR = math.sqrt(10.0 ** (3.0 / 10.0) - 1.0)


def first_order_stats(gain: float, time_constant_s: float, delay_s: float) -> dict[str, Any]:
    """Step and frequency figures of :math:`g e^{-ds}/(Ts+1)`.

    Returns a mapping with ``tf`` (text), ``num``/``den`` (without the delay), ``delay_s``,
    ``rise_time_s`` (10-90 %), ``settling_time_s`` (2 %), ``bandwidth_radps`` (-3 dB); empty
    when the gain or time constant is not finite and positive.

    Examples
    --------
    >>> s = first_order_stats(1.0, 0.1, 0.0)
    >>> round(s["bandwidth_radps"], 2), round(s["rise_time_s"], 3)
    (9.98, 0.22)
    """
    if not (math.isfinite(gain) and math.isfinite(time_constant_s) and time_constant_s > 0):
        return {}
    delay = max(float(delay_s), 0.0) if math.isfinite(delay_s) else 0.0
    return {
        "tf": f"{gain:.4g} exp(-{delay:.4g} s) / ({time_constant_s:.4g} s + 1)",
        "num": [float(gain)],
        "den": [float(time_constant_s), 1.0],
        "delay_s": delay,
        "rise_time_s": time_constant_s * math.log(9.0),
        "settling_time_s": delay + time_constant_s * math.log(50.0),
        "bandwidth_radps": _BW_FACTOR / time_constant_s,
    }
