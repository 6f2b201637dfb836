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

__all__ = ["Fields", "parse_rfc3339", "parse_uuid"]

_E = TypeVar("_E", bound=enum.Enum)
_T = TypeVar("_T")


def parse_uuid(text: str) -> uuid.UUID:
    """An ID as ``uuid.UUID(text)`` reads it (ValueError when it is not one).

    msgspec parses the API's spelling in C, in two fifths of ``uuid.UUID``'s time (every
    listed item has IDs); other spellings ``uuid.UUID`` accepts (braces, ``urn:uuid:``) go to it.
    """
    try:
        return msgspec.convert(text, uuid.UUID)
    except msgspec.ValidationError:
        return uuid.UUID(text)


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

    def _optional(self, key: str, convert: Callable[[str, Any], _T]) -> _T | None:
        value = self._data.get(key)
        return None if value is None or value == "" else convert(key, value)

    def _required(self, key: str, convert: Callable[[str, Any], _T]) -> _T:
        value = self._optional(key, convert)
        if value is None:
            raise self._error(key, "is missing")
        return value

    # -- converters: a present value to its type -----------------------------------------

    def _to_string(self, key: str, value: Any) -> str:
        if not isinstance(value, str):
            raise self._error(key, f"should be a string, got {_json_type(value)}")
        return value

    def _to_id(self, key: str, value: Any) -> uuid.UUID:
        text = self._to_string(key, value)
        try:
            return parse_uuid(text)
        except ValueError:
            raise self._error(key, f"is not a UUID: {text!r}") from None

    def _to_integer(self, key: str, value: Any) -> int:
        if isinstance(value, float) and value.is_integer():
            return int(value)
        if not isinstance(value, int) or isinstance(value, bool):
            raise self._error(key, f"should be an integer, got {_json_type(value)}")
        return value

    def _to_number(self, key: str, value: Any) -> float:
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise self._error(key, f"should be a number, got {_json_type(value)}")
        try:
            return float(value)
        except OverflowError:  # an integer of hundreds of digits
            raise self._error(key, "is a number too large for a double") from None

    def _to_flag(self, key: str, value: Any) -> bool:
        if not isinstance(value, bool):
            raise self._error(key, f"should be true or false, got {_json_type(value)}")
        return value

    def _to_timestamp(self, key: str, value: Any) -> datetime:
        text = self._to_string(key, value)
        moment = parse_rfc3339(text)
        if moment is None:
            raise self._error(key, f"is not an RFC 3339 timestamp: {text!r}")
        if moment.tzinfo is None:
            raise self._error(key, f"has no time zone: {text!r}")
        return moment

    def _to_list(self, key: str, value: Any) -> list[Any]:
        if not isinstance(value, list):
            raise self._error(key, f"should be a list, got {_json_type(value)}")
        return value

    def _to_mapping(self, key: str, value: Any) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self._error(key, f"should be an object, got {_json_type(value)}")
        return value

    # -- accessors -----------------------------------------------------------------------

    def opt_string(self, key: str) -> str | None:
        return self._optional(key, self._to_string)

    def id(self, key: str) -> uuid.UUID:
        return self._required(key, self._to_id)

    def opt_id(self, key: str) -> uuid.UUID | None:
        return self._optional(key, self._to_id)

    def opt_choice(self, key: str, kind: type[_E]) -> _E | str | None:
        """A member of the open enumeration `kind`; a value it lacks (one the platform
        added after this client) is kept as its raw string, never an error."""
        text = self.opt_string(key)
        if text is None:
            return None
        try:
            return kind(text)
        except ValueError:
            return text

    def opt_number(self, key: str) -> float | None:
        return self._optional(key, self._to_number)

    def integer(self, key: str) -> int:
        return self._required(key, self._to_integer)

    def opt_integer(self, key: str) -> int | None:
        return self._optional(key, self._to_integer)

    def flag(self, key: str) -> bool:
        """A boolean; absent: false."""
        return self._optional(key, self._to_flag) or False

    def timestamp(self, key: str) -> datetime:
        return self._required(key, self._to_timestamp)

    def opt_timestamp(self, key: str) -> datetime | None:
        return self._optional(key, self._to_timestamp)

    def ids(self, key: str) -> tuple[uuid.UUID, ...]:
        """A list of IDs; absent: empty."""
        items = self._optional(key, self._to_list) or ()
        return tuple([self._to_id(key, item) for item in items])

    def strings(self, key: str) -> tuple[str, ...]:
        """A list of strings; absent: empty."""
        items = self._optional(key, self._to_list) or ()
        return tuple([self._to_string(key, item) for item in items])

    def string_map(self, key: str) -> dict[str, str]:
        """An object of strings (the spec's ``additionalProperties: string``); absent: {}."""
        value = self._optional(key, self._to_mapping) or {}
        return {str(k): self._to_string(f"{key}.{k}", v) for k, v in value.items()}


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
