"""Training-only parts of learned locomotion: commands, a terrain curriculum and gait shaping.

:class:`LocoTraining` wraps one training sub-environment of a ``loco-*`` task. The
environment's reward, its metrics and ``citygen bench`` stay the paper's (tracking with a
0.25 m/s kernel, ``-2 v_z^2``, ``-0.01 |a_t - a_(t-1)|^2``, ``-100`` on a fall); the wrapper
adds what makes the same policy learnable on a laptop in hours:

- **Commands.** With probability ``command_mix`` an episode's command is drawn from
  :data:`COMMANDS` (forward speed, sideways speed, yaw rate in the robot's frame) instead of
  the task's own ``(1, 0, 0)``, so the general model also follows the velocity commands a
  navigation policy gives it. With ``command_resample`` (s) such an episode draws a new one
  at that mean interval (each step with probability ``dt / command_resample``; Isaac Lab's
  velocity task resamples every 10 s): a navigation policy changes its command every 0.1 s,
  and a model that only ever held one command for a whole episode sat down on a slope when
  the command changed (the traverse's Human-AI-Mode-1).
- **Terrain curriculum** (Rudin et al. 2022, "Learning to Walk in Minutes"): the Urban-Loc
  training grids rise in difficulty with the row. Each sub-environment keeps a level (a row),
  starts on one of the easiest ``start_rows`` rows (legged_gym's ``max_init_terrain_level``:
  a stage continuing a run that climbed the grid spreads its levels up to where that run
  stood, instead of spending about 1M steps climbing back) and draws a random column; an
  episode that covers more than half a region (4 m) moves it a row up, one that covers less
  than half of what its command asked moves it a row down; a level past the hardest row
  restarts at a random one. With ``level_on_commands="falls"`` an episode on a drawn command
  moves it only down, on a fall: a turning or slow command never covers 4 m and a turning one
  never its straight-line distance, so by distance such episodes pull every level to the
  easiest rows (the curriculum stalled at row 4 of 30 with 60 % of episodes on drawn
  commands). With ``random_rows`` a share of episodes starts on a row drawn from the whole
  grid and leaves the level alone: a curriculum keeps a robot at the edge of what it
  masters, so it never meets the terrain past that edge, which a test grid reaches (its
  stairs to 0.30 m), and does there what it does at the edge: tries, and falls.
- **Fall penalty** (``fall_penalty``): the multiple of the paper's ``-100`` on a fall that
  training pays (1: the paper's; legged_gym's rough-terrain policies train with none, a fall
  costing only the rewards it ends), so that a policy on stairs is not taught that standing
  at the first riser beats trying; above 1, balance is bought with distance.
- **Foot clearance** (``foot_clearance`` times :meth:`LocoTraining._foot_clearance`): swinging
  feet lower than :data:`FOOT_CLEARANCE` over the ground under them pay the square of the
  shortfall (Isaac Lab's Spot reward), so that feet lift over a stair's edge.
- **Leg collisions** (``leg_collision`` times the number of leg links, feet not counted,
  touching the ground: legged_gym's ``collision`` term on thighs and calves), so that a leg
  is lifted over a riser instead of knocked against it. ``clearance_height`` sets the foot
  clearance term's height (:data:`FOOT_CLEARANCE` unless set): a 0.17 m riser asks for more.
- **Turn progress** (``turn_progress``): ``w_z / c_wz`` clipped to [-1, 1] where the command
  turns (|c_wz| > 0.1 rad/s), the forward-progress term's twin for yaw: the tracking kernel
  pays a robot standing under a 1 rad/s command almost nothing, so nothing led the general
  model to turn in place (it walked forward and turned while walking only).
- **Heading progress** (``heading_progress``): where the episode holds a heading (a straight
  command under heading control), the share of the commanded speed made good along the
  commanded direction *in the world* (the held heading turned by the command's own angle),
  clipped to [-1, 1]. The forward-progress term is in the robot's frame, so a robot driving
  in circles at the commanded speed earns all of it; this one averages zero around a circle.
  The wheeled-legged robot's general model learnt to circle on the mixed grid (circling keeps
  it off harder terrain: the curriculum moves a robot that covers little ground a row down).
- **Base height** (``base_height``): ``-((h_stand - h) / h_stand)^2`` where the base stands
  lower than its standing height ``h_stand`` over the ground under it (``h``), nothing
  above it (legged_gym's ``base_height`` term, one-sided): asked to back up and turn at
  once, the general model learnt to sit down and stay there, 0.18 m high against 0.30, and
  a navigation policy on its legs waited in vain for the goal to move.
- **Orientation** (``orientation``): legged_gym's ``orientation`` term, ``-|g_xy|^2`` a step
  on top of the gait shaping's tilt term: the wheeled-legged robot's general model crossed
  the test grid's steep slope faces at full height and rolled over sideways (its 0.72 m track
  under a 0.58 m base tips past about 32 degrees of roll), where legs can level the base.
- **Edge stop** (``edge_stop``, privileged: the ground raster, which the robot sees only
  through its height map): where the ground along the commanded direction within
  :data:`EDGE_LOOK` ahead of the base rises by more than ``edge_height`` (m) over
  :data:`EDGE_SPAN` (a riser higher than the robot can climb), the gait shaping's tracking and
  progress terms are paid against a zero command and ``edge_stop`` times the speed made
  toward the riser is taken off: stand at a riser you cannot climb. The paper's stair test
  reaches 0.30 m risers, above a quadruped's standing height; its balance there (92 %) is
  only possible by not trying them, and neither a fall at three times the paper's penalty
  nor random rows taught PPO to stop (the policy kept trying and falling). Risers down
  count only deeper than ``edge_drop`` (m; 0: never): the quadruped's stair model walks down
  some of a pyramid's 0.23-0.30 m risers.
- **Descent speed** (``descent_speed``, privileged like the edge stop): where the ground along
  the commanded direction within :data:`EDGE_LOOK` ahead drops by more than ``descent_drop``
  over :data:`EDGE_SPAN` (a riser down), the tracking and progress terms are paid against the
  command cut to this speed (m/s): walk down slowly. The quadruped's stair model fell on the
  test's pyramid tops walking down 0.21-0.26 m risers at 1.5-1.8 m/s under a 1 m/s command,
  pitching past 45 degrees; the tracking kernel alone (``exp(-0.5^2 / 0.25)`` = 0.37 of its
  pay at 1.5 m/s) did not slow it.
- **Only positive rewards** (``only_positive``, legged_gym's ``only_positive_rewards``): a
  step's reward before the fall's ``-100`` is clipped at zero, so that a noisy first policy
  whose penalties cost more per step than a fall (the wheeled-legged robot's torques: about
  -4.6 a step at the starting noise against +0.9 standing still) does not learn to fall at once.
- **Gait shaping** (``shaping`` times the legged_gym terms, per step): a broad tracking
  kernel ``exp(-|v_xy - c_xy|^2 / 0.25) + 0.5 exp(-(w_z - c_wz)^2 / 0.25)`` (the paper's
  0.25 m/s kernel pays nothing to a robot still 1 m/s short of its command, so nothing leads
  a standing robot to walk), a forward-progress term ``v_xy . c_xy / |c_xy|^2`` clipped to
  [-1, 1] (the share of the commanded speed made good along the command: linear from a
  standstill, so the first steps already pay), ``-0.05 |w_xy|^2``, ``-0.5 |g_xy|^2`` (tilt),
  ``-1e-5 |tau|^2``, ``-2.5e-7 |qdd|^2`` (both times ``effort_scale``: the wheeled-legged
  robot's kp 1500 joints pay ~190x the quadruped's torque penalty for the same action
  noise), ``alive`` a step (a survival bonus, 0 unless set) and a foot air-time reward
  ``+1.0 sum (t_air - 0.25)`` at each touch-down while the command asks to move (the stepping
  that a trot needs; not for a robot whose locomotion action drives wheels, which roll where a
  foot steps).
"""

