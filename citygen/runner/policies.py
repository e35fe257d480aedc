"""Baseline policies for the runner's environments, and the traverse control modes.

A policy is ``reset(env)`` at the start of an episode (``env`` the unwrapped environment,
so a baseline may read privileged state such as the occupancy map and the agents) and
``act(obs) -> action`` every step. :func:`make_policy` builds one by name:

- ``random``: uniform actions from the action space (seeded);
- ``planner`` (navigation, traverse): A* on the occupancy grid inflated by the robot's
  radius, pure pursuit along the path, reactive avoidance of moving agents
  (:class:`citygen.runner.control.planner.Planner`);
- ``stand``, ``trot`` (locomotion): the PD stand and trot controllers of
  :mod:`citygen.runner.control.gaits`; for a biped (the ``humanoid``) the stand and the scripted
  walk of :mod:`citygen.runner.control.gaits_biped`;
- traverse control modes ``human``, ``ai``, ``human-ai-mode-1``, ``human-ai-mode-2`` (the
  paper's four) and ``shared-cautious``, ``shared-efficient``: who drives is decided at
  *decision points* (every :data:`DECISION_INTERVAL` m along the route) from the risk ahead
  (:func:`risk`); a person is a pluggable :class:`Driver`, with :class:`ScriptedOracle`
  standing in for one in tests and benchmarks. The paper's two shared modes drive with the
  robot's foundational navigation models dispatched by the situation (:func:`situation`,
  :class:`DispatchingNavigator`); Mode-1 also walks, on learned legs, on the terrain
  locomotion model of the ground ahead (:func:`ground_ahead`);
- a learned model's file (``FILE.npz``, ``FILE.zip``; :mod:`citygen.runner.learn`), which on a
  traverse is the ``ai`` mode's navigator (:class:`LearnedNavigator`).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

from citygen.errors import SpecError

#: Metres of progress between two decisions of a shared-autonomy mode.
DECISION_INTERVAL = 10.0
#: Pure-pursuit lookahead (m) of the planner baseline.
LOOKAHEAD = 1.0
#: Radius (m) around the robot in which agents count toward the risk.
RISK_RADIUS = 6.0


class Policy(Protocol):
    def reset(self, env: Any) -> None: ...

    def act(self, obs: Any) -> np.ndarray: ...


class RandomPolicy:
    """Uniform random actions (the lower bound of every table)."""

    def __init__(self, seed: int = 0):
        self.seed = seed
        self._space = None
        self._episode = 0

    def reset(self, env: Any) -> None:
        self._space = env.action_space
        self._space.seed(self.seed + self._episode)
        self._episode += 1

    def act(self, obs: Any) -> np.ndarray:
        return self._space.sample()


class PlannerPolicy:
    """A* + pure pursuit + reactive avoidance of agents, on the environment's maps.

    ``caution`` scales the avoidance horizon and the speed near agents (1 the default; the
    scripted oracle of the traverse uses a more cautious setting)."""

    def __init__(self, caution: float = 1.0, avoid_agents: bool = True):
        self.caution = caution
        self.avoid_agents = avoid_agents
        self.env = None
        self.planner = None
        self._goal = None

    def reset(self, env: Any) -> None:
        from citygen.runner.control.planner import Planner

        self.env = env
        robot = env.robot
        self.planner = Planner(
            env.prepared.occupancy, robot.radius, free=env.prepared.free, lookahead=LOOKAHEAD,
            max_speed=robot.max_speed / self.caution, max_yaw_rate=robot.max_yaw_rate,
            horizon=1.5 * self.caution,
        )  # fmt: skip
        self._goal = None

    def act(self, obs: Any) -> np.ndarray:
        env = self.env
        x, y, _, yaw = env.handle.pose(env.data)
        goal = tuple(env._goal())
        if goal != self._goal:
            self.planner.plan((x, y), goal)
            self._goal = goal
        if self.avoid_agents:
            v, w = self.planner.command((x, y, yaw), *env.others())
        else:
            v, w = self.planner.command((x, y, yaw))
        if v > 0 and wait_for_walk(env, x, y, yaw):
            v = 0.0
        return np.array([v / env.robot.max_speed, w / env.robot.max_yaw_rate], dtype=np.float32).clip(-1, 1)


def wait_for_walk(env: Any, x: float, y: float, yaw: float) -> bool:
    """Whether the robot at ``(x, y)`` facing ``yaw`` stands at the edge of a signalised
    crosswalk that does not show *walk* (in a city; once on a crosswalk it walks on)."""
    if not getattr(env.scene, "signals", None) or getattr(env, "prepared", None) is None:
        return False
    from citygen.runner.agents.signals import crossings_of

    c = crossings_of(env.prepared, env.scene)
    if c.crosswalk_at(np.array([[x, y]]))[0] >= 0:
        return False
    reach = env.robot.radius + np.array([0.3, 1.0])
    ahead = np.stack([x + reach * math.cos(yaw), y + reach * math.sin(yaw)], axis=1)
    return bool(c.no_walk(ahead, env.steps * env.dt).any())


class GaitPolicy:
    """The PD stand or trot controller of :mod:`citygen.runner.control.gaits` as a policy (a
    biped's stand or walk of :mod:`citygen.runner.control.gaits_biped`)."""

    def __init__(self, gait: str):
        self.gait = gait
        self.controller = None
        self.env = None

    def reset(self, env: Any) -> None:
        from citygen.runner.control import gaits, gaits_biped
        from citygen.runner.tasks import check_policy

        check_policy(env.task_kind, env.robot, self.gait)  # locomotion, a robot a gait drives
        self.env = env
        biped = len(env.robot.legs) == 2
        if self.gait == "stand":
            self.controller = gaits_biped.BipedStand() if biped else gaits.StandController()
        elif biped:
            self.controller = gaits_biped.BipedWalk(command=tuple(env.command))
        else:
            self.controller = gaits.TrotController(command=tuple(env.command))
        self.t = 0.0

    def act(self, obs: Any) -> np.ndarray:
        a = self.controller.act(self.env.handle, self.env.data, self.t)
        self.t += self.env.dt
        # the gaits drive the legs; wheels on them (the wheeled-legged robot's) stay still
        full = np.zeros(self.env.action_space.shape, dtype=np.float32)
        full[: len(a)] = a
        return full.clip(-1, 1)


# --- traverse control modes ---------------------------------------------------------------


class Driver(Protocol):
    """A person at the controls: ``act(env, obs) -> action`` for the steps they drive."""

    def reset(self, env: Any) -> None: ...

    def act(self, env: Any, obs: Any) -> np.ndarray: ...


class ScriptedOracle:
    """Stands in for a person: the planner with privileged knowledge of every agent, a longer
    avoidance horizon and a lower speed (a careful teleoperator)."""

    def __init__(self):
        self._policy = PlannerPolicy(caution=1.6)

    def reset(self, env: Any) -> None:
        self._policy.reset(env)

    def act(self, env: Any, obs: Any) -> np.ndarray:
        return self._policy.act(obs)


#: Metres ahead along the route of the sub-goal a learned navigator steers to, at most up to
#: the next waypoint (its training goals lie 5-9 m away; the traverse's waypoints up to 23 m apart).
CARROT = 6.0
#: A learned navigator that moved less than ``STUCK[1]`` m in ``STUCK[0]`` s backs up for
#: ``BACK_UP[0]`` s at ``BACK_UP[1]`` of its top speed (the back-up recovery of a navigation
#: stack such as Nav2's), then drives on.
STUCK = (2.0, 0.15)
BACK_UP = (1.0, 0.5)
#: Failed attempts at one stretch of a traverse after which a learned navigator hands that
#: stretch (up to the next waypoint) to the classical planner.
HANDOVER = 2
#: Robot -> the task of its shipped learned baseline that drives its traverse's ``ai`` mode
#: (:class:`LearnedNavigator`). A baseline is listed only once it completed that robot's
#: track (``citygen bench --task traverse --policy FILE.npz`` on urban-tra-standard, in
#: ``learn/baselines/README.md``): the learned NavStatic quadruped completes the 1,200 m in
#: 2,435 s with 25 attempts. Robots not listed are driven by the planner (:class:`PlannerPolicy`).
TRAVERSE_AI: dict[str, str] = {"quadruped": "nav-static"}


def carrot(
    route: list[tuple[float, float]], waypoint: int, xy: tuple[float, float], ahead: float
) -> np.ndarray:
    """The point ``ahead`` m along the leg that ends at ``route[waypoint]`` past the robot's
    projection on it, never beyond that waypoint: the traverse counts a waypoint only within
    its tolerance (0.5 m), so a sub-goal cutting the corner would pass it by."""
    pts = np.asarray(route, dtype=np.float64)
    a = pts[max(waypoint - 1, 0)]
    b = pts[min(waypoint, len(pts) - 1)]
    leg = b - a
    n = float(leg @ leg)
    t = 0.0 if n == 0 else float(np.clip((np.asarray(xy) - a) @ leg / n, 0.0, 1.0))
    here = a + t * leg
    step = float(np.hypot(*(b - here)))
    return here + (b - here) * (ahead / step) if step > ahead else b.copy()


class LearnedNavigator:
    """The paper's AI mode: "a general navigation model to make waypoint following". The
    learned PPO policy (``--policy FILE.npz`` on a traverse, or the baseline of
    :data:`TRAVERSE_AI`) is the local navigator: it
    sees only what it was trained on (goal, velocity, height and local maps) and steers to a
    sub-goal :data:`CARROT` m ahead, as it was trained to reach goals a few metres away.

    The sub-goal runs along a path to the next waypoint planned on the scene's static
    occupancy map (a robot's map-based global planner; ``guide="map"``, the default), or
    along the straight leg between waypoints (``guide="route"``), which on a track lined
    with furniture points the navigator into objects it then has to find its way around.

    At the edge of a signalised crosswalk that does not show walk it does not drive forwards
    (:func:`wait_for_walk`, as the planner). A navigator wedged against an object
    (:data:`STUCK`) backs up (:data:`BACK_UP`) and
    tries again. It acts on the policy's mean, except after a back-up or a failed attempt:
    backed up from a wedge or put back at the last waypoint, a deterministic policy would
    wedge or fail the same way again, so until it reaches the next waypoint it draws its
    actions from the policy's trained Gaussian (as in training; seeded by the episode). After
    :data:`HANDOVER` failed attempts at one stretch, the classical planner
    (:class:`PlannerPolicy`) drives that stretch: the AI is the learned navigator with a
    classical recovery, so it completes a route its learned part alone would fail forever,
    and its attempts count every failure of the learned part."""

    def __init__(self, path: str, guide: str = "map"):
        from citygen.runner.learn.policy import load_policy

        if guide not in ("map", "route"):
            raise ValueError(f"LearnedNavigator: guide must be 'map' or 'route', got {guide!r}")
        self.path = path
        self.guide = guide
        self.policy = load_policy(path)
        self.env = None
        self.planner = None

    def reset(self, env: Any) -> None:
        from citygen.runner.control.planner import Planner

        self.env = env
        self.planner = Planner(
            env.prepared.occupancy, env.robot.radius, free=env.prepared.free, replan_distance=1.0
        )
        self._goal = None
        self._trail: list[tuple[float, float]] = []
        self._backing = 0
        self._attempts, self._reached = getattr(env, "attempts", 0), getattr(env, "waypoint", 0)
        self._failed = 0
        self._explore = False
        self.fallback = PlannerPolicy()
        self.fallback.reset(env)
        from citygen.runner.envs.base import episode_rng

        self._rng = episode_rng(env)

    def subgoal(self, x: float, y: float) -> np.ndarray:
        """Where the navigator steers from ``(x, y)``: :data:`CARROT` m ahead on the guide."""
        env = self.env
        if self.guide == "route":
            return carrot(env.route, env.waypoint, (x, y), CARROT)
        from citygen.runner.control.pursuit import point_ahead

        goal = tuple(env._goal())
        path = self.planner.path
        if goal != self._goal or path is None or self.planner.off_path((x, y)):
            path = self.planner.plan((x, y), goal)
            self._goal = goal
        if path is None:  # no free cell near the robot: the straight way
            return carrot(env.route, env.waypoint, (x, y), CARROT)
        return point_ahead(path, (x, y), CARROT)

    def stuck(self, x: float, y: float) -> bool:
        """Whether the robot, now at ``(x, y)``, moved less than ``STUCK[1]`` m over the last
        ``STUCK[0]`` s (a reset of the traverse, a jump, starts the trail again)."""
        n = max(1, round(STUCK[0] / self.env.dt))
        if self._trail and math.dist(self._trail[-1], (x, y)) > 1.0:
            self._trail.clear()
        self._trail = [*self._trail[-n:], (x, y)]
        return len(self._trail) > n and math.dist(self._trail[0], (x, y)) < STUCK[1]

    def act(self, obs: Any) -> np.ndarray:
        env = self.env
        attempts, reached = getattr(env, "attempts", 0), getattr(env, "waypoint", 0)
        if reached != self._reached:
            self._failed, self._explore = 0, False
        elif attempts > self._attempts:
            self._failed, self._explore = self._failed + 1, True
        self._attempts, self._reached = attempts, reached
        if self._failed >= HANDOVER:
            return self.fallback.act(obs)
        x, y, _, yaw = env.handle.pose(env.data)
        if self._backing == 0 and self.stuck(x, y):
            self._backing = max(1, round(BACK_UP[0] / env.dt))
            self._trail.clear()
            self._explore = True  # the mean, backed up, would drive into the same wedge
        if self._backing > 0:
            self._backing -= 1
            return np.array([-BACK_UP[1], 0.0], dtype=np.float32)
        gx, gy = self.subgoal(x, y)
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = gx - x, gy - y
        obs = {**obs, "goal": np.array([c * dx + s * dy, -s * dx + c * dy], dtype=np.float32)}
        action = np.array(self.policy.predict(obs, self._rng if self._explore else None)[0], copy=True)
        if action[0] > 0 and wait_for_walk(env, x, y, yaw):  # as the planner: walk on walk only
            action[0] = 0.0
        return action


def traverse_ai(robot: str, locomotion: str = "servo") -> Policy:
    """The AI of a traverse for ``robot``: :class:`LearnedNavigator` on its shipped learned
    baseline named in :data:`TRAVERSE_AI` (on learned legs, the one fine-tuned on them if one
    ships), else the privileged planner (:class:`PlannerPolicy`)."""
    from citygen.runner.learn.policy import shipped

    found = shipped(locomotion)
    if (TRAVERSE_AI.get(robot), robot) in found:
        return LearnedNavigator(str(found[(TRAVERSE_AI[robot], robot)]))
    return PlannerPolicy()


#: The foundational navigation tasks, one shipped model each per robot (Urban-Nav 1-3).
FOUNDATIONAL_NAV = ("nav-clear", "nav-static", "nav-dynamic")
#: Situation -> the foundational models to drive it with, best first, when a robot lacks some.
NAV_FALLBACK = {
    "nav-dynamic": ("nav-dynamic", "nav-static", "nav-clear"),
    "nav-static": ("nav-static", "nav-dynamic", "nav-clear"),
    "nav-clear": ("nav-clear", "nav-static", "nav-dynamic"),
}
#: Metres around the robot within which an object (an obstacle or building cell of the
#: occupancy map) makes the situation NavStatic's: the half width of the local map a
#: navigation model sees (6.4 m).
OBSTACLE_RADIUS = 3.2
#: Metres along the heading, from behind the base (its hind feet) to ahead of it, whose
#: terrain chooses Human-AI-Mode-1's locomotion model (:func:`ground_ahead`); the height map
#: a locomotion model sees reaches 0.8 m ahead of the base.
GROUND_AHEAD = (-0.3, 1.0)


def situation(env: Any) -> str:
    """The foundational navigation task of the robot's situation, the paper's "scene
    conditions" by which Human-AI-Mode-1 and -2 dispatch navigation models: ``"nav-dynamic"``
    with a person or vehicle within :data:`RISK_RADIUS` m, else ``"nav-static"`` with an
    object within :data:`OBSTACLE_RADIUS` m, else ``"nav-clear"``."""
    x, y, _, _ = env.handle.pose(env.data)
    xy, _, _ = env.others()
    if len(xy) and bool(np.any(np.hypot(xy[:, 0] - x, xy[:, 1] - y) < RISK_RADIUS)):
        return "nav-dynamic"
    occ = env.prepared.occupancy
    g = occ.grid
    r = OBSTACLE_RADIUS
    rows, cols = g.window((x - r, y - r, x + r, y + r))
    objects = [occ.classes.index("obstacle"), occ.classes.index("building")]
    near = np.isin(occ.labels[rows, cols], objects)
    if near.any():
        dx = g.xs()[cols][None, :] - x
        dy = g.ys()[rows][:, None] - y
        if bool(np.any(near & (np.hypot(dx, dy) <= r))):
            return "nav-static"
    return "nav-clear"


def ground_ahead(env: Any) -> str:
    """The terrain Human-AI-Mode-1 walks on a terrain model for: the first kind that is not
    ``"flat"`` on the occupancy map's terrain layer along the heading from
    ``GROUND_AHEAD[0]`` to ``GROUND_AHEAD[1]`` m (every 0.1 m, from behind forwards), else
    ``"flat"``: on a slope until the hind feet leave it, on the next one from a metre before it."""
    x, y, _, yaw = env.handle.pose(env.data)
    occ = env.prepared.occupancy
    along = np.arange(GROUND_AHEAD[0], GROUND_AHEAD[1] + 1e-9, 0.1)
    px, py = x + along * math.cos(yaw), y + along * math.sin(yaw)
    flat = occ.terrain_classes.index("flat")
    for a, b in zip(px, py, strict=True):
        kind = int(occ.terrain[occ.cell(a, b)])
        if kind != flat:
            return occ.terrain_classes[kind]
    return "flat"


def locomotion_for(terrain: str) -> str:
    """The locomotion model Human-AI-Mode-1 dispatches for ``terrain`` (of :func:`ground_ahead`):
    the terrain's own model on ``slope``, ``stair`` and ``rough`` (the general one where the
    robot has none, :meth:`~citygen.runner.envs.legs.LearnedLegs.use`), the general model on
    flat ground: it was taught to follow navigation's commands (turn in place, back up), the
    flat model only straight-ahead commands held to a heading."""
    return "general" if terrain == "flat" else terrain


class DispatchingNavigator(LearnedNavigator):
    """The paper's "dispatch of foundational navigation models" (Human-AI-Mode-1 and -2): the
    robot's shipped NavClear, NavStatic and NavDynamic models (``paths``: task -> file), the
    one for the situation (:func:`situation`; :data:`NAV_FALLBACK` where a robot lacks it)
    chosen at every decision point by :meth:`dispatch`; between them it drives as
    :class:`LearnedNavigator` does (the same sub-goal, back-up, sampling and handover)."""

    def __init__(self, paths: dict[str, str], guide: str = "map"):
        from citygen.runner.learn.policy import load_policy

        if not paths:
            raise ValueError("DispatchingNavigator: expected at least one navigation model, got none")
        first = next(t for t in (*NAV_FALLBACK["nav-static"], *paths) if t in paths)
        super().__init__(paths[first], guide)
        self.paths = dict(paths)
        self.policies = {t: self.policy if t == first else load_policy(p) for t, p in self.paths.items()}
        #: The task whose model drives now.
        self.task = first

    def dispatch(self, env: Any) -> str:
        """Drive with the model of ``env``'s situation from now on; returns its task."""
        want = situation(env)
        self.task = next((t for t in NAV_FALLBACK[want] if t in self.policies), self.task)
        self.policy, self.path = self.policies[self.task], self.paths[self.task]
        return self.task


def foundational_navigator(robot: str, locomotion: str = "servo") -> Policy:
    """The foundational navigation of ``robot``: :class:`DispatchingNavigator` over its
    shipped models of :data:`FOUNDATIONAL_NAV` (on learned legs, those fine-tuned on them
    where one ships), else (none shipped) the planner."""
    from citygen.runner.learn.policy import shipped

    found = shipped(locomotion)
    paths = {t: str(found[(t, robot)]) for t in FOUNDATIONAL_NAV if (t, robot) in found}
    return DispatchingNavigator(paths) if paths else PlannerPolicy()


def risk(env: Any) -> float:
    """Risk of the stretch ahead, in [0, 1]: agents within :data:`RISK_RADIUS` m (vehicles
    count double), uneven terrain under the next metres and non-walkable ground there."""
    x, y, _, yaw = env.handle.pose(env.data)
    xy, _, rad = env.others()
    near = 0.0
    if len(xy):
        d = np.hypot(xy[:, 0] - x, xy[:, 1] - y)
        near = float(np.sum((d < RISK_RADIUS) * np.where(rad > 1.0, 2.0, 1.0)))
    ahead = np.linspace(0.5, 4.0, 8)
    px, py = x + ahead * math.cos(yaw), y + ahead * math.sin(yaw)
    occ = env.prepared.occupancy
    terrain = occ.terrain[tuple(np.array([occ.cell(a, b) for a, b in zip(px, py, strict=True)]).T)]
    uneven = float(np.mean(terrain != occ.terrain_classes.index("flat")))
    off = float(np.mean([not env.prepared.walkable[occ.cell(a, b)] for a, b in zip(px, py, strict=True)]))
    return min(1.0, 0.15 * near + 0.4 * uneven + 0.3 * off)


class ControlMode:
    """A traverse control mode: at each decision point the mode chooses who drives until the
    next one. ``threshold`` is the risk at or above which a person takes over (0: always a
    person, above 1: never). ``ai`` drives when no person does; by default the robot's
    general navigation model (:func:`traverse_ai`), or with ``navigation="foundational"`` its
    foundational models (:func:`foundational_navigator`), the one for the situation
    dispatched at each decision point the AI drives from. With ``terrain_legs`` (on learned
    legs) the locomotion model is the one of the ground ahead (:func:`ground_ahead`,
    :meth:`~citygen.runner.envs.legs.LearnedLegs.use`), chosen every step whoever drives:
    the person at a decision point looks at the stretch to the next one, which on the track
    crosses several terrains, and sets the model for each; elsewhere the general one."""

    def __init__(
        self, threshold: float, driver: Driver | None = None, interval: float = DECISION_INTERVAL,
        ai: Policy | None = None, *, navigation: str = "general", terrain_legs: bool = False,
    ):  # fmt: skip
        if navigation not in ("general", "foundational"):
            raise ValueError(
                f"ControlMode: navigation must be 'general' or 'foundational', got {navigation!r}"
            )
        self.threshold = threshold
        self.driver = driver or ScriptedOracle()
        self.interval = interval
        self.navigation = navigation
        self.terrain_legs = terrain_legs
        self.ai = ai
        self._given = ai is not None
        self._robot: tuple[str, str] | None = None  # whose AI self.ai is, and on what legs
        self.env = None

    def reset(self, env: Any) -> None:
        self.env = env
        walk = "learned" if getattr(env, "legs", None) is not None else "servo"
        if not self._given and self._robot != (env.robot.name, walk):
            make_ai = traverse_ai if self.navigation == "general" else foundational_navigator
            self.ai, self._robot = make_ai(env.robot.name, walk), (env.robot.name, walk)
        self.ai.reset(env)
        self.driver.reset(env)
        self._last = None
        self._travelled = math.inf
        self.human = False

    def act(self, obs: Any) -> np.ndarray:
        env = self.env
        x, y, _, _ = env.handle.pose(env.data)
        if self._last is not None:
            self._travelled += math.hypot(x - self._last[0], y - self._last[1])
        self._last = (x, y)
        if self._travelled >= self.interval:
            self._travelled = 0.0
            self.human = risk(env) >= self.threshold
            if not self.human and isinstance(self.ai, DispatchingNavigator):
                self.ai.dispatch(env)
        if self.terrain_legs and getattr(env, "legs", None) is not None:
            env.legs.use(locomotion_for(ground_ahead(env)))
        if hasattr(env, "set_operator"):
            env.set_operator(self.human)
        return self.driver.act(env, obs) if self.human else self.ai.act(obs)


#: Traverse control modes: risk threshold for a person to take over. The paper's four:
#: ``human`` (the person drives all the way on the general locomotion model), ``ai`` (the
#: general navigation and locomotion models), ``human-ai-mode-1`` and ``human-ai-mode-2``
#: (:data:`PAPER_SHARED`); and citygen's two earlier shared modes, the general navigation
#: model with a person taking over at a lower (``shared-cautious``) or higher
#: (``shared-efficient``) risk. The paper's shared modes take over at shared-efficient's
#: threshold: the paper's shared modes cost a person 16 % of the human mode's time, of
#: citygen's shared-efficient 21 % and shared-cautious 62 % (docs/training.md).
MODES = {
    "human": 0.0,
    "shared-cautious": 0.25,
    "shared-efficient": 0.55,
    "ai": math.inf,
    "human-ai-mode-1": 0.55,
    "human-ai-mode-2": 0.55,
}
#: The paper's shared modes: the foundational navigation models dispatched by the situation,
#: a person taking over at the risk of :data:`MODES`, and (True) the terrain locomotion
#: models dispatched by the ground ahead (Mode-1) or (False) the general one (Mode-2).
PAPER_SHARED = {"human-ai-mode-1": True, "human-ai-mode-2": False}

POLICIES = ("random", "planner", "stand", "trot", *MODES)


def make_policy(name: str, *, seed: int = 0, driver: Driver | None = None, task: str | None = None) -> Policy:
    """A baseline by name (see the module docstring). A learned model's file on a ``traverse``
    is that traverse's AI: the ``ai`` mode with it as the :class:`LearnedNavigator`."""
    if name == "random":
        return RandomPolicy(seed)
    if name == "planner":
        return PlannerPolicy()
    if name in ("stand", "trot"):
        return GaitPolicy(name)
    if name in PAPER_SHARED:
        return ControlMode(MODES[name], driver, navigation="foundational", terrain_legs=PAPER_SHARED[name])
    if name in MODES:
        return ControlMode(MODES[name], driver)
    if name.lower().endswith((".npz", ".zip")):  # a learned model (citygen.runner.learn)
        if task == "traverse":
            return ControlMode(MODES["ai"], driver, ai=LearnedNavigator(name))
        from citygen.runner.learn.policy import load_policy

        return load_policy(name)
    raise SpecError(f"policy: expected one of {', '.join(POLICIES)}, got {name!r}")
