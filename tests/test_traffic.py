"""City traffic: signal plans, vehicles that queue at red and go on green, yield in junctions
and never overlap; signals validated, generated for a city and exported.

The hand-made junction: a four-way intersection ``b1`` (centre ``(15, 0)``) between two
straights along +x; cars drive east from ``b0`` through ``b1`` into ``b2``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import citygen
from citygen.geometry.roads import block_sockets
from citygen.runner.agents.footprints import Footprints
from citygen.runner.agents.footprints import depth as footprint_depth
from citygen.runner.agents.lanes import drive_path, speed_limit
from citygen.runner.agents.signals import SignalPlan
from citygen.runner.agents.traffic import CityTraffic, _overlapping
from citygen.spec import Scene
from citygen.spec.agents import Vehicle
from citygen.spec.blocks import Connection, Intersection, Pose2, Straight
from citygen.spec.signals import Signal

LANE = 3.5


def _blocks():
    b0 = Straight(id="b0", kind="straight", pose=Pose2(position=(-150.0, 0.0)), length=150.0, lane_width=LANE)
    b1 = Intersection(id="b1", kind="intersection", pose=Pose2(position=(0.0, 0.0)), arm_length=15.0,
                      lane_width=LANE)  # fmt: skip
    b2 = Straight(id="b2", kind="straight", pose=Pose2(position=(30.0, 0.0)), length=150.0, lane_width=LANE)
    up = math.pi / 2
    b3 = Straight(id="b3", kind="straight", pose=Pose2(position=(15.0, -165.0), yaw=up), length=150.0,
                  lane_width=LANE)  # fmt: skip
    b4 = Straight(id="b4", kind="straight", pose=Pose2(position=(15.0, 15.0), yaw=up), length=150.0,
                  lane_width=LANE)  # fmt: skip
    links = {
        "b0": [("out", "b1", "in")],
        "b1": [("in", "b0", "out"), ("out", "b2", "in"), ("right", "b3", "out"), ("left", "b4", "in")],
        "b2": [("in", "b1", "out")],
        "b3": [("out", "b1", "right")],
        "b4": [("in", "b1", "left")],
    }
    return [
        b.model_copy(
            update={
                "sockets": block_sockets(b),
                "connections": tuple(Connection(socket=s, block=o, to_socket=t) for s, o, t in links[b.id]),
            }
        )
        for b in (b0, b1, b2, b3, b4)
    ]


def _car(k: int, x: float, route=("b0", "b1", "b2"), goal=(170.0, -LANE / 2)):
    return {"id": f"car-{k}", "kind": "vehicle", "start": (x, -LANE / 2), "goal": goal, "route": route,
            "speed": 12.0}  # fmt: skip


SIGNAL = {
    "id": "signal-b1",
    "junction": "b1",
    "cycle": 50.0,
    "phases": [
        {"id": "left-right", "lanes": ["left:0", "right:0"], "green": 20.0},
        {"id": "in-out", "lanes": ["in:0", "out:0"], "green": 20.0},
    ],
}


def junction(cars, signal=SIGNAL) -> Scene:
    return Scene(
        format="citygen.scene/1",
        bounds={"min": (-160.0, -170.0), "max": (190.0, 170.0)},
        blocks=_blocks(),
        agents=cars,
        signals=[signal] if signal else None,
    )


def test_the_signal_plan_cycles_through_green_amber_and_red():
    plan = SignalPlan([Signal.model_validate(SIGNAL)])
    states = [plan.lane("b1", "in:0", t) for t in (0.0, 19.9, 24.9, 25.0, 44.9, 45.0, 47.9, 48.0, 75.0)]
    assert states == ["red", "red", "red", "green", "green", "amber", "amber", "red", "green"]
    assert plan.lane("b1", "left:0", 10.0) == "green" and plan.lane("b0", "in:0", 10.0) is None


def test_vehicles_queue_at_red_and_the_queue_clears_on_green():
    cars = [_car(k, x) for k, x in enumerate((-40.0, -55.0, -70.0, -85.0))]
    traffic = CityTraffic(junction(cars), dt=0.1)
    stop = traffic.drives[0].passages[0].s_stop
    # Red for them until t = 25 s: they drive up and stand in a queue behind the stop line.
    while traffic.t < 24.0:
        traffic.step()
        assert not _overlapping(traffic.pos, traffic.yaw, traffic.length, traffic.width).any()
        assert traffic.s[0] + traffic.length[0] / 2 <= stop + 1e-6
    assert np.all(traffic.v < 0.05), traffic.v
    fronts = traffic.pos[:, 0] + traffic.length / 2
    gaps = (traffic.pos[:-1, 0] - traffic.length[:-1] / 2) - fronts[1:]
    assert np.all(gaps > 0.5) and np.all(gaps < 5.0), gaps  # bumper to bumper, in order
    assert stop - 3.0 < traffic.s[0] + traffic.length[0] / 2 <= stop
    # Green at 25 s: within the green every car has crossed the junction.
    passed = np.zeros(len(cars), bool)
    while traffic.t < 45.0:
        traffic.step()
        assert not _overlapping(traffic.pos, traffic.yaw, traffic.length, traffic.width).any()
        passed |= traffic.pos[:, 0] > 30.0
    assert passed.all(), traffic.pos
    assert traffic.entered_red == 0


def test_crossing_vehicles_at_an_unsignalised_junction_take_turns_and_never_overlap():
    x = 15.0 + LANE / 2
    north = {"id": "car-n", "kind": "vehicle", "start": (x, -60.0), "goal": (x, 160.0),
             "route": ("b3", "b1", "b4"), "speed": 12.0}  # fmt: skip
    east = _car(0, -45.0)
    traffic = CityTraffic(junction([east, north], signal=None), dt=0.1)
    both_inside, through = 0, np.zeros(2, bool)
    for _ in range(300):
        traffic.step()
        assert not _overlapping(traffic.pos, traffic.yaw, traffic.length, traffic.width).any()
        inside = np.all(np.abs(traffic.pos - (15.0, 0.0)) < 8.0, axis=1)
        both_inside += int(inside.all())
        through |= (traffic.pos[0, 0] > 30.0, traffic.pos[1, 1] > 15.0)
        assert np.all(traffic.v <= speed_limit(_blocks()[0]) + 1e-9)
    assert both_inside == 0
    assert through.all()  # both went through, one after the other


def test_a_left_turn_keeps_the_left_lane_up_to_the_junction():
    blocks = _blocks()
    car = citygen.spec.Vehicle.model_validate(
        {**_car(0, -100.0, route=("b0", "b1", "b4"), goal=(15.0 - LANE / 2 + 2 * LANE, 140.0))}
    )
    two = [b.model_copy(update={"lanes": 2}) for b in blocks]
    path = drive_path(car, two)
    near = path.points[np.argmin(np.abs(path.points[:, 0] + 2.0))]  # just before the junction
    assert near[1] == pytest.approx(-1.5 * LANE, abs=0.3)  # the inner of the two eastbound lanes
    assert path.passages[0].lane == "in:1"


def test_a_phase_naming_a_missing_lane_or_crosswalk_is_one_problem_at_its_path():
    bad = {**SIGNAL, "phases": [{**SIGNAL["phases"][0], "lanes": ["left:0", "north:0"]},
                                {**SIGNAL["phases"][1], "crosswalks": ["zone-9"]}]}  # fmt: skip
    problems = citygen.validate(junction([], signal=bad))
    assert [p.path for p in problems] == [
        "$.signals[0].phases[0].lanes[1]",
        "$.signals[0].phases[1].crosswalks[0]",
    ]
    assert "'north:0'" in str(problems[0]) and "sockets in, out, left, right" in str(problems[0])
    short = {**SIGNAL, "cycle": 45.0}
    assert [str(p) for p in citygen.validate(junction([], signal=short))] == [
        "$.signals[0].cycle: expected the sum of the phases' green, amber and red times (50 s), got 45"
    ]
    assert citygen.validate(junction([], signal=SIGNAL)) == []


def test_vehicles_starting_inside_a_junction_start_and_restart_past_its_exit():
    cars = [_car(k, x, route=("b1", "b2"), goal=(75.0, -LANE / 2)) for k, x in enumerate((5.0, 8.0))]
    scene = junction(cars)
    exit_x = [
        c["start"][0] + drive_path(Vehicle.model_validate(c), scene.blocks).passages[0].s_exit for c in cars
    ]
    traffic = CityTraffic(scene, dt=0.1)
    rear = lambda: traffic.pos[:, 0] - traffic.length / 2  # noqa: E731
    assert (
        np.all(rear() > exit_x)
        and not _overlapping(traffic.pos, traffic.yaw, traffic.length, traffic.width).any()
    )
    restarts = 0
    for _ in range(300):  # red for them at first (they are past the junction: no matter)
        s = traffic.s.copy()
        traffic.step()
        restarts += int((traffic.s < s).sum())
        assert np.all(rear() > exit_x) and np.all(traffic.pos[:, 0] + traffic.length / 2 <= 75.0 + 1e-9)
    assert restarts >= 2


def test_a_trip_ends_with_the_front_at_the_goal_or_before_a_junction_and_sees_past_its_end():
    person, radius = np.array([[61.0, -LANE / 2]]), 0.3  # just past the first goal
    ends, restarts = [], []
    for goal in (60.0, 12.0):  # on the straight past the junction; inside the junction
        traffic = CityTraffic(junction([_car(0, -60.0, goal=(goal, -LANE / 2))], signal=None), dt=0.1)
        end = traffic.total[0] + traffic.length[0] / 2 - 60.0  # where the front stops
        ends.append(end)
        restarts.append(0)
        for _ in range(300):
            s = traffic.s[0]
            traffic.step(person, [radius])
            restarts[-1] += int(traffic.s[0] < s)
            box = Footprints(traffic.pos, traffic.yaw, traffic.length, traffic.width, traffic.v)
            assert footprint_depth(person, [radius], box)[0] < 0.0
            assert traffic.pos[0, 0] + traffic.length[0] / 2 <= end + 1e-9
    car = Vehicle.model_validate(_car(0, -60.0, goal=(12.0, -LANE / 2)))
    assert ends == pytest.approx([60.0, drive_path(car, _blocks()).passages[0].s_stop - 60.0])
    # Before its goal the first car sees the person past it, stops and waits (no restart);
    # the second ends its trip at the stop line and starts again.
    assert restarts[0] == 0 and restarts[1] >= 1
