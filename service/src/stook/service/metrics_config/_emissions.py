"""Emission files (one JSON object a line) into one polars frame per topic.

Lines are read by polars' CSV reader (one column, no quoting: a raw control character
cannot be in valid JSON), then checked and unpacked by DuckDB's JSON functions, all
jobs at once: no Python step per row. A job's lines keep their numbers, so that a bad
row is named by its file and line.
"""

from __future__ import annotations

import io
import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from stook.service.metrics_config._errors import EmissionsError
from stook.service.metrics_config._jobs import METADATA_COLUMNS, JobMeta
from stook.service.metrics_config._model import METADATA_TABLE, MetricsConfig, Topic
from stook.service.metrics_config._schema import DUCKDB_TYPES, polars_type, value_problem

if TYPE_CHECKING:
    import duckdb
    import polars as pl

Tables = Mapping[str, "pl.DataFrame"]
"""One frame per topic (its schema's columns, then timestamp, job_id, batch_id,
experience_name, build_version), and `metadata`, one row per job."""

# Emissions of one job beyond this many lines are refused (a line's number is a u32).
_MAX_LINE = 2**32 - 1


class EmissionsSet:
    """The emissions of the jobs of one evaluation, added job by job.

    ``add_job`` reads a job's lines (cheap); ``tables`` checks every row against its
    topic's schema and builds the frames, all jobs at once.
    """

    def __init__(self, config: MetricsConfig) -> None:
        self._config = config
        self._jobs: list[JobMeta] = []
        self._names: list[str] = []
        self._lines: list[pl.DataFrame] = []
        self._ids: set[str] = set()

    def add_job(
        self, meta: JobMeta, source: Path | bytes | None, *, name: str | None = None
    ) -> None:
        """One job: its metadata and its emissions (a file, its bytes, or None: the job
        emitted nothing). `name` names the source in errors."""
        if meta.job_id in self._ids:
            raise EmissionsError(f"job {meta.job_id} was added twice")
        label = name or (str(source) if isinstance(source, Path) else f"job {meta.job_id}")
        data: bytes | None
        if isinstance(source, Path):
            try:
                data = source.read_bytes()
            except OSError as exc:
                raise EmissionsError(f"{source}: cannot be read ({exc.strerror or exc})") from None
        else:
            data = source
        index = len(self._jobs)
        self._ids.add(meta.job_id)
        self._jobs.append(meta)
        self._names.append(label)
        if data and data.strip():
            self._lines.append(_read_lines(data, index, label))

    def tables(self) -> dict[str, pl.DataFrame]:
        """The topic frames and the metadata frame (see `Tables`)."""
        import duckdb

        metadata = _metadata_frame(self._jobs)
        topics = self._config.topics
        if not self._lines:
            frames = {name: _empty_topic(topic) for name, topic in topics.items()}
            return {**frames, METADATA_TABLE: metadata}
        import polars as pl

        lines = pl.concat(self._lines, rechunk=True)
        con = duckdb.connect(":memory:")
        try:
            con.register("raw_lines", lines)
            con.register("jobs", metadata.with_row_index("job"))
            self._check(con)
            frames = {name: self._topic_frame(con, topic) for name, topic in topics.items()}
        finally:
            con.close()
        return {**frames, METADATA_TABLE: metadata}

    def _topic_frame(self, con: duckdb.DuckDBPyConnection, topic: Topic) -> pl.DataFrame:
        import polars as pl

        frame = _topic_frame(con, topic)
        # The check refused nulls, so a null here is a value that did not convert: an
        # int beyond 64 bits.
        for column in topic.schema:
            unconverted = frame.filter(pl.col(column).is_null())
            if unconverted.height:
                job, line_no = unconverted.row(0)[-2:]
                raise EmissionsError(
                    f"{self._where(job, line_no)}: topic {topic.name!r}, column {column!r}: "
                    f"the value does not fit a {topic.schema[column]} (64 bits)"
                )
        return frame.drop("job", "line_no")

    def _check(self, con: duckdb.DuckDBPyConnection) -> None:
        """Raise EmissionsError for the first bad row (by job, then line)."""
        invalid = con.execute(
            "SELECT job, line_no FROM raw_lines WHERE NOT json_valid(line) "
            "ORDER BY job, line_no LIMIT 1"
        ).fetchone()
        if invalid is not None:
            raise EmissionsError(f"{self._where(invalid[0], invalid[1])}: not a JSON object")
        con.execute(
            "CREATE TEMP TABLE lines AS SELECT job, line_no, line, "
            "json_extract_string(line, '/$metadata/topic') AS topic, "
            "json_structure(line) AS structure FROM raw_lines"
        )
        groups = con.execute("SELECT DISTINCT topic, structure FROM lines").fetchall()
        bad: dict[tuple[str | None, str], str] = {}
        for topic, structure in groups:
            problem = self._row_problem(topic, json.loads(structure))
            if problem is not None:
                bad[(topic, structure)] = problem
        if not bad:
            return
        # One query for the earliest bad line, however many kinds of bad rows there are.
        import polars as pl

        kinds = pl.DataFrame(
            {"topic": [k[0] for k in bad], "structure": [k[1] for k in bad]},
            schema={"topic": pl.String, "structure": pl.String},
        )
        con.register("bad_kinds", kinds)
        first = con.execute(
            "SELECT l.job, l.line_no, l.topic, l.structure FROM lines AS l JOIN bad_kinds AS b "
            "ON l.topic IS NOT DISTINCT FROM b.topic AND l.structure = b.structure "
            "ORDER BY l.job, l.line_no LIMIT 1"
        ).fetchone()
        assert first is not None
        job, line_no, topic, structure = first
        raise EmissionsError(f"{self._where(job, line_no)}: {bad[(topic, structure)]}")

    def _where(self, job: int, line_no: int) -> str:
        return f"{self._names[job]} line {line_no}"

    def _row_problem(self, topic_name: str | None, structure: Any) -> str | None:
        if not isinstance(structure, dict):
            return "not a JSON object"
        meta = structure.get("$metadata")
        if not isinstance(meta, dict) or meta.get("topic") != "VARCHAR":
            return "no '$metadata' object with a 'topic' string"
        topic = self._config.topics.get(topic_name or "")
        if topic is None:
            return f"topic {topic_name!r} is not in the config"
        if meta.get("timestamp", "NULL") not in ("BIGINT", "UBIGINT", "NULL"):
            return f"topic {topic_name!r}: '$metadata.timestamp' must be integer nanoseconds"
        if meta.get("event", "NULL") not in ("BOOLEAN", "NULL"):
            return f"topic {topic_name!r}: '$metadata.event' must be true or false"
        data = structure.get("$data")
        if not isinstance(data, dict):
            return f"topic {topic_name!r}: no '$data' object"
        for column, kind in topic.schema.items():
            if column not in data:
                return f"topic {topic_name!r}, column {column!r}: missing"
            problem = value_problem(kind, data[column])
            if problem is not None:
                return f"topic {topic_name!r}, column {column!r}: {problem}"
        for column in data:
            if column not in topic.schema:
                return f"topic {topic_name!r}, column {column!r}: not in the topic's schema"
        return None


