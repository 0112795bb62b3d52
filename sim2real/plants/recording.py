"""Record a session on the foreign plant: play a command script, get the base's log.

What a user does on a real base with ``ros2 bag play excite.mcap`` and ``ros2 bag record``,
:func:`record_plan` does on the plant in one call: it plays the script's commands (an
excitation plan of ``sim2real sysid plan``, :func:`sysid.plan.plan_excitation`, or any object
with the same ``t_s``, ``v_mps``, ``w_radps`` and ``duration_s``) on one plant session and
returns the recorded log (:class:`~sim2real.logs.Trace`: the commands and the base's odometry).

Examples
--------
>>> from robots.spec import load_spec
>>> from sysid.plan import plan_excitation
>>> from sim2real.plants.closed_loop import PlantSessions
>>> plan = plan_excitation(load_spec("turtlebot3_burger"), 20.0)
>>> trace = record_plan(plan, PlantSessions.of("turtlebot3_burger"), seed=0)
>>> trace.cmd_v.size, bool(trace.meas_t_ns.size > 500)
(200, True)
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from sim2real.errors import Sim2RealValueError
from sim2real.logs.trace import Trace
from sim2real.plants.closed_loop import PlantSessions
from sim2real.plants.diff_drive import FloatArray, PlantParams, run_plant, run_to_trace

__all__ = ["CommandScript", "record_plan"]


class CommandScript(Protocol):
    """What :func:`record_plan` plays: commands from t = 0 and the script's length."""

    @property
    def t_s(self) -> FloatArray: ...

    @property
    def v_mps(self) -> FloatArray: ...

    @property
    def w_radps(self) -> FloatArray: ...

    @property
    def duration_s(self) -> float: ...


def record_plan(
    plan: CommandScript,
    plant: PlantParams | PlantSessions,
    *,
    seed: int,
    name: str = "",
) -> Trace:
    """The log of ``plan`` played on one session of ``plant``.

    Parameters
    ----------
    plan : CommandScript
        The script (e.g. :class:`sysid.plan.ExcitationPlan`).
    plant : PlantParams or PlantSessions
        A fixed session, or sessions to draw one from.
    seed : int
        Seeds ``numpy.random.default_rng(seed)``, which draws the session (for
        :class:`PlantSessions`) and then the transport and sensor noise.
    name : str
        The log's name (``Trace.meta.path``).

    Returns
    -------
    Trace
        ``/cmd_vel`` as published and the base's ``/odom``.
    """
    if isinstance(plant, PlantSessions):
        rng = np.random.default_rng(seed)
        params = plant.draw(rng)
    elif isinstance(plant, PlantParams):
        params, rng = plant, np.random.default_rng(seed)
    else:
        raise Sim2RealValueError(
            f"plant must be a PlantParams or PlantSessions, got {type(plant).__name__}; build "
            "one with sim2real.plants.closed_loop.PlantSessions.of(robot)"
        )
    robot = getattr(plan, "robot", params.robot)
    if robot != params.robot:
        raise Sim2RealValueError(
            f"the plan was designed for robot '{robot}' but the plant is a '{params.robot}'; "
            f"plan for '{params.robot}' (sim2real sysid plan --robot {params.robot})"
        )
    run = run_plant(params, plan.t_s, plan.v_mps, plan.w_radps, duration_s=plan.duration_s, rng=rng)
    return run_to_trace(run, name=name)
