r"""Command arrival-time jitter in the fit: errors in the input, as a residual covariance.

A log records when each command was published (or reached the recorder), not when the base's
firmware acted on it: every message crosses a transport (a serial link, a Wi-Fi hop, a driver's
loop) whose latency varies from message to message. The model's response to a command is
therefore known only up to that command's arrival time. A change of the command by
:math:`\Delta c_k` that arrives :math:`\delta_k` late moves the response by
:math:`\delta_k g_k`, with :math:`g_k = \partial y/\partial t_k` the model's sensitivity to
that command's time: every sample of the transient that follows moves together, and by the
response's rate of change (Orear, 1982: the effective variance of errors in the input). With
independent :math:`\delta_k \sim N(0, \sigma_t^2)` the data residuals have the covariance

.. math:: \Sigma = D + \sigma_t^2 G G^T, \qquad D = \mathrm{diag}(s_v^2, \ldots, s_w^2),

one column :math:`g_k` per command that changes the target. Counted as white noise, this
timing error makes the residuals largest, and correlated, exactly at the step transients,
where the damping of the response is measured: the sandwich covariance then hands back most
of what the transients tell (on unsmoothed PI-loop bases, the viscous friction terms).
Marginalising the arrival times instead (the generalised least squares of :math:`\Sigma`;
the same as estimating one arrival offset per command with prior sd :math:`\sigma_t`, profiled
out) discounts only the timing direction :math:`g_k` of each transient and keeps its shape.

:func:`estimate_jitter` finds :math:`\sigma_t` from the residuals of a fit (the log cannot
tell the transport's jitter: its stamps are the publisher's), a robust method of moments over
the commands' arrival errors that the residuals show, and :func:`arrival_whitener` builds the
whitening the fit then uses when the jitter is significant and above the model's step (the
step's own error looks like timing of up to a step): with
:math:`\tilde\Sigma = D^{-1/2}\Sigma D^{-1/2} = L L^T` (banded Cholesky over the instants in
time order: each sensitivity is cut where it has decayed to :data:`SUPPORT_SHARE` of its
peak), the residuals become :math:`D^{1/2} L^{-1} D^{-1/2} f`: the innovations of the timing
covariance, in the fit's own channel scales, so that with :math:`\sigma_t = 0` the fit is
exactly the unwhitened one.

The jitter moves the data's mean too: a transient averaged over its arrival time starts
earlier and rises slower than the response at the mean arrival, which a fit without it
reads as a shorter delay and more damping (on the Burger's model with a 10 ms jitter, a
delay 6-8 ms short and viscous friction at 3x the truth). The whitened problem therefore
models the expected response over the jitter (:meth:`sysid._problem.Problem.scaled_sim_many`,
Gauss-Hermite over the delay): the delay is the mean arrival, the jitter its spread.

Examples
--------
>>> import numpy as np
>>> g = np.array([[0.0], [1.0], [0.5], [0.0]])  # one command's sensitivity: v rows, w rows
>>> w = Whitener.build([g], sigma_t_s=0.01, scale_v=0.001, scale_w=0.001, key=((0.0, 1.0, 2),))
>>> late = 0.01 * g[:, 0]  # the command 10 ms late: residuals along its timing direction
>>> round(float(np.linalg.norm(w.apply(late)) / np.linalg.norm(late)), 3)  # 1/sqrt(1 + 125)
0.089
>>> [x + 0.0 for x in w.apply(np.array([1.0, 0.0, 0.0, 0.0])).tolist()]  # timing cannot
[1.0, 0.0, 0.0, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import cholesky_banded, solve_banded
from scipy.optimize import brentq

from robots.arrays import FloatArray
from robots.params import DriveParams
from robots.reduced import GridCommands
from sysid._logs import LogArrays
from sysid._problem import Problem
from sysid.steady import robust_sd

__all__ = [
    "ARRIVAL_STEP_S",
    "MIN_COMMANDS",
    "SUPPORT_SHARE",
    "JitterEstimate",
    "Whitener",
    "arrival_sensitivities",
    "arrival_whitener",
    "estimate_jitter",
    "logs_key",
]

#: Forward-difference shift of one command's arrival time, s (below the model's 1/240 s step:
#: the grid's command averages are linear in it).
ARRIVAL_STEP_S = 0.002
#: A command's sensitivity is cut where it has decayed below this share of its peak.
SUPPORT_SHARE = 1e-3
#: Commands simulated per compiled call.
_BATCH = 64
#: Sampling sd of the robust (MAD) scale of m normal draws, times sqrt(m).
_MAD_SE = 1.166
#: Fewest changing commands whose arrival errors tell the jitter: (2 x 1.166)^2 x 9, where
#: twice the robust scale's sampling error is 1/3.
MIN_COMMANDS = 49
#: Arrival errors beyond this many sds (at the robust estimate) are misses of the model, left
#: out of the mean square; a standard normal cut there has E z^2 = _CUT_SQUARE.
_CUT, _CUT_SQUARE = 3.0, 0.9733


@dataclass(frozen=True, kw_only=True)
class Sensitivity:
    """One log's arrival-time sensitivities, cut to their supports.

    Attributes
    ----------
    n : int
        The log's measurement instants (its residual rows are ``2 n``: v then w).
    start : ndarray of int
        First instant of each command's support.
    v, w : list of ndarray
        Each command's sensitivity of the scaled v and w from ``start`` on, 1/s.
    """

    n: int
    start: NDArray[np.intp]
    v: list[FloatArray]
    w: list[FloatArray]

    @property
    def m(self) -> int:
        """Commands."""
        return int(self.start.size)


def _changes(cmd_v: FloatArray, cmd_w: FloatArray) -> NDArray[np.intp]:
    """Indices of the commands that change the target (the first one counts from rest)."""
    dv = np.diff(cmd_v, prepend=0.0)
    dw = np.diff(cmd_w, prepend=0.0)
    return np.flatnonzero((dv != 0.0) | (dw != 0.0))


def _shifted(base: GridCommands, t_s: float, dv: float, dw: float, h: float) -> GridCommands:
    """``base`` with a command change (dv, dw) at grid time ``t_s`` arriving ``h`` later: the
    old command holds over ``[t_s, t_s + h)`` (the averages of the one or two steps it
    overlaps)."""
    uv, uw = base.u_v.copy(), base.u_w.copy()
    a = (t_s - base.t0_s) / base.dt_s
    j0 = math.floor(a)
    for j in (j0, j0 + 1):
        if 0 <= j < uv.size:
            share = max(0.0, min(a + h / base.dt_s, j + 1.0) - max(a, float(j)))
            uv[j] -= dv * share
            uw[j] -= dw * share
    return GridCommands(
        t0_s=base.t0_s,
        dt_s=base.dt_s,
        delay_s=base.delay_s,
        timeout_s=base.timeout_s,
        u_v=uv,
        u_w=uw,
    )


def arrival_sensitivities(prob: Problem, params: DriveParams) -> list[Sensitivity]:
    """Each log's sensitivities of the scaled model outputs to the arrival time of each
    command that changes the target, at ``params`` (forward differences of
    :data:`ARRIVAL_STEP_S`; unwhitened), cut to where they exceed :data:`SUPPORT_SHARE` of
    their peak."""
    out = []
    h = ARRIVAL_STEP_S
    for i, g in enumerate(prob.logs):
        base = prob.grid_commands(i, params)
        n = g.meas_t_s.size
        y0 = prob.scaled_sim_commands(i, params, [base])[0]
        ks = _changes(g.cmd_v, g.cmd_w)
        dv, dw = np.diff(g.cmd_v, prepend=0.0), np.diff(g.cmd_w, prepend=0.0)
        starts, cols_v, cols_w = [], [], []
        for lo in range(0, ks.size, _BATCH):
            batch = ks[lo : lo + _BATCH]
            cmds = [
                _shifted(base, float(g.cmd_t_s[k]) + base.delay_s, dv[k], dw[k], h) for k in batch
            ]
            sens = (prob.scaled_sim_commands(i, params, cmds) - y0) / h
            for row in sens:
                size = np.maximum(np.abs(row[:n]), np.abs(row[n:]))
                peak = float(size.max()) if size.size else 0.0
                if not peak > 0.0:
                    continue
                on = np.flatnonzero(size > SUPPORT_SHARE * peak)
                a, b = int(on[0]), int(on[-1]) + 1
                starts.append(a)
                cols_v.append(row[a:b].copy())
                cols_w.append(row[n + a : n + b].copy())
        out.append(_sorted(n, starts, cols_v, cols_w))
    return out


def _sorted(n: int, starts: list[int], v: list[FloatArray], w: list[FloatArray]) -> Sensitivity:
    """A :class:`Sensitivity` with its commands sorted by the start of their support."""
    order = np.argsort(np.array(starts, dtype=np.intp), kind="stable")
    return Sensitivity(
        n=n,
        start=np.array(starts, dtype=np.intp)[order],
        v=[v[k] for k in order],
        w=[w[k] for k in order],
    )


def _gram(sens: Sensitivity, channel: str) -> FloatArray:
    """The commands' Gram matrix :math:`G_c^T G_c` of one channel in lower banded form
    (``out[d, a]`` = column ``a + d`` times column ``a``; the commands are sorted by the start
    of their support, so each overlaps only the next few)."""
    cols = sens.v if channel == "v" else sens.w
    m = sens.m
    ends = sens.start + np.array([c.size for c in cols], dtype=np.intp)
    pairs: list[tuple[int, int, float]] = []
    width = 0
    for a in range(m):
        b = a
        while b < m and sens.start[b] < ends[a]:
            lo, hi = int(sens.start[b]), int(min(ends[a], ends[b]))
            if hi > lo:
                x = cols[a][lo - sens.start[a] : hi - sens.start[a]]
                y = cols[b][lo - sens.start[b] : hi - sens.start[b]]
                pairs.append((b - a, a, float(x @ y)))
                width = max(width, b - a)
            b += 1
    out = np.zeros((width + 1, m))
    for d, a, value in pairs:
        out[d, a] = value
    return out


def _projection(sens: Sensitivity, f: FloatArray, channel: str) -> FloatArray:
    """:math:`G_c^T f_c` of one channel (``f`` the log's residual rows, v then w)."""
    cols = sens.v if channel == "v" else sens.w
    off = 0 if channel == "v" else sens.n
    return np.array(
        [float(c @ f[off + a : off + a + c.size]) for a, c in zip(sens.start, cols, strict=True)]
    )


@dataclass(frozen=True, kw_only=True)
class JitterEstimate:
    """The arrival-time jitter a fit's residuals show (:func:`estimate_jitter`).

    Attributes
    ----------
    sigma_t_s : float
        Standard deviation of the commands' arrival times about their logged times, s.
    scale_v, scale_w : float
        The white residual scale of each channel (robust), in the fit's scaled units.
    commands : int
        Commands whose arrival moves the response (the ones that change the target).
    spread : float
        Robust scale of the commands' arrival errors estimated from the residuals, each over
        its own standard error: about 1 when the commands arrive on time (the residuals are
        white noise), above it when they do not.
    """

    sigma_t_s: float
    scale_v: float
    scale_w: float
    commands: int
    spread: float

    @property
    def significant(self) -> bool:
        """The residuals show the jitter, and tell it well: :attr:`spread` is above 1 by more
        than twice the sampling error of a robust scale of :attr:`commands` normal draws
        (1.166 / sqrt(m)), and that error is at most 1/6 (at least :data:`MIN_COMMANDS`
        commands change the target: a log that holds a few commands for long says too little
        of a transport's jitter to weigh its transients by it)."""
        m = max(self.commands, 1)
        return (
            self.sigma_t_s > 0.0
            and m >= MIN_COMMANDS
            and self.spread > 1.0 + 2.0 * _MAD_SE / math.sqrt(m)
        )


def estimate_jitter(
    sens: Sequence[Sensitivity], f: FloatArray, max_jitter_s: float = math.inf
) -> JitterEstimate:
    r"""The arrival-time jitter :math:`\sigma_t` the data residuals ``f`` show (the problem's
    layout: per log its v rows, then its w rows), at most ``max_jitter_s``.

    Each channel's white scale is the residuals' robust sd (most samples are not in a
    transient). The commands' arrival errors are estimated jointly by generalised least
    squares on the residuals, :math:`\hat\delta = K^{-1} G^T D^{-1} f` with
    :math:`K = G^T D^{-1} G`, each with its standard error :math:`e_k =
    \sqrt{(K^{-1})_{kk}}`; :math:`\sigma_t` is the value at which
    :math:`\hat\delta_k/\sqrt{\sigma_t^2 + e_k^2}` has a robust scale of 1 (a method of
    moments), then a mean square of 1 over the commands within three of those scales (the
    more efficient moment, the misses of the model left out). Robust, because a few transients the model misses for another reason (a limit,
    a friction it lumps differently) give a few huge :math:`\hat\delta_k`: a Gaussian
    likelihood of all of them puts :math:`\sigma_t` at 3-5x the truth on such plant logs.
    """
    n_v = np.concatenate([f[o : o + s.n] for o, s in zip(_offsets(sens), sens, strict=True)])
    n_w = np.concatenate(
        [f[o + s.n : o + 2 * s.n] for o, s in zip(_offsets(sens), sens, strict=True)]
    )
    s_v = max(robust_sd(n_v), 1e-12) if n_v.size else 1.0
    s_w = max(robust_sd(n_w), 1e-12) if n_w.size else 1.0
    deltas, errors = [], []
    for off, s in zip(_offsets(sens), sens, strict=True):
        if s.m == 0:
            continue
        fl = f[off : off + 2 * s.n]
        k = _dense(_gram(s, "v")) / s_v**2 + _dense(_gram(s, "w")) / s_w**2
        b = _projection(s, fl, "v") / s_v**2 + _projection(s, fl, "w") / s_w**2
        k[np.diag_indices_from(k)] *= 1.0 + 1e-9  # a command the others nearly repeat
        cov = np.linalg.pinv(k, hermitian=True)
        deltas.append(cov @ b)
        errors.append(np.sqrt(np.clip(np.diag(cov), 1e-300, None)))
    m = sum(d.size for d in deltas)
    if m == 0:
        return JitterEstimate(sigma_t_s=0.0, scale_v=s_v, scale_w=s_w, commands=0, spread=0.0)
    delta, err = np.concatenate(deltas), np.concatenate(errors)

    def spread(sigma: float) -> float:
        return robust_sd(delta / np.sqrt(sigma**2 + err**2))

    at_zero = spread(0.0)
    top = min(max_jitter_s, 1.0)
    sigma = 0.0
    if at_zero > 1.0:
        sigma = top if spread(top) > 1.0 else float(brentq(lambda x: spread(x) - 1.0, 0.0, top))
        # then the mean square over the commands within _CUT robust sds (the misses out), the
        # more efficient moment: a normal cut there keeps E z^2 = _CUT_SQUARE
        keep = np.abs(delta) <= _CUT * np.sqrt(sigma**2 + err**2)

        def square(x: float) -> float:
            return float(np.mean(delta[keep] ** 2 / (x**2 + err[keep] ** 2))) - _CUT_SQUARE

        if square(0.0) <= 0.0:
            sigma = 0.0
        else:
            sigma = top if square(top) > 0.0 else float(brentq(square, 0.0, top))
    return JitterEstimate(sigma_t_s=sigma, scale_v=s_v, scale_w=s_w, commands=m, spread=at_zero)


def _dense(band: FloatArray) -> FloatArray:
    """The symmetric matrix of a lower banded form (``band[d, a]`` = entry ``(a + d, a)``)."""
    m = band.shape[1]
    out = np.zeros((m, m))
    for d in range(band.shape[0]):
        idx = np.arange(m - d)
        out[idx + d, idx] = band[d, : m - d]
        out[idx, idx + d] = band[d, : m - d]
    return out


def _offsets(sens: Sequence[Sensitivity]) -> list[int]:
    out, off = [], 0
    for s in sens:
        out.append(off)
        off += 2 * s.n
    return out


@dataclass(frozen=True, kw_only=True)
class _LogFactor:
    """One log's banded Cholesky factor of :math:`\\tilde\\Sigma` over the interleaved
    instants (v, w of instant 0, of instant 1, ...) and its channel scales."""

    n: int
    band: FloatArray  # (bandwidth + 1, 2 n), lower form of scipy.linalg.solve_banded
    lower: int
    scale: FloatArray  # (2 n,) interleaved: s_v, s_w, s_v, ...


@dataclass(frozen=True, kw_only=True)
class Whitener:
    """The map :math:`f \\mapsto D^{1/2} L^{-1} D^{-1/2} f` of each log's residual rows.

    Attributes
    ----------
    key : tuple
        (first time, last time, samples) of each log it was made for.
    n_rows : int
        Residual rows it maps (all logs).
    sigma_t_s : float
        The arrival-time jitter it whitens, s.
    """

    key: tuple[tuple[float, float, int], ...]
    n_rows: int
    sigma_t_s: float
    factors: tuple[_LogFactor, ...]

    @classmethod
    def build(
        cls,
        columns: Sequence[FloatArray],
        *,
        sigma_t_s: float,
        scale_v: float,
        scale_w: float,
        key: tuple[tuple[float, float, int], ...],
    ) -> Whitener:
        """From dense sensitivities (one ``(2 n, m)`` array per log, v rows then w rows)."""
        sens = []
        for g in columns:
            n = g.shape[0] // 2
            starts, cv, cw = [], [], []
            for col in g.T:
                size = np.maximum(np.abs(col[:n]), np.abs(col[n:]))
                on = np.flatnonzero(size > 0.0)
                if not on.size:
                    continue
                a, b = int(on[0]), int(on[-1]) + 1
                starts.append(a)
                cv.append(col[a:b].copy())
                cw.append(col[n + a : n + b].copy())
            sens.append(_sorted(n, starts, cv, cw))
        return cls.of(sens, sigma_t_s=sigma_t_s, scale_v=scale_v, scale_w=scale_w, key=key)

    @classmethod
    def of(
        cls,
        sens: Sequence[Sensitivity],
        *,
        sigma_t_s: float,
        scale_v: float,
        scale_w: float,
        key: tuple[tuple[float, float, int], ...],
    ) -> Whitener:
        """From the cut sensitivities of :func:`arrival_sensitivities`."""
        factors = tuple(_factor(s, sigma_t_s, scale_v, scale_w) for s in sens)
        return cls(
            key=key,
            n_rows=sum(2 * s.n for s in sens),
            sigma_t_s=sigma_t_s,
            factors=factors,
        )

    def apply(self, x: FloatArray) -> FloatArray:
        """The whitened rows of ``x`` (last axis: the residual rows of every log)."""
        x = np.asarray(x, dtype=np.float64)
        out = np.empty_like(x)
        off = 0
        for fac in self.factors:
            n = fac.n
            block = x[..., off : off + 2 * n]
            inter = np.empty_like(block)
            inter[..., 0::2], inter[..., 1::2] = block[..., :n], block[..., n:]
            rhs = (inter / fac.scale).reshape(-1, 2 * n).T
            y = solve_banded((fac.lower, 0), fac.band, rhs, check_finite=False)
            y = (y.T * fac.scale).reshape(inter.shape)
            out[..., off : off + n], out[..., off + n : off + 2 * n] = y[..., 0::2], y[..., 1::2]
            off += 2 * n
        return out


def _factor(sens: Sensitivity, sigma_t: float, s_v: float, s_w: float) -> _LogFactor:
    """The banded Cholesky factor of :math:`I + \\sigma_t^2 \\tilde G \\tilde G^T` (interleaved
    instants, :math:`\\tilde G = D^{-1/2} G`)."""
    n = sens.n
    scale = np.tile([s_v, s_w], n)
    lower = 1
    for a, c in zip(sens.start, sens.v, strict=True):
        del a
        lower = max(lower, 2 * c.size - 1)
    band = np.zeros((lower + 1, 2 * n))
    band[0] = 1.0
    for a, cv, cw in zip(sens.start, sens.v, sens.w, strict=True):
        col = np.empty(2 * cv.size)
        col[0::2], col[1::2] = sigma_t * cv / s_v, sigma_t * cw / s_w
        r0 = 2 * int(a)
        for d in range(col.size):
            band[d, r0 : r0 + col.size - d] += col[d:] * col[: col.size - d]
    chol = cholesky_banded(band, lower=True, check_finite=False)
    return _LogFactor(n=n, band=chol, lower=lower, scale=scale)


def arrival_whitener(
    prob: Problem, params: DriveParams, f: FloatArray
) -> tuple[JitterEstimate, Whitener | None]:
    """The arrival-time jitter that the residuals ``f`` (unwhitened) of ``prob`` at ``params``
    show, and the whitening of it; None when it is not significant
    (:attr:`JitterEstimate.significant`), within the model's step ``prob.dt_s`` (the step's
    own error moves each response by up to a step: a jitter that small is not told from it),
    or at its bound, half the command period (an ordered link cannot move commands that far:
    the residuals are something the linearised timing does not explain)."""
    sens = arrival_sensitivities(prob, params)
    period = _command_period(prob.logs)
    est = estimate_jitter(sens, f, max_jitter_s=0.5 * period)
    if not (est.significant and prob.dt_s < est.sigma_t_s < 0.5 * period):
        return est, None
    return est, Whitener.of(
        sens,
        sigma_t_s=est.sigma_t_s,
        scale_v=est.scale_v,
        scale_w=est.scale_w,
        key=logs_key(prob.logs),
    )


def _command_period(logs: Sequence[LogArrays]) -> float:
    """The median interval between the logs' commands, s (inf with fewer than two).

    A transport that keeps the commands in order (one link, one queue) cannot move one by much
    more than the interval to its neighbours: the jitter is bounded at half of it, where a
    normal error would swap about one pair in three.
    """
    gaps = np.concatenate([np.diff(g.cmd_t_s) for g in logs] or [np.zeros(0)])
    gaps = gaps[gaps > 0]
    return float(np.median(gaps)) if gaps.size else math.inf


def logs_key(logs: Sequence[LogArrays]) -> tuple[tuple[float, float, int], ...]:
    """(first time, last time, samples) of each log: what a :class:`Whitener` was made for."""
    return tuple((float(g.meas_t_s[0]), float(g.meas_t_s[-1]), int(g.meas_t_s.size)) for g in logs)
