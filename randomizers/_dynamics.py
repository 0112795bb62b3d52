"""Per-episode randomisation of the drive-model parameters (friction, mass, delay, limits)."""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from randomizers._base import Randomizer, check_name, check_number, check_scale, stream_key
from randomizers._protocol import DRIVE_PROTOCOL, require_protocol
from randomizers.errors import RandomizationNotAppliedError, RandomizerValueError
from robots.errors import RobotsError
from robots.params import MAY_BE_NEGATIVE, MUST_BE_POSITIVE, DriveParams, read_params_file
from robots.randomization import DriveDistribution

__all__ = [
    "MAX_SPREAD",
    "DynamicsRandomizer",
    "check_spread",
    "default_bounds",
    "load_distribution",
    "stream_generator",
]

# Same rules as robots.params: these must stay > 0, these may be negative, the rest >= 0.
_POSITIVE = MUST_BE_POSITIVE
_SIGNED = MAY_BE_NEGATIVE
#: Floor of a must-be-positive parameter, as a fraction of its range centre / fitted value.
POSITIVE_FLOOR_FRACTION = 0.01
#: Largest ``spread`` of a sysid distribution: ten times its standard deviations. Wider than
#: that the identified covariance no longer shapes the draws (they pile up at the schema's
#: plausible-range edges); give the ranges by hand with ``uniform``/``normal`` instead.
MAX_SPREAD = 10.0


def check_spread(spread: Any) -> float:
    """Return ``spread`` as a float after checking it is a number in [0, :data:`MAX_SPREAD`].

    Examples
    --------
    >>> check_spread(3)
    3.0
    """
    value = check_number(spread, argument="spread")
    if not 0.0 <= value <= MAX_SPREAD:
        raise RandomizerValueError(
            f"DynamicsRandomizer: argument 'spread' must be in [0, {MAX_SPREAD:g}] (a multiplier "
            f"on the sysid distribution's standard deviations, 1 = as identified), got "
            f"{spread!r}; for wider ranges give 'uniform' or 'normal' by hand"
        )
    return value


def default_bounds(name: str, centre: float) -> tuple[float, float]:
    """Physical clip range of a drive parameter when no ``bounds`` entry is given.

    ``>= 0`` for friction, delay and the like; ``>= 1 %`` of the centre for parameters that must
    be positive (gains, limits); unbounded for ``added_mass_kg`` / ``added_yaw_inertia_kgm2``
    (the env's geometry decides; pass ``bounds`` to keep the total mass positive).

    Examples
    --------
    >>> default_bounds("coulomb_v_fwd_n", 2.0), default_bounds("motor_gain_nms_per_rad", 0.5)
    ((0.0, inf), (0.005, inf))
    """
    if name in _SIGNED:
        return -math.inf, math.inf
    if name in _POSITIVE:
        return POSITIVE_FLOOR_FRACTION * abs(centre), math.inf
    return 0.0, math.inf


def stream_generator(seed: int | None, name: str) -> np.random.Generator:
    """The generator a randomizer called ``name`` draws from after ``reset(seed=seed)``.

    ``sim2real agree --ensemble`` draws its parameter sets from
    ``stream_generator(seed, "DynamicsRandomizer")``, so its members are exactly the episodes
    of a default-named :class:`DynamicsRandomizer` reset with the same seed.

    Examples
    --------
    >>> a = stream_generator(3, "DynamicsRandomizer").standard_normal()
    >>> a == stream_generator(3, "DynamicsRandomizer").standard_normal()
    True
    """
    return np.random.Generator(
        np.random.PCG64(np.random.SeedSequence(entropy=seed, spawn_key=stream_key(name)))
    )