def _read_lines(data: bytes, job: int, label: str) -> pl.DataFrame:
    import polars as pl

    try:
        frame = pl.read_csv(
            io.BytesIO(data),
            has_header=False,
            separator="\x1f",
            quote_char=None,
            new_columns=["line"],
            schema={"line": pl.String},
        )
    except pl.exceptions.ComputeError as exc:
        raise EmissionsError(f"{label}: not UTF-8 JSON lines ({exc})") from None
    return (
        frame.with_row_index("line_no", offset=1)
        .filter(pl.col("line").str.strip_chars().str.len_bytes() > 0)
        .select(pl.lit(job, dtype=pl.UInt32).alias("job"), "line_no", "line")
    )


def _metadata_frame(jobs: list[JobMeta]) -> pl.DataFrame:
    import polars as pl

    schema: dict[str, pl.DataType] = {c: pl.String() for c in METADATA_COLUMNS}
    schema["tags"] = pl.List(pl.String())
    columns: dict[str, list[Any]] = {c: [] for c in METADATA_COLUMNS}
    for job in jobs:  # one step per job, not per row
        for column in METADATA_COLUMNS:
            value = getattr(job, column)
            columns[column].append(list(value) if column == "tags" else value)
    return pl.DataFrame(columns, schema=schema)


def _topic_schema(topic: Topic) -> pl.Schema:
    import polars as pl

    schema: dict[str, pl.DataType] = {c: polars_type(k) for c, k in topic.schema.items()}
    schema["timestamp"] = pl.Int64()
    for column in ("job_id", "batch_id", "experience_name", "build_version"):
        schema[column] = pl.String()
    return pl.Schema(schema)


def _empty_topic(topic: Topic) -> pl.DataFrame:
    import polars as pl

    return pl.DataFrame(schema=_topic_schema(topic))


def _quote(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def _topic_frame(con: duckdb.DuckDBPyConnection, topic: Topic) -> pl.DataFrame:
    structure = {
        "$metadata": {"timestamp": "BIGINT"},
        "$data": {column: DUCKDB_TYPES[kind] for column, kind in topic.schema.items()},
    }
    columns = [f's."$data".{_quote(c)} AS {_quote(c)}' for c in topic.schema]
    columns.append('s."$metadata".timestamp AS timestamp')
    shape = "'" + json.dumps(structure).replace("'", "''") + "'"
    query = (
        f"SELECT {', '.join(columns)}, j.job_id, j.batch_id, j.experience_name, j.build_version, "
        "job, line_no "
        f"FROM (SELECT job, line_no, json_transform(line, {shape}) AS s FROM lines "
        "WHERE topic = ?) JOIN jobs AS j USING (job) ORDER BY job, line_no"
    )
    # (duckdb's stubs do not type the relation a query is)
    relation: Any = con.sql(query, params=[topic.name])
    frame: pl.DataFrame = relation.pl()
    return frame.cast(_topic_schema(topic))  # job and line_no keep their types
