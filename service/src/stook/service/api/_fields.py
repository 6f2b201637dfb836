"""Reading one API object's JSON into typed values; errors name the object and the field.

What every model's ``from_json`` is built from: strings, IDs, open enumerations (a value
this client does not know is kept as its raw string), numbers, flags and RFC 3339
timestamps, each required or optional, with the API's habit of writing "" for unset.
"""

from __future__ import annotations

import enum
import re
import uuid
from collections.abc import Mapping
from datetime import UTC, datetime, timedelta, timezone
from typing import Any, TypeVar

import msgspec

from stook.service.api._errors import ApiResponseError

__all__ = ["Fields", "parse_rfc3339", "parse_uuid"]

_E = TypeVar("_E", bound=enum.Enum)


def parse_uuid(text: str) -> uuid.UUID:
    """An ID as ``uuid.UUID(text)`` reads it (ValueError when it is not one).

    The form the API writes (RFC 4122's hex digits, hyphenated or not) is parsed by
    msgspec, in C, in two fifths of the time ``uuid.UUID`` takes: each item of a listing has
    an ID of its own, and that was a sixth of the item's decoding. Any other spelling that
    ``uuid.UUID`` accepts (braces, a ``urn:uuid:`` prefix) goes to it.
    """
    try:
        return msgspec.convert(text, uuid.UUID)
    except msgspec.ValidationError:
        return uuid.UUID(text)


# RFC 3339 as the platform's Go encoder writes it (RFC3339Nano: up to nine fractional
# digits) and as the RFC allows it (lower-case t and z, any number of fractional digits).
_RFC3339 = re.compile(
    r"(\d{4})-(\d{2})-(\d{2})[Tt ](\d{2}):(\d{2}):(\d{2})(?:\.(\d+))?"
    r"(?:([Zz])|([+-])(\d{2}):(\d{2}))"
)


