"""Navigation and the traverse on learned legs: a legged robot that walks where navigation
sends it on its general locomotion model instead of the ideal servo on its base.

``make_env("nav-static", robot="quadruped", locomotion="learned")`` (``--locomotion
learned`` on ``citygen bench``, ``run`` and ``train``; :data:`LOCOMOTION`; the same for
``"traverse"`` on ``bench`` and ``run``) gives the
:class:`~citygen.runner.envs.nav.NavEnv` a :class:`LearnedLegs`: each navigation step's
action, the velocity ``(v, w)`` the servo would track, becomes the velocity command
``(vx, vy, wz) = (v, 0, w)`` of the robot's general locomotion model, clipped into the
ranges it was trained on (:data:`citygen.runner.learn.loco.COMMANDS`: the quadruped's servo
backs up at 1 m/s and turns at 1.5 rad/s, the model learnt at most 0.5 and 1), and a
quadruped's command that backs up while it turns (at :data:`BACK_AND_TURN` rad/s or more)
turning in place instead: asked to do both, its general model sits down and stays there
(:func:`citygen.runner.learn.shipped_models.general_locomotion`), which sets the joints'
targets every :data:`~citygen.runner.envs.loco.LOCO_DT` s (50 Hz; several times per
navigation step) from what :class:`~citygen.runner.envs.loco.LocoEnv` would observe in the
same state (:func:`citygen.runner.envs.legged.leg_observation`), on the same MJCF robot, PD
servos and contacts. The robot starts standing with its feet on the ground, as in
locomotion. A fall (LocoEnv's rule: the body, not the legs, pressing on the ground with
more than :data:`~citygen.runner.envs.loco.FALL_FORCE` N, checked after every 50 Hz step;
or, as on the servo, the base tipped past 60 degrees, here for a second: :data:`TIPPED`)
ends the navigation episode as leaving the scene does: a failure (success 0, SPL 0, the
route completed up to the fall, reward -100), counted by the episode's ``fall_rate``
metric (100 when it ended in a fall, else 0); on the traverse it is a failed trial instead
(:mod:`~citygen.runner.envs.traverse`). :meth:`LearnedLegs.use` swaps in one of the robot's
shipped terrain models between two navigation steps (the traverse's Human-AI-Mode-1).
The models act on their mean, except when the robot is wedged (:data:`WEDGE`: still while
asked to move): then for :data:`UNWEDGE` s on draws from their trained Gaussian.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from citygen.errors import Problem, SpecError
from citygen.runner.envs import legged
from citygen.runner.envs.base import episode_rng
from citygen.runner.envs.loco import FALL_FORCE, LOCO_DT
from citygen.runner.learn.loco import COMMANDS

#: The name of the robot's general locomotion model among :attr:`LearnedLegs.files`.
GENERAL = "general"
#: Per robot, the yaw rate (rad/s) from which a command backing up turns in place instead.
#: The quadruped's general model, asked (-0.5 m/s, -1 rad/s) or (-0.25, -1), sits down (its
#: base 0.18 m high against 0.30) and no longer moves; turning in place (0.86 and -1.19 rad/s
#: asked +-1) and backing up straight (-0.22 m/s asked -0.5) it does. The servo's NavStatic
#: policy asks both at once when its goal is behind it: on learned legs 13 of its first 32
#: episodes ended at their start, seated (success 28.1 % of 64 episodes, 48.4 % with this
#: rule). The wheeled-legged robot's model backs up under both (-0.26 m/s) and barely turns in
#: place (0.28 rad/s asked 1): the rule would halve its NavStatic success (12.5 -> 6.3 % of
#: 32), so it has none.
BACK_AND_TURN: dict[str, float] = {"quadruped": 0.3}
#: A robot on learned legs whose base stays tipped past ``TIPPED[0]`` (the cosine of its up
#: axis from the vertical: 60 degrees, the servo's rule, :meth:`~citygen.runner.envs.nav.NavEnv._fallen`)
#: for ``TIPPED[1]`` s has fallen although its body does not press on the ground. On the
#: traverse the quadruped's general model lay on its side, propped on its legs, for 6-14 s
#: until the track's stuck rule put it back (4 of the Human mode's first 38 attempts); counted
#: at once, the tilt made falls of recoveries (the AI mode's falls 37 -> 63, its time 2,601 ->
#: 2,874 s).
TIPPED = (0.5, 1.0)
#: A robot asked to move (:data:`WEDGE_COMMAND`: m/s forward or back, rad/s of yaw) whose
#: base moved less than ``WEDGE[1]`` m/s and turned less than ``WEDGE[2]`` rad/s for
#: ``WEDGE[0]`` s is wedged; its model then acts on a draw from its trained Gaussian (as in
#: training) for :data:`UNWEDGE` s. On the traverse's stairs the quadruped's general model
#: froze with a calf jammed under a step's edge (about 800 N on it): a feed-forward policy's
#: mean in a still state is a still action, so the mean holds the wedge for ever (and backing
#: up does not free it), while 2 s of its own noise freed it and it walked on up the flight.
WEDGE = (1.0, 0.02, 0.02)
WEDGE_COMMAND = (0.1, 0.2)
UNWEDGE = 2.0

#: Values of the ``locomotion`` option: the ideal servo on the base (the default, with which
#: the shipped navigation results were measured) or the robot's learned general model.
LOCOMOTION = ("servo", "learned")


def learned_legs(env: Any, locomotion: str) -> LearnedLegs | None:
    """The learned legs of navigation environment ``env`` for ``locomotion`` (None for the
    servo), or a one-line error: an unknown value, a task other than navigation, a robot
    without legs or without a shipped general locomotion model."""
    if locomotion not in LOCOMOTION:
        raise SpecError([Problem("locomotion", " or ".join(LOCOMOTION), repr(locomotion))])
    if locomotion == "servo":
        return None
    return LearnedLegs(env)


def general_model(task: str, robot: Any) -> Path:
    """The general locomotion model that walks ``robot`` (a :class:`~citygen.runner.robots.Robot`)
    through navigation ``task`` on learned legs, or a one-line error: a task other than
    navigation, a robot without legs or without a shipped general locomotion model. The
    general model trained on navigation's changing commands where one ships
    (``loco-general-<robot>-nav.npz``): navigation changes its command every 0.1 s."""
    from citygen.runner.learn.shipped_models import PolicyError, general_locomotion

    if not task.startswith("nav") and task != "traverse":
        tasks = "nav-clear, nav-static, nav-dynamic, traverse"
        raise SpecError(
            f"--locomotion learned: expected a navigation task or the traverse ({tasks}), got {task}"
        )
    if not robot.leg_joints:
        raise SpecError(
            f"--locomotion learned: the {robot.name} robot has no legs to walk on; "
            "expected a legged robot, or --locomotion servo"
        )
    try:
        return general_locomotion(robot.name, "navigation")
    except PolicyError as exc:
        raise PolicyError(f"--locomotion learned: {exc}") from None


def free_damping(robot: Any) -> np.ndarray:
    """The damping of ``robot``'s free joint as its own MJCF has it. The ideal servo writes
    its velocity feedback there in the compiled scene's model (``RobotHandle._damp``), which
    every environment of the process on that scene shares: legs walking after a servo (a
    bench of both in one process) put it back."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(robot.xml, dict(robot.assets))
    a = int(model.jnt_dofadr[model.body_jntadr[model.body(robot.base_body).id]])
    return model.dof_damping[a : a + 6].copy()


