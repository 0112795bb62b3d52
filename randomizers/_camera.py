"""Jitter of the depth camera's mount pose (Liang et al. 2020)."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from randomizers._base import (
    Randomizer,
    check_choice,
    check_name,
    check_nonnegative,
    check_scale,
)
from randomizers._protocol import CAMERA_PROTOCOL, require_protocol
from randomizers.errors import RandomizationNotAppliedError

__all__ = ["CameraPoseJitter"]

_RESAMPLE = ("episode", "step")
_POSE_ATOL = 1e-6  # m and rad; envs may store the pose in float32


class CameraPoseJitter(
    gym.Wrapper[Any, Any, Any, Any], Randomizer, gym.utils.RecordConstructorArgs
):
    r"""Perturb the camera's mount pose per episode (default) or per step.

    Liang et al. (2020) vary where the depth camera is mounted during training to give the policy
    different perspectives. The pose in the base frame becomes
    :math:`(\mathbf p_0 + \delta_p, \boldsymbol\rho_0 + \delta_\rho)` with
    :math:`\delta_p \sim \mathcal N(0, (c\,\sigma_p)^2 I_3)` m and
    :math:`\delta_\rho \sim \mathcal N(0, (c\,\sigma_\rho)^2 I_3)` (roll, pitch, yaw; σ given in
    degrees), around the nominal pose read from the env at the first reset.

    Uses the camera protocol on ``env.unwrapped`` (``get_camera_pose``, ``set_camera_pose``,
    ``get_camera_view_matrix``). The pose is set *before* the env's reset (per-episode mode)
    or step (per-step mode) so the observation returned already uses it; the env must keep a
    set pose across reset. After each reset (and each step in per-step mode) the wrapper checks
    that the env reports the new pose. Once, at the first seeded reset with a non-zero jitter,
    it also checks that the rendered view matrix differs from the one of a probe reset of
    ``env.unwrapped`` with the same seed and the nominal pose (so envs whose view matrix is
    that of the last rendered frame are covered). Failures raise
    :class:`~randomizers.errors.RandomizationNotAppliedError`.

    Parameters
    ----------
    env : gymnasium.Env
        Env implementing the camera protocol.
    position_std_m : float
        σ_p of each position offset, m (>= 0). Liang et al. (2020) give no figure; the default 2 cm is
        our choice (a hand-mounted bracket's play), not a published value.
    orientation_std_deg : float
        σ_ρ of each roll/pitch/yaw offset, degrees (>= 0); default 2° (our choice as well).
    resample : {"episode", "step"}
        New pose each episode or each step.
    scale : float
        Curriculum scale c in [0, 1] multiplying both σ.
    name : str, optional
        Unique name in the stack; default ``CameraPoseJitter``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import CameraPoseJitter
    >>> class Cam(gym.Env):  # a toy env with the camera protocol
    ...     observation_space = gym.spaces.Box(-1.0, 1.0, (1,))
    ...     action_space = gym.spaces.Discrete(1)
    ...     xyz, rpy = np.array([0.1, 0.0, 0.3]), np.zeros(3)
    ...     def get_camera_pose(self):
    ...         return self.xyz.copy(), self.rpy.copy()
    ...     def set_camera_pose(self, xyz, rpy):
    ...         self.xyz, self.rpy = np.array(xyz), np.array(rpy)
    ...     def get_camera_view_matrix(self):  # a real env returns its renderer's matrix
    ...         return np.concatenate([self.xyz, self.rpy])
    ...     def reset(self, *, seed=None, options=None):
    ...         super().reset(seed=seed)
    ...         return np.zeros(1, np.float32), {}
    ...     def step(self, action):
    ...         return np.zeros(1, np.float32), 0.0, False, False, {}
    >>> env = CameraPoseJitter(Cam(), position_std_m=0.01, orientation_std_deg=1.0)
    >>> _, info = env.reset(seed=0)
    >>> record = info["randomization"]["CameraPoseJitter"]
    >>> bool(np.allclose(env.unwrapped.xyz, record["xyz_m"]))
    True
    >>> bool(np.allclose(env.unwrapped.xyz - [0.1, 0.0, 0.3], record["position_offset_m"]))
    True
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        position_std_m: float = 0.02,
        orientation_std_deg: float = 2.0,
        *,
        resample: str = "episode",
        scale: float = 1.0,
        name: str | None = None,
    ) -> None:
        position_std_m = check_nonnegative(position_std_m, argument="position_std_m", unit="m")
        orientation_std_deg = check_nonnegative(
            orientation_std_deg, argument="orientation_std_deg", unit="deg"
        )
        resample = check_choice(resample, argument="resample", choices=_RESAMPLE)
        scale = check_scale(scale)
        require_protocol(env, CAMERA_PROTOCOL, "CameraPoseJitter")
        name = check_name(name, env, "CameraPoseJitter")
        self._wrap(
            env,
            position_std_m=position_std_m,
            orientation_std_deg=orientation_std_deg,
            resample=resample,
            scale=scale,
            name=name,
        )
        self.position_std_m = position_std_m
        self.orientation_std_deg = orientation_std_deg
        self.resample = resample
        self.nominal_pose: tuple[np.ndarray, np.ndarray] | None = None
        self.offset = (np.zeros(3), np.zeros(3))
        self._view_checked = False

    def _draw_and_set(self) -> None:
        assert self.nominal_pose is not None  # read in reset() before the first draw
        c = self.scale
        d_xyz = c * self.position_std_m * self.rng.standard_normal(3)
        d_rpy = np.deg2rad(c * self.orientation_std_deg) * self.rng.standard_normal(3)
        self.offset = (d_xyz, d_rpy)
        self.env.unwrapped.set_camera_pose(  # type: ignore[attr-defined]
            self.nominal_pose[0] + d_xyz, self.nominal_pose[1] + d_rpy
        )

    def _target(self) -> tuple[np.ndarray, np.ndarray]:
        assert self.nominal_pose is not None
        return self.nominal_pose[0] + self.offset[0], self.nominal_pose[1] + self.offset[1]

    def _check_pose(self) -> None:
        base = self.env.unwrapped
        xyz, rpy = (np.asarray(v, dtype=np.float64) for v in base.get_camera_pose())  # type: ignore[attr-defined]
        want_xyz, want_rpy = self._target()
        if not (
            np.allclose(xyz, want_xyz, rtol=0, atol=_POSE_ATOL)
            and np.allclose(rpy, want_rpy, rtol=0, atol=_POSE_ATOL)
        ):
            raise RandomizationNotAppliedError(
                f"CameraPoseJitter: after set_camera_pose({want_xyz.tolist()}, "
                f"{want_rpy.tolist()}) {type(base).__name__}.get_camera_pose() returned "
                f"({xyz.tolist()}, {rpy.tolist()}); the env must keep a set camera pose, "
                "also across reset()"
            )

    def _view_with_nominal_pose(
        self, seed: int | None, options: dict[str, Any] | None
    ) -> np.ndarray | None:
        """View matrix of a probe reset of the base env with the nominal pose (or None).

        Done once, at the first seeded reset with a non-zero jitter: the same seed gives the
        same base pose, so the two renders differ only by the mount pose. Envs whose view
        matrix is "the last rendered frame" need such a render to compare with.
        """
        if self._view_checked or seed is None:
            return None
        if not (np.any(self.offset[0]) or np.any(self.offset[1])):
            return None
        assert self.nominal_pose is not None
        base = self.env.unwrapped
        base.set_camera_pose(*self.nominal_pose)  # type: ignore[attr-defined]
        base.reset(seed=seed, options=options)
        nominal = np.array(base.get_camera_view_matrix(), dtype=np.float64)  # type: ignore[attr-defined]
        base.set_camera_pose(*self._target())  # type: ignore[attr-defined]
        return nominal

    def _check_view(self, nominal: np.ndarray | None) -> None:
        """The rendered view must differ from the nominal pose's render at the same base pose."""
        if nominal is None:
            return
        base = self.env.unwrapped
        jittered = np.asarray(base.get_camera_view_matrix(), dtype=np.float64)  # type: ignore[attr-defined]
        if np.array_equal(jittered, nominal):
            raise RandomizationNotAppliedError(
                f"CameraPoseJitter: {type(base).__name__}.set_camera_pose() took the jittered "
                f"pose (offset {self.offset[0].tolist()} m, {self.offset[1].tolist()} rad) but "
                "get_camera_view_matrix() did not change; the renderer must use the pose set"
            )
        self._view_checked = True

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Set a new camera pose, reset the env and check that the pose took effect."""
        self._begin_episode(seed)
        if self.nominal_pose is None:
            xyz, rpy = self.env.unwrapped.get_camera_pose()  # type: ignore[attr-defined]
            self.nominal_pose = (
                np.array(xyz, dtype=np.float64, copy=True),
                np.array(rpy, dtype=np.float64, copy=True),
            )
        self._draw_and_set()
        nominal_view = self._view_with_nominal_pose(seed, options)
        obs, info = self.env.reset(seed=seed, options=options)
        self._check_pose()
        self._check_view(nominal_view)
        return obs, self._record(info, self._values())

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env (with a new pose first in per-step mode)."""
        if self.resample == "step":
            self._draw_and_set()
            self._check_pose()
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.resample == "step":
            self._record(info, self._values())
        return obs, reward, terminated, truncated, info

    def _values(self) -> dict[str, Any]:
        xyz, rpy = self._target()
        return {
            "position_offset_m": self.offset[0].tolist(),
            "orientation_offset_rad": self.offset[1].tolist(),
            "xyz_m": xyz.tolist(),
            "rpy_rad": rpy.tolist(),
            "scale": self.scale,
        }
