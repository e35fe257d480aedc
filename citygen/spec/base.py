"""Building blocks of every spec model: strict scalars, vectors and the model base.

The pydantic models in :mod:`citygen.spec` check *shape*: types, required keys,
enumerations, numeric bounds and list lengths. That is exactly what the generated
JSON Schema expresses, so an editor validating against ``schemas/*.json`` and
pydantic accept the same documents. Everything a schema cannot say (polygons
valid, objects not overlapping, neighbouring tiles agreeing) is checked by
:func:`citygen.validate`, which returns a list of problems instead of raising.

Scalars are strict so that JSON Schema and pydantic agree: a float field takes
numbers (not ``"1.5"``, not ``true``), an integer field takes whole numbers
(``3`` or ``3.0``), non-finite numbers are rejected. Every float is quantised to
:data:`PRECISION` decimals on validation, so a model always equals the model
read back from its own JSON, and exporters see the same numbers whether a scene
came from the generator or from disk.

Every numeric bound is inclusive (``ge``, ``le``) and a multiple of 1e-4. Rounding is
monotonic, so a value inside such a bound stays inside once quantised, and JSON
Schema (which sees the unrounded value) and pydantic agree on every document. An
exclusive bound (``gt=0``) would break that: 4e-05 passes it, then rounds to 0.0.
"""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from pydantic import AfterValidator, AllowInfNan, BaseModel, BeforeValidator, ConfigDict, Field, Strict

#: Decimal places kept for every float in a scene (1e-4 m, 1e-4 rad, 1e-4 s).
PRECISION = 4


def quantize(value: float) -> float:
    """Round to :data:`PRECISION` decimals; ``-0.0`` becomes ``0.0``."""
    return round(value, PRECISION) + 0.0


def quantize_array(values: np.ndarray) -> np.ndarray:
    """:func:`quantize` of every element of a float array, bit for bit, but vectorised.

    ``rint(x * 10**4) / 10**4`` is the float nearest ``k / 10**4`` (the division is exact
    then correctly rounded), so it equals Python's correctly rounded ``round`` unless the
    product rounded across a half; those few elements are rounded one by one.

    >>> quantize_array(np.array([0.12345, -0.00001, 2.5e-05, 1.00005]))
    array([0.1235, 0.    , 0.    , 1.0001])
    """
    values = np.asarray(values, dtype=float)
    scaled = values * 10.0**PRECISION
    out = np.rint(scaled) / 10.0**PRECISION + 0.0
    near_half = np.abs(np.abs(scaled - np.floor(scaled)) - 0.5) < 1e-6
    for index in zip(*np.nonzero(near_half), strict=True):
        out[index] = quantize(float(values[index]))
    return out


def _whole_number(value: Any) -> Any:
    # JSON Schema's "integer" admits 3.0; so does citygen. Booleans are not numbers.
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


Float = Annotated[float, Strict(), AllowInfNan(False), AfterValidator(quantize)]
"""A finite float, rounded to :data:`PRECISION` decimals."""

Int = Annotated[int, Strict(), BeforeValidator(_whole_number)]
"""A whole number (``3`` or ``3.0``, never ``true`` or ``"3"``)."""

Bool = Annotated[bool, Strict()]


def bounded_float(ge: float, le: float) -> Any:
    """A :data:`Float` within ``[ge, le]``, checked on the number as written (as JSON
    Schema checks it), then quantised. Bounds must be multiples of 1e-4."""
    return Annotated[float, Strict(), AllowInfNan(False), Field(ge=ge, le=le), AfterValidator(quantize)]


def bounded_int(ge: int, le: int) -> Any:
    """An :data:`Int` within ``[ge, le]``."""
    # The before-validator wraps what precedes it, so 3.0 becomes 3 before the bounds.
    return Annotated[int, Strict(), Field(ge=ge, le=le), BeforeValidator(_whole_number)]


Yaw = bounded_float(-6.2832, 6.2832)
"""A heading in radians, counter-clockwise about +Z from +x, within [-2 pi, 2 pi]."""

Vec2 = tuple[Float, Float]
"""``[x, y]`` in metres."""

Vec3 = tuple[Float, Float, Float]
"""``[x, y, z]`` in metres."""

Identifier = Annotated[
    str,
    Strict(),
    Field(
        min_length=1,
        max_length=64,
        pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.:-]*$",
        description="An identifier unique within its list: letters, digits, _ . : -",
    ),
]


class SpecModel(BaseModel):
    """Base of every spec and config model: immutable, unknown keys are errors."""

    model_config = ConfigDict(
        frozen=True,
        extra="forbid",
        validate_by_name=True,
        validate_by_alias=True,
        serialize_by_alias=True,
        use_attribute_docstrings=True,
    )


def to_jsonable(model: BaseModel) -> dict[str, Any]:
    """The model as plain JSON data: aliases used, unset optional (``None``) fields left out."""
    return model.model_dump(mode="json", by_alias=True, exclude_none=True)
