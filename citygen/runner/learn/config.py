"""The configuration of a ``citygen train`` run: one frozen pydantic model, the paper's PPO
hyperparameters as defaults (appendix, "Hyper-parameters of RL in urban navigation").

The paper gives horizon 200, learning rate 4e-4, gamma 0.99, GAE lambda 0.95, clip 0.2,
value-loss coefficient 1.0, entropy coefficient 5e-4, and a train batch of 256 envs x 60
steps cut into SGD minibatches of 3,840 (four minibatches per batch). It names neither the
network nor the number of epochs: citygen uses two hidden layers of 128 (tanh) for the actor
and the critic and 5 epochs. On a laptop CPU the batch is ``envs`` x ``n_steps`` with
``n_steps`` = the horizon (200), still cut into :attr:`TrainConfig.minibatches` = 4.

A ``--config FILE`` (TOML or JSON) holds any of the fields; command-line options override it.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

#: Observation keys a navigation policy sees: the goal, its own velocity and the local map
#: (through a CNN). The 1.6 m x 1.0 m ``height_map`` stays out: the local map's elevation
#: layer covers its ground at 0.2 m, and its 187 extra inputs slowed NavClear to 10-16 %
#: training success at 100k steps where these three keys reach 51 %.
NAV_KEYS = ("goal", "velocity", "local_map")
#: The observation key of a gait's phase, which a policy riding on a gait reads beside the
#: environment's (``gait``; :mod:`citygen.runner.learn.residual` gives it).
PHASE_KEY = "gait_phase"
#: Observation keys a locomotion policy sees: the paper's, and the base's tilt.
LOCO_KEYS = (
    "base_lin_vel", "base_ang_vel", "projected_gravity", "command", "joint_pos", "joint_vel", "last_action",
    "height_map",
)  # fmt: skip

#: The training split of each task kind (the test split is :data:`citygen.runner.envs.DEFAULT_SPLIT`).
TRAIN_SPLIT = {
    "nav-clear": "urban-nav-1-train",
    "nav-static": "urban-nav-2-train",
    "nav-dynamic": "urban-nav-3-train",
    "loco-flat": "urban-loc-1-train",
    "loco-slope": "urban-loc-2-train",
    "loco-stair": "urban-loc-3-train",
    "loco-rough": "urban-loc-4-train",
}

PositiveInt = Annotated[int, Field(ge=1)]
#: Bounds on what sizes a run's memory: a layer's width, the hidden layers' weights in all,
#: and the samples of one rollout (sub-environments x steps).
Width = Annotated[int, Field(ge=1, le=4096)]
Channels = Annotated[int, Field(ge=1, le=1024)]
Kernel = Annotated[int, Field(ge=1, le=64)]
"""A CNN layer's kernel size or stride."""
MAX_HIDDEN_WEIGHTS = 20_000_000
MAX_ROLLOUT = 1_000_000


