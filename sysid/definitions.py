"""The scores' definitions in words and the fit's choices, for help texts and reports.

A module without numpy, so that ``sim2real --help`` can quote a definition without loading
the numerical code that computes it (:mod:`sysid.metrics`).

Examples
--------
>>> from sysid.definitions import FIT_PERCENT_DEFINITION
>>> FIT_PERCENT_DEFINITION.startswith("FIT % = 100")
True
"""

from __future__ import annotations

__all__ = ["FIT_PERCENT_DEFINITION", "LOSSES"]

#: What "FIT %" means everywhere (CLI help, report): the one definition, see
#: :func:`sysid.metrics.fit_percent`.
FIT_PERCENT_DEFINITION = (
    "FIT % = 100 (1 - |y - y_sim| / |y - mean(y)|) per channel over all samples (MATLAB "
    "'compare'; |.| the Euclidean norm): 100 = perfect, 0 = no better than the mean, < 0 worse"
)

#: The robust losses :func:`sysid.fit_drive` takes (scipy's ``least_squares`` names).
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
