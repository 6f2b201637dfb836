"""The field readers every model's ``from_json`` is built from: what they read, and how
they word what they cannot."""

from __future__ import annotations

import uuid
from datetime import UTC, datetime

import pytest

from stook.service.api._errors import ApiResponseError
from stook.service.api._fields import Fields, parse_rfc3339

CANONICAL = "61fbd861-8d13-523b-9236-d0af9a8ecadb"


@pytest.mark.parametrize(
    "text", [CANONICAL, CANONICAL.upper(), CANONICAL.replace("-", ""), "{" + CANONICAL + "}"]
)
def test_an_id_reads_as_uuid_reads_it(text: str) -> None:
    assert Fields("Job", {"jobID": text}, "jobID").id("jobID") == uuid.UUID(CANONICAL)


@pytest.mark.parametrize("text", ["1234", CANONICAL + "0", CANONICAL[:-1] + "g"])
def test_what_is_no_id_is_refused_naming_the_field(text: str) -> None:
    with pytest.raises(ApiResponseError) as caught:
        Fields("Job", {"jobID": text}, "jobID").id("jobID")
    assert str(caught.value) == f"Job {text}: field 'jobID' is not a UUID: {text!r}"


@pytest.mark.parametrize(
    ("text", "moment"),
    [
        # RFC 3339 allows a leap second; it is read as the last instant before it.
        ("2016-12-31T23:59:60Z", datetime(2016, 12, 31, 23, 59, 59, 999_999, tzinfo=UTC)),
        ("2016-12-31T23:59:60.5Z", datetime(2016, 12, 31, 23, 59, 59, 999_999, tzinfo=UTC)),
        ("2016-12-31t23:59:60z", datetime(2016, 12, 31, 23, 59, 59, 999_999, tzinfo=UTC)),
    ],
)
def test_a_leap_second_is_read_not_refused(text: str, moment: datetime) -> None:
    assert parse_rfc3339(text) == moment
    fields = Fields("Job", {"creationTimestamp": text}, "jobID")
    assert fields.opt_timestamp("creationTimestamp") == moment


@pytest.mark.parametrize("text", ["2016-12-31T23:59:61Z", "2016-12-31T23:60:00Z"])
def test_past_a_leap_second_is_no_time(text: str) -> None:
    assert parse_rfc3339(text) is None


def test_a_number_too_large_for_a_double_is_refused_naming_the_field() -> None:
    fields = Fields("JobMetric", {"metricID": CANONICAL, "value": 10**400}, "metricID")
    with pytest.raises(ApiResponseError) as caught:
        fields.opt_number("value")
    assert str(caught.value) == (
        f"JobMetric {CANONICAL}: field 'value' is a number too large for a double"
    )


def test_a_large_integer_a_double_holds_is_read() -> None:
    fields = Fields("JobMetric", {"value": 2**64 + 1}, "metricID")
    assert fields.opt_number("value") == float(2**64)