class TrainConfig(BaseModel):
    """Everything a training run depends on (units in the descriptions)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    task: Literal[
        "nav-clear", "nav-static", "nav-dynamic", "loco-flat", "loco-slope", "loco-stair", "loco-rough"
    ] = "nav-static"
    split: str | None = Field(None, description="Training split; default the task's train split.")
    robot: str | None = Field(None, description="Robot name; default wheeled (quadruped for locomotion).")
    steps: Annotated[int, Field(ge=1, le=10**10)] = Field(1_000_000, description="Environment steps in all.")
    envs: Annotated[int, Field(ge=1, le=4096)] = Field(8, description="Parallel sub-environments.")
    processes: Annotated[int, Field(ge=0, le=1)] | None = Field(
        None,
        description="0 runs every sub-environment in this process, 1 spreads them over a "
        "process per core (a group each beyond the cores; see citygen.runner.vector); default 1 "
        "when the machine has more than one core and envs > 1.",
    )
    seed: Annotated[int, Field(ge=0, le=2**32 - 1)] = 0
    scenes: Annotated[int, Field(ge=1, le=100_000)] | None = Field(
        None,
        description="Distinct training scenes (the split's first N, extended past its end); "
        "default every scene of the split.",
    )
    sampling: Literal["async", "sync"] = Field(
        "async",
        description="async: every sub-environment draws its own scene at each reset; sync: "
        "all sub-environments run the same scene, a new one every rollout.",
    )
    max_steps: Annotated[int, Field(ge=1, le=1_000_000)] | None = Field(
        None,
        description="Control steps after which a training episode is cut (0.1 s each in navigation, "
        "0.02 s in locomotion; citygen bench --max-steps is the same for a test); default the "
        "task's horizon (navigation: 200 steps, 20 s). Scenes larger than the Urban-Nav ones need "
        "more time to cross (benchmarks/nav_scene_size.py).",
    )
    locomotion: Literal["servo", "learned"] = Field(
        "servo",
        description="Navigation with a legged robot: on the ideal servo on its base, or on learned "
        "legs (its general locomotion model; citygen.runner.envs.legs).",
    )
    # PPO (paper defaults)
    n_steps: Annotated[int, Field(ge=1, le=100_000)] = Field(
        200, description="Rollout steps per sub-environment (the horizon)."
    )
    learning_rate: Annotated[float, Field(gt=0, le=1)] = 4e-4
    lr_schedule: Literal["constant", "linear"] = Field(
        "constant",
        description="constant: learning_rate throughout (the paper); linear: from learning_rate "
        "down to 0 at `steps` (a long fine-tuning run's updates shrink instead of collapsing it).",
    )
    gamma: Annotated[float, Field(ge=0, le=1)] = 0.99
    use_sde: bool = Field(
        False,
        description="Generalised state-dependent exploration (gSDE, Raffin et al. 2022; SB3's use_sde): "
        "action noise that is a function of the state, redrawn every sde_sample_freq steps, instead "
        "of independent per-step noise (smooth exploration: a wheel that keeps turning one way). "
        "The exported policy acts with the mean, as without it.",
    )
    sde_sample_freq: Annotated[int, Field(ge=-1, le=10_000)] = Field(
        -1, description="Steps between two draws of gSDE's noise matrix (-1: once a rollout)."
    )
    gae_lambda: Annotated[float, Field(ge=0, le=1)] = 0.95
    clip_range: Annotated[float, Field(gt=0, le=1)] = 0.2
    vf_coef: Annotated[float, Field(ge=0)] = 1.0
    ent_coef: Annotated[float, Field(ge=0)] = 5e-4
    max_grad_norm: Annotated[float, Field(gt=0)] = 0.5
    n_epochs: Annotated[int, Field(ge=1, le=1000)] = 5
    minibatches: Annotated[int, Field(ge=1, le=100_000)] = Field(
        4, description="SGD minibatches per rollout batch."
    )
    net_arch: Annotated[tuple[Width, ...], Field(max_length=16)] = Field(
        (128, 128),
        description=f"Hidden layer widths (actor and critic): at most 16 layers of at most 4,096 units, "
        f"{MAX_HIDDEN_WEIGHTS:,} weights between them in all.",
    )
    activation: Literal["tanh", "relu", "elu"] = "tanh"
    log_std_init: Annotated[float, Field(ge=-5, le=2)] = Field(
        0.0,
        description="Initial log standard deviation of the Gaussian actions (0: SB3's std 1 on "
        "actions in [-1, 1]). PPO shrinks it slowly: after 300k steps from 0 the NavClear "
        "baselines still sample with std 0.8, so what they were trained to do is the noisy "
        "policy, not the mean a deterministic evaluation runs.",
    )
    log_std_final: Annotated[float, Field(ge=-5, le=2)] | None = Field(
        None,
        description="A ceiling on the actions' log standard deviation, lowered linearly from "
        "log_std_init at step 0 to this at `steps` (None: PPO alone sets it). A deterministic "
        "evaluation runs the mean action; a policy trained with wide noise until the end leans "
        "on that noise to leave places where its mean stands still or circles. Narrowing it "
        "late in the run trains the policy that is evaluated.",
    )
    conv: Annotated[tuple[tuple[Channels, Kernel, Kernel], ...], Field(max_length=8)] = Field(
        ((16, 5, 2), (32, 3, 2)),
        description="CNN over image-like keys (local_map): (channels, kernel, stride) per layer, "
        "then a linear layer of map_features units; () flattens them into the MLP.",
    )
    map_features: Width = Field(128, description="Units the CNN's linear layer gives the MLP.")
    target_kl: Annotated[float, Field(gt=0)] | None = Field(
        None, description="Stop a rollout's epochs early past this approximate KL (None: never)."
    )
    keys: tuple[str, ...] | None = Field(
        None,
        description="Observation keys the policy sees; default goal, velocity and local_map for "
        "navigation, the paper's proprioception and height map for locomotion.",
    )
    stack: tuple[tuple[str, ...], ...] = Field(
        (),
        description="Groups of image-like keys one CNN reads as its input channels, e.g. "
        '[["local_map", "local_map_crossable"]]; every other image-like key gets a CNN of its own. '
        "A layer read beside the local map then shares its filters instead of bringing a second "
        "encoder (and map_features more inputs) to train.",
    )
    goal_range: Annotated[float, Field(gt=0)] | None = Field(
        5.0,
        description="Goal vectors longer than this (m) reach the policy scaled to this length, "
        "in training and in the exported policy: a far test goal looks like a training one "
        "(Urban-Nav training goals are 5-9 m away, test goals 7.5-12.5 m). None: the raw goal.",
    )
    progress: Annotated[float, Field(ge=0)] = Field(
        1.0,
        description="Training-only shaping: reward per metre of progress along the walkable geodesic "
        "to the goal (0: the paper's navigation reward alone; see citygen.runner.learn.shaping).",
    )
    reverse: Annotated[float, Field(ge=0)] = Field(
        1.0,
        description="Training-only shaping: reward taken per metre the robot moves backwards (at "
        "1.0 progress in reverse earns nothing, so policies drive forwards as their sensors face); "
        "not on a step that starts in collision, so backing off an obstacle is free.",
    )
    tilt: Annotated[float, Field(ge=0, le=100)] = Field(
        0.0,
        description="Navigation, training only: weight of a lean term (a base leaning past 20 "
        "degrees pays the square of the excess over 8.6 degrees a step; citygen.runner.learn."
        "shaping), so that a wheeled robot learns to slow its turns on a hillside before it "
        "rolls over.",
    )
    gait_shaping: Annotated[float, Field(ge=0, le=100)] = Field(
        1.0,
        description="Locomotion, training only: weight of the gait shaping terms (broad velocity "
        "tracking, tilt, body rates, torques, joint accelerations, feet air time; "
        "citygen.runner.learn.loco); 0: the paper's locomotion reward alone.",
    )
    command_mix: Annotated[float, Field(ge=0, le=1)] = Field(
        0.0,
        description="Locomotion, training only: share of episodes whose velocity command is drawn "
        "from citygen.runner.learn.loco.COMMANDS instead of the task's own (a general model that "
        "follows a navigation policy's commands).",
    )
    command_resample: Annotated[float, Field(ge=0, le=1000)] = Field(
        0.0,
        description="Locomotion, training only: mean interval (s) at which an episode on a drawn "
        "command (command_mix) draws a new one; 0: one command for the whole episode. A "
        "navigation policy changes its command every 0.1 s.",
    )
    level_on_commands: Literal["distance", "falls"] = Field(
        "distance",
        description="Locomotion, training only: how an episode on a drawn command moves its "
        "curriculum level: 'distance' as the task's own command does (up past 4 m, down short of "
        "half the distance asked or on a fall), 'falls' only down, on a fall (turning and slow "
        "commands never cover 4 m).",
    )
    effort_scale: Annotated[float, Field(ge=0, le=10)] = Field(
        1.0,
        description="Locomotion, training only: factor on the gait shaping's torque and joint "
        "acceleration penalties (legged_gym's weights suit a 12-15 kg quadruped; the 76 kg "
        "wheeled-legged robot's joints, at kp 1500, pay ~190x the quadruped's torque penalty "
        "for the same action noise).",
    )
    alive: Annotated[float, Field(ge=0, le=10)] = Field(
        0.0,
        description="Locomotion, training only: reward a step for not having fallen (part of the gait "
        "shaping): where a noisy first policy's penalties outweigh what standing earns, it keeps a "
        "fall the worse choice while leaving the shaping's slope between standing and walking.",
    )
    only_positive: bool = Field(
        False,
        description="Locomotion, training only: a step's reward before the fall penalty is clipped "
        "at zero (legged_gym's only_positive_rewards): where the penalties of a noisy policy cost "
        "more per step than the -100 of a fall (a heavy robot's torques), a policy would otherwise "
        "learn to fall at once. The fall's -100 stays.",
    )
    fall_penalty: Annotated[float, Field(ge=0, le=10)] = Field(
        1.0,
        description="Locomotion, training only: the multiple of the paper's -100 on a fall that the "
        "training reward pays (0: none, as legged_gym's rough-terrain policies train, a fall costing "
        "the rewards it ends; above 1: a fall costs more than the paper's). citygen bench measures "
        "the paper's reward and metrics either way.",
    )
    foot_clearance: Annotated[float, Field(ge=0, le=100)] = Field(
        0.0,
        description="Locomotion, training only: weight of the foot clearance term (swinging feet "
        "lower than clearance_height over the ground under them pay the square of the shortfall; "
        "citygen.runner.learn.loco), so that feet lift over a stair's edge.",
    )
    clearance_height: Annotated[float, Field(gt=0, le=0.5)] = Field(
        0.12,
        description="Locomotion, training only: the height (m) over the ground under it that the "
        "foot clearance term asks of a swinging foot's centre (0.12: a 0.10 m step and the "
        "quadruped's foot radius).",
    )
    leg_collision: Annotated[float, Field(ge=0, le=100)] = Field(
        0.0,
        description="Locomotion, training only: weight of a leg-collision term (minus the number "
        "of leg links, feet not counted, touching the ground: legged_gym's collision penalty on "
        "thighs and calves), so that legs are lifted over a riser instead of knocked against it.",
    )
    turn_progress: Annotated[float, Field(ge=0, le=10)] = Field(
        0.0,
        description="Locomotion, training only: weight of a turn-progress term (the share of a "
        "commanded yaw rate made good, w_z c_wz / c_wz^2 clipped to [-1, 1], where the command "
        "turns): linear from a standstill, as the forward-progress term is for speed, so that a "
        "policy learns to turn in place (the 0.25 rad/s tracking kernel pays a standing robot "
        "almost nothing for a 1 rad/s turn).",
    )
    base_height: Annotated[float, Field(ge=0, le=100)] = Field(
        0.0,
        description="Locomotion, training only: weight of a base-height term (a base lower than "
        "the robot's standing height over the ground under it pays the square of the shortfall "
        "as a share of that height; citygen.runner.learn.loco), so that a policy asked to back "
        "up and turn does not learn to sit down.",
    )
    orientation: Annotated[float, Field(ge=0, le=100)] = Field(
        0.0,
        description="Locomotion, training only: weight of legged_gym's orientation term, "
        "-|g_xy|^2 a step (gravity's share in the base's plane: the base's tilt from level), on top "
        "of the gait shaping's -0.5 |g_xy|^2, so that a robot crossing a slope levels its base "
        "with its legs instead of rolling over (part of the gait shaping: scaled by gait_shaping; "
        "citygen.runner.learn.loco).",
    )
    heading_progress: Annotated[float, Field(ge=0, le=10)] = Field(
        0.0,
        description="Locomotion, training only: weight of a heading-progress term (where the "
        "episode holds a heading, the share of the commanded speed made good along the commanded "
        "direction in the world, clipped to [-1, 1]): the forward-progress term is in the "
        "robot's frame and pays a robot driving in circles in full; this one averages zero "
        "around a circle.",
    )
    gait: Literal["walk", "trot"] | None = Field(
        None,
        description="Locomotion: the policy rides on a scripted gait, 'walk' for a biped (a residual "
        "over its joint action, plus one action setting its speed) or 'trot' for a four-legged robot "
        "(a residual over the terrain-aware trot's action, plus one action setting its swing "
        "height); it reads the gait's phase as gait_phase (citygen.runner.learn.residual). The "
        "exported policy records it; the environment and its metrics stay the paper's.",
    )
    gait_scale: Annotated[float, Field(gt=0, le=2)] = Field(
        0.2,
        description="With gait: the residual's weight on the joint action (a unit of action is "
        "the joint's action scale).",
    )
    gait_max_speed: Annotated[float, Field(ge=0.1, le=1.0)] = Field(
        1.0,
        description="With gait: the fastest (m/s) the policy may ask the walk for, a speed "
        "curriculum by stages (each stage --init the one before with a higher cap); with the "
        "trot, a cap on the forward command it follows.",
    )
    curriculum: bool = Field(
        True,
        description="Locomotion, training only: the terrain curriculum over the training grid's "
        "difficulty rows (Rudin et al. 2022; citygen.runner.learn.loco).",
    )
    random_rows: Annotated[float, Field(ge=0, le=1)] = Field(
        0.0,
        description="Locomotion, training only, with the curriculum: share of episodes started on "
        "a row drawn uniformly from the whole grid, leaving the sub-environment's level as it was "
        "(terrain past what a robot masters, where a fall's penalty teaches it to stop short of "
        "what it cannot cross instead of trying; Rudin et al. 2022 send robots past the last row "
        "to random rows).",
    )
    start_rows: Annotated[int, Field(ge=1, le=1000)] = Field(
        3,
        description="Locomotion, training only, with the curriculum: a sub-environment's first level "
        "is drawn from the grid's easiest this-many rows (legged_gym's max_init_terrain_level + 1); "
        "a stage continuing (--init) a run whose curriculum stood at row N spreads its levels up to "
        "it with N instead of climbing back from row 0 (about 1M steps on the stair grid).",
    )
    edge_stop: Annotated[float, Field(ge=0)] = Field(
        0.0,
        description="Locomotion, training only (privileged: the ground raster): where a riser "
        "up higher than edge_height lies within 0.7 m ahead along the command, the gait shaping pays "
        "for standing instead of the command and takes this times the speed made toward it off "
        "(citygen.runner.learn.loco).",
    )
    edge_height: Annotated[float, Field(gt=0)] = Field(
        0.16, description="Locomotion: the highest riser up (m) the edge stop lets a robot climb."
    )
    edge_drop: Annotated[float, Field(ge=0)] = Field(
        0.0,
        description="Locomotion: with edge_stop, a riser down deeper than this (m) stops the "
        "robot too (0: risers down never do).",
    )
    descent_speed: Annotated[float, Field(ge=0)] = Field(
        0.0,
        description="Locomotion, training only (privileged: the ground raster): where a riser down "
        "deeper than descent_drop lies within 0.7 m ahead along the command, the gait shaping's "
        "tracking and progress terms are paid against the command cut to this speed (m/s; 0: off): "
        "walk down stairs slowly (citygen.runner.learn.loco).",
    )
    descent_drop: Annotated[float, Field(gt=0)] = Field(
        0.05, description="Locomotion: with descent_speed, the shallowest riser down (m) that slows it."
    )
    normalize: bool = Field(True, description="Running mean/std of observations (exported) and rewards.")
    norm_epsilon: Annotated[float, Field(gt=0)] = Field(
        1e-2,
        description="Added to the running variance before dividing: a floor under the scale of "
        "near-constant inputs (a height map on flat ground varies by millimetres; SB3's 1e-8 "
        "would blow its jitter up to the clip).",
    )
    init: str | None = Field(
        None,
        description="A run folder or model.zip whose weights and observation statistics start "
        "this run (same observation keys and action space): fine-tune another robot's or task's policy; "
        "or an exported policy.npz (a shipped baseline): its actor and statistics, a fresh critic.",
    )
    critic_warmup: Annotated[int, Field(ge=0)] = Field(
        0,
        description="Steps at the start of the run (counted from step 0) in which only the critic "
        "learns: the actor, its log_std and the map encoder they share stay as they are. With "
        "--init FILE.npz (which holds no critic) the fresh value head first learns the actor's "
        "returns, so its first advantages do not undo the actor.",
    )
    # Imitation before PPO (citygen.runner.learn.imitate)
    expert: Literal["planner", "terrain"] | None = Field(
        None,
        description="First imitate this expert by DAgger (its rounds below), then train on with PPO "
        "from there. planner (navigation): A* on the scene's maps and pure pursuit; terrain "
        "(locomotion): the robot's shipped terrain models dispatched by the ground ahead, as the "
        "traverse's Human-AI-Mode-1 walks (the general model on flat ground).",
    )
    dagger_iterations: Annotated[int, Field(ge=1, le=1000)] = Field(
        4, description="DAgger rounds: drive episodes with the policy, label them, refit on all."
    )
    dagger_episodes: Annotated[int, Field(ge=1, le=100_000)] = Field(
        100, description="Training episodes each DAgger round drives."
    )
    dagger_epochs: Annotated[int, Field(ge=1, le=1000)] = Field(
        10, description="Passes over the aggregated data set after each DAgger round."
    )
    dagger_lr: Annotated[float, Field(gt=0, le=1)] = Field(1e-4, description="Adam's rate in DAgger's fits.")
    dagger_beta: Annotated[float, Field(ge=0, le=1)] = Field(
        0.5, description="In DAgger's first round, the share of steps the expert drives."
    )
    bc_coef: Annotated[float, Field(ge=0, le=100)] = Field(
        0.0,
        description="Weight of the behaviour-cloning loss on DAgger's data set added to every "
        "PPO update (0: none), so PPO keeps what the expert showed.",
    )
    # CPU and bookkeeping
    torch_threads: Annotated[int, Field(ge=0, le=256)] = Field(
        1,
        description="PyTorch threads while the sub-environments step (0: PyTorch's default); they "
        "use the other cores.",
    )
    update_threads: Annotated[int, Field(ge=0, le=256)] = Field(
        0,
        description="PyTorch threads in PPO's update, while the sub-environments wait (0: every core "
        "this process may use).",
    )
    checkpoint_every: Annotated[int, Field(ge=1)] = Field(50_000, description="Steps between checkpoints.")
    keep_checkpoints: Annotated[int, Field(ge=1)] = 3

    @field_validator("net_arch")
    @classmethod
    def _net_arch_fits_in_memory(cls, net_arch: tuple[int, ...]) -> tuple[int, ...]:
        weights = sum(a * b for a, b in itertools.pairwise(net_arch))
        if weights > MAX_HIDDEN_WEIGHTS:
            raise ValueError(
                f"hidden layers of at most {MAX_HIDDEN_WEIGHTS:,} weights in all (these have {weights:,})"
            )
        return net_arch

    @field_validator("n_steps")
    @classmethod
    def _rollout_fits_in_memory(cls, n_steps: int, info: ValidationInfo) -> int:
        envs = info.data.get("envs", 1)
        if envs * n_steps > MAX_ROLLOUT:
            raise ValueError(
                f"a rollout of at most {MAX_ROLLOUT:,} samples (envs x n_steps; {envs} x this is "
                f"{envs * n_steps:,})"
            )
        return n_steps

    @field_validator("gait")
    @classmethod
    def _gait_for_locomotion(cls, gait: str | None, info: ValidationInfo) -> str | None:
        if gait is not None and not str(info.data.get("task", "")).startswith("loco"):
            raise ValueError(f"a locomotion task (loco-*) for gait {gait!r}")
        return gait

    @field_validator("expert")
    @classmethod
    def _expert_for_its_task(cls, expert: str | None, info: ValidationInfo) -> str | None:
        kind = {"planner": "nav", "terrain": "loco"}.get(expert or "")
        if kind and not str(info.data.get("task", "")).startswith(kind):
            what = "a navigation task (nav-*)" if kind == "nav" else "a locomotion task (loco-*)"
            raise ValueError(f"{what} for expert {expert!r}")
        if expert == "terrain" and info.data.get("gait"):
            raise ValueError("no gait for expert 'terrain' (its models act on joint targets, not on a gait)")
        return expert

    @field_validator("bc_coef")
    @classmethod
    def _cloning_needs_an_expert(cls, coef: float, info: ValidationInfo) -> float:
        if coef > 0 and info.data.get("expert") is None:
            raise ValueError("0 without an expert (bc_coef clones the expert's actions)")
        return coef

    @field_validator("stack")
    @classmethod
    def _stack_reads_observed_keys(cls, stack: tuple[tuple[str, ...], ...], info: ValidationInfo):
        observed = _observed(info.data.get("task", ""), info.data.get("keys"))
        seen: set[str] = set()
        for group in stack:
            if len(group) < 2 or not set(group) <= set(observed) or seen & set(group):
                raise ValueError(
                    f"groups of two or more of the observation keys {list(observed)}, each key in one group"
                )
            seen.update(group)
        return stack

    @property
    def train_split(self) -> str:
        return self.split or TRAIN_SPLIT[self.task]

    @property
    def robot_name(self) -> str:
        return self.robot or ("quadruped" if self.task.startswith("loco") else "wheeled")

    @property
    def obs_keys(self) -> tuple[str, ...]:
        keys = _observed(self.task, self.keys)
        return (*keys, PHASE_KEY) if self.gait and PHASE_KEY not in keys else keys

    @property
    def batch_size(self) -> int:
        """SGD minibatch size (samples)."""
        return max(1, self.envs * self.n_steps // self.minibatches)


def _observed(task: str, keys: tuple[str, ...] | None) -> tuple[str, ...]:
    """The observation keys a run reads: ``keys``, or the task kind's default."""
    if keys:
        return tuple(keys)
    return LOCO_KEYS if task.startswith("loco") else NAV_KEYS


def load_config(path: str | Path | None, **overrides) -> TrainConfig:
    """The config of a file (TOML or JSON; none: the defaults) with ``overrides`` (the
    command line's options that were given) on top; a :class:`~citygen.errors.SpecError`
    naming the file and field when a value is wrong."""
    import difflib

    from citygen.errors import Problem, SpecError
    from citygen.io import parse, read_document

    file = str(path) if path is not None else "command line"
    document = read_document(path) if path is not None else {}
    if not isinstance(document, dict):
        raise SpecError([Problem("$", "a table of TrainConfig fields", type(document).__name__)], file=file)
    fields = list(TrainConfig.model_fields)
    unknown = [
        Problem(
            f"$.{k}",
            f"one of {', '.join(fields)}"
            if not (m := difflib.get_close_matches(k, fields, 1))
            else f"{m[0]!r} (misspelt?)",
            f"unknown field {k!r}",
        )
        for k in document
        if k not in fields
    ]
    if unknown:
        raise SpecError(unknown, file=file)
    document = {**document, **{k: v for k, v in overrides.items() if v is not None}}
    return parse(TrainConfig, document, file=file)
