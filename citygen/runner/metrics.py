"""The URBAN-BENCH metrics, computed by the paper's formulas from per-episode records.

An environment fills one record per episode step by step (:class:`NavEpisode`,
:class:`LocoEpisode`, :class:`TraverseEpisode`: ``record_step(...)`` after every control
step, ``finish(...)`` once at the end); pure functions turn a finished record into one row
of metrics (:func:`nav_metrics`, :func:`loco_metrics`, :func:`traverse_metrics`), and
:func:`summarise` and :func:`format_table` turn rows into the benchmark's table of mean and
standard error. Rows are in the units of the paper's tables, so a summary's means are what
the tables print: percentages for Success Rate, Route Completion, On Walkable Region and
Balance; SPL in [0, 1]; Collision as a ratio of steps in [0, 1]; metres, seconds, m/s.

Notation: an episode has ``T`` recorded steps ``t = 1 .. T`` (``T_F - T_S`` in the paper)
of ``dt`` seconds; positions ``x_0`` (the start) .. ``x_T`` are the robot's ground position
``(x, y)`` in metres. Where the paper's printed formula is ambiguous or inconsistent with
its own tables, the choice made is documented on the metric function.

>>> ep = NavEpisode(start_xy=(0.0, 0.0), best_length=3.0)
>>> for x in (1.0, 2.0, 3.0):
...     ep.record_step((x, 0.0), walkable=x != 2.0, collision=False)
>>> ep.finish(success=True, distance_left=0.2)
>>> {k: round(v, 3) for k, v in nav_metrics(ep).items()}
{'success_rate': 100.0, 'route_completion': 100.0, 'spl': 1.0, 'on_walkable': 66.667, 'collision': 0.0}
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

G = 9.81
"""Standard gravity (m/s^2) of the Mechanical Cost of Transport."""

#: How each metric key is printed by :func:`format_table`: label with unit, decimals.
METRICS: Mapping[str, tuple[str, int]] = {
    "success_rate": ("Success Rate (%)", 2),
    "route_completion": ("Route Completion (%)", 2),
    "on_walkable": ("On Walkable Region (%)", 2),
    "spl": ("SPL", 2),
    "collision": ("Collision", 2),
    "balance": ("Balance (%)", 2),
    "x_displacement": ("X-displacement (m)", 2),
    "ttf": ("TTF (s)", 2),
    "smoothness": ("Smoothness", 2),
    "attempts": ("Attempts to Success", 2),
    "falls": ("Falls", 2),
    "labor_cost": ("Labor Cost (s)", 2),
    "interventions": ("Human Intervention Times", 2),
    "mcot": ("MCoT", 2),
    "speed": ("Speed (m/s)", 2),
    "collision_times": ("Collision Times", 2),
    "time": ("Time (s)", 1),
    "terrain_model_time": ("Terrain Model Time (s)", 1),
    "fall_rate": ("Fall Rate (%)", 2),
    "red_light_crossings": ("Red-light Crossings", 2),
    "roadway_incursions": ("Roadway Incursions", 2),
}


def _xy(point: Sequence[float], name: str) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in point[:2])
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"{name}: expected an (x, y) position in metres, got {point!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"{name}: expected finite metres, got {point!r}")
    return x, y


def _positive(value: float, name: str, unit: str) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not (value > 0 and math.isfinite(value))
    ):
        raise ValueError(f"{name}: expected a positive number of {unit}, got {value!r}")
    return float(value)


def _path_length(start: tuple[float, float], positions: Sequence[tuple[float, float]]) -> float:
    """Sum of ``||x_t - x_{t-1}||`` over the steps (m)."""
    if not positions:
        return 0.0
    p = np.vstack(([start], np.asarray(positions, dtype=np.float64)))
    return float(np.hypot(*np.diff(p, axis=0).T).sum())


def _require_steps(ep: object, steps: int, kind: str) -> None:
    if not getattr(ep, "finished", False):
        raise ValueError(f"{kind}: the episode is not finished; call finish(...) after the last step")
    if steps == 0:
        raise ValueError(f"{kind}: the episode has no steps; record_step(...) at least once")


# --- navigation ------------------------------------------------------------------------------


@dataclass
class TrafficRecord:
    """The robot's traffic behaviour in a city (beyond the paper): how often it stepped onto a
    signalised crosswalk that did not show *walk* (a red-light crossing), and how often it went
    onto the roadway off the crosswalks (a roadway incursion). Each counts entries, not steps.

    >>> rec = TrafficRecord()
    >>> for road, red in ((False, False), (True, False), (True, False), (False, True), (False, False)):
    ...     rec.record_step(on_roadway=road, on_red_crosswalk=red)
    >>> rec.roadway_incursions, rec.red_light_crossings
    (1, 1)
    """

    red_light_crossings: int = 0
    roadway_incursions: int = 0
    _road: bool = False
    _red: bool = False

    def record_step(self, *, on_roadway: bool, on_red_crosswalk: bool) -> None:
        """Where the robot is after a step: on the roadway, on a crosswalk showing no *walk*."""
        self.roadway_incursions += int(on_roadway and not self._road)
        self.red_light_crossings += int(on_red_crosswalk and not self._red)
        self._road, self._red = bool(on_roadway), bool(on_red_crosswalk)

    def metrics(self) -> dict[str, float]:
        return {
            "red_light_crossings": float(self.red_light_crossings),
            "roadway_incursions": float(self.roadway_incursions),
        }


@dataclass
class NavEpisode:
    """One navigation episode (NavClear, NavStatic, NavDynamic), filled step by step.

    ``best_length`` is ``L*_best``, the length (m) of the shortest path the robot can take
    from the start to the goal *region* (the disc of the task's goal tolerance, where success
    fires), and ``route_length`` is ``L_route`` (m, default ``best_length``); the runner takes
    both from :meth:`citygen.runner.control.fields.DistanceField.route`: the any-angle geodesic
    (fast marching, pulled taut round obstacle corners) over the ground the robot can cross
    (the occupancy map inflated by its radius, less edges higher than it steps and tiles it
    cannot climb). ``distance_left`` is measured the same way.
    """

    start_xy: tuple[float, float]
    best_length: float
    route_length: float | None = None
    positions: list[tuple[float, float]] = field(default_factory=list)
    """The robot's ``(x, y)`` (m) after each step."""
    walkable: list[bool] = field(default_factory=list)
    """Whether the robot stood on walkable ground at each step."""
    collision: list[bool] = field(default_factory=list)
    """Whether the robot touched an object or agent at each step."""
    success: bool = False
    distance_left: float = math.nan
    """Geodesic distance (m) from the final position to the goal region."""
    finished: bool = False

    def __post_init__(self) -> None:
        self.start_xy = _xy(self.start_xy, "NavEpisode.start_xy")
        self.best_length = _positive(self.best_length, "NavEpisode.best_length", "metres")
        if self.route_length is None:
            self.route_length = self.best_length
        self.route_length = _positive(self.route_length, "NavEpisode.route_length", "metres")

    def record_step(self, xy: Sequence[float], *, walkable: bool, collision: bool) -> None:
        """Record the state after one control step: position (m), on walkable ground, in contact."""
        self.positions.append(_xy(xy, "NavEpisode.record_step xy"))
        self.walkable.append(bool(walkable))
        self.collision.append(bool(collision))

    def finish(self, *, success: bool, distance_left: float) -> None:
        """Close the episode: whether it reached the goal, geodesic distance (m) left to it."""
        if not (distance_left >= 0):
            raise ValueError(f"NavEpisode.finish: distance_left must be >= 0 metres, got {distance_left!r}")
        self.success, self.distance_left, self.finished = bool(success), float(distance_left), True


