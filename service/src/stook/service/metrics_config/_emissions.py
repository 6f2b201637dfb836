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

DuckDB's JSON reader is also lenient where JSON Lines is not: it takes trailing commas and
keeps the first of two equal keys. So the text is counted too, each job's at once, not
parsed: its marks (`_MARKS`: a key's closing quote and colon, a comma before `]` or `}`)
number exactly its shapes' keys when every line is right, and more when a key is given
twice, a comma trails or a string holds such a mark. Only then are that job's lines
counted one by one, and the lines that differ (and rows with a `metric[]` column, whose
shape merges their entries) decoded again in Python, strictly (`decode_strict`). What no
row shape holds -- nesting deeper than `MAX_DEPTH`, a timestamp outside 64 bits, a null
inside a list, an event without a time -- is refused with its file and line, never
repaired.
"""

from __future__ import annotations

import json
import re
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

MAX_DEPTH = 64
"""How deep a row's JSON (or a job.json) may nest. A row is 2 levels, a `string[]` 3, a
`metric[]` entry 4 and its value a few more; the cap keeps every later step bounded."""

# Every job's text into numbered lines, blank ones dropped, in one query.
_LINES = """
SELECT job, line_no, line
FROM (
  SELECT job, generate_subscripts(parts, 1)::UINTEGER AS line_no, unnest(parts) AS line
  FROM (SELECT job, string_split(text, chr(10)) AS parts FROM texts)
)
WHERE NOT regexp_full_match(line, '\\s*')
"""

# What lines are counted by: a key's closing quote and its colon, and a trailing comma.
# Every key of a line holds one (JSON's spaces are space, tab and CR within a line); a
# string can hold more. One pattern for polars (the jobs' texts) and DuckDB (lines).
_MARKS = r'"[ \t\r]*:|,[ \t\r]*[\]}]'


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
        self._ids: dict[str, str] = {}  # job ID: the name of its source

    def add_job(
        self, meta: JobMeta, source: Path | bytes | None, *, name: str | None = None
    ) -> None:
        """One job: its metadata and its emissions (a file, its bytes, or None: the job
        emitted nothing). `name` names the source in errors."""
        label = name or (str(source) if isinstance(source, Path) else f"job {meta.job_id}")
        if meta.job_id in self._ids:
            raise EmissionsError(
                f"{label}: job {meta.job_id} was added twice (first by {self._ids[meta.job_id]})"
            )
        data: bytes | None
        if isinstance(source, Path):
            try:
                data = source.read_bytes()
            except OSError as exc:
                raise EmissionsError(f"{source}: cannot be read ({exc.strerror or exc})") from None
        else:
            data = source
        index = len(self._jobs)
        self._ids[meta.job_id] = label
        self._jobs.append(meta)
        self._names.append(label)
        if data and data.strip():
            try:
                self._texts.append(data.decode("utf-8"))
            except UnicodeDecodeError as exc:
                line = data.count(b"\n", 0, exc.start) + 1
                column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
                raise EmissionsError(
                    f"{label} line {line}: not UTF-8 (byte {column} of the line)"
                ) from None
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
            # A speed trick: one count over each job's text, not one per line, finds
            # the jobs that need a closer look (none, when all is well): about 0.5 s
            # less per 2 M rows than counting each line.
            marks = texts["text"].str.count_matches(_MARKS).to_list()
            con.register("texts", texts)
            self._split(con)
            con.unregister("texts")
            timed = self._check(con, dict(zip(self._with_text, marks, strict=True)))
            frames = {
                name: self._topic_frame(con, topic, metadata, timed.get(name, 0))
                for name, topic in topics.items()
            }
        finally:
            con.close()
        return {**frames, METADATA_TABLE: metadata}

    def _topic_frame(
        self, con: duckdb.DuckDBPyConnection, topic: Topic, metadata: pl.DataFrame, timed: int
    ) -> pl.DataFrame:
        """The topic's frame; `timed` rows of it gave an integer timestamp."""
        import polars as pl

        frame = _topic_frame(con, topic, metadata)
        # Each check finds its earliest bad row; the earliest of them is said.
        found: list[tuple[int, int, str]] = []

        def first(rows: pl.DataFrame, problem: str) -> None:
            if rows.height:
                job, line_no = rows.select("job", "line_no").row(0)
                found.append((job, line_no, f"topic {topic.name!r}{problem}"))

        # The check refused nulls, so a null here is a value that did not convert: an
        # int beyond 64 bits.
        for column, kind in topic.schema.items():
            first(
                frame.filter(pl.col(column).is_null()),
                f", column {column!r}: the value does not fit a {kind} (64 bits)",
            )
            if kind == "string[]":  # the shape of [null, "a"] is that of ["a"]
                first(
                    frame.filter(pl.col(column).list.eval(pl.element().is_null()).list.any()),
                    f", column {column!r}: null is not a string (in a list of strings)",
                )
        if frame.height - frame["timestamp"].null_count() < timed:
            found.append(self._unconverted_timestamp(con, topic, frame))
        if topic.event:
            first(
                frame.filter(pl.col("timestamp") < 0),
                ": an event's '$metadata.timestamp' must not be negative",
            )
        if found:
            job, line_no, problem = min(found)
            raise EmissionsError(f"{self._where(job, line_no)}: {problem}")
        return frame.drop("job", "line_no")

    def _unconverted_timestamp(
        self, con: duckdb.DuckDBPyConnection, topic: Topic, frame: pl.DataFrame
    ) -> tuple[int, int, str]:
        """The first row whose integer timestamp did not fit 64 bits (the slow path)."""
        import polars as pl

        untimed = frame.filter(pl.col("timestamp").is_null()).select("job", "line_no")
        con.register("untimed", untimed)
        row = con.execute(
            "SELECT u.job, u.line_no FROM untimed AS u JOIN lines AS l USING (job, line_no) "
            """WHERE json_type(l.line, '$."$metadata".timestamp') IN ('UBIGINT', 'BIGINT') """
            "ORDER BY u.job, u.line_no LIMIT 1"
        ).fetchall()
        con.unregister("untimed")
        if not row:  # cannot be: the counts differ
            raise EmissionsError(f"topic {topic.name!r}: a timestamp did not convert")
        problem = f"topic {topic.name!r}: '$metadata.timestamp' does not fit 64 bits"
        return row[0][0], row[0][1], problem

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
                f"SELECT job, line_no, line FROM ({_LINES}) WHERE NOT json_valid(line) "
                "ORDER BY job, line_no LIMIT 1"
            ).fetchall()
            if not invalid:
                message = str(exc).strip().splitlines()[0]
                raise EmissionsError(f"the emissions cannot be read: {message}") from None
            ((job, line_no, line),) = invalid
            why = _why_not_json(con, line)
            raise EmissionsError(f"{self._where(job, line_no)}: not a JSON object{why}") from None

    def _check(self, con: duckdb.DuckDBPyConnection, marks: dict[int, int]) -> dict[str, int]:
        """Raise EmissionsError for the first bad row (by job, then line); `marks` is
        each job's count of `_MARKS`. Per topic, how many rows give an integer timestamp
        (what the frame must then hold)."""
        groups = con.execute(
            "SELECT job, topic, json_structure(line) AS structure, count(*), min(line_no) "
            "FROM lines GROUP BY ALL"
        ).fetchall()
        bad: dict[tuple[str | None, str], str] = {}
        found: list[tuple[int, int, str]] = []  # a bad shape's first line in a job
        shapes: dict[tuple[str | None, str], Any] = {}  # the good ones, decoded
        keys: dict[str, int] = {}  # per good shape
        expected = dict.fromkeys(marks, 0)
        strict: set[str] = set()  # topics whose every row is decoded strictly
        timed: dict[str, int] = {}
        for job, topic, text, rows, first_line in groups:
            if (topic, text) not in bad and (topic, text) not in shapes:
                problem, structure = self._shape_problem(topic, text)
                if problem is not None:
                    bad[(topic, text)] = problem
                else:
                    shapes[(topic, text)] = structure
                    keys[text] = _key_count(structure)
            if (topic, text) in bad:
                found.append((job, first_line, bad[(topic, text)]))
                continue
            if self._has_metric_lists(topic):
                strict.add(topic)
            else:
                expected[job] += keys[text] * rows
            if shapes[(topic, text)]["$metadata"].get("timestamp") in ("BIGINT", "UBIGINT"):
                timed[topic] = timed.get(topic, 0) + rows
        found = [min(found)] if found else []
        if strict:
            for job, count in con.execute(
                "SELECT job, sum(len(regexp_extract_all(line, ?)))::BIGINT FROM lines "
                "WHERE list_contains(?, topic) GROUP BY job",
                [_MARKS, sorted(strict)],
            ).fetchall():
                expected[job] += count
        counted = sorted(job for job, count in marks.items() if count != expected[job])
        if strict or counted:
            before = found[0][:2] if found else None
            found.extend(self._strict_lines(con, strict, counted, keys, before))
        if found:
            job, line_no, problem = min(found)
            raise EmissionsError(f"{self._where(job, line_no)}: {problem}")
        return timed

    def _strict_lines(
        self,
        con: duckdb.DuckDBPyConnection,
        strict: set[str],
        counted: list[int],
        keys: dict[str, int],
        before: tuple[int, int] | None,
    ) -> list[tuple[int, int, str]]:
        """The first line that strict decoding refuses, if any comes before `before`:
        among the rows of the `strict` topics, and the lines of the `counted` jobs whose
        marks differ from their shape's keys."""
        if not strict and not counted:
            return []
        import polars as pl

        shapes = pl.DataFrame(
            {"structure": list(keys), "keys": list(keys.values())},
            schema={"structure": pl.String, "keys": pl.Int64},
        )
        con.register("shape_keys", shapes)
        limit = "" if before is None else "AND (job, line_no) < ($4, $5)"
        result = con.execute(
            "SELECT job, line_no, line FROM ("
            "  SELECT job, line_no, line, topic, json_structure(line) AS structure, "
            "    len(regexp_extract_all(line, $1)) AS marks FROM lines "
            "  WHERE list_contains($2, topic) OR list_contains($3, job)"
            ") LEFT JOIN shape_keys USING (structure) "
            f"WHERE (list_contains($2, topic) OR marks IS DISTINCT FROM keys) {limit} "
            "ORDER BY job, line_no",
            [_MARKS, sorted(strict), counted, *(before or ())],
        )
        found: list[tuple[int, int, str]] = []
        while not found and (batch := result.fetchmany(10_000)):
            for job, line_no, line in batch:
                problem = self._strict_problem(line)
                if problem is not None:
                    found.append((job, line_no, problem))
                    result.abort()  # the rest is not needed
                    break
        con.unregister("shape_keys")
        return found

    def _strict_problem(self, line: str) -> str | None:
        """What strict decoding finds wrong with a line whose shape is right."""
        try:
            row = decode_strict(line)
        except ValueError as exc:
            return str(exc)
        topic = self._config.topics[row["$metadata"]["topic"]]
        for column, kind in topic.schema.items():
            if kind == "metric[]":
                problem = _metric_list_problem(row["$data"][column], event=topic.event)
                if problem is not None:
                    return f"topic {topic.name!r}, column {column!r}: {problem}"
        return None

    def _has_metric_lists(self, topic_name: str | None) -> bool:
        # A metric[] column's shape merges its entries': each row is decoded instead.
        topic = self._config.topics.get(topic_name or "")
        return topic is not None and "metric[]" in topic.schema.values()

    def _where(self, job: int, line_no: int) -> str:
        return f"{self._names[job]} line {line_no}"

    def _shape_problem(self, topic_name: str | None, text: str) -> tuple[str | None, Any]:
        """A shape's problem, or None and the shape decoded."""
        if nesting_depth(text, MAX_DEPTH) > MAX_DEPTH:
            return f"nested deeper than {MAX_DEPTH} levels", None
        structure = json.loads(text)
        return self._row_problem(topic_name, structure), structure

    def _row_problem(self, topic_name: str | None, structure: Any) -> str | None:
        if not isinstance(structure, dict):
            return "not a JSON object"
        meta = structure.get("$metadata")
        if not isinstance(meta, dict) or meta.get("topic") != "VARCHAR":
            return "no '$metadata' object with a 'topic' string"
        topic = self._config.topics.get(topic_name or "")
        if topic is None:
            return f"topic {topic_name!r} is not in the config"
        timestamp = meta.get("timestamp", "NULL")
        if timestamp not in ("BIGINT", "UBIGINT", "NULL"):
            return f"topic {topic_name!r}: '$metadata.timestamp' must be integer nanoseconds"
        if topic.event and timestamp == "NULL":
            return f"topic {topic_name!r}: an event needs a '$metadata.timestamp'"
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


