from collections import Counter
from types import MappingProxyType

from stook.sdk.aggregations._columns import values_by_name


class _OwnGet(dict[str, int]):
    def get(self, key: str, default: object = None) -> int:
        return 7


def test_columns_of_dicts_and_of_other_mappings_agree() -> None:
    jobs = [{"a": 1, "b": 2}, {}, {"b": 3}]
    want = [[1, None, None], [2, None, 3], [None, None, None]]
    assert values_by_name(jobs, ["a", "b", "c"]) == want
    assert values_by_name([MappingProxyType(j) for j in jobs], ["a", "b", "c"]) == want
    # Mixed: any mapping not an exact dict is read through its own get.
    mixed = [jobs[0], MappingProxyType(jobs[1]), Counter(jobs[2])]
    assert values_by_name(mixed, ["a", "b", "c"]) == want
    assert values_by_name([], ["a"]) == [[]]


def test_a_dict_subclass_is_read_through_its_own_get() -> None:
    assert values_by_name([_OwnGet(a=1)], ["a", "z"]) == [[7], [7]]
