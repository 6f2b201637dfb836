"""Which unit to report when jobs disagree: the most common one, ties broken by name.

Keeping "the first unit seen" would make the output depend on the order jobs arrive in.
"""

from __future__ import annotations

from collections import Counter


def pick_unit(units: Counter[str]) -> str:
    named = [(-count, unit) for unit, count in units.items() if unit]
    return min(named)[1] if named else ""
