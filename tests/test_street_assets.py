"""What is particular to the street-equipment categories (citygen.assets.street), beyond
the checks tests/test_assets.py makes of every category: where each goes and which way
it faces, that every style a docstring promises turns up, the stop sign's octagon, the
colour-coded recycling streams and the mast arm reaching over the roadway."""

from __future__ import annotations

import numpy as np
import pytest

from citygen.assets import CATEGORIES, ConvexMesh, resolve, street

SAMPLE = 60  # variants looked at per category: enough for every style to turn up


def _assets(category: str, count: int = SAMPLE):
    return [resolve(f"{category}/{v:04d}") for v in range(count)]


def _sizes(category: str) -> np.ndarray:
    """Height, size_x and size_y (m) of the sampled variants, one row each."""
    rows = []
    for a in _assets(category):
        x0, y0, x1, y1 = a.footprint.bounds
        rows.append((a.height, x1 - x0, y1 - y0))
    return np.array(rows)


def _extent(part) -> np.ndarray:
    points = part.hull_points()
    return points.max(axis=0) - points.min(axis=0)


def test_registered_with_class_anchor_and_zones() -> None:
    expected = {
        "recycling_bin": "curb",
        "mailbox": "curb",
        "newspaper_box": "curb",
        "parking_meter": "curb",
        "telephone_booth": "frontage",
        "advertising_board": "frontage",
        "street_sign": "curb",
        "traffic_light": "crossing",
    }
    assert sorted(street.CATEGORIES) == sorted(expected)
    for name, anchor in expected.items():
        entry = CATEGORIES[name]
        assert entry is street.CATEGORIES[name]
        assert (entry.semantic_class, entry.anchor) == (name, anchor)
        assert "sidewalk" in entry.zones and "roadway" not in entry.zones


def test_every_style_turns_up() -> None:
    signs = _sizes("advertising_board")
    assert (signs[:, 0] < 1.2).any()  # sandwich boards
    assert ((signs[:, 0] > 2.5) & (np.abs(signs[:, 1] - signs[:, 2]) < 0.02)).any()  # round poster columns
    assert ((signs[:, 2] > 1.2) & (signs[:, 1] < 0.5)).any()  # flat poster panels
    meters = _sizes("parking_meter")
    assert (meters[:, 0] > 1.7).any() and (meters[:, 0] < 1.7).any()  # pay stations and heads on posts
    assert (meters[:, 2] < 0.3).any() and (
        (meters[:, 2] > 0.4) & (meters[:, 0] < 1.7)
    ).any()  # single, double
    papers = _sizes("newspaper_box")
    assert (papers[:, 2] < 0.6).any() and ((papers[:, 2] > 0.8) & (papers[:, 2] < 1.1)).any()
    assert (papers[:, 2] > 1.2).any()  # banks of three
    booths = _sizes("telephone_booth")
    assert (booths[:, 0] < 2.0).any() and (booths[:, 0] > 2.1).any()  # pedestal phones and booths
    lights = _sizes("traffic_light")
    assert (lights[:, 1] > 2.0).any() and (lights[:, 1] < 1.0).any()  # mast arms and posts


def test_traffic_light_arms_reach_over_the_roadway() -> None:
    arms = 0
    for asset in _assets("traffic_light"):
        x0, _, x1, _ = asset.footprint.bounds
        assert x0 > -0.4, asset.id  # nothing reaches back over the sidewalk
        assert x1 - x0 <= 6.0
        arms += x1 > 2.0
    assert arms >= 10


def test_stop_signs_are_regular_octagonal_prisms() -> None:
    octagons = []
    for asset in _assets("street_sign"):
        for part in asset.parts:
            if isinstance(part, ConvexMesh) and len(part.vertices) == 16 and part.material == street.SIGN_RED:
                octagons.append(part)
    assert len(octagons) >= 5
    for part in octagons:
        width, thick, height = _extent(part)
        assert width == pytest.approx(height, abs=1e-5)  # as wide across the flats both ways
        assert 0.5 <= width <= 0.9 and thick < 0.02  # a plate facing +y


def test_recycling_stations_sort_streams_by_colour() -> None:
    stations = 0
    for asset in _assets("recycling_bin"):
        streams = {p.material for p in asset.parts if p.material in street.STREAMS}
        assert streams, asset.id  # every bin is colour-coded
        _, y0, _, y1 = asset.footprint.bounds
        if y1 - y0 > 0.75:  # a station of 2-4 compartments, each its own stream
            stations += 1
            assert len(streams) >= 2, asset.id
    assert stations >= 10


def test_user_side_faces_the_sidewalk() -> None:
    """Displays of parking meters and windows of newspaper boxes face -x (the sidewalk at a curb)."""
    for category, look in (("parking_meter", street.SCREEN), ("newspaper_box", street.GLASS)):
        for asset in _assets(category, 20):
            # thin in x: plates on a face at constant x
            fronts = [p for p in asset.parts if p.material == look and _extent(p)[0] < 0.02]
            assert fronts, asset.id
            assert all(p.hull_points()[:, 0].mean() < -0.05 for p in fronts), asset.id
