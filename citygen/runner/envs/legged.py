"""What a legged robot's locomotion model sees and when it has fallen, shared by
:class:`~citygen.runner.envs.loco.LocoEnv` and navigation on learned legs
(:mod:`citygen.runner.envs.legs`), so that a locomotion policy reads the same numbers in
both: the observation's spaces (:func:`leg_spaces`) and values (:func:`leg_observation`),
the robot parts whose pressing on the ground is a fall (:func:`fall_geoms`) and that
pressure (:func:`body_ground_force`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces


def leg_spaces(n_joints: int, n_actions: int, height_map: spaces.Box) -> dict[str, spaces.Box]:
    """The locomotion observation's keys and spaces, in the order a policy reads them: the
    base's velocities and tilt, the command, the leg joints' positions, the joints' (and
    driven wheels') velocities, the last action and the height map."""
    return {
        "base_lin_vel": spaces.Box(-np.inf, np.inf, (3,), np.float32),
        "base_ang_vel": spaces.Box(-np.inf, np.inf, (3,), np.float32),
        "projected_gravity": spaces.Box(-1.0, 1.0, (3,), np.float32),
        "command": spaces.Box(-np.inf, np.inf, (3,), np.float32),
        "joint_pos": spaces.Box(-np.inf, np.inf, (n_joints,), np.float32),
        "joint_vel": spaces.Box(-np.inf, np.inf, (n_actions,), np.float32),
        "last_action": spaces.Box(-1.0, 1.0, (n_actions,), np.float32),
        "height_map": height_map,
    }


def joint_vel_dofs(handle: Any) -> np.ndarray:
    """The dofs of the ``joint_vel`` observation: the leg joints', then the driven wheels'."""
    return np.concatenate([handle.leg_dadr, handle.loco_wheel_dadr]).astype(np.intp)


def fall_geoms(model: Any, handle: Any, robot_geoms: np.ndarray) -> np.ndarray:
    """Mask over ``model``'s geoms of the robot geoms (of ``robot_geoms``, a mask) whose
    pressing on the ground is a fall: the body, not the legs. A leg is every link from a
    foot (or wheel) up to the base, so a knee brushing a knee-high bump is not a fall, the
    trunk, head, torso or an arm touching down is (the base-contact termination of Isaac
    Lab's locomotion tasks, on which URBAN-SIM's are built)."""
    return robot_geoms & ~np.isin(model.geom_bodyid, sorted(leg_bodies(model, handle)))


def leg_bodies(model: Any, handle: Any) -> set[int]:
    """The bodies of the robot's legs: every body from a foot (or wheel) up to the base."""
    legs: set[int] = set()
    for body in model.geom_bodyid[handle.foot_geom_ids].tolist():
        while body != handle.base_id and body > 0 and body not in legs:
            legs.add(body)
            body = int(model.body_parentid[body])
    return legs


def body_ground_force(
    model: Any, data: Any, fall_ids: frozenset[int], ground_ids: frozenset[int], force: np.ndarray
) -> float:
    """Largest normal force (N) of a contact between a ground geom (``ground_ids``) and a
    robot geom that must not touch it (``fall_ids``, of :func:`fall_geoms`), by MuJoCo's
    ``mj_contactForce`` on those contacts only (``force``: its 6-vector output). A step has
    a handful of contacts: looking them up one by one in sets beats numpy's overhead."""
    import mujoco

    if data.ncon == 0:
        return 0.0
    worst = 0.0
    for i, (g1, g2) in enumerate(data.contact.geom.tolist()):
        if (g1 in fall_ids and g2 in ground_ids) or (g2 in fall_ids and g1 in ground_ids):
            mujoco.mj_contactForce(model, data, i, force)
            worst = max(worst, abs(float(force[0])))
    return worst


def leg_observation(
    env: Any,
    keys: tuple[str, ...],
    command: np.ndarray,
    last_action: np.ndarray,
    vel_dofs: np.ndarray,
    pose: tuple[float, float, float, float],
    vel: tuple | None = None,
) -> dict[str, np.ndarray]:
    """The locomotion observation's values for those of ``keys`` it has (:func:`leg_spaces`;
    the rest, such as images, are the caller's) of ``env``'s robot (an environment of
    :mod:`citygen.runner.envs.base`: its data, robot handle and terrain) at its base's
    ``pose`` (``RobotHandle.pose``) and, when the step has it already, ``vel``
    (``RobotHandle._velocity``), with the velocity ``command`` ``(vx, vy, wz)``, the
    ``last_action`` and the ``joint_vel`` dofs ``vel_dofs`` (:func:`joint_vel_dofs`)."""
    d, h = env.data, env.handle
    x, y, _, yaw = pose
    obs: dict[str, np.ndarray] = {}
    if "base_lin_vel" in keys:
        obs["base_lin_vel"] = np.array((h._velocity(d) if vel is None else vel)[:3], dtype=np.float32)
    if "base_ang_vel" in keys:
        obs["base_ang_vel"] = d.qvel[h.dadr + 3 : h.dadr + 6].astype(np.float32)
    if "projected_gravity" in keys:
        # gravity (0, 0, -1) in the base's frame: minus the third row of its rotation
        obs["projected_gravity"] = np.negative(d.xmat[h.base_id][6:9].astype(np.float32))
    if "command" in keys:
        obs["command"] = command.astype(np.float32)
    if "joint_pos" in keys:
        obs["joint_pos"] = (d.qpos[h.leg_qadr] - h.default).astype(np.float32)
    if "joint_vel" in keys:
        obs["joint_vel"] = d.qvel[vel_dofs].astype(np.float32)
    if "last_action" in keys:
        obs["last_action"] = last_action.astype(np.float32)
    if "height_map" in keys:
        obs["height_map"] = env._height_map(x, y, env._terrain_around(x, y, yaw)[0], yaw)
    return obs