def nav_metrics(ep: NavEpisode) -> dict[str, float]:
    """The navigation metrics of one finished episode.

    - ``success_rate`` (%): ``100 s``, ``s`` = 1 when the goal was reached.
    - ``route_completion`` (%): ``100 l / L_route`` where ``l`` is the progress along the
      shortest walkable route, ``L_route - d_left`` clipped to ``[0, L_route]``, with
      ``d_left`` the geodesic distance left to the goal at the end (0 on success: the goal
      counts as reached once within the task's tolerance). Progress, not distance driven, so
      wandering does not count as completing the route.
    - ``spl`` (0..1): Success weighted by Path Length as defined by Anderson et al. 2018,
      ``s L_best / max(l_moving, L_best)`` with ``l_moving`` the length driven
      (``sum ||x_t - x_{t-1}||``). The paper prints ``E[l_moving / L*_best s]``, which can
      exceed 1 and does not fit its own tables (SPL 0.48 at a 97.6 % success rate); the
      standard definition does.
    - ``on_walkable`` (%): ``100 / T sum_t 1_walkable(t)``.
    - ``collision`` (ratio): ``1 / T sum_t 1_collision(t)``.
    """
    steps = len(ep.positions)
    _require_steps(ep, steps, "nav_metrics")
    s = 1.0 if ep.success else 0.0
    route = float(ep.route_length)  # type: ignore[arg-type]
    left = 0.0 if ep.success else ep.distance_left
    progress = min(max(route - left, 0.0), route)
    moved = _path_length(ep.start_xy, ep.positions)
    return {
        "success_rate": 100.0 * s,
        "route_completion": 100.0 * progress / route,
        "spl": s * ep.best_length / max(moved, ep.best_length),
        "on_walkable": 100.0 * sum(ep.walkable) / steps,
        "collision": sum(ep.collision) / steps,
    }


