"""urban-tra-city's traffic over 10 minutes of simulated time, checked at every step: no two
vehicles overlap, no vehicle enters a signalised junction against red, no person stands on the
roadway off the crosswalks or steps onto a crosswalk that does not show *walk*.

The 6,000 steps run the simulation the Traverse environment runs (:class:`SignalCrowd` over
the env's :class:`Crowd` on its occupancy map, :class:`CityTraffic`, both at the env's 0.1 s
step, the robot standing at the task's start) without MuJoCo: the city's env steps at about
1 s each on the 2-core machine. A short run of the real :class:`TraverseEnv` checks the same
invariants on its own agents, in a town made by the city's config on a ninth of its area.

The invariants are measured on the scene's zones, independently of the runner's bookkeeping:
a signalised junction is the ground inside its stop lines (STOP_MARGIN beyond the far edge of
each arm's crosswalks), entered when a vehicle's front bumper crosses one of them.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

import citygen
from citygen.geometry.roads import block_geometry
from citygen.runner.agents.footprints import rectangles
from citygen.runner.agents.lanes import STOP_MARGIN
from citygen.runner.agents.signals import Crossings, SignalCrowd
from citygen.runner.agents.traffic import CityTraffic

pytestmark = pytest.mark.slow

DT = 0.1
# Simulated steps of the rules test: the 10 minutes (each step moves ~200 people
# through ORCA and 30 vehicles, ~10 ms with the checks; ~1.5 minutes on the 2-core machine
# with the city's setup); CITYGEN_TRAFFIC_STEPS sets fewer or more.
STEPS = int(os.environ.get("CITYGEN_TRAFFIC_STEPS", "6000"))


@pytest.fixture(scope="module")
def city(city_file):
    return citygen.load_scene(city_file)


class Invariants:
    """Counts of the three violations, fed one step at a time."""

    def __init__(self, scene, crossings: Crossings):
        self.crossings = crossings
        zones = {z.id: Polygon(z.polygon, z.holes) for z in scene.zones}
        blocks = {b.id: b for b in scene.blocks}
        self.boxes, self.lines, self.signal_of = [], [], []
        for s in scene.signals:
            block = blocks[s.junction]
            g = block_geometry(block)
            c = np.asarray(block.pose.position) + block.arm_length * np.array(
                [math.cos(block.pose.yaw), math.sin(block.pose.yaw)]
            )
            walks = [zones[w] for p in s.phases for w in p.crosswalks]
            box, lines = g.outline.buffer(10.0), []  # bounded by the stop lines, not the curbs
            for arm in g.arms:
                d = np.array([math.cos(arm.yaw), math.sin(arm.yaw)])
                mine = [
                    w
                    for w in walks
                    if np.dot(np.asarray(w.centroid.coords[0]) - c, d)
                    > 0.7 * np.linalg.norm(np.asarray(w.centroid.coords[0]) - c)
                ]
                if not mine:
                    continue
                # The arm's stop line: STOP_MARGIN beyond the far edge of its crosswalks.
                r = max(float(np.max((np.asarray(w.exterior.coords) - c) @ d)) for w in mine)
                r += STOP_MARGIN - 0.05
                n = np.array([-d[1], d[0]])
                far = [c + d * r + n * 1e3, c + d * r - n * 1e3, c - d * 1e3 - n * 1e3, c - d * 1e3 + n * 1e3]
                box = box.intersection(Polygon(far))
                lines.append((arm.socket, c, d, r))
            self.boxes.append(box)
            self.lines.append(lines)
            self.signal_of.append(s.junction)
        self.tree = shapely.STRtree(self.boxes)
        self.overlaps = self.red_entries = self.off_crosswalk = self.no_walk_entries = self.hits = 0
        self.worst_hit = 0.0
        self.entries = 0
        self._inside: np.ndarray | None = None
        self._walk_before: np.ndarray | None = None

    def vehicles(self, traffic: CityTraffic, t_before: float, s_before: np.ndarray, people=None) -> None:
        """Vehicles' footprints against each other and against ``people`` (a crowd: each
        person's disc), and entries into signalised junctions against red."""
        rects = [Polygon(r) for r in rectangles(traffic.pos, traffic.yaw, traffic.length, traffic.width)]
        tree = shapely.STRtree(rects)
        a, b = tree.query(rects, predicate="intersects")
        pairs = [(i, j) for i, j in zip(a.tolist(), b.tolist(), strict=True) if i < j]
        self.overlaps += sum(rects[i].intersection(rects[j]).area > 1e-6 for i, j in pairs)
        if people is not None and len(people.pos):
            discs = shapely.points(people.pos)
            p, v = tree.query(discs, predicate="dwithin", distance=float(people.radius.max()))
            reach = people.radius[p] - shapely.distance(discs[p], np.asarray(rects, dtype=object)[v])
            self.hits += int(np.count_nonzero(reach > 1e-6))
            self.worst_hit = max(self.worst_hit, float(reach.max(initial=0.0)))
        fwd = np.stack([np.cos(traffic.yaw), np.sin(traffic.yaw)], axis=1)
        front = traffic.pos + fwd * (traffic.length / 2)[:, None]
        inside = np.full(len(front), -1)
        pts, boxes = self.tree.query(shapely.points(front), predicate="within")
        inside[pts] = boxes
        if self._inside is not None:
            moved_on = traffic.s >= s_before  # a vehicle put back at its start did not drive in
            for i in np.flatnonzero((inside >= 0) & (inside != self._inside) & moved_on).tolist():
                self.entries += 1
                k = inside[i]
                # The arm it came in by: the stop line its front was beyond before.
                socket = max(self.lines[k], key=lambda a: float((self._front[i] - a[1]) @ a[2]) - a[3])[0]
                state = self.crossings.plan.lane(self.signal_of[k], f"{socket}:0", t_before)
                self.red_entries += state == "red"
        self._inside, self._front = inside, front

    def people(self, pos: np.ndarray, t_before: float) -> None:
        self.off_crosswalk += int(self.crossings.on_roadway(pos).sum())
        on = self.crossings.crosswalk_at(pos)
        if self._walk_before is not None:
            stepped = (on >= 0) & (self._walk_before < 0)
            if stepped.any():
                self.no_walk_entries += int(self.crossings.no_walk(pos[stepped], t_before).sum())
        self._walk_before = on


