"""A written metric's handle, and the options every metric method takes.

The writer's metric methods build their proto at once and return a `MetricHandle` on
it; the handle's setters change that proto in place and return the handle, so that
calls chain (``w.scalar(...).describe(...).importance(...)``). `MetricOptions` is the
set of keyword arguments shared by every metric type.
"""

from __future__ import annotations

import uuid
from typing import TYPE_CHECKING, Self, TypedDict

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import MetricImportance, MetricStatus, MetricType
from stook.sdk._errors import WriterError

if TYPE_CHECKING:
    from stook.sdk._output import OutputBuilder


class MetricOptions(TypedDict, total=False):
    """What every metric type takes besides its values."""

    status: MetricStatus  # default PASSED
    description: str
    importance: MetricImportance  # default MEDIUM
    blocking: bool
    event: bool  # written for an event (see MetricsWriter.event); names may repeat


def status_of(options: MetricOptions) -> MetricStatus:
    return options.get("status", MetricStatus.PASSED)


FailureDefinition = tuple[float | None, float | None]


class MetricHandle:
    """A metric in a writer; its setters change it in place and return it for chaining."""

    def __init__(self, writer: OutputBuilder, proto: pb.Metric) -> None:
        self._writer = writer
        self._proto = proto

    @property
    def name(self) -> str:
        return self._proto.name

    @property
    def type(self) -> MetricType:
        return MetricType(self._proto.type)

    @property
    def id(self) -> uuid.UUID:
        return uuid.UUID(self._proto.metric_id.id.data)

    @property
    def proto(self) -> pb.Metric:
        return self._proto

    def describe(self, description: str) -> Self:
        self._proto.description = description
        return self

    def status(self, status: MetricStatus) -> Self:
        self._proto.status = pb.MetricStatus.ValueType(MetricStatus(status))
        return self

    def blocking(self, blocking: bool = True) -> Self:
        self._proto.blocking = blocking
        return self

    def importance(self, importance: MetricImportance) -> Self:
        self._proto.importance = pb.MetricImportance.ValueType(MetricImportance(importance))
        return self

    def display(self, should_display: bool = True) -> Self:
        self._proto.should_display = should_display
        return self

    def order(self, order: float) -> Self:
        self._proto.order = order
        return self

    def tag(self, key: str, value: str) -> Self:
        if not key or not value:
            raise WriterError(f"metric {self.name!r}: a tag needs a non-empty key and value")
        self._proto.tags.add(key=key, value=value)
        return self