from __future__ import annotations

import math

import gymnasium
import numpy as np

from citygen.runner.envs.legged import leg_bodies

#: Ranges of the commands drawn for training: forward (m/s), sideways (m/s), yaw rate (rad/s).
COMMANDS = ((-0.5, 1.0), (-0.3, 0.3), (-1.0, 1.0))
#: Weights of the gait shaping terms (see the module docstring).
WEIGHTS = {
    "track_lin": 1.0,
    "track_ang": 0.5,
    "progress": 1.0,
    "ang_vel_xy": -0.05,
    "tilt": -0.5,
    "torque": -1e-5,
    "joint_acc": -2.5e-7,
    "air_time": 1.0,
}
#: Air time (s) a foot is rewarded beyond at its touch-down.
AIR_TIME = 0.25
#: The paper's reward on a fall (``citygen.runner.envs.loco``), kept by ``only_positive``.
FALL_PENALTY = -100.0
#: Rows of the grid a sub-environment may start its curriculum on (the easiest), unless
#: ``start_rows`` says otherwise.
START_ROWS = 3
#: Height (m) of a swinging foot's centre over the ground under it that the foot clearance
#: term asks for (``foot_clearance``): the quadruped's foot radius (0.022 m) over a 0.10 m step.
FOOT_CLEARANCE = 0.12
#: How far ahead of the base (m) the edge stop looks for a riser, in steps of EDGE_SPAN / 2.
EDGE_LOOK = 0.7
#: Horizontal span (m) over which a rise or drop of the ground counts as one riser (twice the
#: ground raster's 5 cm cells: a riser interpolated over one cell falls inside it whole).
EDGE_SPAN = 0.1


