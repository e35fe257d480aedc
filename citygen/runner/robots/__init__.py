"""The runner's robots: embodiments built in code as MJCF, a user's own MJCF or URDF robot
through a small adapter, and a handle that drives a robot inside a compiled scene.

Built-in robots (:data:`BUILTIN`, mesh-free, every geom a primitive), one module each in this
package, registered by :func:`~citygen.runner.robots.registry.register` (a new robot is one new
file here: every test and command that runs over robots picks it up):

- ``wheeled``: a delivery robot, 0.7 m x 0.55 m, 0.5 m tall, about 45 kg; two driven
  wheels (hinge joints with velocity actuators) at mid-length and a frictionless caster
  sphere in front and behind: exact differential drive.
- ``quadruped``: Go2-like, trunk 0.38 x 0.09 x 0.11 m, about 15 kg, 12 hinge joints (hip
  abduction, hip flexion, knee per leg, legs in the order FR, FL, RR, RL) with position
  actuators (kp 60 N m/rad, kd 2 N m s/rad, Go2's torque limits), standing base height 0.30 m.
- ``wheeled_legged``: B2-W-like, about 76 kg, the same 12 leg joints (kp 1500, kd 30) plus a
  driven wheel at each foot (4 velocity actuators), standing base height about 0.58 m.
- ``humanoid``: G1-like, 1.32 m tall, about 35 kg, 21 hinge joints (6 per leg, waist yaw,
  4 per arm) with position actuators and box feet, base (pelvis) height 0.66 m; ideal
  locomotion in navigation, a scripted walk (:mod:`citygen.runner.control.gaits_biped`) in locomotion.
- ``wheelchair``: an electric wheelchair, 0.65 m wide, 1.1 m long, about 110 kg including
  a 70 kg seated person; differential drive on the rear wheels, frictionless front casters.
- ``scooter``: a mobility scooter, 1.27 m x 0.63 m, about 140 kg with a 75 kg rider, 15 km/h;
  Ackermann steering (``nav_mode == "ackermann"``): steered front wheels, driven rear wheels.

Units: metres, kilograms, seconds, radians. Frames: a robot's base frame has +x forward,
+z up; a pose is ``(x, y, ground_z, yaw)`` with ``ground_z`` the ground's height under the
robot and the base origin :attr:`Robot.stand_height` above it.

**Navigation** (:meth:`RobotHandle.drive`): wheeled robots (``nav_mode == "wheels"``:
``wheeled``, ``wheelchair``, ``wheeled_legged``) really drive on their wheels: each
wheel's velocity actuator gets the differential-drive wheel speed of the command,
corrected by a proportional feedback on the measured base speed and yaw rate (it makes up
for skid steering and slip; the four-wheel ``wheeled_legged`` turns by skidding). The legs
of ``wheeled_legged`` hold its drive pose by their PD (:attr:`Robot.drive_pose`: feet under
the hips, a 0.66 m wheelbase; on the walking stance's 0.46 m it rode a wheelie from 1.5
m/s). The ``scooter`` steers its front wheels to the Ackermann angles of the command and
drives its rear wheels with the same feedback; a turn tighter than its steering allows at
low speed becomes a K-turn. The ``quadruped`` and the ``humanoid`` have no learned
locomotion policy under the navigation policy, so they use **ideal locomotion**
(``nav_mode == "base"``): the legs hold the stand pose by PD while a servo of forces and
torques on the base (``data.xfrc_applied``) carries the body's weight
:data:`HOVER_CLEARANCE` above the stand height over the ground under the base (in the
environments, the scene's 5 cm terrain raster, :attr:`RobotHandle.terrain`; otherwise a ray
down through the scene), keeps the trunk level, and tracks the planar velocity ``(v, w)``. Feet then do not
touch flat ground; legs and trunk still collide with obstacles, curbs and agents. Its yaw
torque is of the order of its push at the feet's lever, as a walking robot's is, so a robot
pushing its nose into a bench still turns away from it. The
open-loop trot of :mod:`citygen.runner.control.gaits` is the locomotion baseline, not the
navigation drive (it is not precise enough to track a planner's commands).

**Control timing**: each robot's :attr:`Robot.timestep` physics step (5 ms for the built-in
robots; :data:`TIMESTEP`, 2 ms, for a user's robot), implicit-fast
integrator. Most of a wheeled robot's step is its wheels' contacts: a cylinder on the
ground's boxes is a general convex collision making two. The wheeled robot's tyres are
ellipsoids of the wheel's radius and width (one contact each) and its model uses MuJoCo's
pyramidal friction cone (:attr:`Robot.cone`; the legged robots keep the elliptic one):
together a third off its physics and 42 % more steps per second in one NavStatic
environment (1,419 -> 2,014 steps/s measured back to back, 2026-11-30), planner NavStatic success 96.09 %
on 256 urban-nav-2-test episodes before and after (3 episodes lost, 3 gained). Measured
before (2026-11-28): the ellipsoid alone 93.75 %, a sphere 9 points lost (its bulge hits
what the wheel passes).
:meth:`RobotHandle.drive` reads the base's state and is a feedback loop: the environments
run a wheel drive and the ideal-locomotion servo at :data:`DRIVE_DT` (100 Hz, every
:attr:`RobotHandle.drive_substeps` physics steps, its outputs held in between, as a real
wheel controller does; the servo's velocity feedback is the free joint's damping, which
MuJoCo applies at every physics step); called with no ``dt`` it assumes one call per
physics step. :meth:`RobotHandle.control` runs a whole control step (the drive and
MuJoCo's steps) in one call, as the environments do. A composed robot's geoms are in geom
group :data:`~citygen.runner.robots.handle.ROBOT_GROUP` (the scene's are 0-2), so the
servo's ground rays ignore the robot in one ``mj_ray`` each; renderings turn that group on.
:meth:`RobotHandle.joint_action` only writes
position targets and may run at the control rate (50 Hz = every 10 steps is the usual
choice).

>>> robot = load_robot("wheeled")
>>> robot.nav_mode, robot.radius
('wheels', 0.35)
"""

from citygen.runner.robots.base import (
    HOVER_CLEARANCE,
    IMPRATIO,
    PREFIX,
    TIMESTEP,
    Leg,
    Robot,
    lowest_point,
)
from citygen.runner.robots.handle import DRIVE_DT, RobotHandle, compose, flat_ground, yaw_of
from citygen.runner.robots.registry import BUILTIN, load_robot, register

__all__ = [
    "BUILTIN",
    "DRIVE_DT",
    "HOVER_CLEARANCE",
    "IMPRATIO",
    "PREFIX",
    "TIMESTEP",
    "Leg",
    "Robot",
    "RobotHandle",
    "compose",
    "flat_ground",
    "load_robot",
    "lowest_point",
    "register",
    "yaw_of",
]
