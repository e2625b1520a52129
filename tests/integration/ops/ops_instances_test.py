#!/usr/bin/python3
"""Two kinemetricd instances on one PostgreSQL database (docs/operations.md, "Jobs and several
instances"):
  * the same files uploaded through both at once are stored once (one 201, one 200, one id);
  * both answer the same measurement list and results;
  * calibration jobs queued through either are run by both (each job once, identical results),
    with the batch time of one and of two working instances printed;
  * kill -9 of the instance running a job: the other takes the job over when its lease lapses
    and finishes it (attempts 2), and the killed instance starts again on the same database.
The PostgreSQL server is KINEMETRIC_TEST_DATABASE's, else a private cluster started here with
tests/tools/pg_cluster.sh. Default: batches of 4 plain calibrations (0.1 s each); --long: batches
of 8 with a reduction study (5 to 6 s each), the figures of docs/operations.md."""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import TOOLS, Checks, Server, distinct_dbb, example_dbb  # noqa


def shared_database(tmp):
    """(database URL, cluster dir to stop or None)."""
    cluster = None
    env = dict(os.environ)
    if not env.get("KINEMETRIC_TEST_DATABASE"):
        cluster = os.path.join(tmp, "pg")
        os.makedirs(cluster)
        env["KINEMETRIC_TEST_DATABASE"] = subprocess.run(
            [os.path.join(TOOLS, "pg_cluster.sh"), "start", cluster], check=True,
            capture_output=True, text=True).stdout.strip()
    url = subprocess.run([os.path.join(TOOLS, "test_database.sh"), os.path.join(tmp, "shared")],
                         check=True, capture_output=True, text=True, env=env).stdout.strip()
    return url, cluster


def instance(binary, tmp, name, url, workers):
    return Server(binary, os.path.join(tmp, name),
                  ["--database", url, "--job-lease-s", "2", "--job-workers", str(workers),
                   "--max-queued-jobs", "100", "--access-log", "off"])


def check_dedup(a, b, base, check):
    """Each of 8 new files sent through both instances at once."""
    outcomes = {}

    def send(srv, n, key):
        outcomes[key] = srv.json("POST", "/api/v1/measurements", distinct_dbb(base, n, "inst"))

    for n in range(8):
        ts = [threading.Thread(target=send, args=(srv, n, (n, k))) for k, srv in enumerate((a, b))]
        for t in ts:
            t.start()
        for t in ts:
            t.join()
        (sa, ja), (sb, jb) = outcomes[(n, 0)], outcomes[(n, 1)]
        check(sorted((sa, sb)) == [200, 201], "file %d: answers %d and %d" % (n, sa, sb))
        check(ja["id"] == jb["id"], "file %d: ids %s and %s" % (n, ja["id"], jb["id"]))
    _, la = a.json("GET", "/api/v1/measurements?limit=100")
    _, lb = b.json("GET", "/api/v1/measurements?limit=100")
    check(la == lb, "both instances list the same measurements")
    check(la["total"] == 8, "8 measurements stored, not %s" % la["total"])
    first = la["items"][0]["id"]
    check(a.json("GET", "/api/v1/measurements/%d/results" % first) ==
          b.json("GET", "/api/v1/measurements/%d/results" % first), "the same results")


def upload_hexapod_tests(srv, repo):
    ids = []
    folder = os.path.join(repo, "tests", "fixtures", "browser", "hexapod")
    for name in sorted(os.listdir(folder)):
        with open(os.path.join(folder, name), "rb") as f:
            status, j = srv.json("POST", "/api/v1/measurements", f.read())
        ids.append(j["id"])
    return ids


def wait_jobs(srv, ids, timeout):
    deadline, jobs = time.time() + timeout, {}
    while time.time() < deadline:
        jobs = {i: srv.json("GET", "/api/v1/jobs/%d" % i)[1] for i in ids}
        if all(j["status"] in ("done", "failed") for j in jobs.values()):
            break
        time.sleep(0.1)
    return jobs


