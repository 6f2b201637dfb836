"""Reading one API object's JSON into typed values; errors name the object and the field.

What every model's ``from_json`` is built from: strings, IDs, open enumerations (a value
this client does not know is kept as its raw string), numbers, flags and RFC 3339
timestamps, each required or optional, with the API's habit of writing "" for unset.
"""

from __future__ import annotations

import enum
import functools
import re
import uuid
from collections.abc import Callable, Mapping
from datetime import UTC, datetime, timedelta, timezone
from operator import itemgetter
from typing import Any, TypeVar

from stook.sdk.fastpaths import hex_uuid
from stook.service.api._errors import ApiResponseError

__all__ = ["Fields", "field_reader", "new_uuid", "parse_rfc3339", "parse_uuid", "uuid_text"]

_E = TypeVar("_E", bound=enum.Enum)


_UUID = uuid.UUID

# ``uuid.UUID(text)`` in half the time for the hexadecimal forms the API writes (a batch
# run reads ~23 IDs a job); anything else goes to ``uuid.UUID``, which words the error.
new_uuid = hex_uuid


@functools.lru_cache(maxsize=4_096)
def _text_of(number: int) -> str:
    # What `UUID.__str__` writes, without making a UUID of the number first (that
    # `__init__` was two thirds of a miss: every job ID of a report is one).
    digits = f"{number:032x}"
    return f"{digits[:8]}-{digits[8:12]}-{digits[12:16]}-{digits[16:20]}-{digits[20:]}"


def uuid_text(ident: uuid.UUID) -> str:
    """``str(ident)``, remembered by the ID's number.

    Every request's path names its project and batch, and a job's listings name the job
    twice: formatting them each time (``UUID.__str__`` is Python code) cost five times a
    look-up by the number, an int whose hash is computed in C (a UUID's is not).
    """
    return _text_of(ident.int) if type(ident) is _UUID else str(ident)


# A listing repeats its job and batch IDs in every item; parsing each once saves a third of
# the client's CPU per job-metrics page (measured in report mode).
_parse_uuid = parse_uuid = functools.lru_cache(maxsize=16_384)(new_uuid)

# RFC 3339 as the platform's Go encoder writes it (RFC3339Nano: up to nine fractional
# digits) and as the RFC allows it (lower-case t and z, any number of fractional digits).
_RFC3339 = re.compile(
    r"(\d{4})-(\d{2})-(\d{2})[Tt ](\d{2}):(\d{2}):(\d{2})(?:\.(\d+))?"
    r"(?:([Zz])|([+-])(\d{2}):(\d{2}))"
)


