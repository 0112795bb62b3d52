"""Completion times of three traditional racers (Table 4 of Pozo Ruiz 2024) in Race-v0.

Run: ``.venv/bin/python benchmarks/race_times.py [--seeds 5] [--opponents 2]``.

As in the thesis' traditional-agent experiment, three robots race at once: Robot 1 and Robot 3
plan with Dijkstra, Robot 2 with A*, all follow their plan with DWA
(:class:`sim2real.envs.race_baseline.RaceBaseline`); here they share the track with ORCA
opponents too, through :func:`sim2real.envs.race_parallel_env`. Scenarios: "straight path" =
the ``open`` track (8 m), "curve path" = ``curve`` (9.4 m), "combined path" = ``circuit``
(19.5 m, straight, sharp turns and a roundabout). Prints the mean completion time in seconds
over the seeds where the robot finished, the finish rate, and the thesis' numbers beside them
(its robots and tracks are larger and faster, so only the ordering compares).
"""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from sim2real.envs import race_parallel_env
from sim2real.envs.baselines import DWAConfig, DWAController
from sim2real.envs.race_baseline import RaceBaseline

SCENARIOS = {"straight": "open", "curve": "curve", "combined": "circuit"}
PLANNERS = ("dijkstra", "astar", "dijkstra")
#: Table 4 of Pozo Ruiz (2024), s: robots 1-3 x straight, curve, combined.
THESIS_TABLE_4 = ((28.01, 23.39, 52.12), (28.22, 27.36, 57.24), (28.40, 34.13, 55.76))


def _racers(env: Any) -> list[RaceBaseline]:
    core = env.core
    out = []
    for method in PLANNERS:
        dwa = DWAController(
            beam_angles_rad=core.beam_angles_rad,
            lidar_xy_m=core.lidar_xy,
            range_max_m=core.range_max_m,
            robot_radius_m=core.radius_m,
            action_low=env.action_space("robot_0").low,
            action_high=env.action_space("robot_0").high,
            control_dt=core.control_dt,
            config=DWAConfig(horizon_s=1.5, clearance_cap_m=0.4, margin_m=0.06, velocity=0.5),
        )
        out.append(RaceBaseline(core.track, dwa, method=method))
    return out


def race(track: str, seed: int, opponents: int) -> list[float]:
    """Completion time of each of the three racers in one race (NaN if it did not finish)."""
    env = race_parallel_env(n_robots=3, track=track, num_opponents=opponents)
    racers = _racers(env)
    obs, _ = env.reset(seed=seed)
    for r in racers:
        r.reset()
    times = [math.nan] * 3
    while env.agents:
        actions = {a: racers[int(a[-1])].act(obs[a]) for a in env.agents}
        obs, _, _, _, infos = env.step(actions)
        for a, info in infos.items():
            if info.get("outcome") == "success":
                times[int(a[-1])] = float(info["metrics"]["completion_time_s"])
    env.close()
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--opponents", type=int, default=2)
    args = ap.parse_args()
    table = {
        name: [race(track, s, args.opponents) for s in range(args.seeds)]
        for name, track in SCENARIOS.items()
    }
    print(
        f"Completion time s, mean over finished races (finish rate), {args.seeds} seeds, "
        f"3 racers + {args.opponents} ORCA opponents; [thesis Table 4]"
    )
    print(f"{'robot':<20}" + "".join(f"{name + ' path':>28}" for name in SCENARIOS))
    for k, method in enumerate(PLANNERS):
        cells = []
        for j, name in enumerate(SCENARIOS):
            t = np.array([row[k] for row in table[name]])
            ok = ~np.isnan(t)
            mean = f"{t[ok].mean():6.1f}" if ok.any() else "   n/a"
            cells.append(f"{mean} ({ok.mean():4.0%}) [{THESIS_TABLE_4[k][j]:5.2f}]")
        label = f"Robot {k + 1} ({'A*' if method == 'astar' else 'Dijkstra'})"
        print(f"{label:<20}" + "".join(f"{c:>28}" for c in cells))


if __name__ == "__main__":
    main()