def load_distribution(
    path: str | Path, *, robot: str | None = None, owner: str = "DynamicsRandomizer.from_sysid"
) -> DriveDistribution:
    """The ``randomization`` block of a params file, as a :class:`DriveDistribution`.

    ``robot`` (e.g. the env's robot) must be the file's robot; None accepts the file's own.
    Errors are :class:`~randomizers.errors.RandomizerValueError` naming ``owner`` and the file.
    """
    try:
        if robot is None:
            robot = read_params_file(path).robot
        return DriveDistribution.from_params_file(path, robot=robot)
    except (RobotsError, OSError) as exc:
        raise RandomizerValueError(f"{owner}: {exc}") from None


def env_robot(env: gym.Env[Any, Any]) -> str | None:
    """Name of the robot an env simulates (``env.unwrapped.robot_spec.name``), if it says."""
    spec = getattr(env.unwrapped, "robot_spec", None)
    name = getattr(spec, "name", None)
    return name if isinstance(name, str) else None


def _number(value: Any, argument: str, *, allow_inf: bool) -> float:
    if allow_inf and isinstance(value, float) and math.isinf(value):
        return value
    return check_number(value, argument=argument)


def _check_field(name: Any, argument: str) -> str:
    if name not in DriveParams.names():
        raise RandomizerValueError(
            f"DynamicsRandomizer: argument '{argument}' names unknown drive parameter {name!r}; "
            f"known ones are {list(DriveParams.names())}"
        )
    return str(name)


def _pairs(
    table: Mapping[str, Sequence[float]] | None,
    argument: str,
    what: str,
    *,
    allow_inf: bool = False,
) -> dict[str, tuple[float, float]]:
    out: dict[str, tuple[float, float]] = {}
    for field, pair in (table or {}).items():
        _check_field(field, argument)
        if not (isinstance(pair, Sequence) and not isinstance(pair, str) and len(pair) == 2):
            raise RandomizerValueError(
                f"DynamicsRandomizer: argument '{argument}' entry '{field}' must be {what}, got "
                f"{pair!r}"
            )
        a, b = (
            _number(v, f"{argument}['{field}'][{i}]", allow_inf=allow_inf)
            for i, v in enumerate(pair)
        )
        out[field] = (a, b)
    return out


