"""The WFC solver: tilesets from prototypes and adjacency, valid tilings, pins, weights,
contradictions reported by cell, determinism."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from citygen.errors import GenerationError
from citygen.generate.wfc import (
    ROTATIONS,
    Prototype,
    Tileset,
    Unsatisfiable,
    check,
    counts,
    full_domains,
    rotate,
    solve,
)

# A small coastline tileset: land, sea and a coast tile with land to its north.
COAST = [
    Prototype("land", (("g", "g"),) * 4),
    Prototype("sea", (("w", "w"),) * 4),
    Prototype("coast", (("g", "g"), ("g", "w"), ("w", "w"), ("w", "g")), symmetry="T"),
]


def permutation_tileset(east: list[int], north: list[int]) -> Tileset:
    """Values whose east neighbour must be ``east[v]`` and north neighbour ``north[v]``."""
    n = len(east)
    allowed = np.zeros((4, n, n), dtype=bool)
    for a in range(n):
        allowed[1, a, east[a]] = allowed[3, east[a], a] = True
        allowed[0, a, north[a]] = allowed[2, north[a], a] = True
    return Tileset.from_adjacency([f"v{v}" for v in range(n)], allowed)


# Two swaps that do not commute: around any 2 x 2 block the constraints disagree, whatever
# the first value, and arc consistency cannot see it before a value is chosen.
NON_COMMUTING = permutation_tileset(east=[1, 0, 2], north=[0, 2, 1])


# --- tilesets -----------------------------------------------------------------------


def test_rotation_moves_each_socket_clockwise():
    assert rotate(("n", "e", "s", "w"), 1) == ("w", "n", "e", "s")
    assert rotate(("n", "e", "s", "w"), 4) == ("n", "e", "s", "w")


@pytest.mark.parametrize("symmetry", sorted(ROTATIONS))
def test_symmetry_classes_give_their_number_of_rotations(symmetry):
    sockets = {
        "X": ((1,),) * 4,
        "I": ((1,), (2,), (1,), (2,)),
        "\\": ((1,), (2,), (1,), (2,)),
        "L": ((1,), (1,), (2,), (2,)),
        "T": ((1,), (2,), (3,), (2,)),
    }[symmetry]
    ts = Tileset.from_prototypes([Prototype("p", sockets, symmetry=symmetry)])
    assert len(ts) == ROTATIONS[symmetry]
    assert len(set(ts.sockets)) == ROTATIONS[symmetry]  # every variant is distinct


def test_a_symmetry_class_the_sockets_contradict_is_an_error():
    with pytest.raises(ValueError, match="symmetry 'X'"):
        Tileset.from_prototypes([Prototype("p", ((1,), (2,), (1,), (2,)), symmetry="X")])


def test_adjacency_comes_from_reversed_sockets():
    ts = Tileset.from_prototypes(COAST)
    land, sea, coast = ts.names.index("land"), ts.names.index("sea"), ts.names.index("coast")
    north, east, south = 0, 1, 2
    assert ts.allowed[north, coast, land] and not ts.allowed[north, coast, sea]
    assert ts.allowed[south, coast, sea] and not ts.allowed[south, coast, land]
    assert ts.allowed[east, coast, coast]  # the coastline continues sideways
    assert not ts.allowed[east, coast, land]
    # Adjacency is mutual: b east of a  <=>  a west of b.
    assert np.array_equal(ts.allowed[1], ts.allowed[3].T)
    assert np.array_equal(ts.allowed[0], ts.allowed[2].T)


def test_adjacency_that_is_not_mutual_is_rejected():
    allowed = np.ones((4, 2, 2), dtype=bool)
    allowed[1, 0, 1] = False
    with pytest.raises(ValueError, match="mutual"):
        Tileset.from_adjacency(["a", "b"], allowed)


# --- solutions ------------------------------------------------------------------------


def brute_force(ts: Tileset, domains: np.ndarray) -> bool:
    """Whether any assignment within ``domains`` fits (tiny grids only)."""
    rows, cols, _ = domains.shape
    options = [np.flatnonzero(domains[r, c]) for r in range(rows) for c in range(cols)]
    return any(not check(ts, np.array(choice).reshape(rows, cols)) for choice in itertools.product(*options))


@st.composite
def instances(draw):
    """A random mutual adjacency over up to 4 variants, a tiny grid and random pins."""
    n = draw(st.integers(1, 4))
    rows, cols = draw(st.integers(1, 3)), draw(st.integers(1, 3))
    bits = draw(st.lists(st.booleans(), min_size=2 * n * n, max_size=2 * n * n))
    allowed = np.zeros((4, n, n), dtype=bool)
    allowed[0] = np.array(bits[: n * n]).reshape(n, n)
    allowed[1] = np.array(bits[n * n :]).reshape(n, n)
    allowed[2], allowed[3] = allowed[0].T, allowed[1].T
    pins = draw(st.lists(st.booleans(), min_size=rows * cols * n, max_size=rows * cols * n))
    domains = np.array(pins).reshape(rows, cols, n) | draw(st.booleans())
    return Tileset.from_adjacency([f"v{i}" for i in range(n)], allowed), domains, draw(st.integers(0, 99))


@settings(max_examples=150, deadline=None)
@given(instances())
def test_solutions_fit_and_failures_are_proofs(instance):
    ts, domains, seed = instance
    rows, cols, _ = domains.shape
    try:
        grid = solve(ts, rows, cols, np.random.default_rng(seed), domains=domains)
    except Unsatisfiable as exc:
        assert not brute_force(ts, domains), "a solvable instance was reported unsolvable"
        r, c = exc.cell
        assert 0 <= r < rows and 0 <= c < cols
        assert f"(row {r}, col {c})" in str(exc)
        return
    assert check(ts, grid) == []
    assert domains[np.arange(rows)[:, None], np.arange(cols)[None, :], grid].all(), "a pin was ignored"


def test_pinned_cells_keep_their_variants_and_neighbours_follow():
    ts = Tileset.from_prototypes(COAST)
    domains = full_domains(ts, 6, 6)
    domains[2, :, :] = False
    domains[2, :, ts.names.index("coast")] = True  # a coastline along row 2
    for seed in range(5):
        grid = solve(ts, 6, 6, np.random.default_rng(seed), domains=domains)
        assert check(ts, grid) == []
        assert (grid[2] == ts.names.index("coast")).all()
        # Land lies north of the coastline and sea south of it, never the other way.
        assert not (grid[3] == ts.names.index("sea")).any()
        assert not (grid[1] == ts.names.index("land")).any()


def test_same_generator_state_same_grid_and_other_seeds_differ():
    ts = Tileset.from_prototypes(COAST)
    a = solve(ts, 12, 12, np.random.default_rng(5))
    b = solve(ts, 12, 12, np.random.default_rng(5))
    assert np.array_equal(a, b)
    others = [solve(ts, 12, 12, np.random.default_rng(s)) for s in range(6, 10)]
    assert any(not np.array_equal(a, o) for o in others)


# --- weights -----------------------------------------------------------------------------


def test_variant_weights_set_frequencies_without_constraints():
    allowed = np.ones((4, 2, 2), dtype=bool)
    ts = Tileset.from_adjacency(["a", "b"], allowed, weights=[3.0, 1.0])
    grid = solve(ts, 60, 60, np.random.default_rng(0))
    share = (grid == 0).mean()
    assert abs(share - 0.75) < 0.03, share


def test_a_group_weighs_the_same_whatever_its_number_of_variants():
    # Four "arrow" variants (say rotations) against one "dot", equal group weights: each
    # group gets half the cells, not four fifths and one fifth.
    names = ["dot", "arrow0", "arrow1", "arrow2", "arrow3"]
    ts = Tileset.from_adjacency(
        names, np.ones((4, 5, 5), dtype=bool), groups=["dot"] + ["arrows"] * 4, group_weights={"dot": 1.0}
    )
    grid = solve(ts, 60, 60, np.random.default_rng(1))
    c = counts(ts, [grid])
    assert abs(c["dot"] / grid.size - 0.5) < 0.03, c
    assert abs(c["arrows"] / grid.size - 0.5) < 0.03, c


def test_weightless_variants_appear_only_where_forced():
    allowed = np.ones((4, 2, 2), dtype=bool)
    ts = Tileset.from_adjacency(["a", "b"], allowed, weights=[1.0, 0.0])
    domains = full_domains(ts, 5, 5)
    domains[2, 2] = [False, True]
    grid = solve(ts, 5, 5, np.random.default_rng(0), domains=domains)
    assert grid[2, 2] == 1 and (grid == 1).sum() == 1


# --- contradictions ------------------------------------------------------------------------


def test_no_tiling_is_a_generation_error_naming_the_cell():
    with pytest.raises(Unsatisfiable) as info:
        solve(NON_COMMUTING, 2, 2, np.random.default_rng(0), seed=42)
    err = info.value
    assert isinstance(err, GenerationError) and err.stage == "terrain" and err.seed == 42
    r, c = err.cell
    assert f"(row {r}, col {c})" in str(err) and "seed 42" in str(err)
    # A single row has no 2 x 2 block: the same tileset tiles it.
    row = solve(NON_COMMUTING, 1, 6, np.random.default_rng(0))
    assert check(NON_COMMUTING, row) == []


def test_contradicting_pins_are_reported_at_once():
    ts = Tileset.from_prototypes(COAST)
    domains = full_domains(ts, 3, 3)
    domains[1, 1] = np.array(ts.names) == "coast"  # land must lie north of it ...
    domains[2, 1] = np.array(ts.names) == "sea"  # ... but sea is pinned there
    with pytest.raises(Unsatisfiable, match=r"no tiling .* cell \(row [12], col 1\)"):
        solve(ts, 3, 3, np.random.default_rng(0), domains=domains)


def test_restarts_are_bounded_and_then_the_error_names_a_cell():
    with pytest.raises(Unsatisfiable, match=r"persisted through 3 restart\(s\)") as info:
        solve(NON_COMMUTING, 4, 4, np.random.default_rng(0), max_backtracks=0, max_restarts=3)
    r, c = info.value.cell
    assert 0 <= r < 4 and 0 <= c < 4


def test_backtracking_resolves_contradictions_a_greedy_search_would_hit():
    # A 3-variant adjacency (found by search) on which the first choices lead into a
    # contradiction arc consistency cannot foresee: without backtracking the solver fails,
    # with it the same seed succeeds.
    allowed = np.zeros((4, 3, 3), dtype=bool)
    allowed[0] = [[1, 0, 0], [1, 0, 1], [0, 1, 1]]
    allowed[1] = [[0, 1, 0], [1, 0, 0], [1, 0, 1]]
    allowed[2], allowed[3] = allowed[0].T, allowed[1].T
    ts = Tileset.from_adjacency(["a", "b", "c"], allowed)
    with pytest.raises(Unsatisfiable):
        solve(ts, 3, 3, np.random.default_rng(0), max_backtracks=0, max_restarts=0)
    grid = solve(ts, 3, 3, np.random.default_rng(0), max_restarts=0)
    assert check(ts, grid) == []


def test_check_reports_each_mismatched_pair_once():
    ts = Tileset.from_prototypes(COAST)
    land, sea = ts.names.index("land"), ts.names.index("sea")
    grid = np.array([[land, sea], [land, land]])
    assert check(ts, grid) == [(0, 0, "east"), (0, 1, "north")]
