"""Stage 3: mixed terrain by WFC (sockets from the spec's edge profiles, neighbours that
agree, parameters in range, the configured mix, zones and pins) and the locomotion
curriculum grid."""

from __future__ import annotations

import itertools
import json
import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from citygen.errors import GenerationError
from citygen.generate.terrain import (
    KINDS,
    LEVELS,
    LOC_RANGES,
    RISE_TOL,
    build_curriculum,
    build_terrain,
    cycle_kinds,
    draw_boundary,
    grid_for,
    loc_config,
    symbolic_tile,
    terrain_tileset,
)
from citygen.generate.wfc import check, solve
from citygen.seeding import stage_rng
from citygen.spec.base import to_jsonable
from citygen.spec.config import TerrainConfig, TerrainMix
from citygen.spec.scene import Bounds, Scene
from citygen.spec.terrain import (
    SIDES,
    RoughTile,
    SlopeTile,
    StairTile,
    Terrain,
    edge_profile,
    peak,
    profiles_match,
)
from citygen.spec.zones import Zone
from citygen.validate import validate

OPPOSITE = {"north": "south", "east": "west", "south": "north", "west": "east"}
GRID_32 = Bounds(min=(0.0, 0.0), max=(80.0, 80.0))  # 32 x 32 tiles of 2.5 m


def mismatches(t: Terrain) -> list[tuple[int, int, str]]:
    """Neighbour pairs whose shared edges disagree, by the spec's own profiles_match."""
    profiles: dict[int, dict[str, tuple]] = {}

    def profile(tile, side):
        p = profiles.get(id(tile))
        if p is None:
            p = profiles[id(tile)] = {s: edge_profile(tile, s, t.tile_size) for s in SIDES}
        return p[side]

    bad = []
    for r in range(t.rows):
        for c in range(t.cols):
            here = t.tile(r, c)
            if c + 1 < t.cols and not profiles_match(
                profile(here, "east"), profile(t.tile(r, c + 1), "west")
            ):
                bad.append((r, c, "east"))
            if r + 1 < t.rows and not profiles_match(
                profile(here, "north"), profile(t.tile(r + 1, c), "south")
            ):
                bad.append((r, c, "north"))
    return bad


def out_of_range(t: Terrain, cfg: TerrainConfig) -> list[str]:
    """Every tile parameter outside its configured range."""
    checks = {
        SlopeTile: (("angle", cfg.slope_angle),),
        StairTile: (("step_height", cfg.step_height), ("step_count", cfg.step_count)),
        RoughTile: (("amplitude", cfg.roughness_amplitude), ("scale", cfg.roughness_scale)),
    }
    bad = []
    for tile in {id(x): x for x in t.tiles}.values():
        for name, (lo, hi) in checks.get(type(tile), ()):
            if not lo <= getattr(tile, name) <= hi:
                bad.append(f"{tile.kind}.{name} = {getattr(tile, name)} outside [{lo}, {hi}]")
    return bad


def box(i: int, kind: str, x0: float, y0: float, x1: float, y1: float) -> Zone:
    return Zone(id=f"{kind}-{i}", kind=kind, polygon=((x0, y0), (x1, y0), (x1, y1), (x0, y1)))


# A 15 m street scene: roadway along the bottom, a curb, a sidewalk, a plaza above,
# with a crosswalk-width strip of vegetation at the right.
STREET = (
    box(0, "roadway", 0.0, 0.0, 15.0, 3.6),
    box(1, "curb", 0.0, 3.6, 15.0, 3.8),
    box(2, "sidewalk", 0.0, 3.8, 15.0, 7.0),
    box(3, "plaza", 0.0, 7.0, 12.0, 15.0),
    box(4, "vegetation", 12.0, 7.0, 15.0, 15.0),
)


# --- the tileset ---------------------------------------------------------------------


