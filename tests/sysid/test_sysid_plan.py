"""The excitation plan (sysid.plan): within the limits and the floor, deterministic, complete."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.params import DriveParams
from robots.spec import RobotSpec, load_spec
from sysid.errors import SysidValueError
from sysid.plan import (
    LIMITS,
    MASS_GAIN,
    OVERDRIVE,
    REACH_SD,
    beyond_session,
    information_bound,
    plan_excitation,
    torque_cap_reach,
    unreachable,
    weakly_identified,
)

ROBOTS = ("turtlebot3_burger", "turtlebot2", "turtlebot3_waffle_pi")


@settings(max_examples=15, deadline=None)
@given(
    robot=st.sampled_from(ROBOTS),
    duration_s=st.floats(10.0, 200.0),
    area_m=st.floats(0.5, 6.0),
)
def test_the_plan_stays_within_the_limits_and_the_floor(
    robot: str, duration_s: float, area_m: float
) -> None:
    spec = load_spec(robot)
    plan = plan_excitation(spec, duration_s, area_m=area_m)
    v_lim = min(spec.drive.speed_lim_v_mps, spec.max_v_mps)
    w_lim = min(spec.drive.speed_lim_w_radps, spec.max_w_radps)
    assert plan.t_s.size == round(duration_s * 10.0)
    assert np.abs(plan.v_mps).max() <= OVERDRIVE * v_lim + 1e-12
    assert np.abs(plan.w_radps).max() <= OVERDRIVE * w_lim + 1e-12
    assert np.all(plan.v_mps[-10:] == 0.0) and np.all(plan.w_radps[-10:] == 0.0)
    # the held legs are shortened to the floor, down to a floor of 0.6 s at 110 %
    reach = max(0.5 * area_m, OVERDRIVE * v_lim * 0.6 * 2)
    assert plan.extent_m <= reach
    assert all(0.0 <= b.start_s < b.end_s <= duration_s for b in plan.blocks)


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_90_s_plan_reaches_every_limit_and_excites_every_prior(robot: str) -> None:
    spec = load_spec(robot)
    plan = plan_excitation(spec, 90.0)
    v_lim = min(spec.drive.speed_lim_v_mps, spec.max_v_mps)
    w_lim = min(spec.drive.speed_lim_w_radps, spec.max_w_radps)
    assert np.abs(plan.v_mps).max() == pytest.approx(OVERDRIVE * v_lim)
    assert np.abs(plan.w_radps).max() == pytest.approx(OVERDRIVE * w_lim)
    assert (plan.v_mps > 0).any() and (plan.v_mps < 0).any()
    half = 0.5 * spec.geometry.wheel_separation_m
    outer = (np.abs(plan.v_mps) + half * np.abs(plan.w_radps)) / spec.geometry.wheel_radius_m
    assert outer.max() >= spec.drive.wheel_speed_max_radps  # the wheel cap acts
    kinds = {b.kind for b in plan.blocks}
    assert kinds == {"v steps", "w steps", "speed levels", "ramps", "turns while driving"}
    fitted = {n for n in DriveParams.names() if spec.priors[n].sd > 0}
    assert fitted <= set(plan.identifies()) | set(plan.unreachable)
    assert not set(plan.identifies()) & set(plan.unreachable)
    assert set(MASS_GAIN) <= fitted


def test_the_same_spec_and_duration_give_the_same_script() -> None:
    a = plan_excitation(load_spec("turtlebot2"), 60.0)
    b = plan_excitation(load_spec("turtlebot2"), 60.0)
    np.testing.assert_array_equal(a.v_mps, b.v_mps)
    np.testing.assert_array_equal(a.w_radps, b.w_radps)
    assert a.blocks == b.blocks and a.extent_m == b.extent_m


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"duration_s": 5.0}, "duration_s must be a number >= 10, got 5.0"),
        ({"duration_s": math.nan}, "duration_s must be a number >= 10, got nan"),
        ({"duration_s": 60.0, "rate_hz": 0.5}, "rate_hz must be a number >= 1 Hz"),
        ({"duration_s": 60.0, "area_m": 0.1}, "area_m must be a number >= 0.5"),
    ],
)
def test_bad_input_is_one_sentence(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(SysidValueError, match=match):
        plan_excitation(load_spec("turtlebot2"), **kwargs)
    with pytest.raises(SysidValueError, match=r"spec must be a robots\.spec\.RobotSpec, got str"):
        plan_excitation("turtlebot2", 60.0)


@pytest.mark.parametrize("robot", ROBOTS)
def test_what_a_plan_may_leave_near_its_prior_is_excited_and_argued_from_the_spec(
    robot: str,
) -> None:
    spec = load_spec(robot)
    plan = plan_excitation(spec, 90.0)
    assert set(plan.weak) <= set(plan.identifies())
    assert set(MASS_GAIN[1:]) <= set(plan.weak)
    # fields the spec knows exactly are not offered as identified
    assert not {n for n, p in spec.priors.items() if p.sd == 0} & set(plan.identifies())


def test_the_weak_list_follows_the_physics_of_each_base() -> None:
    burger = weakly_identified(load_spec("turtlebot3_burger"))
    kobuki = weakly_identified(load_spec("turtlebot2"))
    # the Burger's PI loops, with no smoother, ask twice its cap's centre at an arc reversed
    # from the wheel-speed cap: within reach, but a base that gives it shows only a lower bound
    assert "0.167 N m" in burger["wheel_torque_max_nm"]
    # the Kobuki's smoother keeps the cap out of reach: not weak, unreachable (below)
    assert "wheel_torque_max_nm" not in kobuki
    # viscous priors of 2.4 % and 2.3 % of the Burger's loop gain hide behind it; the Kobuki's
    # yaw term (12 %) does not
    assert {"viscous_v_ns_per_m", "viscous_w_nms_per_rad"} <= set(burger)
    assert "2.4 %" in burger["viscous_v_ns_per_m"]
    assert "viscous_w_nms_per_rad" not in kobuki
    # the Burger has no smoother: every command change is a step, where the commands' timing
    # jitter moves the transients more than friction does; the Kobuki's smoother ramps them
    assert all(
        "timing jitter" in burger[n] for n in ("viscous_v_ns_per_m", "viscous_w_nms_per_rad")
    )
    assert "timing jitter" not in kobuki["viscous_v_ns_per_m"]
    # a P-loop base (no integral prior) keeps its friction in the steady state: not weak
    spec = load_spec("turtlebot3_burger")
    p_loop = dataclasses.replace(
        spec,
        priors={
            **spec.priors,
            "speed_loop_ki_per_s": dataclasses.replace(
                spec.priors["speed_loop_ki_per_s"], nominal=0.0
            ),
        },
    )
    assert not {"viscous_v_ns_per_m", "viscous_w_nms_per_rad"} & set(weakly_identified(p_loop))


def _with_drive(robot: str, **drive: float) -> RobotSpec:
    """``robot``'s spec with ``drive`` values, their priors centred on them."""
    spec = load_spec(robot)
    priors = {
        **spec.priors,
        **{n: dataclasses.replace(spec.priors[n], nominal=x) for n, x in drive.items()},
    }
    return dataclasses.replace(spec, drive=spec.drive.replace(**drive), priors=priors)


