"""People by ORCA and vehicles by IDM (citygen.runner.crowd).

Every step of every run below is checked: no two people's discs overlap by more than
``TOL`` (2 cm), no person overlaps the robot's disc by more than ``TOL``, every person's
centre lies on a walkable cell of the occupancy map, and no object or building cell's
centre lies within ``radius - TOL`` of a person's centre (the map's own convention: a cell
is what covers its centre).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

import citygen
from citygen.exporters.occupancy import occupancy
from citygen.runner.agents import orca
from citygen.runner.agents.crowd import Crowd
from citygen.runner.agents.footprints import Footprints
from citygen.runner.agents.footprints import depth as footprint_depth
from citygen.runner.agents.orca import orca_velocities
from citygen.runner.agents.traffic import Traffic
from citygen.spec.agents import Person, Vehicle
from citygen.spec.scene import Scene
from citygen.spec.task import ROBOT_RADIUS

TOL = 0.02
"""Overlap (m) tolerated between discs, and of a disc over an obstacle cell's centre."""
DT = 0.1
ROBOT_R = ROBOT_RADIUS["wheeled"]


# --- ORCA on textbook cases ------------------------------------------------------------------


def _simulate(pos, goals, radius, speed, steps, jitter=0.0, **kw):
    """Integrate ORCA towards ``goals`` (preferred velocities nudged by ``jitter`` m/s of noise, as
    RVO2's examples do against symmetric deadlocks); returns positions and the smallest gap (m)."""
    rng = np.random.default_rng(0)
    pos = np.array(pos, dtype=float)
    vel = np.zeros_like(pos)
    worst = np.inf
    for _ in range(steps):
        d = goals - pos
        dist = np.linalg.norm(d, axis=1, keepdims=True)
        pref = np.where(dist > 1e-9, d / np.maximum(dist, 1e-9), 0.0) * np.minimum(speed, dist / DT)
        pref = pref + rng.normal(0.0, jitter, pref.shape) * (dist > 0.05)
        vel = orca_velocities(pos, vel, pref, radius, speed, dt=DT, **kw)
        pos = pos + vel * DT
        gap = np.linalg.norm(pos[:, None] - pos[None], axis=-1) - 2 * radius
        np.fill_diagonal(gap, np.inf)
        worst = min(worst, float(gap.min()))
    return pos, worst


def test_two_agents_head_on_swap_without_collision():
    # 1 cm off the line: a perfectly symmetric pair stands still (RVO2's examples nudge too).
    start = np.array([[-3.0, 0.01], [3.0, 0.0]])
    pos, worst = _simulate(start, start[::-1], 0.3, 1.0, 150)
    assert worst > -1e-6
    assert np.allclose(pos, start[::-1], atol=0.05)


def test_circle_of_twenty_swaps_to_antipodes():
    ang = np.arange(20) * (2 * np.pi / 20)
    start = 8.0 * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    # RVO2 itself (pyrvo, same settings) jams in a ring with tau = 2 s or 10 s and swaps with 5 s.
    pos, worst = _simulate(start, -start, 0.3, 1.0, 400, jitter=0.01, tau=5.0, neighbor_dist=6.0)
    assert worst > -0.01  # ORCA in discrete steps: at most a hair of overlap
    assert np.max(np.linalg.norm(pos + start, axis=1)) < 0.1


def test_non_cooperative_agent_is_avoided_entirely():
    # A robot driving straight at a person: the person takes the whole avoidance.
    pos = np.array([[0.0, 0.0], [2.0, 0.05]])
    vel = np.array([[0.0, 0.0], [-1.0, 0.0]])
    coop = np.array([True, False])
    v = orca_velocities(pos, vel, np.zeros((2, 2)), 0.3, [1.5, 1.0], dt=DT, cooperative=coop)
    assert np.array_equal(v[1], vel[1])  # the robot keeps its velocity
    shared = orca_velocities(pos, vel, np.zeros((2, 2)), 0.3, [1.5, 1.0], dt=DT)
    assert np.linalg.norm(v[0]) > np.linalg.norm(shared[0]) + 1e-3  # more than its half share


