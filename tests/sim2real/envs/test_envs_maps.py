"""The map generator of Yang et al.: presets, reproducibility, safe discs, obstacle density."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim2real.envs.geometry import disc_clearance
from sim2real.envs.maps import (
    PAPER_RHO_OBS,
    PRESETS,
    MapConfig,
    generate_map,
    get_preset,
    obstacle_density,
)
from sim2real.errors import Sim2RealValueError


def test_presets_carry_table_one_numbers() -> None:
    ranges = {k: (c.n_min, c.n_max) for k, c in PRESETS.items()}
    assert ranges == {
        "TRAIN": (70, 100),
        "TEST1": (5, 50),
        "TEST2": (50, 100),
        "TEST3": (100, 150),
        "TEST4": (150, 200),
    }
    for cfg in PRESETS.values():
        assert (cfg.d_target_m, cfg.r_wall, cfg.cylinder_radius_m) == (8.0, 0.8, 0.34)
        assert (cfg.area_m, cfg.wall_length_m, cfg.wall_thickness_m) == (20.0, 10.0, 0.15)
        assert cfg.goal_tolerance_m == 0.3
    assert set(PAPER_RHO_OBS) == set(PRESETS)
    assert get_preset("test3") is PRESETS["TEST3"]
    with pytest.raises(Sim2RealValueError, match="known presets are TRAIN"):
        get_preset("TEST9")


@pytest.mark.parametrize("name", list(PRESETS))
def test_maps_respect_counts_area_and_safe_discs(name: str) -> None:
    cfg = PRESETS[name]
    for seed in range(5):
        m = generate_map(cfg, np.random.default_rng(seed))
        assert cfg.n_min <= len(m.cylinders) <= cfg.n_max
        assert m.walls.shape[1] == 5 and len(m.walls) <= 4
        np.testing.assert_array_equal(m.start_xy, [0.0, 0.0])
        np.testing.assert_array_equal(m.goal_xy, [8.0, 0.0])
        assert -math.pi <= m.start_yaw_rad <= math.pi
        for p in (m.start_xy, m.goal_xy):
            assert disc_clearance(m.scene, p, cfg.safe_radius_m) > 0.0
        c = m.cylinders[:, :2]
        assert np.all(np.abs(c - [4.0, 0.0]) <= 10.0 - cfg.cylinder_radius_m + 1e-9)
        assert 0.0 < m.rho_obs < 0.25


def test_same_seed_same_map_and_different_seeds_differ() -> None:
    a = generate_map(PRESETS["TRAIN"], np.random.default_rng(7))
    b = generate_map(PRESETS["TRAIN"], np.random.default_rng(7))
    c = generate_map(PRESETS["TRAIN"], np.random.default_rng(8))
    np.testing.assert_array_equal(a.cylinders, b.cylinders)
    np.testing.assert_array_equal(a.walls, b.walls)
    assert a.start_yaw_rad == b.start_yaw_rad
    assert not np.array_equal(a.cylinders[:5], c.cylinders[:5])


def test_wall_probability_is_r_wall() -> None:
    cfg = MapConfig(n_min=0, n_max=0, r_wall=0.8)
    counts = [len(generate_map(cfg, np.random.default_rng(s)).walls) for s in range(200)]
    # 4 walls each with p = 0.8 (minus rare drops after 20 failed placements): mean 3.2
    assert 3.0 < np.mean(counts) < 3.35
    none = MapConfig(n_min=0, n_max=0, r_wall=0.0)
    assert len(generate_map(none, np.random.default_rng(0)).walls) == 0


def test_obstacle_density_matches_analytic_areas() -> None:
    cyl = np.array([[0.0, 0.0, 0.5], [3.0, 0.0, 0.5], [3.2, 0.0, 0.5]])  # two overlap
    wall = np.array([[0.0, 4.0, 4.0, 0.5, 0.3]])
    lens = 2 * 0.25 * math.acos(0.2 / 1.0) - 0.1 * math.sqrt(1.0 - 0.04)  # lens of the 2 discs
    area = 3 * math.pi * 0.25 - lens + 4.0 * 0.5
    rho = obstacle_density(cyl, wall, centre_xy=np.zeros(2), area_m=10.0)
    assert rho == pytest.approx(area / 100.0, rel=0.01)


def test_bad_config_is_refused_with_the_key() -> None:
    with pytest.raises(Sim2RealValueError, match="r_wall"):
        MapConfig(r_wall=1.5)
    with pytest.raises(Sim2RealValueError, match="n_min"):
        MapConfig(n_min=10, n_max=5)


@pytest.mark.parametrize("name", list(PRESETS))
def test_presets_reach_table_one_densities(name: str) -> None:
    """Mean rho_obs (obstacle area / total area) of each preset is inside Table I's range."""
    lo, hi = PAPER_RHO_OBS[name]
    rho = np.array(
        [generate_map(PRESETS[name], np.random.default_rng(s)).rho_obs for s in range(30)]
    )
    assert lo < rho.mean() < hi
    assert np.mean((rho >= lo - 0.01) & (rho <= hi + 0.01)) >= 0.8
