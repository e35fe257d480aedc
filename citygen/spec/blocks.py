"""Road blocks (stage 1): the pieces of a road network and how they connect.

A block is laid out from its entry socket (``pose``) by the builder of its kind;
its ``sockets`` are where other blocks attach, and ``connections`` record which
socket of which block each of this block's sockets is joined to. The sockets
are stored, not recomputed, so a reader needs no road geometry code.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from citygen.spec import limits
from citygen.spec.base import Identifier, SpecModel, Vec2, Yaw, bounded_float, bounded_int

Lanes = bounded_int(1, 4)
LaneWidth = bounded_float(2.0, 5.0)
Length = bounded_float(0.5, 1_000.0)


class Pose2(SpecModel):
    """A position on the ground plane and a heading."""

    position: Vec2
    """``[x, y]`` in metres."""
    yaw: Yaw = 0.0
    """Heading in radians, counter-clockwise from +x."""


class Socket(SpecModel):
    """A place where another block can attach: a road end, pointing out of the block."""

    id: Identifier
    pose: Pose2
    """Centre of the road end; ``yaw`` points away from the block."""


class Connection(SpecModel):
    """One of this block's sockets joined to a socket of another block."""

    socket: Identifier
    """This block's socket."""
    block: Identifier
    """The other block's id."""
    to_socket: Identifier
    """The other block's socket."""


class _Block(SpecModel):
    id: Identifier
    pose: Pose2
    """Pose of the entry socket, heading into the block."""
    lanes: Lanes = 1
    """Lanes in each direction."""
    lane_width: LaneWidth = 3.5
    """Width of one lane, in metres."""
    sockets: tuple[Socket, ...] = Field(default=(), max_length=limits.MAX_SOCKETS)
    connections: tuple[Connection, ...] = Field(default=(), max_length=limits.MAX_SOCKETS)


class Straight(_Block):
    """A straight road segment."""

    kind: Literal["straight"]
    length: Length
    """Length along the road, in metres."""
    one_way: bool | None = None
    """``True``: a one-way road, driven only from its ``in`` socket to its ``out`` socket;
    absent: vehicles drive both ways."""


class Curve(_Block):
    """A circular arc."""

    kind: Literal["curve"]
    radius: bounded_float(5.0, 500.0)
    """Radius of the road's centre line, in metres."""
    angle: bounded_float(-3.1416, 3.1416)
    """Turned angle in radians; positive turns left (counter-clockwise)."""


class Roundabout(_Block):
    """A circular junction with arms at even angles."""

    kind: Literal["roundabout"]
    radius: bounded_float(5.0, 100.0)
    """Radius of the ring road's centre line, in metres."""
    arms: bounded_int(3, 6) = 4
    """Roads meeting at the ring, the entry included."""


class Diverge(_Block):
    """A road that splits: lanes branch off at an angle (lane split, exit ramp)."""

    kind: Literal["diverge"]
    length: Length
    """Length of the main road through the block, in metres."""
    branch_angle: bounded_float(-1.5708, 1.5708)
    """Angle of the branch to the main road in radians; positive branches left."""
    branch_lanes: Lanes = 1
    """Lanes of the branch road in each direction."""


class Merge(_Block):
    """Two roads joining into one (the reverse of a diverge)."""

    kind: Literal["merge"]
    length: Length
    """Length of the main road through the block, in metres."""
    branch_angle: bounded_float(-1.5708, 1.5708)
    """Angle of the joining road to the main road in radians; positive joins from the left."""
    branch_lanes: Lanes = 1
    """Lanes of the branch road in each direction."""


class Intersection(_Block):
    """A four-way intersection."""

    kind: Literal["intersection"]
    arm_length: Length
    """Length of each arm from the centre to its socket, in metres."""
    corner_radius: bounded_float(0.0, 50.0) = 5.0
    """Curb radius at the corners, in metres."""


class TIntersection(_Block):
    """A three-way junction: the road goes on and one side road leaves it."""

    kind: Literal["t_intersection"]
    arm_length: Length
    """Length of each arm from the centre to its socket, in metres."""
    corner_radius: bounded_float(0.0, 50.0) = 5.0
    """Curb radius at the corners, in metres."""
    side: Literal["left", "right"] = "left"
    """Which side of the through road the third arm leaves on."""


class JunctionArm(SpecModel):
    """One road leaving a general junction: its heading, its length and its cross-section."""

    yaw: Yaw
    """Heading of the arm out of the junction, in radians counter-clockwise from +x."""
    length: Length
    """Distance from the junction's centre to the arm's road end (its socket), in metres."""
    lanes: Lanes = 1
    """Lanes in each direction."""
    lane_width: LaneWidth = 3.5
    """Width of one lane, in metres."""


class Junction(_Block):
    """A junction of any shape (five streets, a sharp Y, arms at any angles): a roadway polygon
    and three to eight arms from its centre. Its sockets are the arms' road ends, ``in`` (the
    first arm, where ``pose`` stands heading in) then ``arm1``, ``arm2`` ...; ``lanes`` and
    ``lane_width`` are those of its widest arm."""

    kind: Literal["junction"]
    centre: Vec2
    """Where the arms meet, ``[x, y]`` in metres."""
    arms: tuple[JunctionArm, ...] = Field(min_length=3, max_length=limits.MAX_SOCKETS)
    polygon: tuple[Vec2, ...] = Field(min_length=3, max_length=limits.MAX_POLYGON_VERTICES)
    """The junction's roadway: a simple polygon (counter-clockwise, not closed), in metres."""


Block = Annotated[
    Straight | Curve | Roundabout | Diverge | Merge | Intersection | TIntersection | Junction,
    Field(discriminator="kind"),
]
BLOCK_TYPES = (Straight, Curve, Roundabout, Diverge, Merge, Intersection, TIntersection, Junction)
