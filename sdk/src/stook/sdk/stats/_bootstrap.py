"""A bootstrap interval (and test) for the difference of two means.

Percentile bootstrap: resample, take the mean difference of each resample, read the
interval off the quantiles. Paired (one difference per experience both batches ran) or
unpaired (each batch resampled on its own). The random stream comes from bytes the
caller derives from what is compared (the two batch IDs and the metric's name), so the
same inputs give the same interval, byte for byte.

The two-sided p-value is the classical one: Student's t on the paired differences (n - 1
degrees of freedom), Welch's t for unpaired samples, with the samples' own standard
error. The interval is the bootstrap's; the test is not, because the bootstrap's tail
cannot be read below 2 / (resamples + 1) -- above what Holm's correction asks of the
smallest p-value when many metrics are compared -- and its standard error, being the
plug-in one and noisy, made the family-wise false alarms across 20 metrics of 30 jobs
6 % instead of 5 % (measured; the t-test keeps them at the nominal rate).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

__all__ = ["MeanDifference", "bootstrap_mean_difference", "seed_from"]

# Resamples drawn per block: bounds memory at _BLOCK x n indices for large batches.
_BLOCK = 256


@dataclass(frozen=True, slots=True)
class MeanDifference:
    """candidate mean - baseline mean, its percentile interval and two-sided p-value."""

    estimate: float
    low: float
    high: float
    p_value: float
    paired: bool
    n_baseline: int
    n_candidate: int


def seed_from(*parts: bytes | str) -> bytes:
    """Deterministic seed bytes from what is compared (IDs, names), order-sensitive."""
    digest = hashlib.sha256()
    for part in parts:
        raw = part.encode("utf-8") if isinstance(part, str) else part
        digest.update(len(raw).to_bytes(4, "big"))
        digest.update(raw)
    return digest.digest()


def _generator(seed: bytes) -> np.random.Generator:
    import numpy as np

    return np.random.Generator(np.random.PCG64(int.from_bytes(seed, "big")))


def _resampled_means(
    values: npt.NDArray[np.float64], resamples: int, rng: np.random.Generator
) -> npt.NDArray[np.float64]:
    import numpy as np

    n = values.shape[0]
    out = np.empty(resamples, dtype=np.float64)
    for start in range(0, resamples, _BLOCK):
        stop = min(resamples, start + _BLOCK)
        index = rng.integers(0, n, size=(stop - start, n))
        out[start:stop] = values[index].mean(axis=1)
    return out


def bootstrap_mean_difference(
    baseline: Sequence[float],
    candidate: Sequence[float],
    *,
    paired: bool,
    seed: bytes,
    resamples: int = 2000,
    confidence: float = 0.95,
) -> MeanDifference:
    """The bootstrap interval of mean(candidate) - mean(baseline).

    Paired: `baseline[i]` and `candidate[i]` belong together (the same experience), and
    the differences are resampled. Each side needs at least two values.
    """
    import numpy as np

    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence}")
    if resamples < 1:
        raise ValueError(f"resamples must be at least 1, got {resamples}")
    base = np.asarray(baseline, dtype=np.float64)
    cand = np.asarray(candidate, dtype=np.float64)
    if base.size < 2 or cand.size < 2:
        raise ValueError("each side needs at least two values")
    rng = _generator(seed)
    if paired:
        if base.size != cand.size:
            raise ValueError(f"paired samples differ in length: {base.size} and {cand.size}")
        differences = cand - base
        estimate = float(differences.mean())
        boot = _resampled_means(differences, resamples, rng)
        n = differences.size
        standard_error, df = float(differences.std(ddof=1)) / math.sqrt(n), float(n - 1)
    else:
        estimate = float(cand.mean() - base.mean())
        boot = _resampled_means(cand, resamples, rng) - _resampled_means(base, resamples, rng)
        standard_error, df = _welch(base, cand)
    tail = (1.0 - confidence) / 2.0
    low, high = np.quantile(boot, [tail, 1.0 - tail])
    return MeanDifference(
        estimate=estimate,
        low=float(low),
        high=float(high),
        p_value=_p_value(estimate, standard_error, df),
        paired=paired,
        n_baseline=int(base.size),
        n_candidate=int(cand.size),
    )


def _welch(base: npt.NDArray[np.float64], cand: npt.NDArray[np.float64]) -> tuple[float, float]:
    """The standard error of the difference of means and Welch's degrees of freedom."""
    vb, vc = float(base.var(ddof=1)) / base.size, float(cand.var(ddof=1)) / cand.size
    if vb + vc == 0.0:
        return 0.0, float(min(base.size, cand.size) - 1)
    denominator = vb * vb / (base.size - 1) + vc * vc / (cand.size - 1)
    return math.sqrt(vb + vc), (vb + vc) ** 2 / denominator


def _p_value(estimate: float, standard_error: float, df: float) -> float:
    """Two-sided p-value of `estimate` against 0, Student's t with `df` degrees of freedom."""
    if standard_error == 0.0 or not math.isfinite(standard_error):
        return 1.0 if estimate == 0.0 else 0.0
    from scipy.special import stdtr  # Student's t CDF, as scipy.stats.t.cdf

    return float(2.0 * stdtr(df, -abs(estimate) / standard_error))
