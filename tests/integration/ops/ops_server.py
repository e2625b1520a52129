"""A real kinemetricd for the operations tests: started on a free loopback port with its own
data directory, spoken to over plain HTTP/1.1 (http.client), stopped with a signal.
Also makes distinct DBB measurement files from the example file (small changes of the header
and of one reading) and checks a data directory's database after a stop or a crash: its SQLite
file, or, when KINEMETRIC_TEST_DATABASE names a PostgreSQL server, its PostgreSQL database
(tests/tools/test_database.sh)."""
import hashlib
import http.client
import json
import os
import re
import signal
import sqlite3
import subprocess
import threading
import time

ADMIN_TOKEN = "ops-admin-token-0123456789abcdef"
TOOLS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools")


def database_url(data_dir):
    """The PostgreSQL database of a data directory (created when missing), or None: SQLite."""
    if not os.environ.get("KINEMETRIC_TEST_DATABASE"):
        return None
    out = subprocess.run([os.path.join(TOOLS, "test_database.sh"), data_dir], check=True,
                         capture_output=True, text=True).stdout.strip()
    return out or None


def psql(url, sql):
    """Rows of a query on a PostgreSQL database, each a list of text columns."""
    out = subprocess.run(["psql", "-qtA", "-F", "\t", "-v", "ON_ERROR_STOP=1", "-d", url, "-c", sql],
                         check=True, capture_output=True, text=True).stdout
    return [line.split("\t") for line in out.splitlines() if line]


class Server:
    def __init__(self, binary, data_dir, extra=(), env=None):
        self.binary, self.data_dir, self.extra = binary, data_dir, list(extra)
        self.env = dict(os.environ, KINEMETRIC_BOOTSTRAP_TOKEN=ADMIN_TOKEN, **(env or {}))
        self.proc, self.port, self.lines = None, 0, []
        self.stderr = None  # None: kept in <data_dir>.stderr, told when the server dies

    def start(self, timeout=20):
        os.makedirs(self.data_dir, exist_ok=True)
        self.lines = []
        url = None if "--database" in self.extra else database_url(self.data_dir)
        database = ["--database", url] if url else []
        err = self.stderr
        if err is None:
            err = open(self.data_dir.rstrip("/") + ".stderr", "a")
        self.proc = subprocess.Popen(
            [self.binary, "--listen", "127.0.0.1:0", "--data-dir", self.data_dir, "--threads",
             "8"] + database + self.extra, stdout=subprocess.PIPE, stderr=err, text=True,
            env=self.env)
        if self.stderr is None:
            err.close()
        deadline = time.time() + timeout
        while time.time() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.lines.append(line)
            m = re.search(r"listening on http://127\.0\.0\.1:(\d+)/", line)
            if m:
                self.port = int(m.group(1))
                break
        if not self.port:
            self.proc.kill()
            raise RuntimeError("kinemetricd did not start: " + "".join(self.lines) +
                               self.stderr_tail())
        threading.Thread(target=self._drain, daemon=True).start()
        return self

    def _drain(self):
        for line in self.proc.stdout:
            self.lines.append(line)

    def stderr_tail(self, n=4000):
        """The end of what the server wrote to stderr (when it is kept), for a failure message."""
        try:
            with open(self.data_dir.rstrip("/") + ".stderr", errors="replace") as f:
                return "\n--- kinemetricd stderr ---\n" + f.read()[-n:]
        except OSError:
            return ""

    def signal(self, sig):
        self.proc.send_signal(sig)

    def wait(self, timeout):
        return self.proc.wait(timeout=timeout)

    def kill9(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=10)
        self.port = 0

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode if self.proc else None

    def conn(self, timeout=30):
        return http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)

    def request(self, method, path, body=None, token=ADMIN_TOKEN, headers=None, conn=None):
        """(status, headers dict, body bytes); a fresh connection unless one is given."""
        c = conn or self.conn()
        h = dict(headers or {})
        if token:
            h["Authorization"] = "Bearer " + token
        if body is not None and not isinstance(body, bytes):
            body = json.dumps(body).encode()
            h.setdefault("Content-Type", "application/json")
        try:
            c.request(method, path, body=body, headers=h)
            r = c.getresponse()
            data = r.read()
            return r.status, {k.lower(): v for k, v in r.getheaders()}, data
        except ConnectionRefusedError:
            if self.proc and self.proc.poll() is not None:
                raise RuntimeError("kinemetricd exited (%s) before %s %s%s" % (
                    self.proc.returncode, method, path, self.stderr_tail())) from None
            raise
        finally:
            if conn is None:
                c.close()

    def json(self, method, path, body=None, token=ADMIN_TOKEN, conn=None):
        status, _, data = self.request(method, path, body, token, conn=conn)
        return status, (json.loads(data) if data else None)


