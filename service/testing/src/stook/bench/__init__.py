"""`stook bench`: measure batch-mode fetching against the emulator and the references."""

from stook.bench._engines import run_engine_bench
from stook.bench._measure import Measurement, in_fresh_process, measure_resim, measure_stook
from stook.bench._suite import run_bench

__all__ = [
    "Measurement",
    "in_fresh_process",
    "measure_resim",
    "measure_stook",
    "run_bench",
    "run_engine_bench",
]
