"""A job's metadata: the `metadata` table's row, and the ID columns of its topic rows."""

from __future__ import annotations

import dataclasses
import datetime as dt
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from stook.service.metrics_config._errors import EmissionsError

# The keys whose values are lists of strings.
_LISTS = ("tags", "custom_field_keys", "custom_field_values")


@dataclass(frozen=True, slots=True)
class JobMeta:
    """What a mode (or a job.json) knows about one job. IDs are text (UUIDs as str).

    The experience's custom fields are two parallel lists, as in the platform's
    `metadata` table (`custom_field_values[array_position(custom_field_keys, 'k')]`): one
    pair per value, so a field of several values repeats its key;
    `build_creation_timestamp` is UTC (a naive datetime is taken as UTC)."""

    job_id: str
    batch_id: str | None = None
    project_id: str | None = None
    experience_id: str | None = None
    experience_name: str | None = None
    build_id: str | None = None
    build_version: str | None = None
    batch_name: str | None = None
    job_status: str | None = None
    job_conflated_status: str | None = None
    branch: str | None = None
    tags: tuple[str, ...] = ()
    custom_field_keys: tuple[str, ...] = ()
    custom_field_values: tuple[str, ...] = ()
    build_creation_timestamp: dt.datetime | None = None

    def __post_init__(self) -> None:
        problem = _custom_fields_problem(self.custom_field_keys, self.custom_field_values)
        if problem:
            raise EmissionsError(f"job {self.job_id}: {problem}")

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], *, source: str = "job metadata") -> JobMeta:
        """From a mapping with these keys (`job_id` required; others default to null)."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise EmissionsError(
                f"{source}: unknown key(s) {', '.join(map(repr, unknown))} "
                f"(known: {', '.join(sorted(known))})"
            )
        fields: dict[str, Any] = {}
        for key, value in values.items():
            if key in _LISTS:
                if not isinstance(value, list | tuple) or not all(
                    isinstance(t, str) for t in value
                ):
                    raise EmissionsError(f"{source}: {key!r} must be a list of strings")
                fields[key] = tuple(value)
            elif key == "build_creation_timestamp":
                fields[key] = _utc(value, source)
            elif value is None or isinstance(value, str):
                fields[key] = value
            elif isinstance(value, int | float) and not isinstance(value, bool):
                fields[key] = str(value)
            else:
                raise EmissionsError(f"{source}: {key!r} must be a string, not {value!r:.40}")
        if not fields.get("job_id"):
            raise EmissionsError(f"{source}: 'job_id' is required")
        problem = _custom_fields_problem(
            fields.get("custom_field_keys", ()), fields.get("custom_field_values", ())
        )
        if problem:
            raise EmissionsError(f"{source}: {problem}")
        return cls(**fields)


def _custom_fields_problem(keys: tuple[str, ...], values: tuple[str, ...]) -> str | None:
    if len(keys) != len(values):
        return (
            f"{len(keys)} custom_field_keys but {len(values)} custom_field_values "
            "(one value per key)"
        )
    return None


def _utc(value: Any, source: str) -> dt.datetime | None:
    """An RFC 3339 text (or a datetime) as a naive UTC datetime, the metadata column's."""
    if value is None:
        return None
    stamp: object = value
    if isinstance(value, str):
        try:
            stamp = dt.datetime.fromisoformat(value)
        except ValueError:
            raise EmissionsError(
                f"{source}: 'build_creation_timestamp' must be an RFC 3339 time "
                f"(2025-01-18T14:03:00Z), not {value!r:.40}"
            ) from None
    if not isinstance(stamp, dt.datetime):
        raise EmissionsError(
            f"{source}: 'build_creation_timestamp' must be an RFC 3339 time, not {value!r:.40}"
        )
    if stamp.tzinfo is not None:
        stamp = stamp.astimezone(dt.UTC).replace(tzinfo=None)
    return stamp


METADATA_COLUMNS = tuple(f.name for f in dataclasses.fields(JobMeta))