def test_sockets_agree_with_the_specs_edge_profiles():
    """WFC's adjacency is exactly what validate accepts, for every pair of variants."""
    tts = terrain_tileset()
    ts = tts.tileset
    assert len(ts) == 2 * LEVELS + 2 * 4 * (LEVELS - 1) >= 12
    tiles = [
        symbolic_tile(KINDS[k], int(lv), a) for k, lv, a in zip(tts.kind, tts.level, tts.ascent, strict=True)
    ]
    for d, side in enumerate(SIDES):
        for a, ta in enumerate(tiles):
            for b, tb in enumerate(tiles):
                agree = profiles_match(edge_profile(ta, side, 1.0), edge_profile(tb, OPPOSITE[side], 1.0))
                assert ts.allowed[d, a, b] == agree, (ts.names[a], side, ts.names[b])


def test_rotations_are_the_four_ascents():
    tts = terrain_tileset()
    flights = tts.variants("stair", 0)
    assert sorted(tts.ascent[v] for v in flights) == ["+x", "+y", "-x", "-y"]


# --- the 32 x 32 mixed grid over many seeds ------------------------------------------------


def run_seeds(cfg: TerrainConfig, seeds: range) -> Counter:
    kinds: Counter = Counter()
    for seed in seeds:
        t = build_terrain(GRID_32, (), cfg, stage_rng(seed, "terrain"), seed=seed)  # never raises
        assert (t.rows, t.cols) == (32, 32)
        assert mismatches(t) == [], f"seed {seed}"
        assert out_of_range(t, cfg) == [], f"seed {seed}"
        kinds.update(tile.kind for tile in t.tiles)
    return kinds


def assert_mix(kinds: Counter, mix: TerrainMix) -> None:
    total, weights = sum(kinds.values()), sum(getattr(mix, k) for k in KINDS)
    for k in KINDS:
        share, want = kinds[k] / total, getattr(mix, k) / weights
        assert abs(share - want) <= 0.05, f"{k}: {share:.3f} of tiles, weight {want:.3f}"


def test_400_seeds_of_a_32x32_mixed_grid_agree_stay_in_range_and_follow_the_mix():
    # The benchmark (benchmarks/bench_wfc.py) runs the same check over 10,000 seeds.
    cfg = TerrainConfig()
    assert_mix(run_seeds(cfg, range(400)), cfg.mix)


def test_other_ranges_and_an_uneven_mix():
    cfg = loc_config("test").model_copy(
        update={
            "layout": "wfc",
            "tile_size": 2.5,
            "step_count": (2, 6),
            "mix": TerrainMix(flat=3, slope=1, stair=2, rough=2),
        }
    )
    assert_mix(run_seeds(cfg, range(150)), cfg.mix)


# --- level boundaries ----------------------------------------------------------------------


def sorted_pair(lo, hi, digits=4):
    return st.tuples(lo, hi).map(lambda p: tuple(sorted(round(x, digits) for x in p)))


@settings(max_examples=200, deadline=None)
@given(
    angle=sorted_pair(st.floats(0.0, 0.9), st.floats(0.0, 0.9)),
    height=sorted_pair(st.floats(0.005, 0.5), st.floats(0.005, 0.5)),
    count=sorted_pair(st.integers(1, 12), st.integers(1, 12)),
    size=st.sampled_from([0.5, 2.5, 8.0]),
    seed=st.integers(0, 1000),
)
def test_boundaries_draw_every_parameter_in_range_and_one_rise(angle, height, count, size, seed):
    cfg = TerrainConfig(slope_angle=angle, step_height=height, step_count=count)
    b = draw_boundary(cfg, size, np.random.default_rng(seed))
    assert b.angle is not None or b.steps is not None
    if b.angle is not None:
        assert angle[0] <= b.angle <= angle[1]
        assert abs(size * math.tan(b.angle) - b.rise) <= RISE_TOL
    if b.steps is not None:
        n, h = b.steps
        assert count[0] <= n <= count[1] and height[0] <= h <= height[1]
        assert abs(n * h - b.rise) <= 1e-9