def test_batched_call_equals_calls_per_environment():
    rng = np.random.default_rng(3)
    e, n = 4, 12
    pos = rng.uniform(0, 5, (e, n, 2))
    vel, pref = rng.normal(0, 1, (e, n, 2)), rng.normal(0, 1, (e, n, 2))
    radius, vmax = rng.uniform(0.2, 0.4, (e, n)), rng.uniform(1, 2, (e, n))
    coop = rng.random((e, n)) > 0.1
    sp = rng.uniform(0, 5, (e, n, 3, 2))
    sr = rng.uniform(-0.1, 0.2, (e, n, 3))
    batched = orca_velocities(pos, vel, pref, radius, vmax, dt=DT, cooperative=coop, static=(sp, sr))
    for k in range(e):
        one = orca_velocities(
            pos[k], vel[k], pref[k], radius[k], vmax[k], dt=DT, cooperative=coop[k], static=(sp[k], sr[k])
        )
        assert np.array_equal(batched[k], one)


def test_agrees_with_rvo2_through_pyrvo():
    pyrvo = pytest.importorskip(
        "pyrvo", reason="the reference RVO2 comes with the bench extra (pip install .[bench])"
    )
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(40):
        n = int(rng.integers(2, 25))
        pos, vel = rng.uniform(0, 6, (n, 2)), rng.normal(0, 1, (n, 2))
        pref, radius, vmax = rng.normal(0, 1.2, (n, 2)), rng.uniform(0.2, 0.4, n), rng.uniform(1, 2, n)
        sim = pyrvo.RVOSimulator(DT, 4.0, 8, 2.0, 1.0, 0.3, 2.0)
        for i in range(n):
            sim.add_agent(tuple(pos[i]), 4.0, 8, 2.0, 1.0, float(radius[i]), float(vmax[i]), tuple(vel[i]))
            sim.set_agent_pref_velocity(i, tuple(pref[i]))
        sim.do_step()
        ref = np.array([sim.get_agent_velocity(i).to_tuple() for i in range(n)])
        ours = orca_velocities(
            pos, vel, pref, radius, vmax, dt=DT, tau=2.0, neighbor_dist=4.0, max_neighbors=8
        )
        worst = max(worst, float(np.abs(ours - ref).max()))
    # RVO2 computes in float32, citygen in float64: they differ in the last digits, a little more
    # where the constraints leave no feasible velocity (linearProgram3).
    assert worst < 0.05


@pytest.mark.parametrize("max_neighbors", [10, 1])
def test_agrees_with_rvo2_in_a_dense_crowd(max_neighbors, monkeypatch):
    # 100 agents on 6 m x 6 m: neighbours from the KD-tree, and for most agents the half-planes
    # leave no feasible velocity (RVO2's linearProgram3), also with a single neighbour each.
    pyrvo = pytest.importorskip(
        "pyrvo", reason="the reference RVO2 comes with the bench extra (pip install .[bench])"
    )
    infeasible = []
    least_violation = orca._least_violation

    def counted(lines, *args):
        infeasible.append(lines.shape[-1])
        return least_violation(lines, *args)

    monkeypatch.setattr(orca, "_least_violation", counted)
    rng = np.random.default_rng(1)
    n, worst = 100, 0.0
    for _ in range(5):
        pos, vel = rng.uniform(0, 6, (n, 2)), rng.normal(0, 1, (n, 2))
        pref, radius, vmax = rng.normal(0, 1.2, (n, 2)), rng.uniform(0.2, 0.4, n), rng.uniform(1, 2, n)
        sim = pyrvo.RVOSimulator(DT, 4.0, max_neighbors, 2.0, 1.0, 0.3, 2.0)
        for i in range(n):
            sim.add_agent(
                tuple(pos[i]), 4.0, max_neighbors, 2.0, 1.0, float(radius[i]), float(vmax[i]), tuple(vel[i])
            )
            sim.set_agent_pref_velocity(i, tuple(pref[i]))
        sim.do_step()
        ref = np.array([sim.get_agent_velocity(i).to_tuple() for i in range(n)])
        for reference in (False, True):  # the numba kernel and the plain-numpy reference
            ours = orca_velocities(
                pos, vel, pref, radius, vmax, dt=DT, tau=2.0, neighbor_dist=4.0, max_neighbors=max_neighbors,
                reference=reference,
            )  # fmt: skip
            worst = max(worst, float(np.abs(ours - ref).max()))
    assert sum(infeasible) > 100  # the infeasible case ran for many agents
    assert worst < 0.05  # as in test_agrees_with_rvo2_through_pyrvo


