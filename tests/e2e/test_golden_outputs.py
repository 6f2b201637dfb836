"""Batch and report outputs are byte-identical to those recorded before the refactor of
issue 11 (tests/golden/, recorded at 23548c2 with tools/record_golden_outputs.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.golden.cases import CASES, Case, run_case


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_outputs_match_the_recorded_bytes(case: Case, tmp_path: Path) -> None:
    recorded = case.recorded.read_bytes()
    assert run_case(case, tmp_path) == recorded