# --- locomotion ------------------------------------------------------------------------------


@dataclass
class LocoEpisode:
    """One locomotion episode (LocoFlat, LocoSlope, LocoStair, LocoRough), filled step by step.

    ``target_heading`` (rad, world frame) is the direction of the commanded velocity;
    ``dt`` the control step (s); ``t_start`` the time (s) motion starts. The episode's time
    runs to the fall, or to the last step when the robot never fell.
    """

    start_xy: tuple[float, float]
    target_heading: float
    dt: float
    t_start: float = 0.0
    positions: list[tuple[float, float]] = field(default_factory=list)
    """The base's ``(x, y)`` (m) after each step, up to the fall."""
    torques: list[np.ndarray] = field(default_factory=list)
    """Joint torques (N m) applied at each step."""
    fallen: bool = False
    fall_xy: tuple[float, float] | None = None
    t_fall: float | None = None
    """Time (s) of the fall, or of the episode's end when the robot never fell."""
    finished: bool = False

    def __post_init__(self) -> None:
        self.start_xy = _xy(self.start_xy, "LocoEpisode.start_xy")
        self.dt = _positive(self.dt, "LocoEpisode.dt", "seconds")
        if not math.isfinite(self.target_heading):
            raise ValueError(f"LocoEpisode.target_heading: expected radians, got {self.target_heading!r}")

    def record_step(self, xy: Sequence[float], torques: Sequence[float], *, fallen: bool = False) -> None:
        """Record one control step: base position (m), joint torques (N m), and whether the
        robot lost balance in it (the episode's clock stops at the first fall; later steps are
        ignored)."""
        if self.fallen:
            return
        tau = np.asarray(torques, dtype=np.float64).ravel()
        if self.torques and tau.shape != self.torques[0].shape:
            raise ValueError(
                f"LocoEpisode.record_step: expected {self.torques[0].size} torques, got {tau.size}"
            )
        self.positions.append(_xy(xy, "LocoEpisode.record_step xy"))
        self.torques.append(tau)
        if fallen:
            self.fallen = True
            self.fall_xy = self.positions[-1]
            self.t_fall = self.t_start + len(self.positions) * self.dt

    def finish(self) -> None:
        """Close the episode (without a fall, its end counts as ``t_F`` and ``x_F``)."""
        if not self.fallen and self.positions:
            self.fall_xy = self.positions[-1]
            self.t_fall = self.t_start + len(self.positions) * self.dt
        self.finished = True