def leg_link_geoms(model, handle) -> frozenset[int]:
    """The geoms of ``handle``'s leg links, its feet not counted (the bodies of
    :func:`citygen.runner.envs.legged.leg_bodies`)."""
    ids = np.flatnonzero(np.isin(model.geom_bodyid, sorted(leg_bodies(model, handle)))).tolist()
    return frozenset(ids) - frozenset(int(g) for g in handle.foot_geom_ids)


class LocoTraining(gymnasium.Wrapper):
    """Command sampling, terrain curriculum and gait shaping of one training sub-environment
    (see the module docstring)."""

    def __init__(
        self, env: gymnasium.Env, *, seed: int, rank: int, shaping: float = 1.0,
        command_mix: float = 0.0, curriculum: bool = True, only_positive: bool = False,
        effort_scale: float = 1.0, alive: float = 0.0, fall_penalty: float = 1.0,
        foot_clearance: float = 0.0, turn_progress: float = 0.0, heading_progress: float = 0.0,
        base_height: float = 0.0, leg_collision: float = 0.0, clearance_height: float = FOOT_CLEARANCE,
        command_resample: float = 0.0, level_on_commands: str = "distance", orientation: float = 0.0,
        random_rows: float = 0.0, edge_stop: float = 0.0, edge_height: float = 0.16, edge_drop: float = 0.0,
        start_rows: int = START_ROWS, descent_speed: float = 0.0, descent_drop: float = 0.05,
    ):  # fmt: skip
        super().__init__(env)
        if level_on_commands not in ("distance", "falls"):
            raise ValueError(f"level_on_commands: expected 'distance' or 'falls', got {level_on_commands!r}")
        self._resample = float(command_resample)
        self._level_by_falls = level_on_commands == "falls"
        self._drawn = False  # whether this episode's command was drawn from COMMANDS
        self._collision = float(leg_collision)
        self._clear_h = float(clearance_height)
        self._leg_ids: frozenset[int] = frozenset()
        self._ground_ids: frozenset[int] = frozenset()
        self._leg_model = None  # the model the two sets above are of
        self._base_height = float(base_height)
        self._edge = float(edge_stop)
        self._edge_h = float(edge_height)
        self._edge_drop = float(edge_drop) or math.inf
        self._descent = float(descent_speed)
        self._descent_drop = float(descent_drop)
        self._look = np.arange(0.0, EDGE_LOOK + 1e-9, EDGE_SPAN / 2).tolist()
        self._tilt = WEIGHTS["tilt"] - float(orientation)
        self._fall_refund = (1.0 - float(fall_penalty)) * -FALL_PENALTY
        self._clearance = float(foot_clearance)
        self._turn = float(turn_progress)
        self._heading = float(heading_progress)
        self._held_dir: tuple[float, float] | None = None  # world direction / commanded speed
        self._last_feet: np.ndarray | None = None
        self.shaping = float(shaping)
        self._torque = WEIGHTS["torque"] * float(effort_scale)
        self._joint_acc = WEIGHTS["joint_acc"] * float(effort_scale)
        self._alive = float(alive)
        self.only_positive = bool(only_positive)
        self.command_mix = float(command_mix)
        self.curriculum = bool(curriculum)
        self._rng = np.random.default_rng([seed, rank, 3571])
        self.level: int | None = None
        self._random_rows = float(random_rows)
        self._start_rows = max(int(start_rows), 1)
        self._exploring = False  # this episode is on a drawn row (random_rows): the level stays
        self._start = (0.0, 0.0)
        self._air = np.zeros(0)
        self._stepping = True
        self._last_qvel: np.ndarray | None = None

    # --- episode setup --------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        options = dict(options or {})
        u = self.env.unwrapped
        grid = self._grid(options)
        if self.curriculum and grid is not None and "region" not in options:
            rows, cols = grid.rows, grid.cols
            if self.level is None:
                self.level = int(self._rng.integers(min(self._start_rows, rows)))
            # drawn only when asked for, so that runs without it draw what they drew before
            self._exploring = bool(self._random_rows) and self._rng.random() < self._random_rows
            row = int(self._rng.integers(rows)) if self._exploring else self.level
            options["region"] = (row, int(self._rng.integers(cols)))
        self._drawn = False
        if self.command_mix and "command" not in options and self._rng.random() < self.command_mix:
            options["command"] = self._draw_command()
            self._drawn = True
        obs, info = self.env.reset(seed=seed, options=options)
        h = u.handle
        self._start = tuple(float(v) for v in u.data.qpos[h.qadr : h.qadr + 2])
        self._air = np.zeros(len(h.foot_geom_ids))
        self._bind_model()
        self._stepping = not u.robot.loco_wheels
        self._last_qvel = None
        self._last_feet = None
        self._held_dir = None
        c0, c1 = u.command[:2].tolist()
        speed = math.hypot(c0, c1)
        if self._heading and u.held_heading is not None and speed > 0.1:
            angle = u.held_heading + math.atan2(c1, c0)
            self._held_dir = (math.cos(angle) / speed, math.sin(angle) / speed)
        return obs, info

    def _bind_model(self) -> None:
        """The geom ids the shaping looks contacts up by, of the model the environment runs
        (a new scene's, or a locomotion grid's window: :mod:`citygen.runner.envs.window`)."""
        u = self.env.unwrapped
        h = u.handle
        self._foot_index = {int(g): k for k, g in enumerate(h.foot_geom_ids)}
        if self._collision and u.model is not self._leg_model:
            self._leg_ids = leg_link_geoms(u.model, h)
            self._ground_ids = frozenset(np.flatnonzero(u.prepared.ground_geoms).tolist())
        self._leg_model = u.model

    def _draw_command(self) -> tuple[float, float, float]:
        return tuple(float(self._rng.uniform(lo, hi)) for lo, hi in COMMANDS)

    def _grid(self, options: dict):
        """The terrain grid of the scene the next reset loads (its first scene's: every
        Urban-Loc split has one scene)."""
        u = self.env.unwrapped
        scene = u.scene if getattr(u, "scene", None) is not None else u.source.scene(options.get("index", 0))
        return scene.terrain

    # --- reward ---------------------------------------------------------------------------

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.env.unwrapped.model is not self._leg_model:  # moved out of its window
            self._bind_model()
        if self.shaping:
            reward += self.shaping * self._shaping()
        if self.only_positive:  # clipped before the fall's penalty, which stays
            fall = FALL_PENALTY if info.get("fallen") else 0.0
            reward = max(reward - fall, 0.0) + fall
        if self._fall_refund and info.get("fallen"):
            reward += self._fall_refund
        if (terminated or truncated) and self.curriculum and self.level is not None:
            if not self._exploring:
                self._move_level(bool(terminated))
            info = {**info, "terrain_level": self.level}
        elif self._drawn and self._resample and self._rng.random() < self.env.unwrapped.dt / self._resample:
            command = self._draw_command()  # the next step's; this step's reward was the last one's
            self.env.unwrapped.command[:] = command
            obs = {**obs, "command": np.asarray(command, dtype=np.float32)}
        return obs, reward, terminated, truncated, info

    def _shaping(self) -> float:
        u = self.env.unwrapped
        d, h = u.data, u.handle
        # Plain floats where numpy scalars were: the same IEEE operations without numpy's cost
        # per scalar (tests/test_loco_fast.py holds the reward to the bit).
        c0, c1, c2 = u.command.tolist()
        vx, vy, _, wz = u.base_velocity  # RobotHandle._velocity after the step
        qv = d.qvel
        r, held, share = 0.0, self._held_dir, 1.0
        if (self._edge or self._descent) and (c0 or c1):
            rise, drop = self._risers_ahead(c0, c1)
            speed = math.hypot(c0, c1)
            if self._edge and (rise > self._edge_h or drop > self._edge_drop):
                r -= self._edge * max((vx * c0 + vy * c1) / speed, 0.0)
                c0 = c1 = 0.0  # the terms below pay for standing
                held = None
            elif self._descent and drop > self._descent_drop and speed > self._descent:
                share = self._descent / speed  # the terms below pay for walking down slowly
                c0, c1 = c0 * share, c1 * share
        w = qv[h.dadr + 3 : h.dadr + 5]
        g = d.xmat[h.base_id][6:8]  # the tilt: gravity's x and y in the base's frame (up to sign)
        tau = d.actuator_force[h.leg_act]
        qvel = qv[h.leg_dadr]
        r += WEIGHTS["track_lin"] * math.exp(-((vx - c0) ** 2 + (vy - c1) ** 2) / 0.25)
        r += WEIGHTS["track_ang"] * math.exp(-((wz - c2) ** 2) / 0.25)
        asked = c0 * c0 + c1 * c1
        if asked > 0.01:
            r += WEIGHTS["progress"] * min(max((vx * c0 + vy * c1) / asked, -1.0), 1.0)
        if self._turn and abs(c2) > 0.1:
            r += self._turn * min(max(wz / c2, -1.0), 1.0)
        if held is not None:  # a free joint's linear qvel is in the world frame
            along = (qv[h.dadr] * held[0] + qv[h.dadr + 1] * held[1]) / share
            r += self._heading * min(max(along, -1.0), 1.0)
        r += WEIGHTS["ang_vel_xy"] * float(w @ w)
        r += self._tilt * float(g @ g)
        r += self._alive + self._torque * float(tau @ tau)
        if self._last_qvel is not None:
            acc = (qvel - self._last_qvel) / u.dt
            r += self._joint_acc * float(acc @ acc)
        self._last_qvel = qvel
        touching = self._feet_touching()
        landed = touching & (self._air > 0)
        self._air += u.dt
        if self._stepping and (math.hypot(c0, c1) > 0.1 or abs(c2) > 0.1):
            r += WEIGHTS["air_time"] * float(np.sum((self._air - AIR_TIME) * landed))
        self._air[touching] = 0.0
        if self._clearance:
            r += self._clearance * self._foot_clearance(touching)
        if self._base_height:
            r += self._base_height * self._height_shortfall()
        if self._collision:
            r -= self._collision * self._leg_hits()
        return r

    def _risers_ahead(self, c0: float, c1: float) -> tuple[float, float]:
        """The largest rise and the largest drop (m, both positive) of the ground over
        :data:`EDGE_SPAN` along the commanded direction (the held heading's, where the episode
        holds one) within :data:`EDGE_LOOK` ahead of the base."""
        u = self.env.unwrapped
        x, y, _, yaw = u.handle.pose(u.data)
        angle = (u.held_heading if self._held_dir is not None else yaw) + math.atan2(c1, c0)
        dx, dy = math.cos(angle), math.sin(angle)
        ground_at = u.prepared.ground_at
        h = [ground_at(x + s * dx, y + s * dy) for s in self._look]
        steps = [b - a for a, b in zip(h, h[2:], strict=False)]
        return max(max(steps), 0.0), max(-min(steps), 0.0)

    def _leg_hits(self) -> int:
        """How many leg links (feet not counted) touch the ground after this step."""
        d = self.env.unwrapped.data
        n = d.ncon
        if not n:
            return 0
        legs, ground = self._leg_ids, self._ground_ids
        hit = set()
        for g1, g2 in d.contact.geom[:n].tolist():
            if g1 in legs and g2 in ground:
                hit.add(g1)
            elif g2 in legs and g1 in ground:
                hit.add(g2)
        return len(hit)

    def _height_shortfall(self) -> float:
        """``-((h_stand - h) / h_stand)^2`` where the base's height ``h`` over the ground under
        it is below the robot's standing height ``h_stand``; 0 at or above it."""
        u = self.env.unwrapped
        x, y, z = u.data.qpos[u.handle.qadr : u.handle.qadr + 3].tolist()
        stand = u.robot.stand_height
        short = stand - (z - u.prepared.ground_at(x, y))
        return -((short / stand) ** 2) if short > 0 else 0.0

    def _foot_clearance(self, touching: np.ndarray) -> float:
        """``-sum (H - h)^2 * tanh(2 |v_xy|) / H^2`` over the feet in the air that are lower than
        ``H`` (``clearance_height``, :data:`FOOT_CLEARANCE` unless set) over the ground under them (h), each
        weighted by how fast it swings (Isaac Lab's Spot reward, as a penalty): a swinging foot
        lifted clear of a stair's edge costs nothing, one scuffing along the ground the most."""
        u = self.env.unwrapped
        feet = u.data.geom_xpos[u.handle.foot_geom_ids]
        last, self._last_feet = self._last_feet, feet[:, :2].copy()
        if last is None:
            return 0.0
        ground_at = u.prepared.ground_at
        speed = np.hypot(*(feet[:, :2] - last).T) / u.dt
        total, height = 0.0, self._clear_h
        for (x, y, z), v, down in zip(feet.tolist(), speed.tolist(), touching.tolist(), strict=True):
            if not down:
                short = height - (z - ground_at(x, y))
                if short > 0:
                    total += short * short * math.tanh(2.0 * v)
        return -total / (height * height)

    def _feet_touching(self) -> np.ndarray:
        """Which feet touch anything (the ground, a step) after this step."""
        d = self.env.unwrapped.data
        touching = np.zeros(len(self._air), dtype=bool)
        n = d.ncon
        if n:
            index = self._foot_index
            for g in d.contact.geom[:n].ravel().tolist():
                k = index.get(g)
                if k is not None:
                    touching[k] = True
        return touching

    # --- curriculum -----------------------------------------------------------------------

    def _move_level(self, fell: bool) -> None:
        u = self.env.unwrapped
        grid = u.scene.terrain
        if grid is None:
            return
        h = u.handle
        x, y = (float(v) for v in u.data.qpos[h.qadr : h.qadr + 2])
        walked = math.hypot(x - self._start[0], y - self._start[1])
        asked = math.hypot(*u.command[:2]) * u.steps * u.dt
        if self._drawn and self._level_by_falls:
            if fell:
                self.level = max(self.level - 1, 0)
        elif walked > grid.tile_size / 2 and not fell:
            self.level += 1
        elif walked < asked / 2 or fell:
            self.level = max(self.level - 1, 0)
        if self.level >= grid.rows:
            self.level = int(self._rng.integers(grid.rows))
