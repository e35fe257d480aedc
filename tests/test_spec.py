"""Invariants of the spec models that every later stage relies on."""

from __future__ import annotations

import json

import pytest
from pydantic import ValidationError

from citygen.schema import SCHEMAS, schema_of
from citygen.spec import FRICTION, WALKABLE_ZONES, ZONE_KINDS, ZONE_MATERIAL, Placement, Scene, Zone
from citygen.spec.base import PRECISION
from citygen.spec.surfaces import MATERIALS


def _numeric_bounds(node, path="$"):
    if isinstance(node, dict):
        for key in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
            if key in node:
                yield path, key, node[key], node.get("type")
        for key, value in node.items():
            yield from _numeric_bounds(value, f"{path}.{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from _numeric_bounds(value, f"{path}[{i}]")


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_every_bound_is_inclusive_and_on_the_quantisation_grid(name):
    # Floats are rounded to 1e-4 after validation; only inclusive bounds on that grid
    # keep a rounded value inside them (and JSON Schema and pydantic in agreement).
    schema = schema_of(*SCHEMAS[name])
    bounds = list(_numeric_bounds(schema))
    assert bounds
    for path, key, value, _ in bounds:
        assert not key.startswith("exclusive"), f"{path}: {key} (use an inclusive bound)"
        assert round(value * 10**PRECISION) == value * 10**PRECISION, f"{path}: {key} = {value}"


def test_floats_are_quantised_and_negative_zero_is_gone():
    p = Placement(id="a", asset="bench/0001", position=(1.23456789, -0.00001, 2.0), yaw=0.1 + 0.2)
    assert p.position == (1.2346, 0.0, 2.0) and p.yaw == 0.3
    assert json.dumps(p.position[1]) == "0.0"


def test_models_are_frozen_and_deeply_immutable():
    z = Zone(id="a", kind="plaza", polygon=[(0, 0), (1, 0), (1, 1)])
    with pytest.raises(ValidationError):
        z.kind = "trail"
    assert isinstance(z.polygon, tuple) and isinstance(z.polygon[0], tuple)


def test_python_construction_takes_lists_json_takes_only_json_types():
    Scene(format="citygen.scene/1", bounds={"min": [0, 0], "max": [1, 1]})
    with pytest.raises(ValidationError):
        Scene.model_validate_json('{"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": ["1", 1]}}')


def test_every_zone_kind_has_a_material_and_every_material_a_friction():
    assert set(ZONE_MATERIAL) == set(ZONE_KINDS)
    assert set(FRICTION) == set(MATERIALS)
    assert set(ZONE_KINDS) >= WALKABLE_ZONES
    assert set(ZONE_MATERIAL.values()) <= set(MATERIALS)


def test_zone_surface_defaults_follow_kind_then_material():
    z = Zone(id="a", kind="trail", polygon=[(0, 0), (1, 0), (1, 1)])
    assert (z.walkable, z.surface, z.mu) == (True, "gravel", FRICTION["gravel"])
    z = Zone(id="b", kind="vegetation", material="mulch", friction=0.3, polygon=[(0, 0), (1, 0), (1, 1)])
    assert (z.walkable, z.surface, z.mu) == (False, "mulch", 0.3)


def test_discriminated_union_gives_one_error_for_a_wrong_kind():
    with pytest.raises(ValidationError) as info:
        Scene.model_validate_json(
            '{"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [1, 1]},'
            ' "agents": [{"id": "a", "kind": "pedestrain", "start": [0, 0], "goal": [1, 1]}]}'
        )
    assert len(info.value.errors()) == 1


def test_quantize_array_is_quantize_bit_for_bit():
    import numpy as np

    from citygen.spec.base import quantize, quantize_array

    rng = np.random.default_rng(0)
    values = np.concatenate(
        [
            rng.uniform(-1e4, 1e4, 20_000),
            np.round(rng.uniform(-1e3, 1e3, 20_000), 3),
            (np.arange(-20_000, 20_000) + 0.5) / 1e4,  # halfway cases
            rng.uniform(-1e-3, 1e-3, 5_000),
            [-0.0, 0.0, -0.00004, 0.00005],
        ]
    )
    expected = np.array([quantize(float(v)) for v in values])
    got = quantize_array(values)
    assert got.tobytes() == expected.tobytes()  # equal bits, -0.0 included
