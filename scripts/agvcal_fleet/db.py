"""The results database: SQLite (a file, the default) or PostgreSQL (`postgresql://...`).

One schema for both, created and migrated by the tool (MIGRATIONS, table schema_version).
SQL is written once with `?` placeholders and types both understand (TEXT, BIGINT,
DOUBLE PRECISION); upserts use `INSERT ... ON CONFLICT ... DO UPDATE`, which both have.

Tables (docs/fleet.md has the columns):
  robots              robot id -> drive type, robot file and its hash
  recordings          content hash -> robot, path, size, start time, duration, distance
  files               path, size, mtime -> content hash (so a rerun does not hash again)
  calibrations        per recording: `agvcal solve`'s exit status and message, residual,
                      observability, the held-out check (`--fit-fraction 0.5`) and its verdict
  calibration_params  per recording and parameter: value, sigma, nominal
  diagnoses           per recording: `agvcal diagnose`'s exit status, message, verdict
  diagnosis_effects   per recording, effect and effect parameter: size, sigma, p-value
  runs, tasks         each run of the tool, and which worker did what in it
  findings            the latest analysis's decisions (drift, step, effects), replaced whole
The result tables are a function of the recordings, the robot files and agvcal: the same
fleet gives the same rows whatever the cluster (run ids, workers and times live in runs and
tasks only).
"""
import contextlib
import json
import os
import sqlite3

from .errors import UsageError

MIGRATIONS = [
    # version 1
    [
        """CREATE TABLE robots (
            robot_id TEXT PRIMARY KEY, drive TEXT, robot_file TEXT NOT NULL,
            robot_sha256 TEXT NOT NULL)""",
        """CREATE TABLE recordings (
            sha256 TEXT PRIMARY KEY, robot_id TEXT NOT NULL REFERENCES robots (robot_id),
            path TEXT NOT NULL, size_bytes BIGINT, info_exit INTEGER, info_message TEXT,
            start_utime BIGINT, end_utime BIGINT, duration_s DOUBLE PRECISION,
            distance_m DOUBLE PRECISION, channels TEXT)""",
        "CREATE INDEX recordings_robot ON recordings (robot_id, start_utime)",
        """CREATE TABLE files (
            path TEXT PRIMARY KEY, size_bytes BIGINT NOT NULL, mtime_ns BIGINT NOT NULL,
            sha256 TEXT NOT NULL)""",
        """CREATE TABLE calibrations (
            recording_sha256 TEXT PRIMARY KEY REFERENCES recordings (sha256),
            robot_sha256 TEXT NOT NULL, task_version INTEGER NOT NULL,
            exit_status INTEGER, message TEXT, drive TEXT, intervals INTEGER, outliers INTEGER,
            rms_x DOUBLE PRECISION, rms_y DOUBLE PRECISION, rms_yaw DOUBLE PRECISION,
            condition_number DOUBLE PRECISION, weak TEXT,
            heldout_exit INTEGER, heldout_message TEXT, heldout_verdict TEXT,
            heldout_nominal_error_per_m DOUBLE PRECISION,
            heldout_calibrated_error_per_m DOUBLE PRECISION, heldout_windows INTEGER,
            heldout_calibrated_better INTEGER, heldout_sign_p DOUBLE PRECISION,
            heldout_halves_p DOUBLE PRECISION, heldout_halves_largest TEXT,
            heldout_outside_fit DOUBLE PRECISION)""",
        """CREATE TABLE calibration_params (
            recording_sha256 TEXT NOT NULL REFERENCES recordings (sha256), name TEXT NOT NULL,
            value DOUBLE PRECISION, std DOUBLE PRECISION, nominal DOUBLE PRECISION,
            PRIMARY KEY (recording_sha256, name))""",
        """CREATE TABLE diagnoses (
            recording_sha256 TEXT PRIMARY KEY REFERENCES recordings (sha256),
            robot_sha256 TEXT NOT NULL, task_version INTEGER NOT NULL,
            exit_status INTEGER, message TEXT, verdict TEXT, unexplained INTEGER,
            chi2_before DOUBLE PRECISION, chi2_after DOUBLE PRECISION)""",
        """CREATE TABLE diagnosis_effects (
            recording_sha256 TEXT NOT NULL REFERENCES recordings (sha256), effect TEXT NOT NULL,
            wheel TEXT NOT NULL, param TEXT NOT NULL, value DOUBLE PRECISION,
            std DOUBLE PRECISION, layer TEXT, p_value DOUBLE PRECISION,
            delta_bic DOUBLE PRECISION, heldout_rms_before DOUBLE PRECISION,
            heldout_rms_after DOUBLE PRECISION, regime TEXT,
            PRIMARY KEY (recording_sha256, effect, wheel, param))""",
        """CREATE TABLE runs (
            run_id TEXT PRIMARY KEY, started_utc TEXT NOT NULL, finished_utc TEXT,
            status TEXT NOT NULL, host TEXT, scheduler TEXT, workers INTEGER, fleet TEXT,
            agvcal TEXT, recordings INTEGER, skipped INTEGER, submitted INTEGER,
            done INTEGER, failed INTEGER, lost INTEGER, elapsed_s DOUBLE PRECISION)""",
        """CREATE TABLE tasks (
            run_id TEXT NOT NULL REFERENCES runs (run_id), recording_sha256 TEXT NOT NULL,
            status TEXT NOT NULL, worker TEXT, elapsed_s DOUBLE PRECISION,
            PRIMARY KEY (run_id, recording_sha256))""",
        """CREATE TABLE findings (
            robot_id TEXT NOT NULL, kind TEXT NOT NULL, subject TEXT NOT NULL,
            p_value DOUBLE PRECISION, first_sha256 TEXT, first_utime BIGINT,
            change_utime BIGINT, size DOUBLE PRECISION, size_std DOUBLE PRECISION,
            detail TEXT)""",
    ],
]
SCHEMA_VERSION = len(MIGRATIONS)

