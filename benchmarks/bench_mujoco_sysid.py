"""Benchmark: ``sim2real sysid fit`` against MuJoCo's own system identification, ``mujoco.sysid``.

Both fitters get the same recording of each base of the real development set (the bases, fit
recordings and windows of ``bench_real.py``; no calibration recording), and both fits are
checked by replay in MuJoCo on the recordings of ``bench_real.py`` that neither fit used,
scored by one scorer (``sim2real.agreement``: the log's measurement operator or odometry window,
the agreement tolerances, the 90 % band of 30 robots).

- **ours**: ``sim2real sysid fit FIT --robot SPEC [--window]`` as a user runs it (the fit time
  is the whole command: wall and CPU, interpreter start-up included), replayed with
  ``agree --engine mujoco``'s replay and ensemble (the params file's randomisation block).
- **mujoco.sysid**: the exported model of the spec's defaults (``robots.mjcf.mjcf_text``, what
  ``robots export`` writes) with two odometry sensors added (``tendonvel`` of the ``forward``
  and ``yaw`` tendons: the wheels' v and yaw rate). Controls: the wheel speed targets of the
  logged commands as the exported model's controller computes them with the spec's defaults
  and no delay (``MujocoDrive``: clamp, rate limits, both wheels scaled to a cap that is a
  parameter, through its ``custom_rollout`` hook), on the ``wheel_*_speed`` velocity actuators
  (segments standing still are left out: its normalised residual is 0/0 there). Parameters
  (start: the spec's defaults, as for ``sysid fit``): that wheel-speed cap (and ``ctrlrange``),
  ``kv``, joint ``actuatorfrcrange`` (each [x/20, 20x]) and
  ``armature``, ``damping`` and ``frictionloss`` of the two tendons (from 0 to a force of
  the robot's weight, or its weight across the track), and a signal delay on both sensors
  with its ``SignalTransform.delay`` modifier [0, 0.5] s. ``sysid.optimize`` (its default
  ``mujoco`` least squares, normalised residual, 50 iterations at most), then
  ``sysid.calculate_intervals`` at the optimum. Its band: 30 draws of its parameter
  covariance (clipped to the bounds) replayed, plus white noise of the fit's residual standard
  deviation per axis (a least-squares prediction interval). The fit time is that of the
  fitting code in this process.

One table per base (per checked recording: agreement, band coverage and median width, both
fitters), then a summary: mean agreement and coverage per base and fitter, fit times, and
whether ours is at least theirs at no more fit time.

``--quick``: the Neato only (its fit recording is 27 s), one checked recording, 4 robots a band,
3 iterations at most for mujoco.sysid (the test of this script runs it: every row and figure
is produced, none is a measurement).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import resource
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from _timing import record
from bench_real import BASES, REALDATA, Base, cli, log_path, spec_file

from robots.units import GRAVITY_MPS2

ENSEMBLE_N = 30
QUICK = {"base": "neato", "checks": 1, "ensemble": 4, "iters": 3}
DELAY_MAX_S = 0.5
SENSORS = (("odom_v", "forward"), ("odom_w", "yaw"))


def _window(text: str) -> tuple[float, float] | None:
    if not text:
        return None
    a, b = (float(x) for x in text.split(":"))
    return a, b


def _timed_fit(fit: Path, robot: str, out: Path, window: str) -> tuple[float, float]:
    """``sysid fit`` as a user runs it: (wall s, CPU s of the command)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    cli("sysid", "fit", str(fit), "--robot", robot, "-o", str(out),
        *(("--window", window) if window else ()))  # fmt: skip
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