def batch(submit_to, request, n, check, label):
    """Submits n jobs alternately through the given instances; seconds until all are done."""
    t0 = time.time()
    ids = [submit_to[k % len(submit_to)].json("POST", "/api/v1/calibrations", request)[1]["job_id"]
           for k in range(n)]
    jobs = wait_jobs(submit_to[0], ids, 600)
    seconds = time.time() - t0
    check(all(j["status"] == "done" for j in jobs.values()),
          "%s: every job done: %s" % (label, [j["status"] for j in jobs.values()]))
    params = [j.get("result", {}).get("parameters") for j in jobs.values()]
    check(all(p == params[0] for p in params), "%s: identical results" % label)
    instances = sorted({j["instance"] for j in jobs.values()})
    print("%s: %d jobs in %.2f s (%.2f jobs/s), run by %s" %
          (label, n, seconds, n / seconds, instances), flush=True)
    return seconds, instances


def takeover_request(plain, seconds_per_plain_job):
    """A job long enough to be killed while it runs, short enough to finish soon after: a
    test-set reduction study (about 4 s in a Release build), or where a plain calibration already
    takes a second or more (sanitizer builds, where the study takes minutes) the plain one."""
    if seconds_per_plain_job >= 1.0:
        return plain
    return dict(plain, reduction_study_min_tests=2)


def check_takeover(a, b, request, check):
    """kill -9 of the instance running a long job: the other finishes it."""
    status, sub = a.json("POST", "/api/v1/calibrations", request)
    job_id = sub["job_id"]
    deadline, job = time.time() + 60, None
    while time.time() < deadline:
        job = a.json("GET", "/api/v1/jobs/%d" % job_id)[1]
        if job["status"] == "running" and job["instance"]:
            break
        time.sleep(0.05)
    runner = a if ":%d:" % a.proc.pid in job["instance"] else b
    other = b if runner is a else a
    time.sleep(0.5)
    runner.kill9()
    done = wait_jobs(other, [job_id], 300)[job_id]
    check(done["status"] == "done", "taken over and done: %s %s" % (done["status"],
                                                                    done.get("error")))
    check(done["attempts"] == 2, "attempts %s" % done["attempts"])
    check(":%d:" % other.proc.pid in (done["instance"] or ""), "finished by the other instance")
    print("takeover: job %d finished by %s after kill -9 of %s" %
          (job_id, done["instance"], job["instance"]), flush=True)
    runner.start()
    check(runner.json("GET", "/api/v1/jobs/%d" % job_id)[1]["status"] == "done",
          "the restarted instance sees the job done")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--long", action="store_true")
    args = ap.parse_args()
    binary = os.path.join(args.bin, "kinemetricd")
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        url, cluster = shared_database(tmp)
        servers = []
        try:
            a = instance(binary, tmp, "a", url, 1).start()
            b = instance(binary, tmp, "b", url, 0).start()
            servers = [a, b]
            check_dedup(a, b, example_dbb(args.repo), check)
            with open(os.path.join(args.repo, "tests", "fixtures", "pm600-like.json")) as f:
                machine = f.read()
            ids = upload_hexapod_tests(a, args.repo)
            request = {"machine": json.loads(machine), "measurement_ids": ids}
            if args.long:
                request["reduction_study_min_tests"] = 2  # 5 to 6 s a job
            n = 8 if args.long else 4
            one, _ = batch([a, b], request, n, check, "one working instance")
            b.stop()
            b = instance(binary, tmp, "b", url, 1).start()
            servers = [a, b]
            two, used = batch([a, b], request, n, check, "two working instances")
            check(len(used) == 2, "both instances ran jobs: %s" % used)
            print("throughput: %.2f → %.2f jobs/s (×%.2f)" % (n / one, n / two, one / two))
            check_takeover(a, b, takeover_request(request, one / n), check)
        finally:
            for s in servers:
                s.stop()
            if cluster:
                subprocess.run([os.path.join(TOOLS, "pg_cluster.sh"), "stop", cluster])
    return check.finish("ops_instances_test")


if __name__ == "__main__":
    sys.exit(main())
