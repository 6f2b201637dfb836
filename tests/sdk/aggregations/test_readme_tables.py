"""The README's stook.toml example builds the job-data built-ins it shows, as written."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from stook.sdk.aggregations import (
    ByExperienceTag,
    CategoryTotals,
    EventCounts,
    MergedHistogram,
    ParameterSweep,
    build_all,
)

README = Path(__file__).resolve().parents[3] / "README.md"
KINDS = ("histogram", "category_totals", "events", "sweep", "by_tag")


def test_the_readme_tables_build() -> None:
    blocks = re.findall(r"```toml\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    config = tomllib.loads(next(b for b in blocks if "[[batch.sweep]]" in b))
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
