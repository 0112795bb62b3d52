"""The exported MuJoCo robot: every robot loads and drives; the drive matches the drive model;
bad input; an ensemble member is a field edit; replay speed."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.reduced import simulate
from robots.spec import list_robots, load_spec
from sim2real.agreement.figures import measure_agreement
from sim2real.agreement.replay import replay
from sim2real.cli import main

pytestmark = pytest.mark.mujoco

DEMO_LOG = Path(__file__).resolve().parents[2] / "data" / "demo_validate.mcap"


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse usage errors
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def _commands(seed: int, duration_s: float, v_top: float, w_top: float) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 0.1)
    # piecewise-constant (v, w) held 0.5-2 s, some stops: a teleop-like stream at 10 Hz
    holds = np.cumsum(rng.uniform(0.5, 2.0, t.size))
    k = np.searchsorted(holds, t)
    v = rng.uniform(-0.5, 1.1, t.size)[k] * v_top
    w = rng.uniform(-1.1, 1.1, t.size)[k] * w_top
    stop = rng.random(t.size)[k] < 0.2
    return t, np.where(stop, 0.0, v), np.where(stop, 0.0, w)


@pytest.fixture(scope="module")
def new_robots(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("specs")
    out = {}
    for name, extra in (("neato", ["--drive", "diff"]), ("husky", ["--drive", "skid"])):
        path = root / f"{name}.yaml"
        code = main(
            ["robots", "new", name, "--wheel-separation", "0.5" if name == "husky" else "0.248",
             "--max-speed", "1.0" if name == "husky" else "0.3", *extra, "-o", str(path)]
        )  # fmt: skip
        assert code == 0
        out[name] = path
    return out


@pytest.mark.parametrize("robot", [*list_robots(), "new:neato", "new:husky"])
def test_export_loads_and_drives(
    robot: str, new_robots: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import mujoco

    from sim2real.mujoco import MujocoRobot

    name = str(new_robots[robot[4:]]) if robot.startswith("new:") else robot
    out = tmp_path / "robot.xml"
    code, text, err = _run(capsys, "robots", "export", name, "-o", out)
    assert code == 0, err
    assert "loaded in MuJoCo and drive-checked (forward" in text and ", stops)" in text
    model = mujoco.MjModel.from_xml_path(str(out))
    assert (model.nu, model.ntendon) == (4, 2)
    # forward drives forward (+x), a positive turn turns counter-clockwise, zero stops
    spec = load_spec(name)
    bot = MujocoRobot(spec, xml=out.read_text())
    t = np.arange(0.0, 2.0, 0.1)
    cmd = np.where(t < 1.0, 1.0, 0.0)
    zero = np.zeros_like(t)
    t_out = np.array([0.0, 1.0, 3.0])
    v, _ = bot.replay((t, 0.5 * spec.max_v_mps * cmd, zero), t_out)
    assert v[1] > 0.25 * spec.max_v_mps and abs(v[2]) < 0.01 * spec.max_v_mps
    assert bot.data.qpos[0] > 0.1 * spec.max_v_mps and abs(bot.data.qpos[1]) < 1e-3
    _, w = bot.replay((t, zero, 0.5 * spec.max_w_radps * cmd), t_out)
    assert w[1] > 0.25 * spec.max_w_radps and abs(w[2]) < 0.01 * spec.max_w_radps


@pytest.mark.parametrize(
    ("robot", "changes"),
    [
        ("turtlebot3_burger", {}),
        ("turtlebot2", {}),  # acceleration limits, asymmetric Coulomb friction
        ("turtlebot3_waffle_pi", {"speed_loop_ki_per_s": 6.0}),  # a PI loop
        ("turtlebot2", {"wheel_stall_torque_nm": 1.0, "wheel_no_load_speed_radps": 12.0}),
    ],
)
def test_drive_matches_the_drive_model(robot: str, changes: dict[str, float]) -> None:
    from sim2real.mujoco import MujocoRobot

    spec = load_spec(robot)
    params = spec.drive.replace(**changes)
    t, v, w = _commands(1, 40.0, spec.max_v_mps, spec.max_w_radps)
    t_out = np.arange(0.0, 40.0, 0.05)
    mv, mw = MujocoRobot(spec, params).replay((t, v, w), t_out)
    ref = simulate(params, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, t_out_s=t_out)
    # within the agreement tolerances (0.02 m/s, 0.1 rad/s) nearly everywhere: the two part
    # only in the few steps after a hard reversal (the tyres' contact is not rigid)
    assert np.mean(np.abs(mv - ref.v) <= 0.02) >= 0.97
    assert np.mean(np.abs(mw - ref.w) <= 0.1) >= 0.93
    assert float(np.sqrt(np.mean((mv - ref.v) ** 2))) < 0.01


def test_skid_steer_turns_on_its_effective_track(new_robots: dict[str, Path]) -> None:
    from sim2real.mujoco import MujocoRobot

    spec = load_spec(new_robots["husky"])
    params = spec.drive.replace(track_factor=2.0, driver_track_factor=1.2)
    t = np.arange(0.0, 4.0, 0.1)
    t_out = np.array([0.0, 3.0])
    args = {"cmd_t_s": t, "cmd_v": np.full(t.size, 0.3), "cmd_w": np.full(t.size, 0.8)}
    mv, mw = MujocoRobot(spec, params).replay(tuple(args.values()), t_out)
    ref = simulate(params, spec.geometry, t_out_s=t_out, **args)
    # w = 0.8 * 1.2 / 2 = 0.48 rad/s less friction: the treads' slip, not the geometric track
    assert mw[1] == pytest.approx(ref.w[1], rel=0.03) and mw[1] < 0.55
    assert mv[1] == pytest.approx(ref.v[1], rel=0.03)


def test_skid_steer_clips_each_side_at_the_cap(new_robots: dict[str, Path]) -> None:
    """wheel_cap_per_side: the MuJoCo drive clips each wheel target on its own, as the kernel."""
    from sim2real.mujoco import MujocoRobot

    spec = load_spec(new_robots["husky"])
    t = np.arange(0.0, 4.0, 0.1)
    t_out = np.array([0.0, 3.5])
    # both wheel targets near the cap (14 and 6 rad/s against 10): clipped, the turn slows
    args = {"cmd_t_s": t, "cmd_v": np.full(t.size, 1.0), "cmd_w": np.full(t.size, 1.0)}
    out = {}
    for mode in (0.0, 1.0):
        params = spec.drive.replace(wheel_cap_per_side=mode, accel_lim_w_radps2=6.0)
        mv, mw = MujocoRobot(spec, params).replay(tuple(args.values()), t_out)
        ref = simulate(params, spec.geometry, t_out_s=t_out, **args)
        assert mw[1] == pytest.approx(ref.w[1], rel=0.03), mode
        assert mv[1] == pytest.approx(ref.v[1], rel=0.03), mode
        out[mode] = ref.w[1]
    assert out[0.0] - out[1.0] > 0.15  # the modes part far beyond the 3 % tolerance


def test_new_moves_clear_the_loops_as_the_kernel(new_robots: dict[str, Path]) -> None:
    """command_starts_new_move: the MuJoCo drive clears the integrators where the kernel does
    (a PI loop with Coulomb friction, a command stepped every 0.5 s)."""
    from sim2real.mujoco import MujocoRobot

    spec = load_spec(new_robots["neato"])
    t = np.arange(0.0, 3.0, 0.1)
    v = np.where(np.floor(t / 0.5) % 2 == 0, 0.1, 0.25)  # 0.1 / 0.25 m/s, 0.5 s each
    args = {"cmd_t_s": t, "cmd_v": v, "cmd_w": np.zeros(t.size)}
    t_out = np.arange(0.0, 3.0, 0.05)
    out = {}
    for mode in (0.0, 1.0):
        params = spec.drive.replace(
            command_starts_new_move=mode, speed_loop_ki_per_s=6.0, coulomb_v_fwd_n=0.8,
            coulomb_v_bwd_n=0.8,
        )  # fmt: skip
        mv, _ = MujocoRobot(spec, params).replay(tuple(args.values()), t_out)
        ref = simulate(params, spec.geometry, t_out_s=t_out, **args)
        assert float(np.sqrt(np.mean((mv - ref.v) ** 2))) < 0.002, mode  # measured 0.0014
        out[mode] = ref.v
    # the modes part by 3x what the engines may (measured 0.0084 m/s rms)
    assert float(np.sqrt(np.mean((out[0.0] - out[1.0]) ** 2))) > 0.006


def test_ensemble_member_is_a_field_edit() -> None:
    from sim2real.mujoco import MujocoRobot

    spec = load_spec("turtlebot3_burger")
    heavy = spec.drive.replace(
        added_mass_kg=0.8, added_yaw_inertia_kgm2=0.01, motor_gain_nms_per_rad=0.02,
        viscous_v_ns_per_m=0.5, coulomb_w_nm=0.02, wheel_torque_max_nm=0.12,
    )  # fmt: skip
    t, v, w = _commands(2, 10.0, spec.max_v_mps, spec.max_w_radps)
    args = ((t, v, w), np.arange(0.0, 10.0, 0.05))
    robot = MujocoRobot(spec)
    model = robot.model
    light = robot.replay(*args)
    robot.set_params(heavy)
    assert robot.model is model  # no recompile
    assert model.body("base_link").mass[0] == pytest.approx(robot.spec.base_mass_kg + 0.8, abs=0.2)
    edited = robot.replay(*args)
    fresh = MujocoRobot(spec, heavy).replay(*args)
    np.testing.assert_allclose(edited, fresh, atol=1e-9)
    assert np.max(np.abs(edited[0] - light[0])) > 0.02  # the edit changed the run
    robot.set_params(spec.drive)
    np.testing.assert_allclose(robot.replay(*args), light, atol=1e-9)


def test_export_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    params = tmp_path / "p.yaml"
    doc = {"format": "sim2real.sysid/1", "robot": "turtlebot2", "parameters": {}}
    params.write_text(yaml.safe_dump(doc), encoding="utf-8")
    out = tmp_path / "r.xml"
    code, _, err = _run(
        capsys, "robots", "export", "turtlebot3_burger", "--params", params, "-o", out
    )
    assert code == 2 and err.count("\n") == 1 and "identified for robot 'turtlebot2'" in err
    doc = {**doc, "parameters": {"track_factor": {"value": 1.7}}}
    params.write_text(yaml.safe_dump(doc), encoding="utf-8")
    code, _, err = _run(capsys, "robots", "export", "turtlebot2", "--params", params, "-o", out)
    assert code == 2 and err.count("\n") == 1 and "(a skid steer)" in err and "--drive skid" in err
    code, _, err = _run(capsys, "robots", "export", "turtlebot2", "-o", tmp_path / "r.urdf")
    assert code == 2 and "must end in .xml" in err
    assert not out.exists()


def test_agree_engine_bad_input(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    code, _, err = _run(
        capsys, "agree", DEMO_LOG, "--robot", "turtlebot3_burger", "--engine", "ode"
    )
    assert code == 2 and "invalid choice: 'ode'" in err
    monkeypatch.setitem(sys.modules, "mujoco", None)  # as if not installed
    code, _, err = _run(
        capsys, "agree", DEMO_LOG, "--robot", "turtlebot3_burger", "--engine", "mujoco"
    )
    assert code == 2 and err.count("\n") == 1 and "pip install 'sim2real[mujoco]'" in err


def test_agree_engine_mujoco_near_reduced(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    import json

    figures = {}
    for engine in ("reduced", "mujoco"):
        out = tmp_path / f"{engine}.json"
        code, _, err = _run(
            capsys, "agree", DEMO_LOG, "--robot", "turtlebot3_burger", "--engine", engine,
            "--json", out,
        )  # fmt: skip
        assert code == 0, err
        figures[engine] = json.loads(out.read_text())
    assert figures["mujoco"]["n_samples"] == figures["reduced"]["n_samples"]
    assert abs(figures["mujoco"]["agreement"] - figures["reduced"]["agreement"]) <= 0.02


def test_yaw_coulomb_holds_a_small_turn_command_while_driving() -> None:
    """The axis frictions' dry-friction constraints hold like the drive model's Coulomb terms:
    a turn command whose loop torque stays below coulomb_w_nm does not turn the base."""
    from sim2real.mujoco import MujocoRobot

    spec = load_spec("turtlebot3_burger")
    t = np.arange(0.0, 3.0, 0.1)
    cmd = (t, np.full(t.size, 0.15), np.full(t.size, 0.03))
    t_out = np.array([0.0, 1.5, 2.5])
    ref = simulate(
        spec.drive, spec.geometry, cmd_t_s=cmd[0], cmd_v=cmd[1], cmd_w=cmd[2], t_out_s=t_out
    )
    _, w = MujocoRobot(spec).replay(cmd, t_out)
    assert ref.w[1:] == pytest.approx([0.0, 0.0], abs=1e-9)
    assert np.max(np.abs(w[1:])) <= 0.003


def test_advance_is_apply_and_step_per_step() -> None:
    """MujocoDrive.advance(n) computes the delayed commands of n steps at once: the same run as
    apply + mj_step n times (turtlebot2: delay, acceleration limits, feedback terms)."""
    import mujoco

    from sim2real.mujoco import MujocoRobot

    spec = load_spec("turtlebot2")
    runs = []
    for batched in (False, True):
        robot = MujocoRobot(spec, spec.drive.replace(speed_loop_ki_per_s=4.0))
        robot.reset()
        m, d, drive = robot.model, robot.data, robot.drive
        for k, (v, w) in enumerate([(0.3, 0.0), (0.3, 1.0), (0.0, -1.0), (0.0, 0.0)]):
            drive.command(0.5 * k, v, w)
            if batched:
                drive.advance(m, d, 120)
            else:
                for _ in range(120):
                    drive.apply(m, d)
                    mujoco.mj_step(m, d)
        runs.append(np.concatenate([d.qpos, d.qvel]))
    np.testing.assert_allclose(runs[1], runs[0], atol=1e-12)
    assert runs[0][0] > 0.1  # it drove forward (x, m)


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["turtlebot3_burger", "turtlebot2"])
def test_plant_fleet_agreement_within_two_points(robot: str) -> None:
    """A fleet of the foreign plant (sim2real.plants): fit one session, check the others with
    the same params in both engines."""
    from sim2real.plants.diff_drive import make_fleet
    from sysid import fit_drive

    spec = load_spec(robot)
    fleet = make_fleet(robot, 4, seed=5, duration_s=40.0)
    fit = fit_drive(fleet[:1], geometry=spec.geometry, base_params=spec.drive, robot=spec.name)
    for trace in fleet[1:]:
        reduced, mujoco = (
            measure_agreement(trace, replay(trace, robot=spec, params=fit.params, engine=e))
            for e in ("reduced", "mujoco")
        )
        assert reduced.n_active > 300
        assert abs(mujoco.agreement - reduced.agreement) <= 0.02


@pytest.mark.slow
def test_skid_plant_fleet_on_the_ground_agrees_within_two_points(tmp_path: Path) -> None:
    """A skid steer whose slip comes from tyre forces on the ground (sim2real.plants.skid):
    fit one session, check another with the same params in both engines."""
    from sim2real.plants.skid import husky_like, make_skid_sessions, plant_odometry
    from sysid import fit_drive

    path = tmp_path / "husky.yaml"
    new = ["robots", "new", "husky", "--wheel-separation", "0.555", "--wheel-radius", "0.165",
           "--mass", "50", "--max-speed", "1.0", "--drive", "skid", "-o", str(path)]  # fmt: skip
    assert main(new) == 0
    spec = plant_odometry(load_spec(path))  # the plant's yaw rate is a gyro's
    fit_log, held = make_skid_sessions(husky_like(), 2, seed=7, duration_s=40.0)
    fit = fit_drive([fit_log], geometry=spec.geometry, base_params=spec.drive, robot=spec.name)
    assert fit.params.track_factor > 1.1  # a skid steer: the effective track is wider
    reduced, mujoco = (
        measure_agreement(held, replay(held, robot=spec, params=fit.params, engine=e))
        for e in ("reduced", "mujoco")
    )
    assert reduced.n_active > 300 and reduced.agreement > 0.8
    assert abs(mujoco.agreement - reduced.agreement) <= 0.02


def test_lifted_replay_matches_the_reduced_engine(new_robots: dict[str, Path]) -> None:
    """A skid steer on a stand (a drive like the one fitted on the lifted Husky): the wheels'
    speeds follow the drive model's and the base stays."""
    from sim2real.mujoco import MujocoRobot

    spec = load_spec(new_robots["husky"])
    params = spec.drive.replace(
        track_factor=1.5, driver_track_factor=1.6, speed_loop_ki_per_s=2.9, delay_s=0.12,
        motor_gain_nms_per_rad=36.0, speed_lim_w_radps=1.0, wheel_torque_max_nm=27.0,
        added_mass_kg=43.0, viscous_v_ns_per_m=190.0, coulomb_w_nm=2.4,
        accel_lim_v_mps2=2.6, accel_lim_w_radps2=2.0, wheel_speed_max_radps=6.5,
    )  # fmt: skip
    t, v, w = _commands(2, 60.0, spec.max_v_mps, spec.max_w_radps)
    t_out = np.arange(0.0, 60.0, 0.05)
    bot = MujocoRobot(spec, params, lifted=True)
    mv, mw = bot.replay((t, v, w), t_out)
    ref = simulate(params, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, t_out_s=t_out)
    assert np.max(np.abs(ref.w)) > 0.9 and np.max(np.abs(ref.v)) > 0.5  # turns and drives
    # the two part in the first steps of a speed change (the wheels carry the base's mass
    # only on their own diagonal of MuJoCo's mass matrix)
    assert np.mean(np.abs(mv - ref.v) <= 0.02) >= 0.85
    assert np.mean(np.abs(mw - ref.w) <= 0.1) >= 0.98
    assert float(np.max(np.abs(bot.data.qpos[:2]))) < 1e-3  # the base is held where it stood


def test_lifted_member_edit_keeps_the_wheels_loaded(new_robots: dict[str, Path]) -> None:
    from sim2real.mujoco import MujocoRobot

    spec = load_spec(new_robots["husky"])
    bot = MujocoRobot(spec, spec.drive.replace(track_factor=1.5), lifted=True)
    forward = bot.model.tendon("forward").id
    light = float(bot.model.tendon_armature[forward])
    bot.set_params(spec.drive.replace(track_factor=1.5, added_mass_kg=20.0))
    assert float(bot.model.tendon_armature[forward]) == pytest.approx(light + 20.0)
    assert float(MujocoRobot(spec).model.tendon_armature[forward]) == 0.0  # on the ground: none
