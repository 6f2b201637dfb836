"""The configuration page's stook.toml example builds the job-data built-ins it shows, as
written."""

from __future__ import annotations

import tomllib

from stook.sdk.aggregations import (
    ByExperienceTag,
    CategoryTotals,
    EventCounts,
    MergedHistogram,
    ParameterSweep,
    build_all,
)
from tests.docs_examples import block

KINDS = ("histogram", "category_totals", "events", "sweep", "by_tag")


def test_the_config_page_tables_build() -> None:
    config = tomllib.loads(block("docs/configuration.md", "[[batch.sweep]]", "toml"))
    tables = {kind: config["batch"][kind] for kind in KINDS}
    built = build_all(tables, section="batch")
    by_type = {type(a): a for a in built}
    assert set(by_type) == {
        MergedHistogram,
        CategoryTotals,
        EventCounts,
        ParameterSweep,
        ByExperienceTag,
    }
    metric_histogram = [a for a in built if isinstance(a, MergedHistogram) and a.metric]
    assert [a.metric for a in metric_histogram] == ["Acceleration distribution"]
    assert by_type[ParameterSweep].needs().scalars == {"Braking distance", "Collisions"}