class DynamicsRandomizer(
    gym.Wrapper[Any, Any, Any, Any], Randomizer, gym.utils.RecordConstructorArgs
):
    r"""Draw drive-model parameters (:class:`robots.params.DriveParams`) once per episode.

    Liang et al. (2020) identify extra motor friction and inertia of the real robot; randomising them
    around the identified values makes a policy robust to what identification missed. Two
    ways to say what to draw:

    - **a sysid result** (``sysid=params.yaml``, see :meth:`from_sysid`): every episode is one
      draw of the file's ``randomization`` block,
      :meth:`robots.randomization.DriveDistribution.sample` with ``spread`` = s x c (s the
      ``spread`` argument, c the curriculum scale) -- the one sampler ``sim2real agree
      --ensemble`` uses too (same seed, same robots). The whole parameter set comes from the
      file (the env's own values are replaced), so the env simulates the identified robot
      population; ``spread`` > 1 widens it (every standard deviation in the fit coordinates
      times s, up to :data:`MAX_SPREAD`; draws stay inside the schema's plausible ranges),
      e.g. for a policy that must also survive robots the sessions did not show.
    - **by hand**, field by field, then clipped to ``bounds[name]`` or :func:`default_bounds`:

      - ``uniform={name: [low, high]}``: :math:`m + c\,(u - m)` with
        :math:`u \sim U(low, high)` and centre :math:`m = (low + high)/2`, i.e. the range
        shrinks about its centre with the curriculum scale c;
      - ``normal={name: [mean, std]}``: :math:`\mathrm{mean} + c\,\mathrm{std}\,z`,
        :math:`z \sim \mathcal N(0, 1)`;

      fields are drawn in :class:`~robots.params.DriveParams` declaration order; the others
      keep the env's values (read with ``get_drive_params`` at the first reset).

    The parameters are applied with ``env.unwrapped.set_drive_params`` *before* the env's reset
    (so the whole episode uses them) and read back with ``get_drive_params`` after the set and
    after the reset; a mismatch raises
    :class:`~randomizers.errors.RandomizationNotAppliedError`.

    Parameters
    ----------
    env : gymnasium.Env
        Env implementing the drive protocol.
    uniform : mapping of str to [low, high], optional
        Uniform ranges, in each parameter's unit.
    normal : mapping of str to [mean, std], optional
        Gaussian distributions (std >= 0).
    bounds : mapping of str to [low, high], optional
        Hard clip ranges overriding :func:`default_bounds` (not with ``sysid``).
    sysid : str or Path, optional
        A params file with a ``randomization`` block (``sim2real sysid fit`` writes one); not
        together with ``uniform``/``normal``/``bounds``.
    robot : str, optional
        The robot the env simulates; the params file must be for it. Default: the env's
        ``robot_spec.name`` when it has one, else the file's robot.
    fields : sequence of str, optional
        With ``sysid``: only these fields vary (their marginal); the others stay at the
        distribution's mean.
    spread : float
        With ``sysid``: multiplier s on the distribution's standard deviations, in
        [0, :data:`MAX_SPREAD`] (1 = as identified).
    scale : float
        Curriculum scale c in [0, 1].
    name : str, optional
        Unique name in the stack; default ``DynamicsRandomizer``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import DynamicsRandomizer
    >>> from robots.params import DriveParams
    >>> class Base(gym.Env):  # a toy env with the drive protocol
    ...     observation_space = gym.spaces.Box(-1.0, 1.0, (1,))
    ...     action_space = gym.spaces.Discrete(1)
    ...     params = DriveParams(coulomb_v_fwd_n=1.0)
    ...     def get_drive_params(self):
    ...         return self.params
    ...     def set_drive_params(self, params):
    ...         self.params = params
    ...     def reset(self, *, seed=None, options=None):
    ...         super().reset(seed=seed)
    ...         return np.zeros(1, np.float32), {}
    ...     def step(self, action):
    ...         return np.zeros(1, np.float32), 0.0, False, False, {}
    >>> env = DynamicsRandomizer(Base(), uniform={"coulomb_v_fwd_n": [0.5, 1.5]})
    >>> _, info = env.reset(seed=0)
    >>> drawn = info["randomization"]["DynamicsRandomizer"]["coulomb_v_fwd_n"]
    >>> env.unwrapped.params.coulomb_v_fwd_n == drawn and 0.5 <= drawn <= 1.5
    True
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        *,
        uniform: Mapping[str, Sequence[float]] | None = None,
        normal: Mapping[str, Sequence[float]] | None = None,
        bounds: Mapping[str, Sequence[float]] | None = None,
        sysid: str | Path | None = None,
        robot: str | None = None,
        fields: Iterable[str] | None = None,
        spread: float = 1.0,
        scale: float = 1.0,
        name: str | None = None,
    ) -> None:
        spread = check_spread(spread)
        uni = _pairs(uniform, "uniform", "[low, high]")
        nor = _pairs(normal, "normal", "[mean, std]")
        lim = _pairs(bounds, "bounds", "[low, high]", allow_inf=True)
        scale = check_scale(scale)
        require_protocol(env, DRIVE_PROTOCOL, "DynamicsRandomizer")
        dist = None
        if sysid is not None:
            if uni or nor or lim:
                raise RandomizerValueError(
                    "DynamicsRandomizer: argument 'sysid' draws every parameter from the params "
                    "file; do not also give 'uniform', 'normal' or 'bounds' (use one stack "
                    "entry each)"
                )
            robot = robot if robot is not None else env_robot(env)
            dist = _marginal(load_distribution(sysid, robot=robot), fields, sysid)
        else:
            if fields is not None or robot is not None or spread != 1.0:
                raise RandomizerValueError(
                    "DynamicsRandomizer: arguments 'fields', 'robot' and 'spread' need 'sysid' "
                    "(a params file); pass sysid='params.yaml' or drop them (with 'uniform'/"
                    "'normal' give the width itself)"
                )
            _check_distributions(uni, nor, lim)
        name = check_name(name, env, "DynamicsRandomizer")
        if dist is None:
            arguments: dict[str, Any] = {
                "uniform": {k: list(v) for k, v in uni.items()} or None,
                "normal": {k: list(v) for k, v in nor.items()} or None,
                "bounds": {k: list(v) for k, v in lim.items()} or None,
            }
        else:
            arguments = {
                "sysid": str(sysid),
                "robot": dist.robot,
                "fields": None if fields is None else list(dist.names),
                "spread": spread,
            }
        self._wrap(env, scale=scale, name=name, **arguments)
        self._uniform = uni
        self._normal = nor
        self._bounds = lim
        self._order = [f for f in DriveParams.names() if f in uni or f in nor]
        #: The distribution drawn from (with ``sysid``), else None.
        self.distribution: DriveDistribution | None = dist
        #: Multiplier on the sysid distribution's standard deviations.
        self.spread = spread
        self.nominal: DriveParams | None = None
        self.params: DriveParams | None = None
        self.sampled: dict[str, float] = {}

    @classmethod
    def from_sysid(
        cls,
        path: str | Path,
        *,
        env: gym.Env[Any, Any] | None = None,
        robot: str | None = None,
        scale: float = 1.0,
        fields: Iterable[str] | None = None,
        spread: float = 1.0,
        name: str | None = None,
    ) -> Any:
        """Randomise with the ``randomization`` block of a sysid result (see the class doc).

        Each episode is ``DriveDistribution.sample(rng, 1, spread=spread * scale)``: ``spread``
        (in [0, :data:`MAX_SPREAD`], 1 = as identified) widens the identified population, the
        curriculum ``scale`` (in [0, 1]) shrinks it during training. The file must be
        for the env's robot (``robot``, else ``env.unwrapped.robot_spec.name`` when the env
        has one). Without ``env`` it returns a picklable ``env -> wrapper`` callable for
        ``gymnasium.make_vec(..., wrappers=[...])``; with ``env`` it returns the wrapper.

        Examples
        --------
        >>> make = DynamicsRandomizer.from_sysid("params.yaml", spread=3.0)  # doctest: +SKIP
        >>> env = make(base_env)  # doctest: +SKIP
        """
        check_scale(scale)
        check_spread(spread)
        dist = load_distribution(path, robot=robot)  # fail here, not in a worker
        _marginal(dist, fields, path)
        wanted = None if fields is None else list(fields)
        factory = functools.partial(
            cls,
            sysid=str(path),
            robot=robot,
            fields=wanted,
            spread=spread,
            scale=scale,
            name=name,
        )
        return factory if env is None else factory(env)

    def _draw(self) -> dict[str, float]:
        values: dict[str, float] = {}
        c = self.scale
        for field in self._order:
            if field in self._uniform:
                low, high = self._uniform[field]
                centre = 0.5 * (low + high)
                value = centre + c * (float(self.rng.uniform(low, high)) - centre)
            else:
                centre, std = self._normal[field]
                value = centre + c * std * float(self.rng.standard_normal())
            lo, hi = self._bounds.get(field, default_bounds(field, centre))
            values[field] = float(np.clip(value, lo, hi))
        return values

    def _check_applied(self, when: str) -> None:
        base = self.env.unwrapped
        got = base.get_drive_params()  # type: ignore[attr-defined]
        assert self.params is not None
        want = self.params.to_dict()
        wrong = {
            f: (getattr(got, f), want[f])
            for f in self.sampled
            if not math.isclose(getattr(got, f), want[f], rel_tol=1e-9, abs_tol=1e-12)
        }
        if wrong:
            raise RandomizationNotAppliedError(
                f"DynamicsRandomizer: {when}, {type(base).__name__}.get_drive_params() reports "
                f"(got, set) = {wrong}; set_drive_params must take effect and persist across "
                "reset()"
            )

    def _episode_params(self) -> DriveParams:
        if self.distribution is not None:
            params = self.distribution.sample(self.rng, 1, spread=self.spread * self.scale)[0]
            self.sampled = {f: float(getattr(params, f)) for f in self.distribution.names}
            return params
        assert self.nominal is not None
        self.sampled = self._draw()
        try:
            return self.nominal.replace(**self.sampled)
        except ValueError as exc:
            raise RandomizerValueError(
                f"DynamicsRandomizer: the drawn parameters are not valid ({exc}); narrow the "
                "distributions or pass 'bounds'"
            ) from None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Draw and apply the episode's drive parameters, then reset the env."""
        self._begin_episode(seed)
        base = self.env.unwrapped
        if self.nominal is None:
            self.nominal = base.get_drive_params()  # type: ignore[attr-defined]
        self.params = self._episode_params()
        base.set_drive_params(self.params)  # type: ignore[attr-defined]
        self._check_applied("right after set_drive_params")
        obs, info = self.env.reset(seed=seed, options=options)
        self._check_applied("after reset")
        return obs, self._record(info, {**self.sampled, "scale": self.scale})

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env (the parameters stay fixed within an episode)."""
        return self.env.step(action)


def _marginal(
    dist: DriveDistribution, fields: Iterable[str] | None, path: str | Path
) -> DriveDistribution:
    """``dist`` with only ``fields`` varying (their marginal); the rest fixed at the mean."""
    if fields is None:
        return dist
    wanted = [_check_field(f, "fields") for f in fields]
    missing = [f for f in wanted if f not in dist.names]
    if missing or not wanted:
        raise RandomizerValueError(
            f"DynamicsRandomizer.from_sysid: argument 'fields' names {missing or wanted}, which "
            f"do not vary in '{path}' (no std: fixed or not identified); varying ones: "
            f"{list(dist.names)}"
        )
    keep = [i for i, n in enumerate(dist.names) if n in wanted]
    cov = dist.covariance_array[np.ix_(keep, keep)]
    mean_params = dist.mean_params()
    fixed = {f: float(getattr(mean_params, f)) for f in DriveParams.names() if f not in wanted}
    return DriveDistribution(
        robot=dist.robot,
        geometry=dist.geometry,
        names=tuple(dist.names[i] for i in keep),
        mean=tuple(dist.mean[i] for i in keep),
        covariance=tuple(tuple(float(c) for c in row) for row in cov),
        fixed=fixed,
        noise=dist.noise,
        lower={k: v for k, v in dist.lower.items() if k in wanted},
    )


def _check_distributions(
    uni: dict[str, tuple[float, float]],
    nor: dict[str, tuple[float, float]],
    lim: dict[str, tuple[float, float]],
) -> None:
    if not uni and not nor:
        raise RandomizerValueError(
            "DynamicsRandomizer: give at least one parameter in 'uniform' or 'normal' (or use "
            "DynamicsRandomizer.from_sysid); got neither"
        )
    both = sorted(set(uni) & set(nor))
    if both:
        raise RandomizerValueError(
            f"DynamicsRandomizer: parameter(s) {both} appear in both 'uniform' and 'normal'; "
            "give each parameter one distribution"
        )
    _check_ranges("uniform", uni)
    for field, (_, std) in nor.items():
        if std < 0:
            raise RandomizerValueError(
                f"DynamicsRandomizer: argument 'normal' entry '{field}' has std {std} < 0; the "
                "standard deviation must be >= 0"
            )
    _check_ranges("bounds", lim)


def _check_ranges(argument: str, ranges: dict[str, tuple[float, float]]) -> None:
    for field, (low, high) in ranges.items():
        if low > high:
            raise RandomizerValueError(
                f"DynamicsRandomizer: argument '{argument}' entry '{field}' must have low <= "
                f"high, got [{low}, {high}]"
            )