def parse_rfc3339(text: str) -> datetime | None:
    """An RFC 3339 timestamp (fractions past microseconds truncated; a leap second as
    :59.999999), or None if it is not one.

    ``datetime.fromisoformat`` reads most of them and is fast, so it goes first; the
    rest (a lower-case "t" or "z"; more fractional digits than a given Python reads) are
    read here, so the result does not depend on the Python release.
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
    if second == "60":
        # A leap second (RFC 3339 allows :60), which datetime cannot hold: read as the
        # last instant of the minute before it, so the order of times is kept.
        second, micros = "59", 999_999
    try:
        return datetime(
            int(year),
            int(month),
            int(day),
            int(hour),
            int(minute),
            int(second),
            micros,
            tzinfo=zone,
        )
    except ValueError:  # e.g. month 13, or an offset of a day or more
        return None


class Fields:
    """Reads typed fields from one JSON object; errors name the object and the field.

    ``ids``, when given, holds other objects' IDs read before, by their text, and gets
    those read here (`opt_id`): the items of a listing repeat their owner's IDs (a job's
    metrics each name the job and the batch), and each is then parsed once (see
    ``ApiClient._ids``).
    """

    __slots__ = ("_data", "_id_key", "_ids", "_kind")

    def __init__(
        self, kind: str, data: object, id_key: str, ids: dict[str, uuid.UUID] | None = None
    ) -> None:
        # A dict (what the JSON parser makes) is told by its type, in a fraction of the
        # time a check against the Mapping ABC takes.
        if type(data) is not dict and not isinstance(data, Mapping):
            raise ApiResponseError(f"{kind}: expected a JSON object, got {_json_type(data)}")
        self._data: Mapping[str, Any] = data
        self._kind = kind
        self._id_key = id_key
        self._ids = ids

    @property
    def _label(self) -> str:
        # Made only for an error message: most objects never need one.
        ident = self._data.get(self._id_key)
        return f"{self._kind} {ident}" if isinstance(ident, str) and ident else self._kind

    def _error(self, key: str, problem: str) -> ApiResponseError:
        return ApiResponseError(f"{self._label}: field '{key}' {problem}")

    def _required(self, key: str) -> Any:
        value = self._data.get(key)
        if value is None or value == "":
            raise self._error(key, "is missing")
        return value

    def _optional(self, key: str) -> Any:
        # The API's Go encoder writes "" for unset strings as often as it omits them.
        value = self._data.get(key)
        return None if value == "" else value

    # -- converters: a present value to its type -----------------------------------------

    def _to_string(self, key: str, value: Any) -> str:
        if not isinstance(value, str):
            raise self._error(key, f"should be a string, got {_json_type(value)}")
        return value

    def _to_id(self, key: str, value: Any) -> uuid.UUID:
        text = value if type(value) is str else self._to_string(key, value)
        try:
            return parse_uuid(text)
        except ValueError:
            raise self._error(key, f"is not a UUID: {text!r}") from None

    def _to_choice(self, key: str, value: Any, kind: type[_E]) -> _E | str:
        text = self._to_string(key, value)
        # The enumeration's own map of values to members, which `kind(text)` consults
        # after a slower call through its metaclass. A value it lacks is one the platform
        # added after this client: kept by name, never an error.
        member = kind._value2member_map_.get(text)
        return text if member is None else member  # type: ignore[return-value]

    def _to_integer(self, key: str, value: Any) -> int:
        if isinstance(value, float) and value.is_integer():
            return int(value)
        if not isinstance(value, int) or isinstance(value, bool):
            raise self._error(key, f"should be an integer, got {_json_type(value)}")
        return value

    def _to_number(self, key: str, value: Any) -> float:
        # bool is an int in Python but never a number here.
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise self._error(key, f"should be a number, got {_json_type(value)}")
        try:
            return float(value)
        except OverflowError:  # an integer of hundreds of digits
            raise self._error(key, "is a number too large for a double") from None

    def _to_timestamp(self, key: str, value: Any) -> datetime:
        text = self._to_string(key, value)
        moment = parse_rfc3339(text)
        if moment is None:
            raise self._error(key, f"is not an RFC 3339 timestamp: {text!r}")
        if moment.tzinfo is None:
            raise self._error(key, f"has no time zone: {text!r}")
        return moment

    # -- accessors -------------------------------------------------------------------------
    #
    # Each takes the shape a well-formed answer has first (a string, a list of strings, a
    # float), with one look-up of the key, and leaves everything else to the converters
    # above, which also say what is wrong. A listing is read field by field, item by item:
    # this is most of the client's own CPU per request.

    def opt_string(self, key: str) -> str | None:
        value = self._data.get(key)
        if type(value) is str:
            return value or None
        return None if value is None else self._to_string(key, value)

    def id(self, key: str) -> uuid.UUID:
        value = self._data.get(key)
        if value is None or value == "":
            raise self._error(key, "is missing")
        return self._to_id(key, value)

    def opt_id(self, key: str) -> uuid.UUID | None:
        """Another object's ID (a listing's items name the same job and batch): looked up
        in ``ids``, and parsed once. An object's own ID (`id`) is its own, never looked up
        or kept: that would fill ``ids`` with IDs no other item names."""
        value = self._data.get(key)
        if value is None or value == "":
            return None
        ids = self._ids
        if ids is None:
            return self._to_id(key, value)
        known = ids.get(value) if type(value) is str else None
        if known is None:
            known = ids[value] = self._to_id(key, value)
        return known

    def ids(self, key: str) -> tuple[uuid.UUID, ...]:
        """A list of IDs; absent or null: empty."""
        value = self._data.get(key)
        if type(value) is list:
            return tuple([self._to_id(key, item) for item in value]) if value else ()
        if value is None or value == "":
            return ()
        raise self._error(key, f"should be a list, got {_json_type(value)}")

    def strings(self, key: str) -> tuple[str, ...]:
        """A list of strings; absent or null: empty."""
        value = self._optional(key)
        if value is None:
            return ()
        if not isinstance(value, list):
            raise self._error(key, f"should be a list, got {_json_type(value)}")
        return tuple([self._to_string(key, item) for item in value])

    def string_map(self, key: str) -> dict[str, str]:
        """An object of strings (the spec's ``additionalProperties: string``); absent: {}."""
        value = self._optional(key)
        if value is None:
            return {}
        if not isinstance(value, Mapping):
            raise self._error(key, f"should be an object, got {_json_type(value)}")
        return {str(k): self._to_string(f"{key}.{k}", v) for k, v in value.items()}

    def choice(self, key: str, kind: type[_E], *, default: _E) -> _E | str:
        value = self._data.get(key)
        if type(value) is str and value:  # as `_to_choice` reads a string, without the call
            member = kind._value2member_map_.get(value)
            return value if member is None else member  # type: ignore[return-value]
        if value is None or value == "":
            return default
        return self._to_choice(key, value, kind)

    def opt_choice(self, key: str, kind: type[_E]) -> _E | str | None:
        value = self._data.get(key)
        if type(value) is str and value:  # as in `choice`
            member = kind._value2member_map_.get(value)
            return value if member is None else member  # type: ignore[return-value]
        if value is None or value == "":
            return None
        return self._to_choice(key, value, kind)

    def opt_number(self, key: str) -> float | None:
        value = self._data.get(key)
        if type(value) is float:
            return value
        if value is None or value == "":
            return None
        return self._to_number(key, value)

    def integer(self, key: str) -> int:
        return self._to_integer(key, self._required(key))

    def opt_integer(self, key: str) -> int | None:
        value = self._optional(key)
        return None if value is None else self._to_integer(key, value)

    def flag(self, key: str, *, default: bool) -> bool:
        value = self._data.get(key)
        if type(value) is bool:
            return value
        if value is None or value == "":
            return default
        raise self._error(key, f"should be true or false, got {_json_type(value)}")

    def timestamp(self, key: str) -> datetime:
        return self._to_timestamp(key, self._required(key))

    def opt_timestamp(self, key: str) -> datetime | None:
        value = self._data.get(key)
        if value is None or value == "":
            return None
        if type(value) is str:
            try:  # what parse_rfc3339 tries first: most timestamps the API writes
                moment = datetime.fromisoformat(value)
            except ValueError:
                pass
            else:
                if moment.tzinfo is not None:
                    return moment
        return self._to_timestamp(key, value)


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