def test_bad_arguments_are_one_clear_error():
    with pytest.raises(ValueError, match="pos: expected an array of shape"):
        orca_velocities(np.zeros(3), np.zeros(3), np.zeros(3), 0.3, 1.0, dt=DT)
    with pytest.raises(ValueError, match="dt > 0"):
        orca_velocities(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2)), 0.3, 1.0, dt=0.0)
    with pytest.raises(ValueError, match="radius: expected a scalar or an array of shape"):
        orca_velocities(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2)), [0.3, 0.3, 0.3], 1.0, dt=DT)


# --- people in scenes, checked every step -----------------------------------------------------


class Checker:
    """The invariants of the module docstring, asserted on a crowd at each call."""

    def __init__(self, crowd: Crowd, occ) -> None:
        self.crowd, self.walk = crowd, occ.walkable_mask()
        rows, cols = np.nonzero(occ.obstacle_mask())
        g = occ.grid
        xy = np.stack([g.x0 + (cols + 0.5) * g.resolution, g.y0 + (rows + 0.5) * g.resolution], axis=-1)
        self.obstacles = cKDTree(xy) if len(xy) else None
        self.steps = 0

    def __call__(self, robot_xy, robot_r: float) -> None:
        c, self.steps = self.crowd, self.steps + 1
        if not c.ids:
            return
        gap = np.linalg.norm(c.pos[:, None] - c.pos[None], axis=-1) - (c.radius[:, None] + c.radius[None])
        np.fill_diagonal(gap, np.inf)
        assert gap.min() >= -TOL, f"step {self.steps}: people overlap by {-gap.min():.3f} m"
        depth = c.radius + robot_r - np.linalg.norm(c.pos - robot_xy, axis=1)
        assert depth.max() <= TOL, f"step {self.steps}: a person overlaps the robot by {depth.max():.3f} m"
        row, col = c._cells(c.pos)
        assert self.walk[row, col].all(), (
            f"step {self.steps}: {np.flatnonzero(~self.walk[row, col])} off walkable"
        )
        if self.obstacles is not None:
            d, _ = self.obstacles.query(c.pos)
            assert np.all(d >= c.radius - TOL), (
                f"step {self.steps}: a disc over an obstacle cell by {max(c.radius - d):.3f}"
            )


def drive(scene: Scene, crowd: Crowd, check: Checker, steps: int, *, speed=0.8, brake=0.1, path=None) -> int:
    """A scripted robot disc shuttling along ``path`` (default: the task's start and goal) at
    ``speed``; with ``brake`` (m) it stops rather than come that close to a person, without it it
    never stops. Checks every step before and after the crowd moves; returns the braked steps."""
    a, b = path if path is not None else (np.array(scene.task.start.position), np.array(scene.task.goal))
    a, b = np.asarray(a, float), np.asarray(b, float)
    xy, goal, braked = a.copy(), b, 0
    for _ in range(steps):
        d = goal - xy
        if np.linalg.norm(d) < 1e-6:
            goal = a if goal is b else b
            d = goal - xy
        vel = d / np.linalg.norm(d) * min(speed, np.linalg.norm(d) / DT)
        near = np.linalg.norm(crowd.pos - (xy + vel * DT), axis=1) - crowd.radius - ROBOT_R
        if brake is not None and len(near) and near.min() < brake:
            vel, braked = 0.0 * vel, braked + 1
        xy = xy + vel * DT
        check(xy, ROBOT_R)
        crowd.step(xy, vel, ROBOT_R)
        check(xy, ROBOT_R)
    return braked


@pytest.mark.parametrize(
    "split,index", [("urban-nav-3-test", i) for i in range(6)] + [("urban-nav-3-train", i) for i in range(4)]
)
def test_generated_scenes_keep_people_apart_and_on_walkable_ground(split, index):
    scene = citygen.generate(split, index=index)
    occ = occupancy(scene)
    crowd = Crowd(scene, occ, rng=np.random.default_rng(index), dt=DT)
    assert crowd.ids == [a.id for a in scene.agents if isinstance(a, Person)] and crowd.ids
    check = Checker(crowd, occ)
    drive(scene, crowd, check, 200)
    assert check.steps == 400


