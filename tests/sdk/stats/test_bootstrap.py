"""The seeded bootstrap of a difference in means: deterministic, paired or not, and its
95 % interval covers the true difference in at least 93 % of 1,000 synthetic batches."""

from __future__ import annotations

import numpy as np
import pytest

from stook.sdk.stats import _BLOCK, bootstrap_mean_difference, mean_interval, seed_from


def test_the_same_seed_gives_the_same_interval_and_another_seed_another() -> None:
    rng = np.random.default_rng(1)
    base, cand = list(rng.normal(0, 1, 40)), list(rng.normal(0.2, 1, 40))
    one = bootstrap_mean_difference(base, cand, paired=False, seed=seed_from("a", "b"))
    two = bootstrap_mean_difference(base, cand, paired=False, seed=seed_from("a", "b"))
    other = bootstrap_mean_difference(base, cand, paired=False, seed=seed_from("b", "a"))
    assert one == two
    assert (other.low, other.high) != (one.low, one.high)
    assert one.estimate == pytest.approx(np.mean(cand) - np.mean(base))


def test_seed_bytes_depend_on_every_part_and_its_boundaries() -> None:
    assert seed_from("ab", "c") != seed_from("a", "bc")
    assert seed_from(b"\x01", "x") == seed_from(b"\x01", b"x")
    assert len(seed_from("x")) == 32


def test_pairing_removes_what_the_experience_contributes() -> None:
    rng = np.random.default_rng(2)
    level = rng.normal(0, 10, 60)  # experiences differ a lot ...
    base = level + rng.normal(0, 0.1, 60)
    cand = level + 0.1 + rng.normal(0, 0.1, 60)  # ... the change is small
    seed = seed_from("p")
    paired = bootstrap_mean_difference(list(base), list(cand), paired=True, seed=seed)
    unpaired = bootstrap_mean_difference(list(base), list(cand), paired=False, seed=seed)
    assert paired.paired
    assert not unpaired.paired
    assert paired.low > 0  # the pairs show the shift
    assert unpaired.low < 0 < unpaired.high  # the spread between experiences hides it
    assert paired.p_value < 0.01 < unpaired.p_value


@pytest.mark.parametrize("paired", [True, False])
def test_the_p_value_is_the_t_tests_and_agrees_with_the_interval(paired: bool) -> None:
    from scipy import stats

    rng = np.random.default_rng(3)
    for i, shift in enumerate(np.linspace(0.0, 0.8, 17)):
        base, cand = rng.normal(0, 1, 50), rng.normal(shift, 1, 50)
        d = bootstrap_mean_difference(list(base), list(cand), paired=paired, seed=seed_from(str(i)))
        # Exactly the classical t tests: paired, or Welch's.
        classical = (
            stats.ttest_rel(cand, base) if paired else stats.ttest_ind(cand, base, equal_var=False)
        )
        assert d.p_value == pytest.approx(classical.pvalue, rel=1e-9, abs=1e-12)
        if not 0.03 < d.p_value < 0.07:
            assert (d.p_value < 0.05) is (d.low > 0 or d.high < 0), d


def test_identical_samples_give_no_difference_at_all() -> None:
    d = bootstrap_mean_difference([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], paired=True, seed=b"x")
    assert (d.estimate, d.low, d.high, d.p_value) == (0.0, 0.0, 0.0, 1.0)


def test_large_samples_are_resampled_in_blocks() -> None:
    # More resamples than one block: every block must be filled, none left at zero.
    values = [float(i % 7) for i in range(300)]
    d = bootstrap_mean_difference(
        values, [v + 1.0 for v in values], paired=True, seed=b"b", resamples=3 * _BLOCK + 5
    )
    assert d.low == d.high == d.estimate == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("base", "cand", "paired", "message"),
    [
        ([1.0], [1.0, 2.0], False, "two values"),
        ([1.0, 2.0, 3.0], [1.0, 2.0], True, "differ in length"),
    ],
)
def test_bad_samples_are_refused(
    base: list[float], cand: list[float], paired: bool, message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        bootstrap_mean_difference(base, cand, paired=paired, seed=b"s")


def test_bad_options_are_refused() -> None:
    with pytest.raises(ValueError, match="confidence"):
        bootstrap_mean_difference([1.0, 2.0], [1.0, 2.0], paired=False, seed=b"", confidence=1)
    with pytest.raises(ValueError, match="resamples"):
        bootstrap_mean_difference([1.0, 2.0], [1.0, 2.0], paired=False, seed=b"", resamples=0)


def test_the_t_interval_of_a_mean() -> None:
    from scipy import stats

    values = [1.0, 2.0, 4.0, 7.0]
    ours = mean_interval(values)
    low, high = stats.t.interval(0.95, 3, loc=np.mean(values), scale=stats.sem(values))
    assert ours.low == pytest.approx(low)
    assert ours.high == pytest.approx(high)
    assert mean_interval([5.0]).low == mean_interval([5.0]).high == 5.0
    with pytest.raises(ValueError, match="no values"):
        mean_interval([])
    with pytest.raises(ValueError, match="confidence"):
        mean_interval([1.0, 2.0], 0.0)


@pytest.mark.slow
@pytest.mark.parametrize("paired", [True, False])
def test_the_95_percent_interval_covers_the_true_difference(paired: bool) -> None:
    """1,000 synthetic batch pairs of 60 jobs, skewed values (lognormal, as latencies and
    errors are), a true difference of 0.3: the interval must cover it in >= 93 %."""
    rng = np.random.default_rng(20261122)
    true_difference = 0.3
    covered = 0
    mean = float(np.exp(0.5))  # the lognormal's mean, with sigma 1
    for i in range(1000):
        level = rng.normal(0.0, 2.0, 60)
        base = level + rng.lognormal(0.0, 1.0, 60) - mean
        cand = (level if paired else rng.normal(0.0, 2.0, 60)) + rng.lognormal(0.0, 1.0, 60)
        cand = cand - mean + true_difference
        d = bootstrap_mean_difference(
            list(base), list(cand), paired=paired, seed=seed_from(str(i)), resamples=1000
        )
        covered += d.low <= true_difference <= d.high
    assert covered >= 930, covered
