"""The field types of the scenario schema: SI quantities that a file may give with a unit.

Each type is a ``float`` (or ``int``) annotated with its dimension (:func:`tmaplan.units.
si_validator`: a plain SI number or a string with a unit, ``"12 kn"``, ``"3.5 km"``; a bool is
refused by name) and its range (finite, > 0 or ≥ 0). :func:`frozen` makes a schema class a
frozen, keyword-only pydantic dataclass that refuses unknown keys.
"""

from __future__ import annotations

import math
from typing import Annotated, TypeVar, cast, dataclass_transform

from pydantic import ConfigDict, Field
from pydantic.dataclasses import dataclass as pydantic_dataclass

from tmaplan.units import si_validator

__all__ = [
    "Accuracy",
    "Angle",
    "AngularRate",
    "Bias",
    "Length",
    "NonNegAngle",
    "NonNegInt",
    "NonNegLength",
    "NonNegProcessNoise",
    "NonNegSpeed",
    "NonNegTime",
    "PositiveAngle",
    "PositiveAngularRate",
    "PositiveFrequency",
    "PositiveInt",
    "PositiveLength",
    "PositiveSpeed",
    "PositiveTime",
    "PositiveWeight",
    "Probability",
    "Speed",
    "Spread",
    "Time",
    "Vec2Length",
    "Vec2Speed",
    "WildProbability",
    "frozen",
]

CONFIG = ConfigDict(extra="forbid", arbitrary_types_allowed=False)
"""The pydantic configuration of every schema class: unknown keys are refused."""
_T = TypeVar("_T")


@dataclass_transform(frozen_default=True, kw_only_default=True)
def frozen(cls: type[_T]) -> type[_T]:
    """``cls`` as a frozen, keyword-only pydantic dataclass refusing unknown keys."""
    return cast("type[_T]", pydantic_dataclass(frozen=True, kw_only=True, config=CONFIG)(cls))


_FINITE = Field(allow_inf_nan=False)
_POS = Field(allow_inf_nan=False, gt=0)
_NONNEG = Field(allow_inf_nan=False, ge=0)
Length = Annotated[float, si_validator("length"), _FINITE]
PositiveLength = Annotated[float, si_validator("length"), _POS]
NonNegLength = Annotated[float, si_validator("length"), _NONNEG]
Time = Annotated[float, si_validator("time"), _FINITE]
PositiveTime = Annotated[float, si_validator("time"), _POS]
NonNegTime = Annotated[float, si_validator("time"), _NONNEG]
Angle = Annotated[float, si_validator("angle"), _FINITE]
PositiveAngle = Annotated[float, si_validator("angle"), _POS]
NonNegAngle = Annotated[float, si_validator("angle"), _NONNEG]
Speed = Annotated[float, si_validator("speed"), _FINITE]
NonNegSpeed = Annotated[float, si_validator("speed"), _NONNEG]
PositiveSpeed = Annotated[float, si_validator("speed"), _POS]
AngularRate = Annotated[float, si_validator("angular_rate"), _FINITE]
PositiveAngularRate = Annotated[float, si_validator("angular_rate"), _POS]
PositiveFrequency = Annotated[float, si_validator("frequency"), _POS]
NonNegProcessNoise = Annotated[float, si_validator("process_noise"), _NONNEG]
NonNegInt = Annotated[int, Field(ge=0, strict=True)]
PositiveInt = Annotated[int, Field(gt=0, strict=True)]
Vec2Length = tuple[Length, Length]
Vec2Speed = tuple[Speed, Speed]

# the [faults] table's (tmaplan.scenario.faults)
Probability = Annotated[float, si_validator("dimensionless"),
                        Field(allow_inf_nan=False, ge=0.0, le=1.0)]
WildProbability = Annotated[float, si_validator("dimensionless"),
                            Field(allow_inf_nan=False, ge=0.0, lt=1.0)]
Spread = Annotated[float, si_validator("angle"), Field(allow_inf_nan=False, gt=0.0, le=math.pi)]
Bias = Annotated[float, si_validator("angle"),
                 Field(allow_inf_nan=False, ge=-math.pi / 2, le=math.pi / 2)]

# a contact's (tmaplan.scenario.schema.Contact)
PositiveWeight = Annotated[float, si_validator("dimensionless"), _POS]
Accuracy = Annotated[float, si_validator("dimensionless"),
                     Field(allow_inf_nan=False, gt=0.0, lt=1.0)]
