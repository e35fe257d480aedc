"""citygen.runner.envs.reach: stepping with only the static geoms near the robot collidable
changes nothing MuJoCo computes. Two environments share one compiled scene in this process,
one with collisions restricted to the robot's reach (made aggressive here: 0.4 m of slack,
re-centred every 0.2 m, on a small scene it would leave alone) and one without; driven by the
same actions into the scene's objects, their states agree to the bit at every step, and the
model is whole between steps."""

from __future__ import annotations

import numpy as np
import pytest

from citygen.runner.envs import reach as R
from citygen.runner.make import make_env

STEPS = 150


@pytest.mark.parametrize("robot", ["wheeled", "quadruped"])
def test_reach_changes_no_state(monkeypatch: pytest.MonkeyPatch, robot: str) -> None:
    whole = make_env("nav-static", split="urban-nav-2-test", robot=robot)
    whole.reset(seed=0, options={"index": 5})
    assert whole.unwrapped._reach is None  # an Urban-Nav square: left alone
    monkeypatch.setattr(R, "FROM_GEOMS", 1)
    monkeypatch.setattr(R, "SLACK", 0.4)
    near = make_env("nav-static", split="urban-nav-2-test", robot=robot)
    near.reset(seed=0, options={"index": 5})
    a, b = whole.unwrapped, near.unwrapped
    reach = b._reach
    assert reach is not None and a.model is b.model  # one compiled scene, shared
    contype, conaffinity = np.array(a.model.geom_contype), np.array(a.model.geom_conaffinity)
    body_contype = np.array(a.model.body_contype)
    rng = np.random.default_rng(1)
    contacts, kept, bodies, recentred = 0, [], [], set()
    for _ in range(STEPS):
        action = np.clip(rng.normal(0.6, 0.6, 2), -1, 1).astype(np.float32)
        out_a, out_b = whole.step(action), near.step(action)
        kept.append(reach.kept)
        bodies.append(reach.kept_bodies)
        recentred.add(reach.centre)
        for name in ("qpos", "qvel", "qacc", "xfrc_applied", "sensordata"):
            assert np.array_equal(getattr(a.data, name), getattr(b.data, name)), name
        assert a.data.ncon == b.data.ncon
        n = a.data.ncon
        assert np.array_equal(a.data.contact.geom[:n], b.data.contact.geom[:n])
        assert np.array_equal(a.data.contact.dist[:n], b.data.contact.dist[:n])
        assert out_a[1] == out_b[1] and out_a[2:4] == out_b[2:4]
        contacts += n
        assert np.array_equal(b.model.geom_contype, contype)  # whole again between steps
        assert np.array_equal(b.model.geom_conaffinity, conaffinity)
        if out_a[2] or out_a[3]:
            for env in (whole, near):
                env.reset(seed=0, options={"index": 5})
    static = R.static_geoms(b.model)
    assert min(kept) < static.sum()  # some static geoms were left out of collision detection,
    assert min(bodies) < len(reach.bodies)  # and some objects' bodies
    with reach.near(b.data):  # out of it for the physics call, static geoms only
        out = (b.model.geom_contype == 0) & (b.model.geom_conaffinity == 0)
        assert out.sum() == static.sum() - reach.kept and not (out & ~static).any()
        body_out = (b.model.body_contype == 0) & (b.model.body_conaffinity == 0)
        assert body_out.sum() == len(reach.bodies) - reach.kept_bodies and not body_out[0]
    assert np.array_equal(b.model.body_contype, body_contype)
    assert len(recentred) > 3
    assert contacts > 0  # with the ground (wheels) or the scene's objects (the quadruped's body)
    whole.close()
    near.close()
