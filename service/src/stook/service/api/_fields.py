"""Reading one API object's JSON into typed values; errors name the object and the field.

One accessor per shape (string, ID, open enumeration, number, integer, flag, RFC 3339
timestamp, list), each a converter behind `Fields._optional`: absent, null and "" (the
API's Go encoder writes "" for unset) all read as unset.
"""

from __future__ import annotations

import enum
import re
import uuid
from collections.abc import Callable, Mapping
from datetime import UTC, datetime, timedelta, timezone
from typing import Any, TypeVar

import msgspec

from stook.service.api._errors import ApiResponseError

__all__ = ["Fields", "parse_rfc3339"]

_E = TypeVar("_E", bound=enum.Enum)
_T = TypeVar("_T")
# A present value to its type, or an error naming the object and field (`Fields._error`).
_Converter = Callable[["Fields", str, Any], _T]


# RFC 3339 as the platform's Go encoder writes it (up to nine fractional digits) and as the
# RFC allows it (lower-case t and z, any number of fractional digits).
_RFC3339 = re.compile(
    r"(\d{4})-(\d{2})-(\d{2})[Tt ](\d{2}):(\d{2}):(\d{2})(?:\.(\d+))?"
    r"(?:([Zz])|([+-])(\d{2}):(\d{2}))"
)


def parse_rfc3339(text: str) -> datetime | None:
    """An RFC 3339 timestamp (fractions past microseconds truncated; a leap second as
    :59.999999), or None if it is not one.

    ``datetime.fromisoformat`` reads most and is fast; the rest (lower-case "t" or "z", more
    fractional digits than a given Python reads) are read here, whatever the Python release.
    """
    try:
        return datetime.fromisoformat(text)
    except ValueError:
        pass
    match = _RFC3339.fullmatch(text)
    if match is None:
        return None
    year, month, day, hour, minute, second, fraction, zulu, sign, off_h, off_m = match.groups()
    if zulu:
        zone: timezone = UTC
    else:
        offset = timedelta(hours=int(off_h), minutes=int(off_m))
        zone = timezone(-offset if sign == "-" else offset)
    micros = int((fraction or "0")[:6].ljust(6, "0"))
    if second == "60":  # datetime cannot hold a leap second: the instant before it keeps order
        second, micros = "59", 999_999
    try:
        return datetime(
            int(year), int(month), int(day), int(hour), int(minute), int(second), micros, zone
        )
    except ValueError:  # e.g. month 13, or an offset of a day or more
        return None


def _optional(convert: _Converter[_T]) -> Callable[[Fields, str], _T | None]:
    """The accessor of an optional field: absent, null and "" (the API's Go encoder writes
    "" for unset) read as None, any other value through `convert`."""

    def read(fields: Fields, key: str) -> _T | None:
        value = fields._data.get(key)
        return None if value is None or value == "" else convert(fields, key, value)

    return read


def _required(convert: _Converter[_T]) -> Callable[[Fields, str], _T]:
    """The accessor of a required field: absent, null and "" are an error."""

    def read(fields: Fields, key: str) -> _T:
        value = fields._data.get(key)
        if value is None or value == "":
            raise fields._error(key, "is missing")
        return convert(fields, key, value)

    return read


def _string(fields: Fields, key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise fields._error(key, f"should be a string, got {_json_type(value)}")
    return value


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
    if not isinstance(value, int | float) or isinstance(value, bool):
        raise fields._error(key, f"should be a number, got {_json_type(value)}")
    try:
        return float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise fields._error(key, "is a number too large for a double") from None


def _flag(fields: Fields, key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise fields._error(key, f"should be true or false, got {_json_type(value)}")
    return value


def _timestamp(fields: Fields, key: str, value: Any) -> datetime:
    text = _string(fields, key, value)
    moment = parse_rfc3339(text)
    if moment is None:
        raise fields._error(key, f"is not an RFC 3339 timestamp: {text!r}")
    if moment.tzinfo is None:
        raise fields._error(key, f"has no time zone: {text!r}")
    return moment


def _list(fields: Fields, key: str, value: Any) -> list[Any]:
    if not isinstance(value, list):
        raise fields._error(key, f"should be a list, got {_json_type(value)}")
    return value


def _mapping(fields: Fields, key: str, value: Any) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise fields._error(key, f"should be an object, got {_json_type(value)}")
    return value


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

    def opt_choice(self, key: str, kind: type[_E]) -> _E | str | None:
        """A member of the open enumeration `kind`; a value it lacks (one the platform
        added after this client) is kept as its raw string, never an error."""
        text = self.opt_string(key)
        # The enumeration's own map of values to members, which `kind(text)` consults
        # after a slower call through its metaclass.
        return None if text is None else kind._value2member_map_.get(text, text)  # type: ignore[return-value]

    opt_number = _optional(_number)

    integer = _required(_integer)

    opt_integer = _optional(_integer)

    def flag(self, key: str) -> bool:
        """A boolean; absent: false."""
        return self._opt_flag(key) or False

    timestamp = _required(_timestamp)

    opt_timestamp = _optional(_timestamp)

    def ids(self, key: str) -> tuple[uuid.UUID, ...]:
        """A list of IDs; absent: empty."""
        return tuple([_id(self, key, item) for item in self._opt_list(key) or ()])

    def strings(self, key: str) -> tuple[str, ...]:
        """A list of strings; absent: empty."""
        return tuple([_string(self, key, item) for item in self._opt_list(key) or ()])

    def string_map(self, key: str) -> dict[str, str]:
        """An object of strings (the spec's ``additionalProperties: string``); absent: {}."""
        value = self._opt_mapping(key) or {}
        return {str(k): _string(self, f"{key}.{k}", v) for k, v in value.items()}

    _opt_flag = _optional(_flag)
    _opt_list = _optional(_list)
    _opt_mapping = _optional(_mapping)


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