def test_ten_minutes_of_city_traffic_keep_every_rule_at_every_step(city):
    from citygen.exporters.occupancy import occupancy
    from citygen.runner.agents.crowd import Crowd
    from citygen.runner.scenes import map_resolution

    crossings = Crossings(city)
    crowd = Crowd(city, occupancy(city, map_resolution(city)), rng=np.random.default_rng(0), dt=DT)
    people = SignalCrowd(crowd, crossings)
    traffic = CityTraffic(city, dt=DT, crossings=crossings)
    robot, robot_radius = np.asarray(city.task.start.position, dtype=float), 0.4
    check = Invariants(city, crossings)
    start = traffic.pos.copy()
    held = 0
    for _ in range(STEPS):
        t, s = traffic.t, traffic.s.copy()
        people.step(robot, np.zeros(2), robot_radius, traffic.footprints())
        traffic.step(
            np.concatenate([robot[None], people.pos]), np.concatenate([[robot_radius], people.radius])
        )
        check.vehicles(traffic, t, s, people)
        check.people(people.pos, t)
        held += people.held
    assert traffic.t == pytest.approx(STEPS * DT)
    assert (check.overlaps, check.red_entries, check.off_crosswalk, check.no_walk_entries) == (0, 0, 0, 0)
    assert check.hits == 0, (
        f"people inside vehicles' footprints {check.hits} times, by up to {check.worst_hit:.2f} m"
    )
    # The rules are exercised, not vacuous: vehicles drove through signalised junctions,
    # people waited for walk, and the traffic moved on.
    assert check.entries > 50 and held > 0
    assert np.linalg.norm(traffic.pos - start, axis=1).min() > 0 or traffic.v.max() > 0


def test_the_traverse_env_on_a_town_keeps_the_same_rules(town, tmp_path):
    from citygen.io import save_scene
    from citygen.runner.envs import TraverseEnv

    path = tmp_path / "town.json"
    save_scene(town, path)
    env = TraverseEnv(scene=path, max_steps=40)
    env.reset(seed=0)
    assert isinstance(env.traffic, CityTraffic) and isinstance(env.crowd, SignalCrowd)
    assert len(env.traffic.pos) >= 2 and len(env.crowd.pos) >= 10
    check = Invariants(town, env.crowd.crossings)
    for _ in range(40):
        t, s = env.traffic.t, env.traffic.s.copy()
        *_, terminated, truncated, info = env.step(np.zeros(2))
        check.vehicles(env.traffic, t, s, env.crowd)
        check.people(env.crowd.pos, t)
    assert truncated and not terminated
    assert (check.overlaps, check.red_entries, check.off_crosswalk, check.no_walk_entries, check.hits) == (
        0,
    ) * 5
    assert {"red_light_crossings", "roadway_incursions"} <= set(info["metrics"])
    assert info["metrics"]["roadway_incursions"] == 0  # standing on the sidewalk at the start


def test_vehicles_and_people_never_touch_in_a_crowded_town(town, town_config, seed=1):
    """The town's streets with more people and vehicles, made again from another seed (the
    agents' starts and routes; one seed: the targeted tests of test_traffic.py and test_crowd.py
    hold the two failures the issue found): at every step of 20 s no person's disc reaches into a
    vehicle's footprint (an oriented rectangle) and no two footprints overlap, vehicles
    starting inside a junction included (they start past its exit)."""
    from citygen.exporters.occupancy import occupancy
    from citygen.generate.pipeline import rebuild
    from citygen.runner.agents.crowd import Crowd
    from citygen.runner.scenes import map_resolution

    more = town_config.agents.model_copy(update={"people": 40, "vehicles": 8})
    scene = rebuild(town, "placement", town_config.model_copy(update={"agents": more}), seed=seed)
    crossings = Crossings(scene)
    crowd = Crowd(scene, occupancy(scene, map_resolution(scene)), rng=np.random.default_rng(seed), dt=DT)
    people, traffic = SignalCrowd(crowd, crossings), CityTraffic(scene, dt=DT, crossings=crossings)
    robot = np.asarray(scene.task.start.position, dtype=float)
    check = Invariants(scene, crossings)
    check.vehicles(traffic, 0.0, traffic.s.copy(), people)
    start = traffic.s.copy()
    for _ in range(200):
        t, s = traffic.t, traffic.s.copy()
        people.step(robot, np.zeros(2), 0.4, traffic.footprints())
        traffic.step(np.concatenate([robot[None], people.pos]), np.concatenate([[0.4], people.radius]))
        check.vehicles(traffic, t, s, people)
    assert (check.overlaps, check.red_entries) == (0, 0)
    assert check.hits == 0, (
        f"people inside vehicles' footprints {check.hits} times, by up to {check.worst_hit:.2f} m"
    )
    assert len(traffic.ids) == 8 and np.all(traffic.s != start)  # every vehicle drove