def loco_metrics(ep: LocoEpisode) -> dict[str, float]:
    """The locomotion metrics of one finished episode; ``x_F``, ``t_F`` are the position and
    time of the fall, or of the episode's end when the robot kept its balance.

    - ``balance`` (%): ``100 b``, ``b`` = 1 when the robot did not fall.
    - ``x_displacement`` (m): ``(x_F - x_S) . (cos theta, sin theta)``, the displacement
      along the commanded direction ``theta`` (the paper's ``(x_fall - x_start) cos
      theta_target`` with positions as vectors).
    - ``ttf`` (s): ``t_F - t_S``.
    - ``smoothness`` (N m per step): ``1 / N sum_{t=2}^{N} ||tau_t - tau_{t-1}||`` over the
      ``N`` steps up to the fall (Euclidean norm over the joints); the paper's sum runs over
      steps, so its normaliser ``t_F - t_S`` is read as a count of steps too.
    """
    n = len(ep.positions)
    _require_steps(ep, n, "loco_metrics")
    fx, fy = ep.fall_xy  # type: ignore[misc]
    theta = ep.target_heading
    tau = np.vstack(ep.torques)
    jerk = float(np.linalg.norm(np.diff(tau, axis=0), axis=1).sum()) if n > 1 else 0.0
    return {
        "balance": 0.0 if ep.fallen else 100.0,
        "x_displacement": (fx - ep.start_xy[0]) * math.cos(theta) + (fy - ep.start_xy[1]) * math.sin(theta),
        "ttf": float(ep.t_fall) - ep.t_start,  # type: ignore[arg-type]
        "smoothness": jerk / n,
    }


# --- traverse --------------------------------------------------------------------------------


@dataclass
class TraverseEpisode:
    """One traverse run (possibly many attempts), filled step by step.

    ``mass`` (kg) is the robot's total mass; ``dt`` the control step (s).
    """

    start_xy: tuple[float, float]
    dt: float
    mass: float
    positions: list[tuple[float, float]] = field(default_factory=list)
    """The robot's ``(x, y)`` (m) after each step."""
    reset: list[bool] = field(default_factory=list)
    """Whether the robot was reset (put back after a failure) in each step."""
    intervene: list[bool] = field(default_factory=list)
    """Whether a human was driving in each step."""
    collision: list[bool] = field(default_factory=list)
    """Whether a collision happened in each step (the env decides whether a lasting contact
    counts once, at its first step, or at every step: Collision Times sums these flags)."""
    torques: list[np.ndarray] = field(default_factory=list)
    """Actuator torques (N m) at each step."""
    joint_velocities: list[np.ndarray] = field(default_factory=list)
    """Actuator velocities (rad/s) at each step, matching ``torques``."""
    body_speed: list[float] = field(default_factory=list)
    """The base's ground speed (m/s) at each step."""
    finished: bool = False

    def __post_init__(self) -> None:
        self.start_xy = _xy(self.start_xy, "TraverseEpisode.start_xy")
        self.dt = _positive(self.dt, "TraverseEpisode.dt", "seconds")
        self.mass = _positive(self.mass, "TraverseEpisode.mass", "kilograms")

    def record_step(
        self,
        xy: Sequence[float],
        *,
        torques: Sequence[float],
        joint_velocities: Sequence[float],
        body_speed: float,
        intervene: bool = False,
        reset: bool = False,
        collision: bool = False,
    ) -> None:
        """Record one control step: position (m) after it, actuator torques (N m) and
        velocities (rad/s), base speed (m/s), and the step's flags."""
        tau = np.asarray(torques, dtype=np.float64).ravel()
        vel = np.asarray(joint_velocities, dtype=np.float64).ravel()
        if tau.shape != vel.shape:
            raise ValueError(
                f"TraverseEpisode.record_step: {tau.size} torques but {vel.size} joint velocities"
            )
        if not (body_speed >= 0 and math.isfinite(body_speed)):
            raise ValueError(f"TraverseEpisode.record_step: body_speed must be >= 0 m/s, got {body_speed!r}")
        self.positions.append(_xy(xy, "TraverseEpisode.record_step xy"))
        self.torques.append(tau)
        self.joint_velocities.append(vel)
        self.body_speed.append(float(body_speed))
        self.intervene.append(bool(intervene))
        self.reset.append(bool(reset))
        self.collision.append(bool(collision))

    def finish(self) -> None:
        """Close the run."""
        self.finished = True