def test_the_torque_cap_is_out_of_reach_only_where_no_command_asks_for_it() -> None:
    # the Kobuki's 1 m/s^2, 2 rad/s^2 smoother: an arc reversed from the wheel cap asks
    # 0.063 N m per wheel (2.52 kg x 1 m/s^2 x 0.035 m / 2 = 0.044 N m of it the forward
    # axis), ln(0.208 / 0.0633) / hypot(0.3, 0.5) = 2.0 prior sd below the 0.208 N m cap
    kobuki = torque_cap_reach(load_spec("turtlebot2"))
    assert kobuki is not None and not kobuki.reachable
    assert kobuki.ask_nm == pytest.approx(0.0633, abs=5e-4)
    assert kobuki.margin_sd == pytest.approx(math.log(0.208 / kobuki.ask_nm) / math.hypot(0.3, 0.5))
    why = unreachable(load_spec("turtlebot2"))["wheel_torque_max_nm"]
    assert "0.0633 N m per wheel" in why and "0.208 N m" in why
    plan = plan_excitation(load_spec("turtlebot2"), 90.0)
    assert set(plan.unreachable) == {"wheel_torque_max_nm"}
    assert "wheel_torque_max_nm" not in plan.identifies()
    # the same base without its smoother: every reversal is a step into the PI loops, which
    # ask more than the cap, so a plan can reach it
    bare = torque_cap_reach(_with_drive("turtlebot2", accel_lim_v_mps2=math.inf,
                                        accel_lim_w_radps2=math.inf))  # fmt: skip
    assert bare is not None and bare.reachable and bare.ask_nm > 0.208
    # the Burger has no smoother: reachable; behind a gentle one (0.3 m/s^2, 3 rad/s^2) not
    burger = torque_cap_reach(load_spec("turtlebot3_burger"))
    assert burger is not None and burger.reachable and burger.ask_nm > 2 * 0.081
    assert unreachable(load_spec("turtlebot3_burger")) == {}
    smoothed = _with_drive("turtlebot3_burger", accel_lim_v_mps2=0.3, accel_lim_w_radps2=3.0)
    reach = torque_cap_reach(smoothed)
    assert reach is not None and reach.margin_sd > REACH_SD
    assert set(unreachable(smoothed)) == {"wheel_torque_max_nm"}
    # a cap known exactly is no question
    known = load_spec("turtlebot2")
    known = dataclasses.replace(
        known,
        priors={**known.priors, "wheel_torque_max_nm": dataclasses.replace(
            known.priors["wheel_torque_max_nm"], sd=0.0)},
    )  # fmt: skip
    assert torque_cap_reach(known) is None and unreachable(known) == {}


