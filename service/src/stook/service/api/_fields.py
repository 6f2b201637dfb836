"""Reading one API object's JSON into typed values; errors name the object and the field.

Each accessor of `Fields` is one converter (a present value to its type, or an error) made
optional or required: absent, null and "" (the API's Go encoder writes "" for unset) read
as unset.
"""

from __future__ import annotations

import enum
import uuid
from collections.abc import Callable, Mapping
from datetime import datetime
from typing import Any, TypeVar

import msgspec

from stook.service.api._errors import ApiResponseError

__all__ = ["Fields", "parse_rfc3339"]

_E = TypeVar("_E", bound=enum.Enum)
_T = TypeVar("_T")
_Converter = Callable[["Fields", str, Any], _T]


def parse_rfc3339(text: str) -> datetime | None:
    """An RFC 3339 timestamp (fractions past microseconds truncated), or None if it is not one.

    ``datetime.fromisoformat`` reads it, upper-cased if need be (RFC 3339 allows "t" and
    "z"); a leap second (``:60``), which datetime cannot hold, reads as :59.999999.
    """
    try:
        return datetime.fromisoformat(text)
    except ValueError:
        pass
    text = text.upper()
    leap = text[16:19] == ":60"
    try:
        moment = datetime.fromisoformat(text[:17] + "59" + text[19:] if leap else text)
    except ValueError:
        return None
    return moment.replace(microsecond=999_999) if leap else moment


def _optional(convert: _Converter[_T]) -> Callable[[Fields, str], _T | None]:
    """The accessor of an optional field: unset reads as None, anything else through `convert`."""

    def read(fields: Fields, key: str) -> _T | None:
        value = fields._data.get(key)
        return None if value is None or value == "" else convert(fields, key, value)

    return read


def _required(convert: _Converter[_T]) -> Callable[[Fields, str], _T]:
    """The accessor of a required field: unset is an error."""

    def read(fields: Fields, key: str) -> _T:
        value = fields._data.get(key)
        if value is None or value == "":
            raise fields._error(key, "is missing")
        return convert(fields, key, value)

    return read


def _of_type(kind: type[_T], wording: str) -> _Converter[_T]:
    def convert(fields: Fields, key: str, value: Any) -> _T:
        if not isinstance(value, kind):
            raise fields._error(key, f"should be {wording}, got {_json_type(value)}")
        return value

    return convert


_string = _of_type(str, "a string")
_flag = _of_type(bool, "true or false")
_list = _of_type(list, "a list")
_mapping = _of_type(dict, "an object")


def _id(fields: Fields, key: str, value: Any) -> uuid.UUID:
    try:  # the API's spelling, parsed by msgspec in C in two fifths of uuid.UUID's time
        return msgspec.convert(value, uuid.UUID)
    except msgspec.ValidationError:
        pass
    text = _string(fields, key, value)
    try:  # any other spelling uuid.UUID reads (braces, "urn:uuid:")
        return uuid.UUID(text)
    except ValueError:
        raise fields._error(key, f"is not a UUID: {text!r}") from None


def _integer(fields: Fields, key: str, value: Any) -> int:
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if not isinstance(value, int) or isinstance(value, bool):
        raise fields._error(key, f"should be an integer, got {_json_type(value)}")
    return value


def _number(fields: Fields, key: str, value: Any) -> float:
    if isinstance(value, float):
        return value
    if not isinstance(value, int) or isinstance(value, bool):
        raise fields._error(key, f"should be a number, got {_json_type(value)}")
    try:
        return float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise fields._error(key, "is a number too large for a double") from None


def _timestamp(fields: Fields, key: str, value: Any) -> datetime:
    text = _string(fields, key, value)
    moment = parse_rfc3339(text)
    if moment is None:
        raise fields._error(key, f"is not an RFC 3339 timestamp: {text!r}")
    if moment.tzinfo is None:
        raise fields._error(key, f"has no time zone: {text!r}")
    return moment


class Fields:
    """Reads typed fields from one JSON object; errors name the object and the field."""

    __slots__ = ("_data", "_id_key", "_kind")

    def __init__(self, kind: str, data: object, id_key: str) -> None:
        if not isinstance(data, Mapping):
            raise ApiResponseError(f"{kind}: expected a JSON object, got {_json_type(data)}")
        self._data: Mapping[str, Any] = data
        self._kind = kind
        self._id_key = id_key

    def _error(self, key: str, problem: str) -> ApiResponseError:
        ident = self._data.get(self._id_key)
        label = f"{self._kind} {ident}" if isinstance(ident, str) and ident else self._kind
        return ApiResponseError(f"{label}: field '{key}' {problem}")

    opt_string = _optional(_string)
    id = _required(_id)
    opt_id = _optional(_id)
    opt_number = _optional(_number)
    integer = _required(_integer)
    opt_integer = _optional(_integer)
    timestamp = _required(_timestamp)
    opt_timestamp = _optional(_timestamp)
    _opt_flag = _optional(_flag)
    _opt_list = _optional(_list)
    _opt_mapping = _optional(_mapping)

    def opt_choice(self, key: str, kind: type[_E]) -> _E | str | None:
        """A member of the open enumeration `kind`, or a value it lacks (one the platform
        added later) as its raw string. Looked up in the enumeration's own value map, which
        `kind(text)` reaches after a slower call through its metaclass."""
        text = self.opt_string(key)
        return None if text is None else kind._value2member_map_.get(text, text)  # type: ignore[return-value]

    def flag(self, key: str) -> bool:
        """A boolean; absent: false."""
        return self._opt_flag(key) or False

    def ids(self, key: str) -> tuple[uuid.UUID, ...]:
        """A list of IDs; absent: empty."""
        items = self._opt_list(key)
        return tuple([_id(self, key, item) for item in items]) if items else ()

    def strings(self, key: str) -> tuple[str, ...]:
        """A list of strings; absent: empty."""
        items = self._opt_list(key)
        return tuple([_string(self, key, item) for item in items]) if items else ()

    def string_map(self, key: str) -> dict[str, str]:
        """An object of strings (the spec's ``additionalProperties: string``); absent: {}."""
        value = self._opt_mapping(key) or {}
        return {str(k): _string(self, f"{key}.{k}", v) for k, v in value.items()}


def _json_type(value: object) -> str:
    match value:
        case None:
            return "null"
        case bool():
            return "a boolean"
        case int() | float():
            return "a number"
        case str():
            return f"the string {value!r}" if len(value) <= 40 else "a string"
        case list():
            return "a list"
        case Mapping():
            return "an object"
    return type(value).__name__
