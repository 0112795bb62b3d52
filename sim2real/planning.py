"""What to record for a fit: design an excitation plan and write it as a ROS 2 command script.

The one call behind ``sim2real sysid plan``: :func:`write_plan` designs the plan of a robot
from its spec (:func:`sysid.plan.plan_excitation`) and writes its commands as
``/cmd_vel`` ``geometry_msgs/msg/Twist`` messages in a ROS 2 MCAP file, which
``ros2 bag play excite.mcap`` sends to the base while ``ros2 bag record`` records it.

May import :mod:`robots`, :mod:`sysid` and :mod:`sim2real.logs`.

Examples
--------
>>> plan = write_plan("excite.mcap", "turtlebot3_burger", duration_s=90.0)  # doctest: +SKIP
>>> plan.t_s.size  # doctest: +SKIP
900
"""

from __future__ import annotations

from pathlib import Path

from robots.spec import RobotSpec, load_spec
from robots.units import nanoseconds
from sim2real.logs import write_commands
from sysid.plan import ExcitationPlan, plan_excitation

__all__ = ["SCRIPT_T0_NS", "write_plan"]

#: Log time of a script's first command, ns (any epoch: ``ros2 bag play`` keeps only the
#: spacing of the messages).
SCRIPT_T0_NS = 1_700_000_000_000_000_000


def write_plan(
    path: str | Path,
    robot: str | Path | RobotSpec,
    *,
    duration_s: float = 90.0,
    area_m: float = 3.0,
    rate_hz: float = 10.0,
) -> ExcitationPlan:
    """Design the excitation plan of ``robot`` and write its command script to ``path``.

    Parameters
    ----------
    path : str or Path
        The ``.mcap`` file to write (atomically; its folder must exist).
    robot : str, Path or RobotSpec
        A spec name, a spec file or a loaded spec.
    duration_s, area_m, rate_hz : float
        See :func:`sysid.plan.plan_excitation` (s, m, Hz).

    Returns
    -------
    ExcitationPlan
        The plan written.
    """
    spec = robot if isinstance(robot, RobotSpec) else load_spec(robot)
    plan = plan_excitation(spec, duration_s, rate_hz=rate_hz, area_m=area_m)
    write_commands(
        path,
        cmd_t_ns=SCRIPT_T0_NS + nanoseconds(plan.t_s),
        cmd_v=plan.v_mps,
        cmd_w=plan.w_radps,
    )
    return plan
