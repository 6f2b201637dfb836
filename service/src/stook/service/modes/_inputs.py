"""What the platform hands a metrics build in its inputs folder, and which mode that means.

The rules are the platform's (see shared/seeds/001): ``report_config.json`` present
means report mode, even beside a batch config; else ``batch_metrics_config.json``
means batch mode; else test mode, with ``experience/`` and ``logs/`` folders.
"""

from __future__ import annotations

import difflib
import json
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from stook.service.modes._errors import InputsError

REPORT_CONFIG = "report_config.json"
BATCH_CONFIG = "batch_metrics_config.json"
# How alike a file name must be to a config's to count as a misspelling of it: enough for
# "batch_metric_config.json" or "report-config.json", not for "config.json".
_MISSPELT_CUTOFF = 0.8


@dataclass(frozen=True, slots=True)
class ApiAccess:
    """Where the API is and the token for it. The token never shows in repr or str."""

    api_url: str
    token: str = field(repr=False)
    project_id: uuid.UUID


@dataclass(frozen=True, slots=True)
class BatchInputs:
    access: ApiAccess
    batch_id: uuid.UUID


@dataclass(frozen=True, slots=True)
class ReportInputs:
    access: ApiAccess
    report_id: uuid.UUID


@dataclass(frozen=True, slots=True)
class TestInputs:
    experience_dir: Path
    logs_dir: Path


Inputs = BatchInputs | ReportInputs | TestInputs


def detect(inputs_dir: Path, *, project_id: uuid.UUID | None = None) -> Inputs:
    """Read the inputs folder the way the platform documents it."""
    if not inputs_dir.is_dir():
        raise InputsError(f"inputs folder {str(inputs_dir)!r} does not exist")
    report = inputs_dir / REPORT_CONFIG
    if report.exists():
        doc = _load(report)
        return ReportInputs(
            access=_access(report, doc, project_id, project_required=True),
            report_id=_uuid(report, doc, "reportID"),
        )
    batch = inputs_dir / BATCH_CONFIG
    if batch.exists():
        doc = _load(batch)
        return BatchInputs(
            access=_access(batch, doc, project_id, project_required=False),
            batch_id=_uuid(batch, doc, "batchID"),
        )
    experience, logs = inputs_dir / "experience", inputs_dir / "logs"
    if not experience.is_dir() and not logs.is_dir():
        _refuse_misspelt_config(inputs_dir)
    return TestInputs(experience_dir=experience, logs_dir=logs)


def _refuse_misspelt_config(inputs_dir: Path) -> None:
    """Without a platform config and without test mode's folders, a file named almost like
    a config is a typo, not a test: running test mode would write an empty output and exit
    0, hiding that the batch or report was never looked at."""
    try:
        names = sorted(entry.name for entry in inputs_dir.iterdir() if entry.is_file())
    except OSError:
        return
    for name in names:
        close = difflib.get_close_matches(
            name.lower(), (BATCH_CONFIG, REPORT_CONFIG), n=1, cutoff=_MISSPELT_CUTOFF
        )
        if close:
            raise InputsError(
                f"inputs folder {str(inputs_dir)!r} has {name!r} but no {BATCH_CONFIG}, "
                f"{REPORT_CONFIG}, experience/ or logs/: did you mean {close[0]}?"
            )


def _load(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputsError(f"{path.name}: cannot be read ({exc.__class__.__name__})") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputsError(
            f"{path.name}: not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})"
        ) from None
    if not isinstance(doc, dict):
        raise InputsError(f"{path.name}: must hold a JSON object, not {type(doc).__name__}")
    return doc


def _string(path: Path, doc: dict[str, Any], key: str) -> str:
    if key not in doc:
        raise InputsError(f"{path.name}: missing key {key!r}")
    value = doc[key]
    if not isinstance(value, str) or not value.strip():
        raise InputsError(f"{path.name}: {key!r} must be a non-empty string")
    return value.strip()


def _uuid(path: Path, doc: dict[str, Any], key: str) -> uuid.UUID:
    value = _string(path, doc, key)
    try:
        return uuid.UUID(value)
    except ValueError:
        shown = value if len(value) <= 40 else value[:37] + "..."
        raise InputsError(f"{path.name}: {key!r} is not a UUID: {shown!r}") from None


def _access(
    path: Path, doc: dict[str, Any], project_id: uuid.UUID | None, *, project_required: bool
) -> ApiAccess:
    token = _string(path, doc, "authToken")
    api_url = _string(path, doc, "apiURL").rstrip("/")
    parts = urlsplit(api_url)
    if parts.scheme not in ("http", "https") or not parts.netloc:
        raise InputsError(f"{path.name}: 'apiURL' is not an http(s) URL")
    if "projectID" in doc:
        project = _uuid(path, doc, "projectID")
    elif project_id is not None:
        project = project_id
    else:
        hint = "" if project_required else " (older batch configs lack it)"
        raise InputsError(
            f"{path.name}: missing key 'projectID'{hint}; pass --project-id or set STOOK_PROJECT_ID"
        )
    return ApiAccess(api_url=api_url, token=token, project_id=project)
