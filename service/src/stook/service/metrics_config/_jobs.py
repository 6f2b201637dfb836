"""A job's metadata: the `metadata` table's row, and the ID columns of its topic rows."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from stook.service.metrics_config._errors import EmissionsError


@dataclass(frozen=True, slots=True)
class JobMeta:
    """What a mode (or a job.json) knows about one job. IDs are text (UUIDs as str)."""

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
            if key == "tags":
                if not isinstance(value, list | tuple) or not all(
                    isinstance(t, str) for t in value
                ):
                    raise EmissionsError(f"{source}: 'tags' must be a list of strings")
                fields[key] = tuple(value)
            elif value is None or isinstance(value, str):
                fields[key] = value
            elif isinstance(value, int | float) and not isinstance(value, bool):
                fields[key] = str(value)
            else:
                raise EmissionsError(f"{source}: {key!r} must be a string, not {value!r:.40}")
        if not fields.get("job_id"):
            raise EmissionsError(f"{source}: 'job_id' is required")
        return cls(**fields)


METADATA_COLUMNS = tuple(f.name for f in dataclasses.fields(JobMeta))