def wait_in_flight(srv, n, timeout=10.0):
    """Waits until /metrics counts n requests in flight besides the scrape itself."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        status, _, body = srv.request("GET", "/metrics")
        m = re.search(r"(?m)^kinemetric_http_requests_in_flight (\S+)$", body.decode())
        if status == 200 and m and float(m.group(1)) >= n + 1:
            return True
        time.sleep(0.05)
    return False


def example_dbb(repo):
    with open(os.path.join(repo, "data", "examples", "dbb_xy-r150_ccw.txt"), "rb") as f:
        return f.read()


def distinct_dbb(base, n, tag="ops"):
    """The example DBB file with its own test_id and one reading moved by n nanometres: every n
    gives other bytes (another SHA-256) and still a valid circular test."""
    text = base.decode()
    text = re.sub(r"(?m)^# test_id: .*$", "# test_id: %s-%d" % (tag, n), text, count=1)
    lines = text.split("\n")
    for i, line in enumerate(lines):
        if re.match(r"^\d+,-?\d+\.\d+$", line):
            angle, value = line.split(",")
            lines[i] = "%s,%.6f" % (angle, float(value) + n * 1e-6)
            break
    return "\n".join(lines).encode()


def sha256(data):
    return hashlib.sha256(data).hexdigest()


def check_database(data_dir):
    """(integrity_check answer, measurements without results, {id: sha256 of the raw bytes}).
    On PostgreSQL the answer is "ok" when the tables read back in full (the server keeps its
    own consistency; a kill -9 of kinemetricd cannot damage it)."""
    url = database_url(data_dir)
    if url:
        orphans = int(psql(url, "SELECT COUNT(*) FROM measurements m WHERE NOT EXISTS "
                                "(SELECT 1 FROM results r WHERE r.measurement_id = m.id)")[0][0])
        raw = {int(i): h for i, h in psql(url, "SELECT id, encode(sha256(raw), 'hex') "
                                               "FROM measurements")}
        return "ok", orphans, raw
    db = sqlite3.connect(os.path.join(data_dir, "kinemetric.db"))
    try:
        integrity = db.execute("PRAGMA integrity_check").fetchone()[0]
        orphans = db.execute(
            "SELECT COUNT(*) FROM measurements m WHERE NOT EXISTS "
            "(SELECT 1 FROM results r WHERE r.measurement_id = m.id)").fetchone()[0]
        raw = {row[0]: sha256(row[1]) for row in db.execute("SELECT id, raw FROM measurements")}
        return integrity, orphans, raw
    finally:
        db.close()


def percentile(values, p):
    if not values:
        return float("nan")
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100.0 * (len(s) - 1))))]


class Checks:
    def __init__(self):
        self.failures = []

    def __call__(self, ok, what):
        if not ok:
            self.failures.append(what)
            print("FAIL: " + what, flush=True)
        return ok

    def finish(self, name):
        if self.failures:
            print("%s: %d checks failed" % (name, len(self.failures)))
            return 1
        return 0
