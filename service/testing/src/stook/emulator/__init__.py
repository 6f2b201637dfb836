"""An emulator of the ReSim REST API and its object storage, for tests, demos and benchmarks.

Two loopback origins: the API (``emu.api_url``, bearer-token auth, paged lists, the
endpoints batch and report modes use) and object storage serving each serialized
``Metric`` / ``MetricsData`` at a presigned, expiring URL. Data is synthetic and
deterministic by seed; latency, transient faults and rate limits are configurable::

    from stook.emulator import Emulator, EmulatorConfig

    async with Emulator(EmulatorConfig(jobs_per_batch=200, fault_5xx=0.05)) as emu:
        emu.write_batch_config(inputs_dir)
        ...
        truth = emu.dataset.scalar_values(emu.batch_id)
"""

from stook.emulator._config import EmulatorConfig, Origin, Outage
from stook.emulator._dataset import Dataset
from stook.emulator._emissions import CONFIG_YAML as EMISSIONS_CONFIG_YAML
from stook.emulator._emissions import EMISSIONS_FILE, EMISSIONS_TEMPLATES, write_emissions_config
from stook.emulator._emissions import Row as EmittedRow
from stook.emulator._faults import FaultKind
from stook.emulator._generate import EventTruth, HistogramTruth, Truth
from stook.emulator._server import (
    BATCH_CONFIG,
    REPORT_CONFIG,
    Emulator,
    EmulatorInfo,
    EmulatorProcess,
    main,
    serve,
    serve_with_inputs,
)
from stook.emulator._stats import EmulatorStats
from stook.emulator._store import MetricsOutput, StoredData, StoredEvent, StoredMetric
from stook.emulator._world import BatchKind, BatchSpec, Experience, JobSpec, ReportSpec

__all__ = [
    "BATCH_CONFIG",
    "EMISSIONS_CONFIG_YAML",
    "EMISSIONS_FILE",
    "EMISSIONS_TEMPLATES",
    "REPORT_CONFIG",
    "BatchKind",
    "BatchSpec",
    "Dataset",
    "EmittedRow",
    "Emulator",
    "EmulatorConfig",
    "EmulatorInfo",
    "EmulatorProcess",
    "EmulatorStats",
    "EventTruth",
    "Experience",
    "FaultKind",
    "HistogramTruth",
    "JobSpec",
    "MetricsOutput",
    "Origin",
    "Outage",
    "ReportSpec",
    "StoredData",
    "StoredEvent",
    "StoredMetric",
    "Truth",
    "main",
    "serve",
    "serve_with_inputs",
    "write_emissions_config",
]