@settings(max_examples=8, deadline=None)
@given(accel=st.floats(0.2, 20.0))
def test_a_harder_smoother_asks_more_torque(accel: float) -> None:
    soft = torque_cap_reach(_with_drive("turtlebot2", accel_lim_v_mps2=accel,
                                        accel_lim_w_radps2=2.0 * accel))  # fmt: skip
    hard = torque_cap_reach(_with_drive("turtlebot2", accel_lim_v_mps2=1.5 * accel,
                                        accel_lim_w_radps2=3.0 * accel))  # fmt: skip
    assert soft is not None and hard is not None
    assert hard.ask_nm > soft.ask_nm and hard.margin_sd < soft.margin_sd


@pytest.mark.slow
def test_the_information_bound_says_what_no_session_of_a_length_identifies() -> None:
    spec = load_spec("turtlebot3_burger")
    viscous = {"viscous_v_ns_per_m", "viscous_w_nms_per_rad"}
    # 20 s of the plan hold its v steps and part of its w steps: the viscous terms, the yaw
    # Coulomb term and the mass-gain direction stay above half their prior sd at best
    short = information_bound(spec, 20.0)
    assert viscous | {"coulomb_w_nm", "added_mass_kg"} <= set(beyond_session(short))
    assert short.sd_ratio["viscous_v_ns_per_m"] == pytest.approx(0.79, abs=0.02)
    # 90 s (the speed levels, the turns while driving): within reach in principle, the
    # commands' 10 ms arrival jitter marginalised; left beyond it only the mass-gain direction
    full = information_bound(spec, 90.0)
    assert max(full.sd_ratio[n] for n in viscous) < 0.4
    assert set(beyond_session(full)) == {"added_mass_kg"} and set(MASS_GAIN) >= {"added_mass_kg"}
    assert "informed to 0.8" in beyond_session(full)["added_mass_kg"]
    # a longer session informs every parameter at least as well; limits are not its question
    assert all(full.sd_ratio[n] <= short.sd_ratio[n] + 1e-9 for n in full.sd_ratio)
    assert not set(full.sd_ratio) & set(LIMITS)
    assert set(full.sd_ratio) == {
        n for n, p in spec.priors.items() if p.informative and n not in LIMITS
    }


def test_the_information_bound_refuses_noise_it_cannot_weigh() -> None:
    with pytest.raises(SysidValueError, match="needs noise > 0 and jitter_s >= 0"):
        information_bound(load_spec("turtlebot2"), 20.0, noise=(0.0, 0.02))
