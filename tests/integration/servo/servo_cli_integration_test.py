#!/usr/bin/python3
"""`kinemetric servo …` run as a process on the example files (docs/formats.md §3.10–3.13):
exit status 0 with the documented JSON, the machine written back and used again, and bad input
answered with exit status 2 and a one-line reason naming file, line and field."""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def run(binary, args, cwd):
    p = subprocess.run([binary] + args, cwd=cwd, capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    km = os.path.join(a.bin, "kinemetric")
    failures = []

    def check(ok, what):
        if not ok:
            failures.append(what)

    with tempfile.TemporaryDirectory() as tmp:
        machine = os.path.join(tmp, "identified.json")
        rc, out, err = run(km, ["servo", "identify", "--machine", "data/machines/pm600-like.json",
                                "data/examples/servo_pm600-like_a_ccw.txt", "--write-machine",
                                machine, "--json"], a.repo)
        check(rc == 0, "identify exit %d: %s" % (rc, err))
        if rc == 0:
            j = json.loads(out)
            for key in ("identified", "uncertainty", "residual_rms_N", "condition_number", "fixed",
                        "joint_friction"):
                check(key in j, "identify lacks " + key)
            check(abs(j["identified"]["platform_mass_kg"] - 250.0) < 10.0, "platform mass")
            m = json.load(open(machine))
            check(any(e.get("effect") == "joint_friction" for e in m.get("effects", [])),
                  "the written machine has the joint_friction effect")
            rc, out, err = run(km, ["servo", "force", "--machine", machine,
                                    "data/examples/servo_pm600-like_a_ccw.txt", "--json"], a.repo)
            check(rc == 0, "force exit %d: %s" % (rc, err))
            if rc == 0:
                f = json.loads(out)
                check(len(f["force_N"]) == 72 and len(f["sigma_N"]) == 72, "force per sample")
                check(f["ramps_from"]["joint"] == "machine model", "joint ramp from the model")
                check(all(abs(v) < 30.0 for v in f["mean_force_N"]), "no load: small mean force")
        rc, out, err = run(km, ["servo", "feed-drive", "data/examples/servo_x-strokes.txt",
                                "--json"], a.repo)
        check(rc == 0, "feed-drive exit %d: %s" % (rc, err))
        if rc == 0:
            f = json.loads(out)
            check(abs(f["coulomb_N"] - 30.0) < 1.5, "Coulomb %g" % f["coulomb_N"])
            check(abs(f["ripple"][0]["period_mm"] - 55.0) < 1.1, "ripple period")
        # Bad input: exit 2, one line naming file, line and field.
        bad = os.path.join(tmp, "bad.txt")
        lines = open(os.path.join(a.repo, "data/examples/servo_pm600-like_a_ccw.txt")).read().splitlines()
        lines[15] = lines[15].replace(",", ",x", 1)
        open(bad, "w").write("\n".join(lines) + "\n")
        rc, out, err = run(km, ["servo", "identify", "--machine", "data/machines/pm600-like.json",
                                bad], a.repo)
        check(rc == 2, "bad file exit %d" % rc)
        check("bad.txt" in err and ":16" in err and "x_mm" in err, "bad file message: " + err)
        rc, out, err = run(km, ["servo", "joints", "--machine", "data/machines/pm600-like.json",
                                "data/examples/servo_pm600-like_a_ccw.txt"], a.repo)
        check(rc == 2 and "direction" in err, "joints without a CW/CCW pair: %d %s" % (rc, err))
        # Two feed-drive recordings joined: the second 100 mm further, 10 ms after the first's
        # last sample. Exit 2 naming the line after the jump, pos_mm and the jump.
        lines = open(os.path.join(a.repo, "data/examples/servo_x-strokes.txt")).read().splitlines()
        head = [l for l in lines if l.startswith("#") or l.startswith("t_s")]
        rows = [l.split(",") for l in lines[len(head):]]
        t_end = float(rows[-1][0])
        joined = os.path.join(tmp, "joined.txt")
        second = ["%.3f,%.5f,%s" % (t_end + 0.01 + float(t), float(x) + 100.0, f)
                  for t, x, f in rows]
        open(joined, "w").write("\n".join(lines + second) + "\n")
        rc, out, err = run(km, ["servo", "feed-drive", joined, "--json"], a.repo)
        line_after = len(lines) + 1
        check(rc == 2, "joined recordings exit %d" % rc)
        check("joined.txt:%d" % line_after in err and "pos_mm" in err and "jumps by" in err
              and "two recordings joined" in err, "joined recordings message: " + err)
        check("steady motion in both directions" not in err, "joined: misleading reason " + err)
        # The feed drive's LuGre keys: every parameter identifiable or null with the note.
        rc, out, err = run(km, ["servo", "feed-drive", "data/examples/servo_x-strokes.txt",
                                "--json"], a.repo)
        if rc == 0:
            f = json.loads(out)
            for k, ok in (f.get("lugre_identifiable") or {}).items():
                check(ok == (f["lugre"][k] is not None), "lugre %s null exactly when not "
                      "identifiable" % k)
                check(ok or k in f.get("lugre_note", ""), "lugre_note names " + k)
    for f in failures:
        print("FAIL:", f)
    print("ok" if not failures else "%d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
