"""MuJoCo against the reduced engine on a plant fleet, with the same params file.

Per shipped robot: a fleet of foreign-plant sessions (:func:`sim2real.plants.diff_drive.write_fleet`,
``mixed`` profile, seeded); ``sysid fit`` on session 0, then ``agree --params --ensemble`` of
every other session in the reduced engine and in MuJoCo. The same for a Husky-like skid steer
on the ground (:func:`sim2real.plants.skid.husky_like`, slip from tyre forces; its spec from
``robots new --drive skid``). One row per session and engine:
agreement and band coverage; the target is MuJoCo within 0.02 of the reduced engine's
agreement and within 3 points of its coverage on every row.

Run: ``PYTHONPATH=. python benchmarks/bench_mujoco_plants.py [--sessions N] [--duration S]``
(the ``[mujoco]`` extra).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from sim2real.logs import write_trace
from sim2real.plants.diff_drive import write_fleet
from sim2real.plants.skid import husky_like, make_skid_sessions

REPO = Path(__file__).resolve().parents[1]
ROBOTS = ("turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi")
ENGINES = ("reduced", "mujoco")
HUSKY = ("--wheel-separation", "0.555", "--wheel-radius", "0.165", "--mass", "50",
         "--max-speed", "1.0", "--drive", "skid")  # fmt: skip


def cli(*args: str) -> None:
    """Run ``python -m sim2real ARGS``; raise with its stderr on failure."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    out = subprocess.run([sys.executable, "-m", "sim2real", *args], capture_output=True,
                         text=True, env=env, check=False)  # fmt: skip
    if out.returncode != 0:
        raise RuntimeError(f"sim2real {' '.join(args)} exited {out.returncode}: {out.stderr}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--sessions", type=int, default=4, help="sessions a robot (1 fit, rest checked)"
    )
    ap.add_argument("--duration", type=float, default=60.0, help="session length, s")
    ap.add_argument("--ensemble", type=int, default=20, help="band ensemble size")
    args = ap.parse_args(argv)
    misses = 0
    print("| robot | session | engine | agreement | cov v / w | MuJoCo - reduced |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        for robot in (*ROBOTS, "husky_skid_plant"):
            folder = tmp / robot
            folder.mkdir()
            if robot in ROBOTS:
                logs = write_fleet(folder, robot, args.sessions, seed=7, duration_s=args.duration)
            else:
                sessions = make_skid_sessions(
                    husky_like(), args.sessions, seed=7, duration_s=args.duration
                )
                logs = [write_trace(folder / f"skid_{i}.mcap", tr) for i, tr in enumerate(sessions)]
                spec = folder / "husky.yaml"
                cli("robots", "new", "husky", *HUSKY, "-o", str(spec))
                # the plant's yaw rate is a gyro's, as a user edits the spec to say
                spec.write_text(spec.read_text().replace("w_source: wheels", "w_source: imu"))
                robot = str(spec)
            params = folder / "params.yaml"
            cli("sysid", "fit", str(logs[0]), "--robot", robot, "-o", str(params))
            for log in logs[1:]:
                rows = {}
                for engine in ENGINES:
                    out = folder / f"{log.stem}_{engine}.json"
                    cli("agree", str(log), "--robot", robot, "--params", str(params),
                        "--engine", engine, "--ensemble", str(args.ensemble), "--seed", "0",
                        "--json", str(out))  # fmt: skip
                    rows[engine] = json.loads(out.read_text())
                red, mj = rows["reduced"], rows["mujoco"]
                d_agree = mj["agreement"] - red["agreement"]
                d_cov = max(abs(mj[k] - red[k]) for k in ("coverage_v", "coverage_w"))
                ok = abs(d_agree) <= 0.02 and d_cov <= 0.03
                misses += not ok
                for engine, r in rows.items():
                    diff = (
                        ""
                        if engine == "reduced"
                        else (
                            f"{100 * d_agree:+.1f} / {100 * d_cov:.1f} pts {'ok' if ok else 'MISS'}"
                        )
                    )
                    print(f"| {Path(robot).stem} | {log.stem} | {engine} | {100 * r['agreement']:.1f}"
                          f" | {100 * r['coverage_v']:.1f} / {100 * r['coverage_w']:.1f}"
                          f" | {diff} |", flush=True)  # fmt: skip
    print(f"rows missing the target: {misses}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