# The tables whose rows are the fleet's results (compared by the tests across clusters).
RESULT_TABLES = {
    "robots": "robot_id",
    "recordings": "sha256",
    "calibrations": "recording_sha256",
    "calibration_params": "recording_sha256, name",
    "diagnoses": "recording_sha256",
    "diagnosis_effects": "recording_sha256, effect, wheel, param",
}

# Exit statuses that are a recording's answer (done: a rerun skips it). Anything else
# (1 internal error, a timeout, a lost task) is tried again by the next run.
FINAL_EXITS = (0, 2, 3)


class Database:
    """A connection to the results database named by URL: `postgresql://...` (or
    `postgres://`), `sqlite:///PATH`, or a plain file path (SQLite)."""

    def __init__(self, url):
        self.url = url
        if url.startswith(("postgresql://", "postgres://")):
            self.kind = "postgresql"
            try:
                import psycopg2
            except ImportError:
                raise UsageError(f"--db {url}: PostgreSQL needs psycopg2 (Debian: python3-psycopg2)")
            try:
                self.conn = psycopg2.connect(url)
            except psycopg2.Error as e:
                raise UsageError(f"--db {_redact(url)}: cannot connect ({str(e).strip().splitlines()[0]})")
            self.conn.autocommit = True
            self._error = psycopg2.Error
        else:
            self.kind = "sqlite"
            # sqlite:///relative.db, sqlite:////absolute.db (as SQLAlchemy), or a path
            path = url[len("sqlite:///"):] if url.startswith("sqlite:///") else url
            d = os.path.dirname(os.path.abspath(path))
            if not os.path.isdir(d):
                raise UsageError(f"--db {url}: folder {d} does not exist")
            try:
                self.conn = sqlite3.connect(path, isolation_level=None, timeout=60)
                self.conn.execute("PRAGMA foreign_keys = ON")
                self.conn.execute("PRAGMA journal_mode = WAL")
            except sqlite3.Error as e:
                raise UsageError(f"--db {url}: cannot open ({e})")
            self._error = sqlite3.Error
        self._in_tx = False

    def close(self):
        self.conn.close()

    def _sql(self, sql):
        return sql.replace("?", "%s") if self.kind == "postgresql" else sql

    def execute(self, sql, params=()):
        cur = self.conn.cursor()
        cur.execute(self._sql(sql), tuple(params))
        return cur

    def query(self, sql, params=()):
        cur = self.execute(sql, params)
        return cur.fetchall()

    def query_dicts(self, sql, params=()):
        cur = self.execute(sql, params)
        names = [d[0] for d in cur.description]
        return [dict(zip(names, row)) for row in cur.fetchall()]

    @contextlib.contextmanager
    def transaction(self):
        """All statements inside commit together or not at all."""
        if self._in_tx:
            yield
            return
        self.execute("BEGIN")
        self._in_tx = True
        try:
            yield
        except BaseException:
            self.execute("ROLLBACK")
            raise
        else:
            self.execute("COMMIT")
        finally:
            self._in_tx = False

    # -- schema ---------------------------------------------------------------------------
    def version(self):
        try:
            rows = self.query("SELECT version FROM schema_version")
        except self._error:  # no schema yet
            return 0
        return rows[0][0] if rows else 0

    def migrate(self):
        """Creates the schema or brings it to SCHEMA_VERSION; returns the versions applied."""
        applied = []
        with self.transaction():
            if self.kind == "postgresql":  # one migrating client at a time
                self.execute("SELECT pg_advisory_xact_lock(20200420)")
            self.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
            rows = self.query("SELECT version FROM schema_version")
            current = rows[0][0] if rows else 0
            if current > SCHEMA_VERSION:
                raise UsageError(f"--db {_redact(self.url)}: schema version {current} is newer "
                                 f"than this tool's {SCHEMA_VERSION}; update agvcal-fleet")
            for v in range(current, SCHEMA_VERSION):
                for stmt in MIGRATIONS[v]:
                    self.execute(stmt)
                applied.append(v + 1)
            if not rows:
                self.execute("INSERT INTO schema_version (version) VALUES (?)", (SCHEMA_VERSION,))
            elif applied:
                self.execute("UPDATE schema_version SET version = ?", (SCHEMA_VERSION,))
        return applied

    # -- writes ---------------------------------------------------------------------------
    def upsert(self, table, key_cols, row):
        cols = list(row)
        updates = [c for c in cols if c not in key_cols]
        sql = (f"INSERT INTO {table} ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))}) "
               f"ON CONFLICT ({', '.join(key_cols)}) DO ")
        sql += ("UPDATE SET " + ", ".join(f"{c} = excluded.{c}" for c in updates)) if updates else "NOTHING"
        self.execute(sql, [row[c] for c in cols])

    def insert(self, table, row):
        cols = list(row)
        self.execute(f"INSERT INTO {table} ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))})",
                     [row[c] for c in cols])

    # -- reads ----------------------------------------------------------------------------
    def done_keys(self, task_version):
        """{recording sha256: robot file sha256} of the recordings whose calibration and
        diagnosis are final (FINAL_EXITS) for this task version."""
        rows = self.query(
            "SELECT c.recording_sha256, c.robot_sha256 FROM calibrations c "
            "JOIN diagnoses d ON d.recording_sha256 = c.recording_sha256 "
            "WHERE c.task_version = ? AND d.task_version = ? AND c.robot_sha256 = d.robot_sha256 "
            f"AND c.exit_status IN {FINAL_EXITS} AND d.exit_status IN {FINAL_EXITS} "
            f"AND (c.heldout_exit IN {FINAL_EXITS})",
            (task_version, task_version))
        return dict(rows)

    def result_rows(self, recording_hashes=None):
        """The result tables' rows, sorted, as {table: [tuple, ...]}: what must be identical
        whatever ran them. With RECORDING_HASHES only the rows of those recordings (and
        their robots)."""
        out = {}
        keep = set(recording_hashes) if recording_hashes is not None else None
        robots = None
        if keep is not None:
            robots = {r for (h, r) in self.query("SELECT sha256, robot_id FROM recordings") if h in keep}
        for table, order in RESULT_TABLES.items():
            rows = self.query(f"SELECT * FROM {table} ORDER BY {order}")
            if keep is not None:
                rows = [r for r in rows if (r[0] in robots if table == "robots" else r[0] in keep)]
            out[table] = [tuple(r) for r in rows]
        return out


def _redact(url):
    """URL without its password."""
    if "@" in url and "://" in url:
        scheme, rest = url.split("://", 1)
        cred, host = rest.rsplit("@", 1)
        return f"{scheme}://{cred.split(':')[0]}:***@{host}" if ":" in cred else url
    return url


def dumps(obj):
    """JSON text stored in a TEXT column: stable across runs (sorted keys)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))
