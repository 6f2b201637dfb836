"""`stook bench`: measure batch-mode fetching against the emulator and the references;
`stook bench --probe`: measure a real API with a run's own requests (see _probe)."""

from stook.bench._engines import run_engine_bench
from stook.bench._measure import Measurement, in_fresh_process, measure_resim, measure_stook
from stook.bench._probe import probe
from stook.bench._probe_plan import ProbePlan, read_plan
from stook.bench._probe_results import ProbeResult
from stook.bench._suite import run_bench

__all__ = [
    "Measurement",
    "ProbePlan",
    "ProbeResult",
    "in_fresh_process",
    "measure_resim",
    "measure_stook",
    "probe",
    "read_plan",
    "run_bench",
    "run_engine_bench",
]
