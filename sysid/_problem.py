r"""The MAP least-squares problem: data residuals, prior residuals, a structured FD Jacobian.

The residual vector stacks the scaled output errors of every log (v then w, log by log) and,
after them, one row per informative prior: :math:`w_p (z - \mu)/\sigma` with :math:`w_p` the
data residuals' noise scale (so that the sum of squares is, up to a factor, the negative log
posterior: regularised least squares).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robots.arrays import FloatArray
from robots.measurement import yaw_reading_factor
from robots.params import DriveParams
from robots.reduced import GridCommands, ReducedResponse, pack_params, simulate_grid
from sysid._coords import COORDS, Mapper
from sysid._logs import LogArrays

if TYPE_CHECKING:
    from sysid._timing import Whitener

__all__ = ["ARRIVAL_NODES", "QUANTISED_LEVELS_SHARE", "Problem", "initial_state", "quantised"]


#: Grid commands (:class:`robots.reduced.GridCommands`) kept per log, most recent first.
_CACHED_GRIDS = 4

#: A channel whose nonzero readings take at most this share of distinct values is quantised.
QUANTISED_LEVELS_SHARE = 0.5
#: Fewer nonzero readings than this say nothing of a grid.
_QUANTISED_MIN_READINGS = 20


def quantised(readings: FloatArray) -> bool:
    """Whether a channel's readings lie on a grid of levels: a quantised encoder's speed.

    An encoder's speed is its tick count over a fixed period times a constant, so its
    readings repeat a few levels exactly (the Warthog's and the Husky's wheel speeds: 118
    distinct values in 443 nonzero readings, 77 in 4896), and every speed under one tick per
    period reads exactly zero. A continuous reading (a displacement over a jittered time
    step, a filtered estimate, a gyro's rate) almost never repeats to the last bit (the
    Neato driver's twist: 238 distinct values in 238). True when the nonzero finite readings
    (at least :data:`_QUANTISED_MIN_READINGS`) take at most :data:`QUANTISED_LEVELS_SHARE`
    of their number of distinct values.

    Examples
    --------
    >>> tick = 0.01
    >>> quantised(tick * np.round(np.linspace(-1.0, 1.0, 1000) / tick))
    True
    >>> quantised(np.linspace(0.013, 1.0, 200))
    False
    """
    x = np.asarray(readings, dtype=np.float64)
    x = x[np.isfinite(x) & (x != 0.0)]
    if x.size < _QUANTISED_MIN_READINGS:
        return False
    return np.unique(x).size <= QUANTISED_LEVELS_SHARE * x.size


def initial_state(log: LogArrays) -> tuple[float, float]:
    """Robust (v, w) at the first measurement: median of the first three samples."""
    return float(np.median(log.meas_v[:3])), float(np.median(log.meas_w[:3]))


@dataclass(frozen=True)
class _Reads:
    """How the model is read on one log: query times, and the maps from the model's v and w
    at those times to the measured ones (None: the query times are the measurement times)."""

    t_query: FloatArray
    v: Callable[[FloatArray], FloatArray] | None = None
    w: Callable[[FloatArray], FloatArray] | None = None

    def apply(self, rv: FloatArray, rw: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The measured (v, w) of the model's (v, w) at the query times."""
        return (rv if self.v is None else self.v(rv)), (rw if self.w is None else self.w(rw))


def _reads(log: LogArrays, window_s: float) -> _Reads:
    """The log's measurement operator (:mod:`robots.measurement`) when it has one; else v as
    the mean over the preceding ``window_s`` (Simpson's rule on [t - W, t - W/2, t]; 0 = the
    instantaneous velocity) and w instantaneous."""
    t_s = log.meas_t_s
    if log.measurement is not None:
        op = log.measurement.operator(t_s)
        return _Reads(op.t_query, op.apply, op.apply)
    if window_s <= 0:
        return _Reads(t_s)
    tq, inv = np.unique(
        np.concatenate([t_s - window_s, t_s - 0.5 * window_s, t_s]), return_inverse=True
    )
    n = t_s.size
    lo, mid, hi = inv[:n], inv[n : 2 * n], inv[2 * n :]

    def v_mean(rv: FloatArray) -> FloatArray:
        out: FloatArray = (rv[..., lo] + 4.0 * rv[..., mid] + rv[..., hi]) / 6.0
        return out

    def w_at(rw: FloatArray) -> FloatArray:
        out: FloatArray = rw[..., hi]
        return out

    return _Reads(tq, v_mean, w_at)


class Problem:
    """Residuals ``(sim - meas) * weight / scale`` of v and w at every measurement time.

    Parameters
    ----------
    logs : sequence of LogArrays
        Fitting logs (each simulated from its own commands, starting at its first sample).
    mapper : Mapper
        Coordinate <-> DriveParams map (geometry and motor-gain prior).
    free : sequence of str
        Fields whose coordinates form the vector ``x``.
    ties : dict
        ``{field: source field}`` equalities.
    scale_v, scale_w : float
        Residual scales, m/s and rad/s (e.g. the agreement tolerances).
    weight_v, weight_w : float
        Extra channel weights.
    dt_s : float
        Integration step of the reduced model, s.
    v_window_s : float
        Odometry v is the mean over this preceding window (encoder tick differences), s;
        0 = instantaneous.
    python : bool
        Use the plain-Python model loop (benchmark baseline).
    w_source : {"imu", "wheels"}
        Where the logs' yaw rate comes from: the model's body rate is read times
        :func:`robots.measurement.yaw_reading_factor` (effective over driver's track for wheel
        encoders).
    """

    def __init__(
        self,
        logs: Sequence[LogArrays],
        mapper: Mapper,
        free: Sequence[str],
        ties: dict[str, str],
        *,
        scale_v: float,
        scale_w: float,
        weight_v: float = 1.0,
        weight_w: float = 1.0,
        dt_s: float,
        python: bool = False,
        v_window_s: float = 0.0,
        on_eval: Callable[[int], None] | None = None,
        prior_weight: float = 1.0,
        w_source: str = "imu",
        timing: Whitener | None = None,
    ) -> None:
        yaw_reading_factor(w_source, DriveParams())  # a known source, or one sentence
        self.logs = list(logs)
        self.mapper = mapper
        self.free = tuple(free)
        self.ties = dict(ties)
        self.gain_v = weight_v / scale_v
        self.gain_w = weight_w / scale_w
        self.dt_s = dt_s
        self.python = python
        self.v_window_s = v_window_s
        self.w_source = w_source
        self._queries = [_reads(g, v_window_s) for g in self.logs]
        self.on_eval = on_eval
        self.n_evals = 0
        self.n_steps = 0  # model integration steps run (for the benchmark's accounting)
        self._steps_per_sim = sum(
            max(1, math.ceil(float(g.meas_t_s[-1] - g.meas_t_s[0]) / dt_s)) for g in logs
        )
        self._starts = [initial_state(g) for g in self.logs]
        self._grid_cache: dict[tuple[int, float, float], GridCommands] = {}
        self.rows, self.n_rows = _residual_rows(self.logs)
        self._raw_meas = np.concatenate(
            [np.concatenate([g.meas_v * self.gain_v, g.meas_w * self.gain_w]) for g in self.logs]
        )
        self.meas = self._raw_meas
        #: the whitening of the commands' arrival-time jitter (:mod:`sysid._timing`), or None
        self.timing: Whitener | None = None
        self.set_timing(timing)
        #: rows of a quantised channel (:func:`quantised`), where an exact zero is the grid's
        self.quantised = np.concatenate(
            [np.repeat([quantised(g.meas_v), quantised(g.meas_w)], g.meas_t_s.size) for g in logs]
            or [np.zeros(0, dtype=bool)]
        )
        self._cache_x: FloatArray | None = None
        self._cache_f: FloatArray | None = None
        priors = [mapper.prior(f) for f in self.free]
        #: coordinates with an informative prior, their prior means and sds
        self.prior_idx = np.array([j for j, p in enumerate(priors) if p is not None], dtype=np.intp)
        self.prior_mu = np.array([p[0] for p in priors if p is not None])
        self.prior_sd = np.array([p[1] for p in priors if p is not None])
        #: scale of the prior rows (the data residuals' noise level; set by the fit)
        self.prior_weight = prior_weight
        self._settings = {
            "scale_v": scale_v,
            "scale_w": scale_w,
            "weight_v": weight_v,
            "weight_w": weight_w,
            "dt_s": dt_s,
            "python": python,
            "v_window_s": v_window_s,
            "w_source": w_source,
        }

    def set_timing(self, timing: Whitener | None) -> None:
        """Whiten the data residuals for the commands' arrival-time jitter (``timing``, made
        for these logs by :func:`sysid._timing.arrival_whitener`), or not (None): the model
        outputs and the measurements are both mapped, so every residual, Jacobian and cost
        of the problem is the whitened one."""
        if timing is not None and timing.key != tuple(
            (float(g.meas_t_s[0]), float(g.meas_t_s[-1]), int(g.meas_t_s.size)) for g in self.logs
        ):
            timing = None  # made for other logs (a crop, a window)
        self.timing = timing
        self.meas = self._raw_meas if timing is None else timing.apply(self._raw_meas)
        self._cache_x = self._cache_f = None

    def subset(self, free: Sequence[str]) -> Problem:
        """The same problem over fewer coordinates (the others at the base values)."""
        ties = {k: v for k, v in self.ties.items() if v in free}
        out = Problem(
            self.logs,
            self.mapper,
            free,
            ties,
            on_eval=self.on_eval,
            prior_weight=self.prior_weight,
            timing=self.timing,
            **self._settings,  # type: ignore[arg-type]
        )
        out._grid_cache = self._grid_cache  # same logs, same grid
        return out

    def like(self, logs: Sequence[LogArrays]) -> Problem:
        """The same problem (coordinates, settings, prior weight) on other logs."""
        return Problem(
            logs,
            self.mapper,
            self.free,
            self.ties,
            on_eval=self.on_eval,
            prior_weight=self.prior_weight,
            **self._settings,  # type: ignore[arg-type]
        )

    @property
    def n_data(self) -> int:
        """Number of data residual rows (the prior rows follow)."""
        return self.n_rows

    @property
    def lower(self) -> FloatArray:
        """Lower bounds of the internal coordinates."""
        return np.array([COORDS[f].lower for f in self.free])

    @property
    def upper(self) -> FloatArray:
        """Upper bounds of the internal coordinates."""
        return np.array([COORDS[f].upper for f in self.free])

    def schema_coords(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Schema coordinates z of the free fields at internal ``x``, and dz/dx."""
        return self.mapper.schema_coords(self.free, self.ties, x)

    def prior_residuals(self, x: FloatArray) -> FloatArray:
        r""":math:`w_p (z - \mu)/\sigma` of the fields with an informative prior."""
        if not self.prior_idx.size:
            return np.zeros(0)
        params = self.params(x)
        z = np.array([self.mapper.z(params, self.free[j]) for j in self.prior_idx])
        out: FloatArray = self.prior_weight * (z - self.prior_mu) / self.prior_sd
        return out

    def prior_jacobian(self, x: FloatArray) -> FloatArray:
        """Jacobian of :meth:`prior_residuals` (no simulation: the coordinate map only)."""
        if not self.prior_idx.size:
            return np.zeros((0, len(self.free)))
        _, g = self.schema_coords(x)
        out: FloatArray = (self.prior_weight / self.prior_sd)[:, None] * g[self.prior_idx]
        return out

    def _gain_is_invisible(self) -> bool:
        """With every other internal coordinate held, the motor gain does not change the
        response (no fixed finite torque cap): its data column is exactly zero."""
        return "wheel_torque_max_nm" in self.free or math.isinf(
            self.mapper.base.wheel_torque_max_nm
        )

    def params(self, x: FloatArray) -> DriveParams:
        """DriveParams at coordinate vector ``x``."""
        return self.mapper.from_coords(dict(zip(self.free, map(float, x), strict=True)), self.ties)

    def simulate(self, params: DriveParams) -> list[ReducedResponse]:
        """Model response at every log's measurement times.

        With ``v_window_s > 0`` the reported v is the mean over the preceding window (Simpson's
        rule), as wheel-encoder odometry reports it (tick difference over one odometry
        period); w stays instantaneous, read by :func:`robots.measurement.yaw_reading_factor`.
        """
        return [
            ReducedResponse(t_s=g.meas_t_s, v=v[0], w=w[0])
            for g, (v, w) in zip(self.logs, self._simulate_many([params]), strict=True)
        ]

    def _simulate_many(self, params: Sequence[DriveParams]) -> list[tuple[FloatArray, FloatArray]]:
        """v and w, shape ``(len(params), samples)``, of each log for each parameter set.

        Sub-step delay as an exact time shift: each set is simulated with its delay rounded
        down to the grid and read ``f = delay - k dt`` earlier. With an active rate limiter the
        model's response is otherwise a staircase in the delay (the limiter moves a full
        a dt per step whatever part of the step the new command covers), which breaks the
        finite-difference Jacobian. The system is time-invariant, so both are the same model
        up to the step's own timing resolution. The grid stays anchored one step before each
        log's first query, so the command averages over its steps are computed once per log
        (:class:`robots.reduced.GridCommands`) and every set of one call runs in one compiled
        call (:func:`robots.reduced.simulate_grid`).
        """
        self.n_steps += self._steps_per_sim * len(params)
        steps = np.array([math.floor(p.delay_s / self.dt_s + 1e-9) for p in params], dtype=np.int64)
        delays = [(p.delay_s, k) for p, k in zip(params, steps.tolist(), strict=True)]
        shifts = np.array([d - k * self.dt_s for d, k in delays])
        gains = np.array([yaw_reading_factor(self.w_source, p) for p in params])
        out = []
        for i, reads in enumerate(self._queries):
            v, w = self._simulate_log(i, params, steps, shifts, gains)
            out.append(reads.apply(v, w * gains[:, None]))
        return out

    def _grid(self, i: int) -> tuple[float, int]:
        """Log ``i``'s grid start (one step before its first query time: the grid does not
        move with the sub-step delay) and the steps that reach its last query."""
        t_query = self._queries[i].t_query
        t0 = float(t_query[0]) - self.dt_s
        return t0, max(1, math.ceil((float(t_query[-1]) - t0) / self.dt_s))

    def _simulate_log(
        self,
        i: int,
        params: Sequence[DriveParams],
        steps: NDArray[np.int64],
        shifts: FloatArray,
        gains: FloatArray,
    ) -> tuple[FloatArray, FloatArray]:
        """Body v and w of log ``i`` at its query times for each parameter set, each started
        at the body yaw rate its reading ``gains`` (:func:`yaw_reading_factor`) gives."""
        t0, n = self._grid(i)
        t_query = self._queries[i].t_query
        v0, w0 = self._starts[i]
        geo = self.mapper.geometry
        cmds = [
            self._commands(i, t0, n, int(k) * self.dt_s, p.cmd_timeout_s)
            for p, k in zip(params, steps.tolist(), strict=True)
        ]
        packed = np.stack([pack_params(p, geo) for p in params])
        w0s = w0 / gains
        return simulate_grid(cmds, packed, t_query, shifts, v0=v0, w0=w0s, python=self.python)

    def _commands(
        self, i: int, t0: float, n: int, delay_s: float, timeout_s: float
    ) -> GridCommands:
        """Log ``i``'s grid commands for a delay and timeout (the last few are kept: a
        Jacobian's columns share all but at most one delay)."""
        key = (i, delay_s, timeout_s)
        cmds = self._grid_cache.pop(key, None)
        if cmds is None:
            g = self.logs[i]
            cmds = GridCommands.build(
                g.cmd_t_s,
                g.cmd_v,
                g.cmd_w,
                t0_s=t0,
                dt_s=self.dt_s,
                n=n,
                delay_s=delay_s,
                timeout_s=timeout_s,
            )
        self._grid_cache[key] = cmds  # most recently used last
        while len(self._grid_cache) > _CACHED_GRIDS * len(self.logs):
            del self._grid_cache[next(iter(self._grid_cache))]
        return cmds

    def scaled_sim(self, params: DriveParams) -> FloatArray:
        """Scaled model outputs stacked like the residuals."""
        out: FloatArray = self.scaled_sim_many([params])[0]
        return out

    def scaled_sim_many(self, params: Sequence[DriveParams]) -> FloatArray:
        r""":meth:`scaled_sim` of each parameter set, one row each (one compiled call per log).

        With a whitening of the commands' arrival-time jitter (:meth:`set_timing`) each row is
        the expected response over that jitter, then whitened: the commands reach the base
        ``delay_s`` late on average and :math:`\sigma_t` about it, so the data's mean is the
        response averaged over the arrival time, not the response at the mean arrival
        (errors in the input are not only a variance: a transient averaged over its timing is
        slower and starts earlier, which a model without the average reads as a shorter delay
        and more damping). Each transient moves with its own command's arrival, so the average
        over a shift of all of them is the expected response where transients do not overlap
        within the jitter: three-point Gauss-Hermite over the delay,
        :math:`\tfrac23 y(d) + \tfrac16 y(d \pm \sqrt3 \sigma_t)` (exact for a response
        polynomial up to fifth degree in the arrival time; no arrival before the send).
        """
        nodes = _arrival_nodes(0.0 if self.timing is None else self.timing.sigma_t_s)
        expanded = [p.replace(delay_s=max(p.delay_s + d, 0.0)) for p in params for d, _ in nodes]
        sims = self._simulate_many(expanded if len(nodes) > 1 else params)
        out = np.concatenate(
            [np.concatenate([v * self.gain_v, w * self.gain_w], axis=1) for v, w in sims], axis=1
        )
        if len(nodes) > 1:
            weights = np.array([w for _, w in nodes])
            out = np.einsum("pkn,k->pn", out.reshape(len(params), len(nodes), -1), weights)
        return out if self.timing is None else self.timing.apply(out)

    def grid_commands(self, i: int, params: DriveParams) -> GridCommands:
        """Log ``i``'s grid commands at ``params``' delay (whole steps) and timeout."""
        t0, n = self._grid(i)
        k = math.floor(params.delay_s / self.dt_s + 1e-9)
        return self._commands(i, t0, n, k * self.dt_s, params.cmd_timeout_s)

    def scaled_sim_commands(
        self, i: int, params: DriveParams, commands: Sequence[GridCommands]
    ) -> FloatArray:
        """Log ``i``'s scaled model outputs (its v rows then its w rows, unwhitened), one row
        per grid command set (each on :meth:`grid_commands`' grid) at ``params``: one
        compiled call."""
        k = math.floor(params.delay_s / self.dt_s + 1e-9)
        shift = params.delay_s - k * self.dt_s
        gain = yaw_reading_factor(self.w_source, params)
        v0, w0 = self._starts[i]
        reads = self._queries[i]
        packed = np.repeat(pack_params(params, self.mapper.geometry)[None, :], len(commands), 0)
        v, w = simulate_grid(
            list(commands),
            packed,
            reads.t_query,
            np.full(len(commands), shift),
            v0=v0,
            w0=w0 / gain,
            python=self.python,
        )
        v, w = reads.apply(v, w * gain)
        out: FloatArray = np.concatenate([v * self.gain_v, w * self.gain_w], axis=1)
        return out

    def data_residuals(self, x: FloatArray) -> FloatArray:
        """Scaled output errors at ``x`` (cached for the Jacobian)."""
        if (
            self._cache_f is not None
            and self._cache_x is not None
            and np.array_equal(x, self._cache_x)
        ):
            return self._cache_f
        f = self.scaled_sim(self.params(x)) - self.meas
        self._cache_x, self._cache_f = np.array(x, dtype=np.float64), f
        self.n_evals += 1
        if self.on_eval is not None:
            self.on_eval(self.n_evals)
        return f

    def residuals(self, x: FloatArray) -> FloatArray:
        """Data residuals followed by the prior residuals."""
        return np.concatenate([self.data_residuals(x), self.prior_residuals(x)])

    def groups(self, coupled: bool) -> list[list[int]]:
        """Columns perturbed together: a forward-axis and a yaw-axis coordinate share one
        simulation when the axes are decoupled (no active wheel-speed or torque cap), because
        each then only moves its own channel's residuals."""
        if coupled:
            skip = "motor_gain_nms_per_rad" if self._gain_is_invisible() else ""
            return [[j] for j, f in enumerate(self.free) if f != skip]
        v = [j for j, f in enumerate(self.free) if COORDS[f].axis == "v"]
        w = [j for j, f in enumerate(self.free) if COORDS[f].axis == "w"]
        skip = "motor_gain_nms_per_rad" if self._gain_is_invisible() else ""
        shared = [[j] for j, f in enumerate(self.free) if COORDS[f].axis == "vw" and f != skip]
        pairs = [[a, b] for a, b in zip(v, w, strict=False)]
        rest = [[j] for j in (v[len(w) :] if len(v) > len(w) else w[len(v) :])]
        return shared + pairs + rest

    def jacobian(self, x: FloatArray, coupled: bool) -> FloatArray:
        """Jacobian of :meth:`residuals`: forward differences with grouped columns (see
        :meth:`groups`) for the data rows, exact for the prior rows."""
        return np.concatenate([self.data_jacobian(x, coupled), self.prior_jacobian(x)])

    def data_jacobian(self, x: FloatArray, coupled: bool) -> FloatArray:
        """Forward-difference Jacobian of :meth:`data_residuals` (every column simulated in
        one compiled call per log)."""
        f0 = self.data_residuals(x)
        jac = np.zeros((self.n_rows, len(self.free)))
        lo, hi = self.lower, self.upper
        columns: list[dict[int, float]] = []
        points = []
        for group in self.groups(coupled):
            xp = np.array(x, dtype=np.float64)
            steps = {}
            for j in group:
                h = COORDS[self.free[j]].step
                if xp[j] + h > hi[j]:
                    h = -h
                if xp[j] + h < lo[j]:
                    h = 0.5 * (hi[j] - lo[j]) * 1e-3
                xp[j] += h
                steps[j] = h
            columns.append(steps)
            points.append(self.params(xp))
        if not points:
            return jac
        fps = self.scaled_sim_many(points) - self.meas
        for group, steps, fp in zip(self.groups(coupled), columns, fps, strict=True):
            self.n_evals += 1
            if self.on_eval is not None:
                self.on_eval(self.n_evals)
            for j, h in steps.items():
                if len(group) == 1:  # every row (a slice: no gather)
                    jac[:, j] = (fp - f0) / h
                    continue
                rows = self.rows[COORDS[self.free[j]].axis]
                jac[rows, j] = (fp[rows] - f0[rows]) / h
        return jac