def traverse_metrics(ep: TraverseEpisode, *, min_speed: float = 0.1) -> dict[str, float]:
    """The traverse metrics of one finished run.

    - ``attempts``: ``sum_t 1_reset(t)``, the resets in the run.
    - ``labor_cost`` (s): ``sum_t 1_intervene(t) dt``.
    - ``interventions``: ``sum_t 1_intervene(t) (1 - 1_intervene(t-1))`` with
      ``1_intervene(0) = 0``: the number of times a human took over. (The paper's sum starts
      at ``t = 2``, which would miss a takeover already under way at the first step.)
    - ``mcot``: ``1 / T' sum_t sum_i max(tau_i v_i, 0) / (m g v_body)`` over the ``T'``
      steps whose body speed is at least ``min_speed`` (m/s): standing still the ratio is
      undefined. NaN when no step moved that fast (:func:`summarise` leaves it out).
    - ``speed`` (m/s): ``sum_t ||x_t - x_{t-1}|| / (T dt)``: the paper's mean distance per
      step divided by the step's duration, for the m/s of its table. A step flagged ``reset``
      adds no distance (the robot is put back, it does not move there).
    - ``collision_times``: ``sum_t 1_collision(t)``.
    - ``time`` (s): ``T dt``, the run's duration (every attempt's).
    """
    steps = len(ep.positions)
    _require_steps(ep, steps, "traverse_metrics")
    intervene = np.asarray(ep.intervene, dtype=bool)
    onsets = int(np.count_nonzero(intervene & ~np.concatenate(([False], intervene[:-1]))))
    p = np.vstack(([ep.start_xy], np.asarray(ep.positions, dtype=np.float64)))
    step_len = np.hypot(*np.diff(p, axis=0).T)
    step_len[np.asarray(ep.reset, dtype=bool)] = 0.0
    speed = np.asarray(ep.body_speed)
    moving = speed >= min_speed
    if moving.any():
        power = np.array(
            [np.maximum(t * v, 0.0).sum() for t, v in zip(ep.torques, ep.joint_velocities, strict=True)]
        )
        mcot = float(np.mean(power[moving] / (ep.mass * G * speed[moving])))
    else:
        mcot = math.nan
    return {
        "attempts": float(sum(ep.reset)),
        "labor_cost": float(np.count_nonzero(intervene)) * ep.dt,
        "interventions": float(onsets),
        "mcot": mcot,
        "speed": float(step_len.sum()) / (steps * ep.dt),
        "collision_times": float(sum(ep.collision)),
        "time": steps * ep.dt,
    }


# --- tables ----------------------------------------------------------------------------------


def summarise(rows: Sequence[Mapping[str, float]]) -> dict[str, dict[str, float]]:
    """Mean, standard error of the mean (sample standard deviation, ddof=1, over
    ``sqrt(n)``; 0 for one value) and count ``n`` of each metric over episode rows. Keys in
    the order they first appear; NaN values are left out (``n`` counts the others; mean and
    sem are NaN when none is left)."""
    keys: dict[str, None] = {}
    for row in rows:
        keys.update(dict.fromkeys(row))
    out: dict[str, dict[str, float]] = {}
    for key in keys:
        values = np.array([float(row[key]) for row in rows if key in row], dtype=np.float64)
        values = values[~np.isnan(values)]
        n = values.size
        mean = float(values.mean()) if n else math.nan
        sem = float(values.std(ddof=1) / math.sqrt(n)) if n > 1 else (0.0 if n == 1 else math.nan)
        out[key] = {"mean": mean, "sem": sem, "n": n}
    return out


def format_table(summary: Mapping[str, Mapping[str, float]], title: str) -> str:
    """The URBAN-BENCH table as text: one line per metric, ``label  mean ± sem`` in the
    paper's units (percentages as percent, SPL in 0..1, Collision as a ratio), then ``n``."""
    lines = [title]
    rows = []
    for key, stats in summary.items():
        label, decimals = METRICS.get(key, (key, 2))
        rows.append(
            (label, f"{stats['mean']:.{decimals}f} ± {stats['sem']:.{decimals}f}", str(int(stats["n"])))
        )
    width = max([len("Metric")] + [len(r[0]) for r in rows])
    value_width = max([len("Mean ± SEM")] + [len(r[1]) for r in rows])
    lines.append(f"{'Metric':<{width}}  {'Mean ± SEM':>{value_width}}  n")
    lines.append("-" * (width + value_width + 5))
    lines += [f"{label:<{width}}  {value:>{value_width}}  {n}" for label, value, n in rows]
    return "\n".join(lines)
