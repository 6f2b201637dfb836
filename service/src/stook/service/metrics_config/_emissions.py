"""Emission files (one JSON object a line) into one polars frame per topic.

Each job's text is split into numbered lines, checked and unpacked by DuckDB's JSON
functions, all jobs at once: no Python step per row. A job's lines keep their numbers,
so that a bad row is named by its file and line.

Bad input costs only when it is there: a line that is not JSON fails the query that
splits the texts, and only then is each line tested to name it. Every row's exact JSON
shape is checked (`json_structure`, grouped: a file has few distinct shapes); only when
a shape is bad is the earliest line of it looked up. DuckDB's and polars' typed readers
cannot be the check: both convert quietly (`true` to 1, `"1"` to 1.0, 5 to "5") and drop
unknown keys.
"""

from __future__ import annotations

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

# Every job's text into numbered lines, blank ones dropped, in one query.
_LINES = """
SELECT job, line_no, line
FROM (
  SELECT job, generate_subscripts(parts, 1)::UINTEGER AS line_no, unnest(parts) AS line
  FROM (SELECT job, string_split(text, chr(10)) AS parts FROM texts)
)
WHERE NOT regexp_full_match(line, '\\s*')
"""


class EmissionsSet:
    """The emissions of the jobs of one evaluation, added job by job.

    ``add_job`` reads a job's lines (cheap); ``tables`` checks every row against its
    topic's schema and builds the frames, all jobs at once.
    """

    def __init__(self, config: MetricsConfig) -> None:
        self._config = config
        self._jobs: list[JobMeta] = []
        self._names: list[str] = []
        self._texts: list[str] = []  # of the jobs with emissions
        self._with_text: list[int] = []  # their indexes
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
            try:
                self._texts.append(data.decode("utf-8"))
            except UnicodeDecodeError as exc:
                raise EmissionsError(f"{label}: not UTF-8 JSON lines ({exc})") from None
            self._with_text.append(index)

    def tables(self) -> dict[str, pl.DataFrame]:
        """The topic frames and the metadata frame (see `Tables`)."""
        import duckdb

        metadata = _metadata_frame(self._jobs)
        topics = self._config.topics
        if not self._texts:
            frames = {name: _empty_topic(topic) for name, topic in topics.items()}
            return {**frames, METADATA_TABLE: metadata}
        import polars as pl

        texts = pl.DataFrame(
            {"job": self._with_text, "text": self._texts},
            schema={"job": pl.UInt32, "text": pl.String},
        )
        # No progress bar: DuckDB draws one on the terminal for a query over 2 s.
        con = duckdb.connect(":memory:")
        con.execute("SET enable_progress_bar = false")
        try:
            con.register("texts", texts)
            self._split(con)
            con.unregister("texts")
            self._check(con)
            frames = {
                name: self._topic_frame(con, topic, metadata) for name, topic in topics.items()
            }
        finally:
            con.close()
        return {**frames, METADATA_TABLE: metadata}

    def _topic_frame(
        self, con: duckdb.DuckDBPyConnection, topic: Topic, metadata: pl.DataFrame
    ) -> pl.DataFrame:
        import polars as pl

        frame = _topic_frame(con, topic, metadata)
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

    def _split(self, con: duckdb.DuckDBPyConnection) -> None:
        """The `lines` table: job, line_no, line, topic. EmissionsError names the first
        line that is not JSON."""
        import duckdb

        try:
            con.execute(
                "CREATE TEMP TABLE lines AS SELECT job, line_no, line, "
                f"json_extract_string(line, '/$metadata/topic') AS topic FROM ({_LINES})"
            )
        except duckdb.InvalidInputException as exc:
            # The slow path, once: which line it was (DuckDB's message names none).
            invalid = con.execute(
                f"SELECT job, line_no FROM ({_LINES}) WHERE NOT json_valid(line) "
                "ORDER BY job, line_no LIMIT 1"
            ).fetchone()
            if invalid is None:
                message = str(exc).strip().splitlines()[0]
                raise EmissionsError(f"the emissions cannot be read: {message}") from None
            raise EmissionsError(
                f"{self._where(invalid[0], invalid[1])}: not a JSON object"
            ) from None

    def _check(self, con: duckdb.DuckDBPyConnection) -> None:
        """Raise EmissionsError for the first bad row (by job, then line)."""
        groups = con.execute(
            "SELECT DISTINCT topic, json_structure(line) AS structure FROM lines"
        ).fetchall()
        bad: dict[tuple[str | None, str], str] = {}
        for topic, structure in groups:
            problem = self._row_problem(topic, json.loads(structure))
            if problem is not None:
                bad[(topic, structure)] = problem
        if not bad:
            return
        # The slow path, once: the earliest bad line, however many kinds of bad rows
        # there are (each line's shape again, now kept to be joined).
        import polars as pl

        kinds = pl.DataFrame(
            {"topic": [k[0] for k in bad], "structure": [k[1] for k in bad]},
            schema={"topic": pl.String, "structure": pl.String},
        )
        con.register("bad_kinds", kinds)
        first = con.execute(
            "SELECT l.job, l.line_no, l.topic, l.structure "
            "FROM (SELECT job, line_no, topic, json_structure(line) AS structure FROM lines) "
            "AS l JOIN bad_kinds AS b "
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


def _topic_frame(
    con: duckdb.DuckDBPyConnection, topic: Topic, metadata: pl.DataFrame
) -> pl.DataFrame:
    structure = {
        "$metadata": {"timestamp": "BIGINT"},
        "$data": {column: DUCKDB_TYPES[kind] for column, kind in topic.schema.items()},
    }
    columns = [f's."$data".{_quote(c)} AS {_quote(c)}' for c in topic.schema]
    columns.append('s."$metadata".timestamp AS timestamp')
    shape = "'" + json.dumps(structure).replace("'", "''") + "'"
    query = (
        f"SELECT {', '.join(columns)}, job, line_no "
        f"FROM (SELECT job, line_no, json_transform(line, {shape}) AS s FROM lines "
        "WHERE topic = ?) ORDER BY job, line_no"
    )
    # (duckdb's stubs do not type the relation a query is)
    relation: Any = con.sql(query, params=[topic.name])
    frame: pl.DataFrame = relation.pl()
    # The job's IDs by its index: a gather, in the rows' order, not a join.
    ids = metadata.select("job_id", "batch_id", "experience_name", "build_version")
    frame = frame.with_columns(ids[frame["job"]])
    job_line = frame.select("job", "line_no")
    return frame.drop("job", "line_no").cast(_topic_schema(topic)).hstack(job_line)