class LearnedLegs:
    """The general locomotion model walking ``env``'s legged robot (see the module
    docstring): :meth:`reset` after the environment's, :meth:`walk` instead of the servo's
    control step, :attr:`fell` for the environment's end of episode."""

    def __init__(self, env: Any):
        from citygen.runner.learn.shipped_models import terrain_locomotion

        robot = env.robot
        path = general_model(env.task_kind, robot)
        self.env = env
        n, n_actions = len(robot.leg_joints), len(robot.leg_joints) + len(robot.loco_wheels)
        self._spaces = legged.leg_spaces(n, n_actions, env._height_space())
        self._n_actions = n_actions
        #: Model name -> file: ``"general"`` and the robot's shipped terrain models by terrain
        #: (:func:`~citygen.runner.learn.shipped_models.terrain_locomotion`), which :meth:`use`
        #: swaps in; each read (and checked against the robot) on its first use.
        self.files: dict[str, Path] = {GENERAL: path, **terrain_locomotion(robot.name)}
        self._loaded: dict[str, Any] = {}
        self.use(GENERAL)
        #: 50 Hz steps per navigation step.
        self.repeats = max(1, round(env.dt / LOCO_DT))
        #: Whole steps of the rules' durations: navigation steps still before a wedge
        #: (:data:`WEDGE`), 50 Hz steps tipped before a fall (:data:`TIPPED`).
        self._wedge_steps = max(1, round(WEDGE[0] / env.dt))
        self._tipped_steps = round(TIPPED[1] / LOCO_DT)
        self.command = np.zeros(3)
        self.last_action = np.zeros(n_actions)
        self.fell = False
        #: 50 Hz steps left of acting on draws from the model's Gaussian (:data:`WEDGE`),
        #: navigation steps the robot has been still while asked to move, how often it was
        #: wedged, and 50 Hz steps its base has been tipped past :data:`TIPPED`.
        self._unwedge, self._still, self.wedges, self._tipped = 0, 0, 0, 0
        self._rng = np.random.default_rng(0)
        self._free_damping = free_damping(robot)
        self._force = np.zeros(6)  # mj_contactForce's output
        self._handle = None  # the robot handle the ids below are of

    def _read(self, path: Path) -> Any:
        """The policy in ``path``, or a one-line error when it does not fit this robot's
        locomotion observation and action."""
        from citygen.runner.learn.export import read_policy
        from citygen.runner.learn.shipped_models import PolicyError

        robot, want, n_actions = self.env.robot, self._spaces, self._n_actions
        try:
            policy = read_policy(path)
        except ValueError as exc:
            raise PolicyError(f"{path}: expected a policy exported by `citygen train`, got {exc}") from None
        for key, shape in policy.shapes.items():
            if key not in want or tuple(want[key].shape) != shape:
                found = "no such key" if key not in want else f"shape {tuple(want[key].shape)}"
                raise PolicyError(
                    f"{path}: observation {key!r} of shape {shape}: the {robot.name} robot's "
                    f"locomotion observation has {found}"
                )
        if tuple(policy.meta["action_shape"]) != (n_actions,):
            raise PolicyError(
                f"{path}: action: expected shape ({n_actions},) for the {robot.name} robot, "
                f"the policy gives {tuple(policy.meta['action_shape'])}"
            )
        return policy

    def use(self, name: str) -> str:
        """Walk on model ``name`` from the next 50 Hz step on: ``"general"`` or a terrain
        (``"slope"``) whose model ships for this robot, else the general model; returns the
        name of the model that now acts (:attr:`model`). The command, the last action and
        the robot's state carry over: the new model reads the same observation the old one
        would have (its ``last_action`` the old model's last joint targets), as every model
        here is a feed-forward policy of the same observation without a memory of its own."""
        name = name if name in self.files else GENERAL
        if name not in self._loaded:
            self._loaded[name] = self._read(self.files[name])
        #: The model walking the robot: its name (:attr:`files`), file and policy.
        self.model, self.path, self.policy = name, self.files[name], self._loaded[name]
        self.keys = self.policy.keys
        return name

    def _bind(self) -> None:
        """The ids of the current scene's robot: the geoms whose pressing on the ground is a
        fall, the ground's, the ``joint_vel`` dofs, and the physics steps of one 50 Hz step."""
        env = self.env
        if self._handle is env.handle:
            return
        fall = legged.fall_geoms(env.model, env.handle, env._robot_geoms)
        self._fall_ids = frozenset(np.flatnonzero(fall).tolist())
        self._ground_ids = frozenset(np.flatnonzero(env.prepared.ground_geoms).tolist())
        self._vel_dofs = legged.joint_vel_dofs(env.handle)
        self._substeps = max(1, round(LOCO_DT / env.model.opt.timestep))
        self._handle = env.handle

    def reset(self) -> None:
        """A new episode, or the robot put back after a fall (a traverse's reset): standing
        with its feet on the ground under each where the environment put it (as LocoEnv
        starts), no command, no last action, not fallen, on the general model."""
        env = self.env
        x, y, _, yaw = env.handle.pose(env.data)
        env._spawn(x, y, yaw)
        self._bind()
        self.command[:] = 0.0
        self.last_action[:] = 0.0
        self.fell = False
        self._unwedge, self._still, self._tipped = 0, 0, 0
        self._rng = episode_rng(env, env.steps)  # a reset mid-episode (the traverse's) draws anew
        self.use(GENERAL)

    def observation(self) -> dict[str, np.ndarray]:
        """What the locomotion model reads now (LocoEnv's observation in this state)."""
        env = self.env
        pose = env.handle.pose(env.data)
        return legged.leg_observation(env, self.keys, self.command, self.last_action, self._vel_dofs, pose)

    def walk(self, v: float, w: float) -> None:
        """One navigation step: the command ``(v, 0, w)`` (m/s, rad/s; clipped into the
        model's training ranges; ``v`` 0 where it backs up while turning at the robot's
        :data:`BACK_AND_TURN` or more) to the locomotion model, which sets the joints' targets
        every :data:`LOCO_DT` s (:attr:`repeats` times) as in LocoEnv's step; stops at a
        fall (:attr:`fell`)."""
        import mujoco

        env = self.env
        self._bind()
        m, d, h = env.model, env.data, env.handle
        (v_lo, v_hi), _, (w_lo, w_hi) = COMMANDS
        v, w = min(max(v, v_lo), v_hi), min(max(w, w_lo), w_hi)
        if v < 0.0 and abs(w) >= BACK_AND_TURN.get(env.robot.name, math.inf):
            v = 0.0
        self.command[:] = (v, 0.0, w)
        m.dof_damping[h.dadr : h.dadr + 6] = self._free_damping  # no servo's (free_damping)
        x0, y0, _, yaw0 = h.pose(d)
        for _ in range(self.repeats):
            rng = self._rng if self._unwedge > 0 else None
            self._unwedge = max(0, self._unwedge - 1)
            a = np.asarray(self.policy.predict(self.observation(), rng)[0], dtype=np.float64)
            a = np.minimum(np.maximum(a, -1.0), 1.0)
            h.joint_action(d, a)
            mujoco.mj_step(m, d, nstep=self._substeps)
            self.last_action = a
            if legged.body_ground_force(
                m, d, self._fall_ids, self._ground_ids, self._force
            ) > FALL_FORCE or self._lying(d.xmat[h.base_id][8]):
                self.fell = True
                return
        self._watch_wedge(x0, y0, yaw0, v, w)

    def _lying(self, up: float) -> bool:
        """After a 50 Hz step with the base's up axis at cosine ``up`` from the vertical:
        whether it has been tipped past :data:`TIPPED` for long enough to have fallen."""
        self._tipped = self._tipped + 1 if up < TIPPED[0] else 0
        return self._tipped >= self._tipped_steps

    def _watch_wedge(self, x0: float, y0: float, yaw0: float, v: float, w: float) -> None:
        """After a navigation step asked ``(v, w)`` from the pose ``(x0, y0, yaw0)``: count
        the time the robot has stood still while asked to move, and once it is wedged
        (:data:`WEDGE`) act on the model's Gaussian for the next :data:`UNWEDGE` s."""
        env, dt = self.env, self.env.dt
        x, y, _, yaw = env.handle.pose(env.data)
        turned = abs(math.remainder(yaw - yaw0, math.tau))
        moving = math.hypot(x - x0, y - y0) >= WEDGE[1] * dt or turned >= WEDGE[2] * dt
        asked = abs(v) >= WEDGE_COMMAND[0] or abs(w) >= WEDGE_COMMAND[1]
        # whole steps counted: ten summed 0.1 s steps fall short of 1.0 s by a rounding
        self._still = 0 if moving or not asked else self._still + 1
        if self._still >= self._wedge_steps and self._unwedge == 0:
            self._unwedge, self._still = max(1, round(UNWEDGE / LOCO_DT)), 0
            self.wedges += 1