def test_people_reach_their_goals():
    arrived = total = 0
    for index in range(6):
        scene = citygen.generate("urban-nav-3-test", index=index)
        occ = occupancy(scene)
        crowd = Crowd(scene, occ, rng=np.random.default_rng(index), dt=DT)
        check = Checker(crowd, occ)
        far = np.array([-100.0, -100.0])  # the robot out of the way
        for _ in range(400):
            crowd.step(far, np.zeros(2), ROBOT_R)
            check(far, ROBOT_R)
        arrived += int(np.count_nonzero(crowd.arrivals >= 1))
        total += len(crowd.ids)
    assert arrived >= 0.8 * total, f"{arrived} of {total} people reached their goal in 40 s"


def test_same_rng_same_motion():
    scene = citygen.generate("urban-nav-3-test", index=2)
    occ = occupancy(scene)
    runs = []
    for _ in range(2):
        crowd = Crowd(scene, occ, rng=np.random.default_rng(7), dt=DT)
        for _ in range(50):
            crowd.step(np.array(scene.task.start.position), np.zeros(2), ROBOT_R)
        runs.append(crowd.pos.tobytes())
    assert runs[0] == runs[1]
    crowd.reset(np.random.default_rng(8))
    assert np.array_equal(crowd.pos, crowd.start) and not crowd.vel.any()


def test_a_kept_crowd_moves_as_a_new_one():
    """crowd_of builds a scene's clearance and paths once per prepared scene: every later
    episode's crowd (a copy, reset with its own generator) moves as a crowd built anew, and
    an episode leaves the kept one as it was."""
    from types import SimpleNamespace

    from citygen.runner.agents.crowd import crowd_of

    scene = citygen.generate("urban-nav-3-test", index=2)
    prepared = SimpleNamespace(occupancy=occupancy(scene))
    robot = np.array(scene.task.start.position)
    runs = []
    for seed in (7, 8, 7):
        fresh = Crowd(scene, prepared.occupancy, rng=np.random.default_rng(seed), dt=DT)
        kept = crowd_of(prepared, scene, rng=np.random.default_rng(seed), dt=DT)
        assert kept is not prepared._crowd[2]
        for _ in range(40):
            for crowd in (fresh, kept):
                crowd.step(robot, np.zeros(2), ROBOT_R)
        assert kept.pos.tobytes() == fresh.pos.tobytes() and kept.arrivals.tolist() == fresh.arrivals.tolist()
        runs.append(kept.pos.tobytes())
    assert runs[0] == runs[2] != runs[1]
    template = prepared._crowd[2]
    assert np.array_equal(template.pos, template.start) and not template.vel.any()


def _plaza(people: list[Person], size=(24.0, 24.0), cross: float | None = 5.0) -> Scene:
    """A square of plain ground with a plaza on it: a cross of arms ``cross`` m wide, or all of it."""
    w, h = size
    if cross is None:
        ring = [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]
    else:
        a, b = (w - cross) / 2, (w + cross) / 2
        c, d = (h - cross) / 2, (h + cross) / 2
        ring = [
            [a, 0],
            [b, 0],
            [b, c],
            [w, c],
            [w, d],
            [b, d],
            [b, h],
            [a, h],
            [a, d],
            [0, d],
            [0, c],
            [a, c],
        ]
    return Scene.model_validate(
        {
            "format": "citygen.scene/1",
            "bounds": {"min": [0.0, 0.0], "max": [w, h]},
            "zones": [{"id": "plaza", "kind": "plaza", "polygon": ring}],
            "agents": [p.model_dump() for p in people],
        }
    )


def _crossing_people(n: int, rng: np.random.Generator) -> list[Person]:
    """``n`` pedestrians at the ends of a 24 m cross with 5 m arms, each bound for the opposite end."""
    out, taken = [], []
    while len(out) < n:
        arm = int(rng.integers(4))
        along, across = rng.uniform(0.6, 7.0), rng.uniform(10.0, 14.0)
        p = [(along, across), (24 - along, across), (across, along), (across, 24 - along)][arm]
        q = [(24 - along, across), (along, across), (across, 24 - along), (across, along)][arm]
        if any(math.dist(p, t) < 0.75 for t in taken):
            continue
        taken.append(p)
        out.append(Person(id=f"p{len(out)}", kind="pedestrian", start=p, goal=q, radius=0.3, speed=1.3))
    return out


