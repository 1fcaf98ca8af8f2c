"""The ``drawing:`` key of a mechanism file: how stick drawings show the mechanism.

``drawing: {plates: [{name: top, frames: [b1, b2, b3]}], auto_plates: true}`` -- each plate is
a filled polygon through the origins of the listed frames or joints, in the listed order
(kim1995 Figs. 2, 4, 6 draw the Stewart base and moving plates this way). Names are resolved
against the built mechanism in :func:`mechkin.model.drawing.resolve_plates` (frames first,
then joints); with ``auto_plates`` a link with no declared plate whose joints and cut frames span
a plane is drawn as the convex hull of those points. No numbers, so no units.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

Name = Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_.\-]*$")]


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)


class PlateSpec(_Spec):
    """A plate or platform drawn as a filled polygon through joint frames of one link."""

    name: Name
    frames: Annotated[list[Name], Field(min_length=3)]
    description: str | None = None


class DrawingSpec(_Spec):
    """How stick drawings show the mechanism (plates; links are always joint to joint)."""

    plates: list[PlateSpec] = Field(default_factory=list)
    auto_plates: bool = True