def decode_strict(text: str) -> Any:
    """JSON as JSON Lines has it: no trailing comma, no key twice in an object, nesting at
    most `MAX_DEPTH` (NaN and Infinity pass: Python's json, and so ReSim's Emitter, write
    them). ValueError says what is wrong, and where when it can."""
    if nesting_depth(text, MAX_DEPTH) > MAX_DEPTH:
        raise ValueError(f"nested deeper than {MAX_DEPTH} levels")
    try:
        return json.loads(text, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as exc:
        where = f"line {exc.lineno}, column {exc.colno}" if "\n" in text else f"column {exc.colno}"
        before = text[: exc.pos].rstrip()
        if before.endswith(",") and text[exc.pos : exc.pos + 1] in ("]", "}"):
            raise ValueError(f"a trailing comma ({where})") from None
        raise ValueError(f"not JSON: {exc.msg} ({where})") from None


# A JSON text's tokens that nesting depends on: an escape (two characters), a quote, a
# bracket. One pass, whatever the text holds.
_NESTING_TOKENS = re.compile(r'\\.|["\[\]{}]', re.DOTALL)


def nesting_depth(text: str, limit: int) -> int:
    """How deep the JSON `text` nests; counting stops once past `limit`."""
    depth = deepest = 0
    quoted = False
    for match in _NESTING_TOKENS.finditer(text):
        token = match.group()
        if token == '"':
            quoted = not quoted
        elif quoted or len(token) == 2:
            continue
        elif token in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > limit:
                    break
        else:
            depth -= 1
    return deepest


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result = dict(pairs)
    if len(result) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise ValueError(f"the key {key!r} is given twice in one object")
            seen.add(key)
    return result


def _key_count(structure: Any) -> int:
    """How many keys a shape's objects hold (a list's shape holds one of its items')."""
    count = 0
    stack = [structure]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            count += len(node)
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
    return count


def _metric_list_problem(entries: list[Any], *, event: bool) -> str | None:
    """Why a `metric[]` value is not a list of metrics ({name, type, value, unit?}), an
    event's with names once each."""
    names: set[str] = set()
    for index, entry in enumerate(entries):
        if not isinstance(entry, dict):
            shown = json.dumps(entry)
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            return f"entry {index} is not a metric object ({{name, type, value}}): {shown}"
        name = entry.get("name")
        if event and name:  # the events' writer takes named entries, by str(name)
            if str(name) in names:
                return f"two event metrics are named {str(name)!r}"
            names.add(str(name))
    return None


def _why_not_json(con: duckdb.DuckDBPyConnection, line: str) -> str:
    """DuckDB's reason a line is not JSON, without the line it quotes ('' if none)."""
    import duckdb

    try:
        con.execute("SELECT json(?)", [line])
    except duckdb.Error as exc:
        found = re.search(r"Malformed JSON at byte (\d+) of input: ([^.]*)", str(exc))
        if found:
            return f" ({found.group(2)}, byte {int(found.group(1)) + 1})"
    return ""


def _metadata_frame(jobs: list[JobMeta]) -> pl.DataFrame:
    import polars as pl

    schema: dict[str, pl.DataType] = {c: pl.String() for c in METADATA_COLUMNS}
    for column in ("tags", "custom_field_keys", "custom_field_values"):
        schema[column] = pl.List(pl.String())
    schema["build_creation_timestamp"] = pl.Datetime("us")  # UTC, as the platform's
    columns: dict[str, list[Any]] = {c: [] for c in METADATA_COLUMNS}
    for job in jobs:  # one step per job, not per row
        for column in METADATA_COLUMNS:
            value = getattr(job, column)
            columns[column].append(list(value) if isinstance(value, tuple) else value)
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