class PeerModel:
    """The exported model as mujoco.sysid fits it, and its replay (a ``ReplayEngine``).

    ``params`` is the mujoco.sysid ``ParameterDict``; :meth:`set_vector` compiles the model
    of a parameter vector (mujoco.sysid's ``apply_param_modifiers``, as its residual does).
    """

    name = "mujoco.sysid"

    def __init__(self, spec: Any) -> None:
        import mujoco
        from mujoco import sysid

        from robots._kernel import pack_params
        from robots.mjcf import mjcf_text

        self.mj, self.sysid, self.spec = mujoco, sysid, spec
        self.mjspec = mujoco.MjSpec.from_string(mjcf_text(spec, spec.drive))
        for name, tendon in SENSORS:
            sensor = self.mjspec.add_sensor()
            sensor.name, sensor.type = name, mujoco.mjtSensor.mjSENS_TENDONVEL
            sensor.objtype, sensor.objname = mujoco.mjtObj.mjOBJ_TENDON, tendon
        self.params = self._parameters()
        self.model = self.mjspec.compile()
        self.data = mujoco.MjData(self.model)
        # the targets before the actuators' ctrlrange (a fitted parameter) clamps each wheel
        self._packed = pack_params(
            spec.drive.replace(wheel_speed_max_radps=math.inf), spec.geometry
        )

    def _parameters(self) -> Any:
        sysid, spec, d = self.sysid, self.spec, self.spec.drive
        weight_n = d.total_mass_kg(spec.geometry) * GRAVITY_MPS2
        sep = spec.wheels.separation_m

        def per_wheel(kind: str, edit: Any) -> Any:
            def apply(s: Any, p: Any) -> None:
                for side in ("left", "right"):
                    edit(
                        getattr(s, kind)(
                            f"wheel_{side}_{'speed' if kind == 'actuator' else 'joint'}"
                        ),
                        p.value[0],
                    )

            return apply

        def set_kv(a: Any, k: float) -> None:
            a.gainprm[0], a.biasprm[2] = k, -k

        def on_tendon(tendon: str, attr: str) -> Any:
            def apply(s: Any, p: Any) -> None:
                t = s.tendon(tendon)
                values = np.array(getattr(t, attr), dtype=float).ravel()
                values[0] = p.value[0]
                setattr(t, attr, values if values.size > 1 else float(values[0]))

            return apply

        kv, cap, top = d.motor_gain_nms_per_rad, d.wheel_torque_max_nm, d.wheel_speed_max_radps
        top = top if math.isfinite(top) else spec.max_v_mps / spec.wheels.radius_m
        rows = (
            ("kv", kv, kv / 20, kv * 20, per_wheel("actuator", set_kv)),
            ("speed_cap", top, top / 20, top * 20,
             per_wheel("actuator", lambda a, c: setattr(a, "ctrlrange", [-c, c]))),
            ("torque_cap", cap, cap / 20, cap * 20,
             per_wheel("joint", lambda j, c: setattr(j, "actfrcrange", [-c, c]))),
            ("armature", 0.0, 0.0, 100.0 * spec.wheels.spin_inertia_kgm2,
             per_wheel("joint", lambda j, a: setattr(j, "armature", a))),
            ("fwd_damping", d.viscous_v_ns_per_m, 0.0, weight_n, on_tendon("forward", "damping")),
            ("fwd_frictionloss", d.coulomb_v_fwd_n, 0.0, weight_n,
             on_tendon("forward", "frictionloss")),
            ("yaw_damping", d.viscous_w_nms_per_rad, 0.0, weight_n * sep,
             on_tendon("yaw", "damping")),
            ("yaw_frictionloss", d.coulomb_w_nm, 0.0, weight_n * sep,
             on_tendon("yaw", "frictionloss")),
            ("delay_s", 0.1, 0.0, DELAY_MAX_S, None),
        )  # fmt: skip
        params = sysid.ParameterDict()
        for name, start, lo, hi, modifier in rows:
            params.add(sysid.Parameter(name, min(max(start, lo), hi), lo, hi, modifier=modifier))
        params.move_off_bounds()
        return params

    def set_vector(self, x: Any) -> None:
        """Compile the model of parameter vector ``x`` (in place of the current one)."""
        self.params.update_from_vector(np.asarray(x, dtype=np.float64))
        self.model = self.sysid.apply_param_modifiers(self.params, self.mjspec)

    @property
    def delay_s(self) -> float:
        return float(self.params["delay_s"].value[0])

    def _run(
        self, cmd: Any, t0: float, t_end: float, start: tuple[float, float]
    ) -> tuple[Any, Any, Any]:
        """(initial state, controls on the model's grid from ``t0``, grid) of a run."""
        from robots.reduced import delayed_step_average
        from sim2real.mujoco import _wheel_targets

        dt, d, spec = float(self.model.opt.timestep), self.spec.drive, self.spec
        n = max(1, math.ceil((t_end - t0) / dt))
        grid = t0 + dt * np.arange(n + 1, dtype=np.float64)
        kw = {"delay_s": 0.0, "timeout_s": d.cmd_timeout_s}
        u_v = delayed_step_average(cmd[0], cmd[1], grid, dt, **kw)
        u_w = delayed_step_average(cmd[0], cmd[2], grid, dt, **kw)
        targets = _wheel_targets(u_v, u_w, start[0], start[1], dt, self._packed)
        ctrl = np.zeros((n + 1, self.model.nu))
        ctrl[:, :2] = targets[:, :2]  # (left, right); column 2 flags a new move
        v0, w0 = start
        r, half = spec.wheels.radius_m, 0.5 * spec.wheels.separation_m
        qpos = np.zeros(self.model.nq)
        qpos[2], qpos[3] = spec.base_link_height_m, 1.0
        qvel = np.zeros(self.model.nv)
        qvel[0], qvel[5] = v0, w0
        qvel[6], qvel[7] = (v0 - w0 * half) / r, (v0 + w0 * half) / r
        return self.sysid.create_initial_state(self.model, qpos, qvel), ctrl, grid

    def sequences(self, traces: list[Any]) -> Any:
        """mujoco.sysid's ``ModelSequences`` of the segments of ``traces`` (its measured data)."""
        sysid = self.sysid
        states, controls, measured = [], [], []
        for seg in (s for t in traces for s in t.segments()):
            if not (np.any(seg.meas_v) or np.any(seg.meas_w)):
                continue  # standing still: the normalised residual is 0/0 there
            t = np.asarray(seg.meas_t_s, dtype=np.float64)
            start = (float(seg.meas_v[0]), float(seg.meas_w[0]))
            cmd = (seg.cmd_t_s, seg.cmd_v, seg.cmd_w)
            state, ctrl, grid = self._run(cmd, float(t[0]), float(t[-1]), start)
            states.append(state)
            controls.append(sysid.TimeSeries.from_control_names(grid - t[0], ctrl, self.model))
            data = np.column_stack([seg.meas_v, seg.meas_w])
            measured.append(sysid.TimeSeries.from_names(t - t[0], data, self.model))
        names = [f"segment {i}" for i in range(len(states))]
        return sysid.ModelSequences("robot", self.mjspec, names, states, controls, measured)

    def capped(self, ctrl: Any, params: Any) -> Any:
        """``ctrl`` with both wheel targets scaled together to the fitted ``speed_cap`` (the
        controller's wheel-speed cap, a parameter here)."""
        cap = float(params["speed_cap"].value[0])
        peak = np.max(np.abs(ctrl[:, :2]), axis=1)
        out = np.array(ctrl, dtype=np.float64)
        out[:, :2] *= np.minimum(1.0, cap / np.maximum(peak, 1e-12))[:, None]
        return out

    def rollout(self, **kw: Any) -> Any:
        """mujoco.sysid's ``custom_rollout``: its own rollout of the controls capped by each
        candidate's ``speed_cap`` (the control depends on a parameter)."""
        controls, params = kw.pop("control_signal"), kw.pop("param_dicts")
        per = len(controls) // len(params)  # the segments of each candidate, in order
        capped = [
            self.sysid.TimeSeries(c.times, self.capped(c.data, params[i // per]), c.signal_mapping)
            for i, c in enumerate(controls)
        ]
        return self.sysid.sysid_rollout(control_signal=capped, **kw)

    def replay(self, cmd: Any, t_out_s: Any, start: tuple[float, float]) -> tuple[Any, Any]:
        """Odometry sensors at ``t_out_s``, delayed by the fitted delay (``ReplayEngine``)."""
        from mujoco import rollout

        t_out = np.asarray(t_out_s, dtype=np.float64)
        t0 = float(t_out[0])
        state, ctrl, grid = self._run(cmd, t0, float(t_out[-1]), start)
        ctrl = self.capped(ctrl, self.params)
        _, sensors = rollout.rollout(self.model, self.data, state, ctrl[:-1])
        sensors = np.squeeze(sensors, axis=0)
        at = grid  # the start state, then the state after each step
        v = np.concatenate(([start[0]], sensors[:, 0]))
        w = np.concatenate(([start[1]], sensors[:, 1]))
        shifted = t_out - self.delay_s
        return np.interp(shifted, at, v), np.interp(shifted, at, w)


@dataclass(frozen=True)
class PeerFit:
    """mujoco.sysid's result: the model, its optimum, covariance, intervals, residual sd."""

    model: PeerModel
    x: Any
    cov: Any
    half_width: Any
    noise_sd: tuple[float, float]
    wall_s: float
    cpu_s: float


def peer_fit(spec: Any, traces: list[Any], max_iters: int) -> PeerFit:
    """Fit the exported model with mujoco.sysid (see the module docstring); timed."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    peer = PeerModel(spec)
    sysid = peer.sysid
    transform = sysid.SignalTransform()
    transform.delay("odom_*", peer.params["delay_s"])
    residual_fn = sysid.build_residual_fn(
        models_sequences=[peer.sequences(traces)],
        modify_residual=transform.apply,
        custom_rollout=peer.rollout,
    )
    with contextlib.redirect_stdout(io.StringIO()):  # its optimizer prints every iteration
        best, result = sysid.optimize(
            peer.params, residual_fn, optimizer="mujoco", verbose=False, max_iters=max_iters
        )
    residuals, predicted, measured = residual_fn(result.x, best, return_pred_all=True)
    try:
        cov, half = sysid.calculate_intervals(residuals, result.jac)
    except np.linalg.LinAlgError:  # a Jacobian with non-finite entries: no interval
        cov, half = np.zeros((result.x.size, result.x.size)), np.full(result.x.size, np.inf)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    pairs = zip(predicted, measured, strict=True)  # one list (of one series) per segment
    diff = np.concatenate([m[0].data - p[0].data for p, m in pairs])
    peer.set_vector(result.x)
    sd = tuple(float(s) for s in np.std(diff, axis=0))
    return PeerFit(peer, result.x, cov, half, (sd[0], sd[1]), wall, cpu)


def peer_members(fit: PeerFit, trace: Any, spec: Any, n: int, seed: int, window_s: float) -> Any:
    """Replays of ``n`` draws of mujoco.sysid's parameter covariance (clipped to the bounds)."""
    from sim2real.agreement.replay import replay

    rng = np.random.default_rng(seed)
    lo, hi = fit.model.params.get_bounds()
    cov = np.nan_to_num(np.asarray(fit.cov, dtype=np.float64), nan=0.0, posinf=0.0)
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))  # its round-off: PSD again
    cov = (vectors * np.clip(values, 0.0, None)) @ vectors.T
    draws = np.clip(rng.multivariate_normal(fit.x, cov, size=n, method="eigh"), lo, hi)
    p = spec.drive.replace(delay_s=0.0)
    runs = []
    for x in draws:
        fit.model.set_vector(x)
        runs.append(replay(trace, robot=spec, params=p, engine=fit.model, odom_v_window_s=window_s))
    fit.model.set_vector(fit.x)
    return np.stack([r.v for r in runs]), np.stack([r.w for r in runs])


def score(
    base: Base, ref: str, spec: Any, params: Path, peer: PeerFit, n: int, tmp: Path
) -> dict[str, dict[str, float]]:
    """Agreement and band of both fits on one checked recording (one scorer)."""
    from robots.params import load_drive_params
    from robots.randomization import DriveDistribution, ObservationNoise
    from sim2real.agreement.figures import ensemble_of_members, measure_agreement, run_ensemble
    from sim2real.agreement.replay import replay
    from sim2real.agreement.study import parse_odom_v_window
    from sim2real.logs._screen import read_for_robot

    trace, _ = read_for_robot(log_path(ref, tmp), spec)
    window_s = parse_odom_v_window("auto", spec.odometry.rate_hz, v_source=spec.odometry.v_source)
    ours = load_drive_params(params, robot=spec.name, base=spec.drive)
    sim = replay(trace, robot=spec, params=ours, engine="mujoco", odom_v_window_s=window_s)
    dist = DriveDistribution.from_params_file(params, robot=spec.name)
    ens = run_ensemble(trace, robot=spec, distribution=dist, n=n, seed=0, engine="mujoco",
                       odom_v_window_s=window_s)  # fmt: skip
    theirs = spec.drive.replace(delay_s=0.0)
    peer_sim = replay(trace, robot=spec, params=theirs, engine=peer.model, odom_v_window_s=window_s)
    noise = ObservationNoise(std_v_mps=peer.noise_sd[0], std_w_radps=peer.noise_sd[1])
    members = peer_members(peer, trace, spec, n, 0, window_s)
    peer_ens = ensemble_of_members(trace, members, noise=noise, seed=0)
    return {
        who: {
            "agreement": measure_agreement(trace, s).agreement,
            "coverage_v": e.coverage_v,
            "coverage_w": e.coverage_w,
            "width_v": e.band_width_v_mps,
            "width_w": e.band_width_w_radps,
        }
        for who, s, e in (("ours", sim, ens), ("mujoco.sysid", peer_sim, peer_ens))
    }


def run_base(base: Base, quick: bool, summary: list[dict[str, Any]]) -> None:
    from robots.spec import load_spec
    from sim2real.logs._screen import read_for_robot

    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        robot = spec_file(base, tmp)
        spec = load_spec(robot)
        window = base.fit_window
        params = tmp / "params.yaml"
        wall, cpu = _timed_fit(REALDATA / base.fit, robot, params, str(window))
        fit_trace, _ = read_for_robot(REALDATA / base.fit, spec)
        if (bounds := _window(str(window))) is not None:
            fit_trace = fit_trace.window(*bounds)
        peer = peer_fit(spec, [fit_trace], int(QUICK["iters"]) if quick else 50)
        n = int(QUICK["ensemble"]) if quick else ENSEMBLE_N
        print(f"\n## {base.name}: both fit on {base.fit} {window or '(whole)'}")
        print(f"fit time: ours {wall:.1f} s wall ({cpu:.1f} s CPU), whole command; "
              f"mujoco.sysid {peer.wall_s:.1f} s wall ({peer.cpu_s:.1f} s CPU)")  # fmt: skip
        shown = ", ".join(
            f"{k} {x:.4g} +- {h:.2g}"
            for k, x, h in zip(peer.model.params.keys(), peer.x, peer.half_width, strict=True)
        )
        print(f"mujoco.sysid's fit (95 % intervals): {shown}; residual sd v {peer.noise_sd[0]:.3g} "
              f"m/s, w {peer.noise_sd[1]:.3g} rad/s")  # fmt: skip
        print("| checked | fitter | agreement | cov v / w | width v / w |")
        print("|---|---|---|---|---|")
        checks = base.quick_checks or base.checks
        rows: dict[str, list[dict[str, float]]] = {"ours": [], "mujoco.sysid": []}
        for ref in checks[: int(QUICK["checks"])] if quick else base.checks:
            name = ref.removeprefix("neato_").split("_20")[0][:34]
            for who, r in score(base, ref, spec, params, peer, n, tmp).items():
                rows[who].append(r)
                print(f"| {name} | {who} | {100 * r['agreement']:.1f} | {100 * r['coverage_v']:.1f}"
                      f" / {100 * r['coverage_w']:.1f} | {r['width_v']:.3f} / {r['width_w']:.3f} |",
                      flush=True)  # fmt: skip
        for who, rs in rows.items():
            summary.append({
                "base": base.name, "fitter": who, "n": len(rs),
                "agreement": float(np.mean([r["agreement"] for r in rs])),
                "coverage_v": float(np.nanmean([r["coverage_v"] for r in rs])),
                "coverage_w": float(np.nanmean([r["coverage_w"] for r in rs])),
                "wall_s": wall if who == "ours" else peer.wall_s,
                "cpu_s": cpu if who == "ours" else peer.cpu_s,
            })  # fmt: skip


def print_summary(summary: list[dict[str, Any]], quick: bool) -> None:
    print("\n## Summary (mean over the checked recordings)")
    print("| base | fitter | checked | agreement | cov v / w | fit wall s | fit CPU s |")
    print("|---|---|---|---|---|---|---|")
    for s in summary:
        print(f"| {s['base']} | {s['fitter']} | {s['n']} | {100 * s['agreement']:.1f} | "
              f"{100 * s['coverage_v']:.1f} / {100 * s['coverage_w']:.1f} | {s['wall_s']:.1f} | "
              f"{s['cpu_s']:.1f} |")  # fmt: skip
    held = []
    for ours, theirs in zip(summary[::2], summary[1::2], strict=True):
        better = ours["agreement"] >= theirs["agreement"]
        faster = ours["cpu_s"] <= theirs["cpu_s"]
        held.append(better and faster)
        if not quick:  # the headline figures of docs/benchmarks.md (results_page.py)
            record(
                "against mujoco.sysid",
                f"{ours['base']}: agreement ours / mujoco.sysid, fit CPU s",
                f"{100 * ours['agreement']:.1f} / {100 * theirs['agreement']:.1f} %, "
                f"{ours['cpu_s']:.1f} / {theirs['cpu_s']:.1f} s",
                "ours >= theirs at no more fit CPU",
                better and faster,
            )
        print(f"{ours['base']}: agreement ours {'>=' if better else '<'} mujoco.sysid; "
              f"fit CPU ours {'<=' if faster else '>'} mujoco.sysid")  # fmt: skip
    print(f"target held (ours >= theirs at no more fit CPU): {sum(held)}/{len(held)} bases")


def _missing() -> str:
    """Why the benchmark cannot run here ("" when it can)."""
    if not REALDATA.is_dir():
        return f"{REALDATA} is absent"
    try:
        import mujoco.sysid  # noqa: F401
    except ImportError:
        return "mujoco.sysid is not installed (pip install 'sim2real[mujoco]')"
    return ""


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--base", choices=[b.name for b in BASES], action="append")
    parser.add_argument("--quick", action="store_true", help="the Neato, one check, 4 robots")
    args = parser.parse_args()
    if missing := _missing():
        print(f"skipped: {missing}")
        return
    chosen = [QUICK["base"]] if args.quick else (args.base or [b.name for b in BASES])
    summary: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    for base in BASES:
        if base.name in chosen:
            run_base(base, args.quick, summary)
    print_summary(summary, args.quick)
    print(f"{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