def test_ranges_that_share_no_rise_keep_one_kind_per_boundary():
    # Ramps of at most 0.5 degrees rise 2 cm over a tile; stairs rise at least 0.8 m.
    cfg = TerrainConfig(slope_angle=(0.0, 0.01), step_height=(0.2, 0.3), step_count=(4, 6))
    kinds: Counter = Counter()
    for seed in range(30):
        t = build_terrain(GRID_32, (), cfg, stage_rng(seed, "terrain"))
        assert mismatches(t) == [] and out_of_range(t, cfg) == []
        for tile in t.tiles:
            kinds[tile.kind] += 1
        flights = {(type(x).__name__, x.height) for x in t.tiles if isinstance(x, SlopeTile | StairTile)}
        assert len({h for _, h in flights}) == len(flights), "slope and stair from the same level"
    assert kinds["slope"] > 0 and kinds["stair"] > 0


# --- zones, pins, bounds ----------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(12))
def test_street_scene_roadway_flat_at_zero_and_the_scene_validates(seed):
    bounds = Bounds(min=(0.0, 0.0), max=(15.0, 15.0))
    start, goal = (7.5, 5.5), (4.0, 13.0)
    t = build_terrain(
        bounds, STREET, TerrainConfig(), stage_rng(seed, "terrain"), seed=seed, flat_at=[start, goal]
    )
    assert (t.rows, t.cols, t.tile_size) == (6, 6, 2.5)
    # Rows 0 and 1 (y < 5 m) hold roadway or curb: flat at street level.
    for c in range(6):
        for r in (0, 1):
            assert t.tile(r, c).kind == "flat" and t.tile(r, c).height == 0.0
    # Tiles within 0.5 m of the start and the goal are flat.
    for x, y in (start, goal):
        assert t.tile(int(y // 2.5), int(x // 2.5)).kind == "flat"
    assert t.tile(2, 2).kind == t.tile(2, 3).kind == "flat"  # the start sits on their shared edge
    scene = Scene(format="citygen.scene/1", bounds=bounds, zones=STREET, terrain=t)
    assert validate(scene) == []


def test_street_scenes_get_terraces_between_plaza_levels():
    bounds = Bounds(min=(0.0, 0.0), max=(15.0, 15.0))
    heights, flights = set(), Counter()
    for seed in range(40):
        t = build_terrain(bounds, STREET, TerrainConfig(), stage_rng(seed, "terrain"))
        heights |= {x.height for x in t.tiles}
        flights.update(x.ascent for x in t.tiles if isinstance(x, SlopeTile | StairTile))
    assert len(heights) > 1, "no level changes at all"
    # The street runs along x: only flights rising along y can run from side to side.
    assert set(flights) <= {"+y", "-y"} and flights


def test_rough_tiles_take_the_zones_paving():
    bounds = Bounds(min=(0.0, 0.0), max=(15.0, 15.0))
    seen: dict[str, set] = {}
    for seed in range(20):
        t = build_terrain(bounds, STREET, TerrainConfig(), stage_rng(seed, "terrain"))
        for r in range(t.rows):
            for c in range(t.cols):
                tile = t.tile(r, c)
                if isinstance(tile, RoughTile):
                    zone = "vegetation" if c * 2.5 >= 12.0 and r * 2.5 >= 7.0 else "paved"
                    seen.setdefault(zone, set()).add(tile.material)
    assert seen["vegetation"] <= {"grass", "soil"}
    assert seen["paved"] <= {"concrete", "cobblestone", "paving_stone"}


@pytest.mark.parametrize(
    ("size", "tile", "shape"),
    [((12.0, 10.0), 2.0, (5, 6)), ((10.3, 7.9), 2.5, (3, 4)), ((1.0, 30.0), 1.0, (30, 1))],
)
def test_grids_fit_bounds_that_are_no_multiple_of_the_tile(size, tile, shape):
    bounds = Bounds(min=(1.0, 2.0), max=(1.0 + size[0], 2.0 + size[1]))
    g = grid_for(bounds, 2.5)
    assert (g.tile_size, (g.rows, g.cols)) == (tile, shape)
    for seed in range(5):
        t = build_terrain(bounds, (), TerrainConfig(), stage_rng(seed, "terrain"))
        assert validate(Scene(format="citygen.scene/1", bounds=bounds, terrain=t)) == []
        if g.short_x:  # the ground beyond the grid is at 0: no cliff at its edge
            assert all(
                edge_profile(t.tile(r, t.cols - 1), "east", t.tile_size) == ("level", 0.0)
                for r in range(t.rows)
            )
        if g.short_y:
            assert all(
                edge_profile(t.tile(t.rows - 1, c), "north", t.tile_size) == ("level", 0.0)
                for c in range(t.cols)
            )


def test_same_seed_same_terrain_other_seeds_differ():
    def doc(seed):
        t = build_terrain(GRID_32, STREET, TerrainConfig(), stage_rng(seed, "terrain"), flat_at=[(3.0, 9.0)])
        return json.dumps(to_jsonable(t), sort_keys=True)

    assert doc(3) == doc(3)
    assert len({doc(s) for s in range(3, 8)}) == 5


def test_a_mix_without_flat_ground_still_keeps_the_road_flat():
    cfg = TerrainConfig(mix=TerrainMix(flat=0, slope=0, stair=0, rough=1))
    bounds = Bounds(min=(0.0, 0.0), max=(15.0, 15.0))
    t = build_terrain(bounds, STREET, cfg, stage_rng(1, "terrain"))
    assert {t.tile(0, c).kind for c in range(6)} == {"flat"}
    assert {t.tile(r, c).kind for r in range(3, 6) for c in range(6)} == {"rough"}


def test_impossible_terrain_pins_are_a_generation_error_naming_the_cell():
    # The stage's own pins always admit flat ground at level 0, so it cannot contradict
    # itself; a caller pinning a level-2 flat tile beside a street-level one can.
    tts = terrain_tileset()
    domains = np.ones((3, 3, len(tts.tileset)), dtype=bool)
    domains[0, 1] = np.isin(np.arange(len(tts.tileset)), tts.variants("flat", 0))
    domains[1, 1] = np.isin(np.arange(len(tts.tileset)), tts.variants("flat", 2))
    with pytest.raises(GenerationError, match=r"stage 'terrain' \(seed 9\).*cell \(row [01], col 1\)"):
        solve(tts.tileset, 3, 3, np.random.default_rng(0), domains=domains, seed=9)
    domains[1, 1] = np.isin(np.arange(len(tts.tileset)), tts.variants("flat", 0))
    assert check(tts.tileset, solve(tts.tileset, 3, 3, np.random.default_rng(0), domains=domains)) == []


# --- the locomotion curriculum -----------------------------------------------------------------


def test_loc_configs_carry_the_papers_ranges():
    train, test = loc_config("train"), loc_config("test")
    assert (train.step_height, train.slope_angle, train.roughness_amplitude) == (
        (0.05, 0.23),
        (0.0, 0.3805),  # grades 0-0.4, as Isaac Lab's slope_range
        (0.02, 0.10),
    )
    assert (test.step_height, test.slope_angle, test.roughness_amplitude) == (
        (0.10, 0.30),
        (0.05, 0.6747),  # grades 0.05-0.8
        (0.05, 0.20),
    )
    assert (train.grid, test.grid) == ((30, 30), (16, 16))
    assert train.layout == test.layout == "curriculum"
    assert loc_config("train", "stair").mix == TerrainMix(flat=0, slope=0, stair=1, rough=0)
    with pytest.raises(ValueError, match="split"):
        loc_config("validation")


@pytest.mark.parametrize("split", sorted(LOC_RANGES))
def test_curriculum_rows_rise_in_difficulty_and_regions_meet_level(split):
    cfg = loc_config(split)
    t = build_curriculum(cfg, np.random.default_rng(0))
    rows, cols = cfg.grid
    assert (t.rows, t.cols) == (rows, cols)
    field = {
        "slope": ("angle", cfg.slope_angle),
        "stair": ("step_height", cfg.step_height),
        "rough": ("amplitude", cfg.roughness_amplitude),
    }
    for c in range(cols):
        kind = t.tile(0, c).kind
        assert {t.tile(r, c).kind for r in range(rows)} == {kind}, "a column keeps its kind"
        if kind in field:
            name, (lo, hi) = field[kind]
            values = [getattr(t.tile(r, c), name) for r in range(rows)]
            assert values[0] == pytest.approx(lo, abs=1e-12) and values[-1] == pytest.approx(hi, abs=1e-12)
            assert all(a < b for a, b in itertools.pairwise(values)), values
            if kind == "slope":  # linear in grade, as Isaac Lab's slope_range, not in angle
                steps = np.diff(np.tan(values))
                assert steps == pytest.approx(np.full(rows - 1, steps.mean()), abs=3e-4)  # angles to 1e-4
                assert np.diff(values) != pytest.approx(np.full(rows - 1, np.diff(values).mean()), rel=1e-3)
    fixed = {"stair": "step_count", "rough": "scale"}  # widths do not scale with difficulty
    for c in range(cols):
        name = fixed.get(t.tile(0, c).kind)
        if name:
            assert len({getattr(t.tile(r, c), name) for r in range(rows)}) == 1
    assert mismatches(t) == []
    extent = Bounds(min=(0.0, 0.0), max=(cols * cfg.tile_size, rows * cfg.tile_size))
    assert validate(Scene(format="citygen.scene/1", bounds=extent, terrain=t)) == []
    shapes = {t.tile(0, c).shape for c in range(cols) if t.tile(0, c).kind in ("slope", "stair")}
    assert shapes == {"pyramid", "pit"}


def test_curriculum_columns_cycle_kinds_by_the_mix():
    assert cycle_kinds(TerrainMix(), 8) == ["flat", "slope", "stair", "rough"] * 2
    kinds = cycle_kinds(TerrainMix(flat=1, slope=2, stair=0, rough=1), 40)
    assert Counter(kinds) == {"slope": 20, "flat": 10, "rough": 10}
    assert all(a != b or a == "slope" for a, b in itertools.pairwise(kinds))


def test_pyramids_and_pits_have_level_edges():
    for shape, sign in (("pyramid", 1), ("pit", -1)):
        stair = StairTile(kind="stair", height=0.5, step_height=0.2, step_count=3, shape=shape)
        slope = SlopeTile(kind="slope", height=0.5, angle=0.3, ascent="-y", shape=shape)
        for tile in (stair, slope):
            assert {edge_profile(tile, s, 8.0) for s in SIDES} == {("level", 0.5)}
        assert peak(stair, 8.0) == pytest.approx(sign * 0.6)
        assert peak(slope, 9.0) == pytest.approx(sign * 3.0 * math.tan(0.3))


def test_the_stage_lays_out_a_curriculum_within_the_bounds():
    cfg = loc_config("test", "rough")
    side = 16 * cfg.tile_size
    t = build_terrain(Bounds(min=(5.0, 5.0), max=(5.0 + side, 5.0 + side)), (), cfg, stage_rng(0, "terrain"))
    assert t.origin == (5.0, 5.0) and {x.kind for x in t.tiles} == {"rough"}
    with pytest.raises(GenerationError, match="does not fit"):
        build_terrain(
            Bounds(min=(0.0, 0.0), max=(side - 1.0, side)), (), cfg, stage_rng(0, "terrain"), seed=4
        )
    unsized = cfg.model_copy(update={"grid": None})
    t = build_terrain(Bounds(min=(0.0, 0.0), max=(24.0, 40.0)), (), unsized, stage_rng(0, "terrain"))
    assert (t.rows, t.cols) == (5, 3)


def test_a_grid_beyond_the_specs_limits_is_a_clear_error():
    huge = Bounds(min=(0.0, 0.0), max=(10_000.0, 10_000.0))
    with pytest.raises(GenerationError, match=r"4000 x 4000 tiles .* use a larger tile_size"):
        build_terrain(huge, (), TerrainConfig(), stage_rng(0, "terrain"), seed=1)
