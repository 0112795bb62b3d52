"""Is the Husky's MuJoCo/reduced gap the lifted wheels? Replays of a lifted log in MuJoCo variants.

The Husky recordings of the real development set (``husky_lifted_a``, ``husky_lifted_b``) were
made with the wheels off the ground; the measured (v, w) are the wheel encoders' speeds turned
into body speeds. The exported MuJoCo model stands on the floor, where the tyres' ground scrub
loads the wheel loops. This script fits ``husky_lifted_a`` (0-155 s), then replays
``husky_lifted_b`` with the same params in the reduced engine and in MuJoCo variants, and
prints the agreement of each with the log and the rms difference of each from the reduced
engine:

- ``reduced``: the drive model ``sysid fit`` fits;
- ``mujoco``: the exported model on the floor, body velocity read out (``agree --engine mujoco``);
- ``mujoco-lifted``: the base held up, contacts off, the base's mass and inertia on the
  wheels (``agree --engine mujoco-lifted``);
- the exported model read through its wheel encoders (the geometric separation, as the log is
  read), with the tyres' friction lowered to 0.3 (either read-out), and with no friction anywhere (the wheels
  unloaded, as on a stand).

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


class MujocoVariant:
    """The exported robot with every geom's sliding friction set to ``friction`` (a contact
    takes the larger of its two geoms'; None: as exported), (v, w) read from the base or,
    with ``encoders``, from the wheel speeds through the radius and the geometric separation
    (as the log's encoders are read)."""

    def __init__(
        self, spec: RobotSpec, params: Any, *, friction: float | None, encoders: bool
    ) -> None:
        mu = "as exported" if friction is None else f"{friction:g}"
        self.name = f"mujoco, friction {mu}, {'encoders' if encoders else 'base'}"
        self.robot = MujocoRobot(spec, params)
        if friction is not None:
            self.robot.model.geom_friction[:, 0] = friction
        r, sep = spec.wheels.radius_m, spec.wheels.separation_m

        def wheel_velocity() -> tuple[float, float]:
            qvel, dofs = self.robot.data.qvel, self.robot.drive._wheel_dof
            wl, wr = float(qvel[dofs[0]]), float(qvel[dofs[1]])
            return 0.5 * r * (wl + wr), r * (wr - wl) / sep

        if encoders:
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
        "mujoco-lifted": replay(trace, robot=spec, params=p, engine="mujoco-lifted"),
    }
    for friction, encoders in ((None, True), (0.3, False), (0.3, True), (0.0, True)):
        engine = MujocoVariant(spec, p, friction=friction, encoders=encoders)
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
