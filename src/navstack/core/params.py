"""Base class for validated parameter sets (Nav2 parameter names, Nav2 defaults).

Every plugin and algorithm takes a ``Params`` subclass.  Unknown keys, wrong types and
out-of-range values raise :class:`~navstack.core.errors.ConfigError` naming the file,
the key path and a "did you mean" suggestion, never a pydantic traceback.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping
from typing import Any, Self

from pydantic import BaseModel, ConfigDict, ValidationError, ValidationInfo, field_validator
from pydantic_core import PydanticCustomError

from navstack.core.errors import ConfigError, ConfigErrors, did_you_mean


class Params(BaseModel):
    """Frozen, strict-keys pydantic model; subclass with Nav2-named fields."""

    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True)

    @field_validator("*", mode="before")
    @classmethod
    def _no_lax_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        """Refuse ``true`` or ``"1.5"`` for a number, as Nav2's typed parameters do
        (pydantic's lax mode would coerce them silently)."""
        if isinstance(value, bool | str) and info.field_name is not None:
            annotation = cls.model_fields[info.field_name].annotation
            if _is_numeric(annotation) and not _admits(annotation, type(value)):
                raise PydanticCustomError("number_type", "Input should be a valid number")
        return value

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Validate ``data``; raise ``ConfigError`` (one per problem) on failure."""
        try:
            return cls.model_validate(dict(data or {}))
        except ValidationError as exc:
            raise validation_to_config_error(exc, cls, file=file, key_path=key_path) from None

    def updated(self, **changes: Any) -> Self:
        """A validated copy with ``changes`` applied."""
        return type(self).from_mapping({**self.model_dump(), **changes})


def _members(annotation: Any) -> tuple[Any, ...]:
    origin = typing.get_origin(annotation)
    if origin is typing.Union or origin is types.UnionType:
        return typing.get_args(annotation)
    return (annotation,)


def _is_numeric(annotation: Any) -> bool:
    return any(m in (int, float) for m in _members(annotation))


def _admits(annotation: Any, kind: type) -> bool:
    return any(m is kind for m in _members(annotation))


def _join(prefix: str, loc: tuple[int | str, ...]) -> str:
    parts = [prefix] if prefix else []
    for item in loc:
        parts.append(f"[{item}]" if isinstance(item, int) else str(item))
    return ".".join(parts).replace(".[", "[")


def _fields_at(model: type[BaseModel], loc: tuple[int | str, ...]) -> list[str]:
    """Field names of the (nested) model that owns the last element of ``loc``."""
    current: Any = model
    for item in loc[:-1]:
        if isinstance(item, int):
            continue
        fields = getattr(current, "model_fields", None)
        if not fields or item not in fields:
            return []
        ann = fields[item].annotation
        current = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
        if current is None:
            return []
    fields = getattr(current, "model_fields", None)
    return list(fields) if fields else []


def validation_to_config_error(exc: ValidationError, model: type[BaseModel], *, file: str = "",
                               key_path: str = "") -> ConfigError:
    """Turn a pydantic ``ValidationError`` into a (multi-)``ConfigError``."""
    errors: list[ConfigError] = []
    for err in exc.errors():
        loc = tuple(err["loc"])
        path = _join(key_path, loc)
        if err["type"] == "extra_forbidden":
            hint = did_you_mean(str(loc[-1]), _fields_at(model, loc)).strip(" ()")
            errors.append(ConfigError("unknown key", file=file, key_path=path, suggestion=hint))
        elif err["type"] == "missing":
            errors.append(ConfigError("required key is missing", file=file, key_path=path))
        else:
            got = err.get("input")
            errors.append(ConfigError(f"{err['msg']} (got {got!r})", file=file, key_path=path))
    return errors[0] if len(errors) == 1 else ConfigErrors(errors)