@pytest.mark.slow
def test_crowded_crossing_with_a_robot_through_it():
    scene = _plaza(_crossing_people(60, np.random.default_rng(0)))
    occ = occupancy(scene)
    crowd = Crowd(scene, occ, rng=np.random.default_rng(1), dt=DT)
    check = Checker(crowd, occ)
    drive(scene, crowd, check, 300, speed=0.6, path=((0.5, 12.0), (23.5, 12.0)))
    assert np.count_nonzero(crowd.arrivals >= 1) >= 30  # most cross the junction in 30 s


def test_people_dodge_a_robot_that_never_stops():
    rng = np.random.default_rng(4)
    people, taken = [], []
    while len(people) < 30:
        p, q = rng.uniform(1, 19, 2), rng.uniform(1, 19, 2)
        if any(math.dist(p, t) < 0.8 for t in taken) or abs(p[1] - 10) < 1.2:
            continue
        taken.append(p)
        people.append(Person(id=f"p{len(people)}", kind="pedestrian", start=p, goal=q, radius=0.3, speed=1.3))
    scene = _plaza(people, size=(20.0, 20.0), cross=None)
    occ = occupancy(scene)
    crowd = Crowd(scene, occ, rng=np.random.default_rng(5), dt=DT)
    check = Checker(crowd, occ)
    drive(scene, crowd, check, 200, speed=1.0, brake=None, path=((1.0, 10.0), (19.0, 10.0)))


def test_crowd_without_people_and_bad_dt():
    scene = _plaza([], cross=None)
    crowd = Crowd(scene, occupancy(scene, 0.25), rng=np.random.default_rng(0), dt=DT)
    crowd.step((1.0, 1.0), (0.0, 0.0), ROBOT_R)
    assert crowd.pos.shape == (0, 2) and crowd.headings().shape == (0,)
    with pytest.raises(ValueError, match="dt: expected a step > 0"):
        Crowd(scene, occupancy(scene, 0.25), rng=np.random.default_rng(0), dt=0)


# --- vehicles by IDM ----------------------------------------------------------------------------


def _road(cars: list[Vehicle], length=400.0) -> Scene:
    block = {
        "id": "road-0",
        "kind": "straight",
        "pose": {"position": [0.0, 10.0], "yaw": 0.0},
        "lanes": 1,
        "lane_width": 3.5,
        "sockets": [
            {"id": "in", "pose": {"position": [0.0, 10.0], "yaw": math.pi}},
            {"id": "out", "pose": {"position": [length, 10.0], "yaw": 0.0}},
        ],
        "connections": [],
        "length": length,
    }
    return Scene.model_validate(
        {
            "format": "citygen.scene/1",
            "bounds": {"min": [0.0, 0.0], "max": [length, 20.0]},
            "blocks": [block],
            "agents": [c.model_dump() for c in cars],
        }
    )


def _car(i: int, x0: float, x1: float, speed: float) -> Vehicle:
    return Vehicle(
        id=f"car-{i}", kind="vehicle", start=(x0, 8.25), goal=(x1, 8.25), speed=speed, route=("road-0",)
    )


def test_free_road_reaches_desired_speed():
    traffic = Traffic(_road([_car(1, 5.0, 395.0, 10.0)]), dt=DT)
    assert np.allclose(traffic.paths[0][[0, -1], 1], 8.25)  # the right lane, heading +x
    for _ in range(300):
        traffic.step()
    assert traffic.v[0] > 0.95 * 10.0
    assert abs(traffic.yaw[0]) < 1e-9 and abs(traffic.pos[0, 1] - 8.25) < 1e-9


