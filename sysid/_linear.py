"""The linear part of the fitted drive as transfer functions (python-control).

python-control is the field's standard toolbox for LTI analysis; it gives the classical step
and frequency figures engineers compare bases by (rise time, settling time, bandwidth) from
the identified first-order-plus-dead-time model :math:`G(s) = g\\,e^{-ds}/(T s + 1)`, with the
dead time as a 3rd-order Pade approximant for the step figures.
"""

from __future__ import annotations

import math
from typing import Any

import control

__all__ = ["first_order_stats"]


def first_order_stats(gain: float, time_constant_s: float, delay_s: float) -> dict[str, Any]:
    """Step and frequency figures of :math:`g e^{-ds}/(Ts+1)`.

    Returns a mapping with ``tf`` (text), ``num``/``den`` (without the delay), ``delay_s``,
    ``rise_time_s`` (10-90 %), ``settling_time_s`` (2 %), ``bandwidth_radps`` (-3 dB).

    Examples
    --------
    >>> s = first_order_stats(1.0, 0.1, 0.0)
    >>> round(s["bandwidth_radps"], 2), round(s["rise_time_s"], 3)
    (9.98, 0.22)
    """
    if not (math.isfinite(gain) and math.isfinite(time_constant_s) and time_constant_s > 0):
        return {}
    sys = control.tf([gain], [time_constant_s, 1.0])
    full = sys
    if delay_s > 1e-6:
        num, den = control.pade(delay_s, 3)
        full = sys * control.tf(num, den)
    horizon = 10.0 * (time_constant_s + delay_s)
    info = control.step_info(full, timepts=[horizon * i / 1000 for i in range(1001)])
    return {
        "tf": f"{gain:.4g} exp(-{delay_s:.4g} s) / ({time_constant_s:.4g} s + 1)",
        "num": [float(gain)],
        "den": [float(time_constant_s), 1.0],
        "delay_s": float(delay_s),
        "rise_time_s": float(info["RiseTime"]),
        "settling_time_s": float(info["SettlingTime"]),
        "bandwidth_radps": float(control.bandwidth(sys)),
    }
