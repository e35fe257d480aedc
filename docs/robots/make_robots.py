"""Render docs/robots/NAME.png: every built-in robot standing on flat ground, as the runner
composes it, with MuJoCo's offscreen renderer.

Run from the repository: ``MUJOCO_GL=egl python docs/robots/make_robots.py [NAME ...]``
(EGL needs ``libegl1 libgl1-mesa-dri``; ``osmesa`` works too). The camera looks at the
robot's front left side from a distance scaled to its size; a 1 m grid on the floor.
"""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image

from citygen.runner.robots import BUILTIN, RobotHandle, compose, flat_ground, load_robot
from citygen.runner.robots.handle import render_option

OUT = Path(__file__).resolve().parent
SIZE = (480, 400)  # width, height in pixels


def _checker(xml: str) -> str:
    """The flat scene with a 1 m checker texture on the ground and a second light."""
    asset = (
        "<asset><texture name='grid' type='2d' builtin='checker' width='256' height='256' "
        "rgb1='0.82 0.82 0.8' rgb2='0.72 0.72 0.7'/><material name='grid' texture='grid' "
        "texrepeat='20 20'/><texture type='skybox' builtin='gradient' rgb1='0.85 0.9 0.95' "
        "rgb2='0.55 0.65 0.8' width='64' height='64'/></asset>\n  <worldbody>"
    )
    xml = xml.replace("<worldbody>", asset, 1).replace('rgba="0.8 0.8 0.78 1"', 'material="grid"')
    return xml.replace(
        "</worldbody>", '<light pos="-2 -3 4" dir="0.4 0.6 -0.8" diffuse="0.5 0.5 0.5"/></worldbody>'
    )


def render(name: str) -> Path:
    robot = load_robot(name)
    ground = flat_ground()
    ground = type(ground)(_checker(ground.xml), ground.assets)
    model = compose(ground, robot, (0.0, 0.0, 0.0, 0.0))
    model.vis.global_.offwidth, model.vis.global_.offheight = SIZE
    data = mujoco.MjData(model)
    handle = RobotHandle(model, robot)
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    lo = np.min(data.geom_xpos[handle.geom_ids] - model.geom_rbound[handle.geom_ids, None], axis=0)
    hi = np.max(data.geom_xpos[handle.geom_ids] + model.geom_rbound[handle.geom_ids, None], axis=0)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = (lo + hi) / 2
    camera.distance = 1.6 * float(np.max(hi - lo)) + 0.3
    camera.azimuth, camera.elevation = 150.0, -18.0
    with mujoco.Renderer(model, SIZE[1], SIZE[0]) as renderer:
        renderer.update_scene(data, camera, scene_option=render_option())  # the robot's geom group too
        pixels = renderer.render()
    path = OUT / f"{name}.png"
    Image.fromarray(pixels).save(path, optimize=True)
    return path


if __name__ == "__main__":
    for name in sys.argv[1:] or BUILTIN:
        print(render(name))
