"""Is the Husky's MuJoCo/reduced gap the lifted wheels? Replays on a frictionless floor.

The Husky recordings of the real development set (``husky_lifted_a``, ``husky_lifted_b``) were
made with the wheels off the ground; the measured (v, w) are the wheel encoders' speeds turned
into body speeds. The exported MuJoCo model stands on the floor, where the skids' ground scrub
loads the wheel loops. This script fits ``husky_lifted_a`` (0-155 s), then replays
``husky_lifted_b`` with the same params in three engines and prints the agreement of each with
the log and the rms difference of each MuJoCo variant from the reduced engine:

- ``reduced``: the drive model ``sysid fit`` fits;
- ``mujoco``: the exported model on the floor, body velocity read out (``agree --engine mujoco``);
- ``mujoco-frictionless``: the same model with the floor's friction set to zero, (v, w) read
  from the wheel speeds through the geometric radius and either the geometric separation (as
  the log's encoders are read) or the effective track (``track_factor`` x separation, as the
  reduced engine relates wheels and body).

Run: ``PYTHONPATH=. python benchmarks/bench_mujoco_lifted.py`` (the ``[mujoco]`` extra and
``/work/shared/realdata``; about 40 s).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from robots.randomization import DriveDistribution
from robots.spec import RobotSpec, load_spec
from sim2real.agreement.figures import measure_agreement
from sim2real.agreement.replay import ReplayResult, replay
from sim2real.logs import read_trace
from sim2real.mujoco import Commands, MujocoRobot

REALDATA = Path(os.environ.get("SIM2REAL_REALDATA", "/work/shared/realdata"))
REPO = Path(__file__).resolve().parents[1]
SPEC_ARGS = ("--wheel-separation", "0.538", "--wheel-radius", "0.15875", "--drive", "skid")


class FrictionlessMujoco:
    """The exported robot on a floor without friction, (v, w) read from its wheel speeds."""

    def __init__(self, spec: RobotSpec, params: Any, *, track_factor: float) -> None:
        self.name = f"mujoco-frictionless (read through track x {track_factor:.2f})"
        self.robot = MujocoRobot(spec, params)
        m = self.robot.model
        m.geom_friction[m.geom("floor").id] = 0.0
        r, sep = spec.wheels.radius_m, spec.wheels.separation_m
        track_m = sep * track_factor

        def wheel_velocity() -> tuple[float, float]:
            qvel, dofs = self.robot.data.qvel, self.robot.drive._wheel_dof
            wl, wr = float(qvel[dofs[0]]), float(qvel[dofs[1]])
            return 0.5 * r * (wl + wr), r * (wr - wl) / track_m

        self.robot.velocity = wheel_velocity  # type: ignore[method-assign]

    def replay(
        self, cmd: Commands, t_out_s: np.ndarray, start: tuple[float, float]
    ) -> tuple[np.ndarray, np.ndarray]:
        return self.robot.replay(cmd, t_out_s, start)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        env = dict(os.environ, PYTHONPATH=str(REPO))
        run = [sys.executable, "-m", "sim2real"]
        spec_path, params_path = tmp / "husky.yaml", tmp / "params.yaml"
        subprocess.run([*run, "robots", "new", "husky", *SPEC_ARGS, "-o", str(spec_path)],
                       check=True, env=env, capture_output=True)  # fmt: skip
        subprocess.run([*run, "sysid", "fit", str(REALDATA / "husky_lifted_a/trace.csv"),
                        "--robot", str(spec_path), "-o", str(params_path), "--window", "0:155"],
                       check=True, env=env, capture_output=True)  # fmt: skip
        spec = load_spec(spec_path)
        p = DriveDistribution.from_params_file(params_path, robot=spec.name).mean_params()
    trace = read_trace(REALDATA / "husky_lifted_b/trace.csv", time_source="auto")
    sims: dict[str, ReplayResult] = {
        "reduced": replay(trace, robot=spec, params=p, engine="reduced"),
        "mujoco": replay(trace, robot=spec, params=p, engine="mujoco"),
    }
    for factor in (1.0, float(p.track_factor)):
        engine = FrictionlessMujoco(spec, p, track_factor=factor)
        sims[engine.name] = replay(trace, robot=spec, params=p, engine=engine)
    t = (trace.meas_t_ns - trace.meas_t_ns[0]) * 1e-9
    turn = (t > 55.0) & (t < 58.0)
    print(f"husky_lifted_b, params fitted on husky_lifted_a 0:155; steady turn t = 55-58 s: "
          f"log w {trace.meas_w[turn].mean():.2f} rad/s")  # fmt: skip
    print("| engine | agreement | rms v - reduced (m/s) | rms w - reduced (rad/s) | turn w |")
    print("|---|---|---|---|---|")
    red = sims["reduced"]
    for name, sim in sims.items():
        agree = measure_agreement(trace, sim).agreement
        dv = float(np.sqrt(np.mean((sim.v - red.v) ** 2)))
        dw = float(np.sqrt(np.mean((sim.w - red.w) ** 2)))
        print(f"| {name} | {100 * agree:.1f} % | {dv:.3f} | {dw:.3f} | {sim.w[turn].mean():.2f} |")


if __name__ == "__main__":
    main()