def parse_rfc3339(text: str) -> datetime | None:
    """An RFC 3339 timestamp (fractions past microseconds truncated), or None if it is not one.

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
    try:
        return datetime(
            int(year),
            int(month),
            int(day),
            int(hour),
            int(minute),
            int(second),
            int((fraction or "0")[:6].ljust(6, "0")),
            tzinfo=zone,
        )
    except ValueError:  # e.g. month 13, or an offset of a day or more
        return None


class Fields:
    """Reads typed fields from one JSON object; errors name the object and the field."""

    # Each accessor first takes the shape a well-formed answer has (checked by exact type,
    # the cheapest test) and falls back to the general path, which also says what is wrong.
    # A listing item is read field by field, so this is most of the client's parsing time
    # per request (a metric item: 6.0 µs before, 4.3 after).
    __slots__ = ("_data", "_id_key", "_kind")

    def __init__(self, kind: str, data: object, id_key: str) -> None:
        if type(data) is not dict and not isinstance(data, Mapping):
            raise ApiResponseError(f"{kind}: expected a JSON object, got {_json_type(data)}")
        self._data: Mapping[str, Any] = data
        self._kind = kind
        self._id_key = id_key

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
        text = self._to_string(key, value)
        try:
            return _parse_uuid(text)
        except ValueError:
            raise self._error(key, f"is not a UUID: {text!r}") from None

    def _to_choice(self, key: str, value: Any, kind: type[_E]) -> _E | str:
        text = self._to_string(key, value)
        # The value map is what `kind(text)` consults, minus the metaclass call (a tenth of
        # the time spent parsing a job's metric listing). A value it lacks is one the
        # platform added after this client: kept by name, never an error.
        member = kind._value2member_map_.get(text)
        return text if member is None else member  # type: ignore[return-value]

    def _to_integer(self, key: str, value: Any) -> int:
        if isinstance(value, float) and value.is_integer():
            return int(value)
        if not isinstance(value, int) or isinstance(value, bool):
            raise self._error(key, f"should be an integer, got {_json_type(value)}")
        return value

    def _to_timestamp(self, key: str, value: Any) -> datetime:
        text = self._to_string(key, value)
        moment = parse_rfc3339(text)
        if moment is None:
            raise self._error(key, f"is not an RFC 3339 timestamp: {text!r}")
        if moment.tzinfo is None:
            raise self._error(key, f"has no time zone: {text!r}")
        return moment

    # -- accessors -------------------------------------------------------------------------

    def opt_string(self, key: str) -> str | None:
        value = self._data.get(key)
        if type(value) is str:
            return value or None
        value = self._optional(key)
        return None if value is None else self._to_string(key, value)

    def id(self, key: str) -> uuid.UUID:
        value = self._data.get(key)
        if type(value) is str and value:
            try:
                return _parse_uuid(value)
            except ValueError:
                pass  # said below
        return self._to_id(key, self._required(key))

    def opt_id(self, key: str) -> uuid.UUID | None:
        value = self._data.get(key)
        if type(value) is str:
            if not value:
                return None
            try:
                return _parse_uuid(value)
            except ValueError:
                pass  # said below
        value = self._optional(key)
        return None if value is None else self._to_id(key, value)

    def ids(self, key: str) -> tuple[uuid.UUID, ...]:
        value = self._data.get(key)
        if type(value) is list and not value:
            return ()
        if type(value) is list and all(type(item) is str for item in value):
            try:
                return tuple(map(_parse_uuid, value))
            except ValueError:
                pass  # the general path below names the item at fault
        value = self._optional(key)
        if value is None:
            return ()
        if not isinstance(value, list):
            raise self._error(key, f"should be a list, got {_json_type(value)}")
        return tuple(self._to_id(key, item) for item in value)

    def strings(self, key: str) -> tuple[str, ...]:
        """A list of strings; absent or null: empty."""
        value = self._optional(key)
        if value is None:
            return ()
        if not isinstance(value, list):
            raise self._error(key, f"should be a list, got {_json_type(value)}")
        return tuple(self._to_string(key, item) for item in value)

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
        if type(value) is str and value:
            member = kind._value2member_map_.get(value)
            return value if member is None else member  # type: ignore[return-value]
        value = self._optional(key)
        return default if value is None else self._to_choice(key, value, kind)

    def opt_choice(self, key: str, kind: type[_E]) -> _E | str | None:
        value = self._data.get(key)
        if type(value) is str and value:
            member = kind._value2member_map_.get(value)
            return value if member is None else member  # type: ignore[return-value]
        value = self._optional(key)
        return None if value is None else self._to_choice(key, value, kind)

    def opt_number(self, key: str) -> float | None:
        value = self._data.get(key)
        if type(value) is float:
            return value
        value = self._optional(key)
        if value is None:
            return None
        # bool is an int in Python but never a metric value.
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise self._error(key, f"should be a number, got {_json_type(value)}")
        return float(value)

    def integer(self, key: str) -> int:
        return self._to_integer(key, self._required(key))

    def opt_integer(self, key: str) -> int | None:
        value = self._optional(key)
        return None if value is None else self._to_integer(key, value)

    def flag(self, key: str, *, default: bool) -> bool:
        value = self._data.get(key)
        if type(value) is bool:
            return value
        value = self._optional(key)
        if value is None:
            return default
        if not isinstance(value, bool):
            raise self._error(key, f"should be true or false, got {_json_type(value)}")
        return value

    def timestamp(self, key: str) -> datetime:
        return self._to_timestamp(key, self._required(key))

    def opt_timestamp(self, key: str) -> datetime | None:
        value = self._optional(key)
        return None if value is None else self._to_timestamp(key, value)


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


def field_reader(keys: tuple[str, ...]) -> Callable[[Mapping[str, Any]], tuple[Any, ...]]:
    """The values of `keys` in an item of a listing, as a tuple, in one call (KeyError when
    the item leaves one out).

    The keys are looked up as orjson makes them: it keeps one string per short key for the
    whole process (its key cache), so each field is found by identity, where a string of
    the same text made elsewhere costs a comparison of the text per lookup (a sixth of
    reading a metric listing). They are equal to `keys` whatever orjson does: only the
    speed depends on it. Call it once the first answer has come (orjson is imported then).
    """
    import orjson

    as_read = tuple(orjson.loads(orjson.dumps(dict.fromkeys(keys))))
    assert as_read == keys
    return itemgetter(*as_read)