#: Gauss-Hermite nodes of the expected response over the commands' arrival-time jitter.
ARRIVAL_NODES = 3


def _arrival_nodes(sigma_t_s: float) -> list[tuple[float, float]]:
    """(delay shift s, weight) of the Gauss-Hermite rule of :data:`ARRIVAL_NODES` nodes for a
    normal arrival time of sd ``sigma_t_s`` (one node of weight 1 at no jitter)."""
    if not sigma_t_s > 0.0:
        return [(0.0, 1.0)]
    x, w = np.polynomial.hermite_e.hermegauss(ARRIVAL_NODES)
    return [(sigma_t_s * float(a), float(b)) for a, b in zip(x, w / w.sum(), strict=True)]


def _residual_rows(logs: Sequence[LogArrays]) -> tuple[dict[str, NDArray[np.int64]], int]:
    """The data residual rows of each channel ("v", "w", both "vw") and their number: each
    log's v rows, then its w rows, log after log."""
    rows_v, rows_w, offset = [], [], 0
    for g in logs:
        n = g.meas_t_s.size
        rows_v.append(np.arange(offset, offset + n))
        rows_w.append(np.arange(offset + n, offset + 2 * n))
        offset += 2 * n
    rows = {"v": np.concatenate(rows_v), "w": np.concatenate(rows_w), "vw": np.arange(offset)}
    return rows, offset