def test_vehicle_stops_behind_a_stopped_one():
    traffic = Traffic(_road([_car(1, 5.0, 395.0, 12.0), _car(2, 120.0, 395.0, 0.0)]), dt=DT)
    for _ in range(600):
        traffic.step()
        bumper = traffic.pos[1, 0] - traffic.pos[0, 0] - (traffic.length[0] + traffic.length[1]) / 2
        assert bumper > 0.0
    assert traffic.v[0] < 0.05 and traffic.v[1] == 0.0
    assert bumper >= 2.0 - 1e-6  # IDM's jam distance s0


def test_vehicle_stops_for_the_robot_in_its_lane():
    traffic = Traffic(_road([_car(1, 5.0, 395.0, 10.0)]), dt=DT)
    robot = np.array([[80.0, 8.6]])
    for _ in range(400):
        traffic.step(robot, [ROBOT_R])
    assert traffic.v[0] < 0.05
    assert 80.0 - ROBOT_R - (traffic.pos[0, 0] + traffic.length[0] / 2) >= 2.0 - 1e-6
    traffic.reset()
    for _ in range(400):
        traffic.step(np.array([[80.0, 14.0]]), [ROBOT_R])  # on the other side of the road: no reason to stop
    assert traffic.pos[0, 0] > 150.0


def test_people_walk_round_vehicles_never_into_them():
    """A car stands across a plaza and a bus drives through it (stopping, as traffic does, for
    whoever stands in front of it) while 30 people cross: no one's disc ever reaches into a
    vehicle's footprint, and most get across."""
    rng = np.random.default_rng(2)
    people = []
    while len(people) < 30:
        y0, y1 = rng.uniform(2, 18, 2)
        p, q = (rng.uniform(0.5, 3.0), y0), (rng.uniform(17.0, 19.5), y1)
        if len(people) % 2:
            p, q = q, p
        if all(math.dist(p, o.start) > 0.8 for o in people):
            people.append(
                Person(id=f"p{len(people)}", kind="pedestrian", start=p, goal=q, radius=0.3, speed=1.3)
            )
    scene = _plaza(people, size=(20.0, 20.0), cross=None)
    occ = occupancy(scene)
    crowd = Crowd(scene, occ, rng=np.random.default_rng(3), dt=DT)
    check = Checker(crowd, occ)
    far = np.array([-100.0, -100.0])
    cars = Footprints(np.array([[10.0, 10.0], [10.0, -4.0]]), np.array([0.4, math.pi / 2]),
                      np.array([4.5, 10.0]), np.array([1.8, 2.5]), np.zeros(2))  # fmt: skip
    stops = 0
    for _ in range(250):
        bus = Footprints(*(np.asarray(f)[1:] for f in cars[:4]), np.ones(1))
        go = footprint_depth(crowd.pos, crowd.radius + 0.3, bus, ahead=1.0).max() < 0  # its brake
        stops += not go
        cars = cars._replace(speed=np.array([0.0, float(go)]))
        crowd.step(far, np.zeros(2), ROBOT_R, cars)
        check(far, ROBOT_R)
        cars = cars._replace(pos=cars.pos + np.array([[0.0, 0.0], [0.0, DT * cars.speed[1]]]))
        assert footprint_depth(crowd.pos, crowd.radius, cars).max() <= 1e-3
    assert np.count_nonzero(crowd.arrivals >= 1) >= 15 and cars.pos[1, 1] > 0.0 and stops  # all moved


@pytest.mark.parametrize("index", range(3))
def test_paths_on_the_nodes_a_class_keeps_are_the_whole_grids(index):
    """Crowd._hops runs Dijkstra on the path grid's nodes a clearance class keeps (and the
    targets' nodes): every next hop is the one Dijkstra on the whole grid gives
    (_hops_whole, the reference), ties broken alike; no hop from the nodes it leaves out."""
    scene = citygen.generate("urban-nav-3-test", index=index)
    crowd = Crowd(scene, occupancy(scene), rng=np.random.default_rng(0), dt=DT)
    groups = np.floor(crowd.need / 0.05 + 1e-9) * 0.05
    for need in np.unique(groups):
        members = np.flatnonzero(groups == need)
        src = crowd._node_of(np.concatenate([crowd.goal[members], crowd.start[members]]))
        whole = crowd._hops_whole(need, src)
        assert (whole >= 0).sum(axis=1).min() > 10  # paths through the square
        assert np.array_equal(crowd._hop[members].swapaxes(0, 1).reshape(whole.shape), whole)
