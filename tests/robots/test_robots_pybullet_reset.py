"""``PybulletRobot.reset()`` gives a fresh robot: after a reset the same commands give, bit for bit,
the numbers of a robot just built at that pose (the project's "same seed, same numbers").

pybullet keeps a contact point, and the impulse it carried in the last physics step (the
solver's warm start), for as long as the two bodies stay within the contact breaking threshold,
whatever ``resetBasePositionAndOrientation`` does. A reset that only put the body back therefore
started the next run from the last step's wheel impulses when the robot stood near where it was
reset to (one 0.1 s step at 0.2 m/s, 1 cm): in the run below, a TurtleBot3 Burger's speed was
up to 5.6e-4 m/s off and its wheel speeds 2.0e-2 rad/s (Waffle Pi 5.4e-4, 1.8e-2; TurtleBot 2 none).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pybullet as p
import pytest

from robots import PybulletRobot
from robots.world import add_box, add_ground

ROBOTS = ["turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi"]

#: 1 s of commands (v [m/s], w [rad/s]) at 10 Hz: straight, a turn, a reversal.
COMMANDS = [(0.2, 0.0)] * 3 + [(0.2, 0.6)] * 4 + [(-0.1, -0.8)] * 3

#: A wall 0.4 m ahead of the start pose (centre, half extents), in the "box" worlds.
WALL = ((0.45, 0.0, 0.2), (0.05, 0.5, 0.2))


def _run(bot: PybulletRobot) -> np.ndarray:
    """Per control step: true (v, w), pose, wheel speeds, the last physics step's torques."""
    rows = []
    for v, w in COMMANDS:
        bot.step(v, w, 0.1)
        rows.append((*bot.velocity, *bot.pose, *bot.wheel_speeds(), *bot.wheel_torques))
    return np.array(rows)


def _one_step(bot: PybulletRobot) -> None:
    bot.step(0.2, 0.0, 0.1)  # 1 cm: the wheel contacts are still within the breaking threshold


def _turning(bot: PybulletRobot) -> None:
    for _ in range(20):
        bot.step(0.2, 0.6, 0.1)


def _into_the_wall(bot: PybulletRobot) -> None:
    for _ in range(40):
        bot.step(0.2, 0.0, 0.1)
    assert p.getContactPoints(bodyA=bot.body_id, physicsClientId=bot.client)  # it touches


BEFORE: dict[str, tuple[Callable[[PybulletRobot], None], tuple[float, float, float], bool]] = {
    # what ran before the reset, the reset pose, whether the world has the wall
    "one_step": (_one_step, (0.0, 0.0, 0.0), False),
    "turning": (_turning, (0.0, 0.0, 0.0), False),
    "turning_reset_elsewhere": (_turning, (1.0, -0.5, 0.7), False),
    "pushed_the_wall": (_into_the_wall, (0.2, 0.0, 0.0), True),
}


@pytest.mark.parametrize("before", list(BEFORE))
@pytest.mark.parametrize("name", ROBOTS)
def test_reset_gives_a_fresh_robots_numbers(name: str, before: str) -> None:
    run_before, pose, wall = BEFORE[before]
    with PybulletRobot(name, start_pose=pose) as fresh:
        if wall:
            add_box(fresh.client, *WALL)
        want = _run(fresh)
    with PybulletRobot(name) as bot:
        if wall:
            add_box(bot.client, *WALL)
        run_before(bot)
        bot.reset(*pose)
        got = _run(bot)
    assert np.ptp(want[:, 2]) > 0.02  # it drove
    np.testing.assert_array_equal(got, want)
    with PybulletRobot(name) as bot:  # twice in a row: the same again
        if wall:
            add_box(bot.client, *WALL)
        run_before(bot)
        bot.reset(*pose)
        _run(bot)
        bot.reset(*pose)
        np.testing.assert_array_equal(_run(bot), want)


def test_putting_the_body_back_keeps_pybullets_contact_impulses() -> None:
    # why reset does more than place the body: pybullet's own state carries over
    with PybulletRobot("turtlebot3_burger") as fresh:
        want = _run(fresh)
    with PybulletRobot("turtlebot3_burger") as bot:
        _one_step(bot)
        bot._place(0.0, 0.0, 0.0)  # the body, the wheels and the drive state only
        got = _run(bot)
    assert np.max(np.abs(got[:, 0] - want[:, 0])) > 1e-4  # m/s; measured 5.6e-4


def _two_robots() -> tuple[int, PybulletRobot, PybulletRobot]:
    client = p.connect(p.DIRECT)
    p.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
    add_ground(client)
    a = PybulletRobot("turtlebot3_burger", client=client)
    b = PybulletRobot("turtlebot2", client=client, start_pose=(0.0, 2.0, 0.0))
    return client, a, b


def _run_both(a: PybulletRobot, b: PybulletRobot) -> np.ndarray:
    rows = []
    for v, w in COMMANDS:
        a.step(v, w, 0.1)
        b.step(0.5 * v, -w, 0.1)
        rows.append((*a.velocity, *a.pose, *b.velocity, *b.pose))
    return np.array(rows)


def test_resets_in_a_shared_client_give_a_fresh_worlds_numbers() -> None:
    client, a, b = _two_robots()
    want = _run_both(a, b)
    p.disconnect(client)
    client, a, b = _two_robots()
    try:
        a.step(0.2, 0.0, 0.1)  # 1 cm, and b stood: both keep their wheel contacts
        a.reset()
        b.reset(0.0, 2.0, 0.0)
        np.testing.assert_array_equal(_run_both(a, b), want)
    finally:
        p.disconnect(client)


def test_a_reset_leaves_the_other_robots_in_its_client_alone() -> None:
    traces = []
    for reset in (True, False):
        client, a, b = _two_robots()
        try:
            for _ in range(3):
                a.step(0.2, 0.0, 0.1)
                b.step(0.1, 0.3, 0.1)
            if reset:
                a.reset()
            else:
                a._place(0.0, 0.0, 0.0)  # same state of a, without reset's contact pass
            traces.append(np.array([(*b.step(0.1, 0.3, 0.1), *b.pose) for _ in range(5)]))
        finally:
            p.disconnect(client)
    np.testing.assert_array_equal(traces[0], traces[1])
