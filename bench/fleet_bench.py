#!/usr/bin/python3
"""Fleet benchmark (docs/fleet.md): a synthetic fleet made with the simulator, processed by
agvcal-fleet, the decisions scored against the simulator's truth, and the throughput
measured on 1 and 2 LocalCluster workers and on 2 workers in separate network namespaces
joined over TCP to a scheduler in a third.

  bench/fleet_bench.py [--robots 200] [--recordings 10] [--subset 24] [--work DIR] [--nice 10]

1. `agvcal-fleet synth`: ROBOTS robots (10 % drifting, 10 % with a step on a known day,
   15 % getting a lidar latency on the same day, the rest constant), RECORDINGS each over
   70 days, two truncated recordings.
2. The whole fleet on a LocalCluster of 2 workers, then `agvcal-fleet analyze`; scored:
   steps found within one recording of their day, drifting robots flagged, robots with
   constant parameters flagged (false alarms), the fleet-wide latency's robots.
3. Throughput on the first SUBSET robots: LocalCluster 1 worker, 2 workers, and 2 `dask
   worker` processes in network namespaces of their own, joined over veth/bridge TCP to a
   `dask scheduler` (and the client) in a third. Every run starts on an empty database;
   the three give identical rows (checked). Needs root for `ip netns`.
Prints a Markdown report (and writes it to --out).
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(HERE, "scripts"))
FLEET = os.path.join(HERE, "scripts", "agvcal-fleet")


def sh(cmd, check=True, **kw):
    return subprocess.run(cmd, check=check, text=True, **kw)


def load():
    return os.getloadavg()[0]


def run_fleet(fleet_yaml, db, workers=None, scheduler=None, nice=0, prefix=()):
    cmd = list(prefix) + ["nice", "-n", str(nice), FLEET, "run", fleet_yaml, "--db", db, "--quiet"]
    cmd += ["--scheduler", scheduler] if scheduler else ["--workers", str(workers)]
    l0, t0 = load(), time.monotonic()
    r0 = os.times()
    sh(cmd)
    el = time.monotonic() - t0
    r1 = os.times()
    cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
    return el, l0, load(), cpu


def count(db):
    import sqlite3
    con = sqlite3.connect(db)
    n = con.execute("SELECT count(*) FROM recordings").fetchone()[0]
    con.close()
    return n


class Netns:
    """A scheduler namespace with a bridge, and worker namespaces on veth pairs into it."""

    def __init__(self, n_workers, tag):
        self.hub = f"fb{tag}-hub"
        self.workers = [f"fb{tag}-w{i + 1}" for i in range(n_workers)]
        self.procs = []
        sh(["ip", "netns", "add", self.hub])
        sh(["ip", "-n", self.hub, "link", "set", "lo", "up"])
        sh(["ip", "-n", self.hub, "link", "add", "br0", "type", "bridge"])
        sh(["ip", "-n", self.hub, "addr", "add", "10.77.0.1/24", "dev", "br0"])
        sh(["ip", "-n", self.hub, "link", "set", "br0", "up"])
        for i, w in enumerate(self.workers):
            sh(["ip", "netns", "add", w])
            sh(["ip", "-n", w, "link", "set", "lo", "up"])
            sh(["ip", "-n", self.hub, "link", "add", f"vh{i + 1}", "type", "veth", "peer", "name", "eth0",
                "netns", w])
            sh(["ip", "-n", self.hub, "link", "set", f"vh{i + 1}", "master", "br0", "up"])
            sh(["ip", "-n", w, "addr", "add", f"10.77.0.{11 + i}/24", "dev", "eth0"])
            sh(["ip", "-n", w, "link", "set", "eth0", "up"])

    def start(self, work, nice):
        log = open(os.path.join(work, "cluster.log"), "w")
        self.procs.append(subprocess.Popen(
            ["ip", "netns", "exec", self.hub, "nice", "-n", str(nice), "dask", "scheduler", "--host",
             "10.77.0.1", "--port", "8786", "--no-dashboard"], stdout=log, stderr=log, cwd=work))
        time.sleep(3)
        for i, w in enumerate(self.workers):
            self.procs.append(subprocess.Popen(
                ["ip", "netns", "exec", w, "nice", "-n", str(nice), "dask", "worker", "tcp://10.77.0.1:8786",
                 "--host", f"10.77.0.{11 + i}", "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                 "--name", w, "--local-directory", work], stdout=log, stderr=log, cwd=work))
        # wait for the workers, asking from the scheduler's namespace
        probe = ("from distributed import Client; import time\n"
                 "c = Client('tcp://10.77.0.1:8786', timeout=60)\n"
                 "t0 = time.monotonic()\n"
                 f"while len(c.scheduler_info()['workers']) < {len(self.workers)} and time.monotonic() - t0 < 120:\n"
                 "    time.sleep(0.5)\n"
                 "print(len(c.scheduler_info()['workers']))\n")
        out = sh(["ip", "netns", "exec", self.hub, "/usr/bin/python3", "-c", probe], capture_output=True).stdout
        if int(out.strip().splitlines()[-1]) != len(self.workers):
            raise RuntimeError("the workers did not join: see " + os.path.join(work, "cluster.log"))

    def cpu(self):
        """CPU seconds of the scheduler and workers and everything they ran (their agvcal
        children included once waited for)."""
        import psutil
        total = 0.0
        for p in self.procs:
            try:
                pp = psutil.Process(p.pid)
                for q in [pp] + pp.children(recursive=True):
                    t = q.cpu_times()
                    total += t.user + t.system + t.children_user + t.children_system
            except psutil.Error:
                pass
        return total

    def close(self):
        for p in reversed(self.procs):
            p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
        for ns in self.workers + [self.hub]:
            sh(["ip", "netns", "del", ns], check=False)


def score(fleet_dir, findings):
    with open(os.path.join(fleet_dir, "truth.json")) as f:
        truth = json.load(f)
    idx = {os.path.join(fleet_dir, rc["file"]): j
           for r in truth["robots"].values() for j, rc in enumerate(r["recordings"])}
    trend = [f for f in findings if f["kind"] in ("drift", "step")]
    out = {"steps": [], "drifts": [], "false": [], "effect_robot_flags": [], "constant": 0, "effect_robots": 0}
    for rid, r in sorted(truth["robots"].items()):
        mine = [f for f in trend if f["robot_id"] == rid]
        if r["scenario"] == "step":
            steps = [f for f in mine if f["kind"] == "step" and f["subject"] in r["changed"]]
            got = sorted({idx[f["detail"]["first_path"]] for f in steps})
            ok = bool(got) and all(abs(g - r["change_recording"]) <= 1 for g in got)
            out["steps"].append((rid, r["kind"], r["change_recording"], got, ok))
        elif r["scenario"] == "drift":
            ok = any(f["subject"] in r["changed"] for f in mine)
            kinds = sorted({f["kind"] for f in mine if f["subject"] in r["changed"]})
            out["drifts"].append((rid, r["kind"], ok, kinds))
        else:
            out["constant" if r["scenario"] == "constant" else "effect_robots"] += 1
            if mine:
                out["false" if r["scenario"] == "constant" else "effect_robot_flags"].append(
                    (rid, [f["why"] for f in mine]))
    fw = [f for f in findings if f["kind"] == "fleet_effect"]
    eff = sorted(rid for rid, r in truth["robots"].items() if r["scenario"] == "effect")
    found = sorted({x for f in fw if f["subject"] == "time_offset" for x in f["detail"]["robots"]})
    onset_ok = 0
    for f in fw:
        for rid, pth in f["detail"]["first_recordings"].items():
            if rid in truth["robots"] and truth["robots"][rid].get("effect_recording") is not None:
                onset_ok += abs(idx[pth] - truth["robots"][rid]["effect_recording"]) <= 1
    out["fleet_effect"] = {"true": len(eff), "found": len(set(found) & set(eff)),
                           "extra": sorted(set(found) - set(eff)), "onset_within_one": onset_ok,
                           "findings": [f["why"] for f in fw]}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", type=int, default=200)
    ap.add_argument("--recordings", type=int, default=10)
    ap.add_argument("--days", type=float, default=70)
    ap.add_argument("--subset", type=int, default=24, help="robots of the throughput runs")
    ap.add_argument("--work", default="/tmp/agvcal-fleet-bench")
    ap.add_argument("--nice", type=int, default=10)
    ap.add_argument("--seed", type=int, default=2025)
    ap.add_argument("--skip-full", action="store_true", help="throughput runs only")
    ap.add_argument("--skip-netns", action="store_true")
    ap.add_argument("--repeat", type=int, default=1,
                    help="rounds of the throughput runs (the machine's other load varies)")
    ap.add_argument("--reuse", action="store_true", help="keep a fleet already in WORK/fleet")
    ap.add_argument("--out", help="write the Markdown report here too")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    fleet_dir = os.path.join(args.work, "fleet")
    lines = [f"Fleet benchmark: {args.robots} robots x {args.recordings} recordings over {args.days:g} days "
             f"(seed {args.seed}); {platform.node()}, {os.cpu_count()} cores, started at load {load():.1f}", ""]
    t0 = time.monotonic()
    if not (args.reuse and os.path.exists(os.path.join(fleet_dir, "truth.json"))):
        sh(["nice", "-n", str(args.nice), FLEET, "synth", fleet_dir, "--robots", str(args.robots),
            "--recordings", str(args.recordings), "--days", str(args.days), "--seed", str(args.seed),
            "--broken", "2", "--jobs", "2", "--quiet", "--force"])
        lines.append(f"synthetic fleet made in {time.monotonic() - t0:.0f} s")
    fy = os.path.join(fleet_dir, "fleet.yaml")

    if not args.skip_full:
        db = os.path.join(args.work, "full.sqlite")
        if os.path.exists(db):
            os.remove(db)
        el, l0, l1, cpu = run_fleet(fy, db, workers=2, nice=args.nice)
        n = count(db)
        lines += ["", "## Whole fleet, LocalCluster of 2 workers", "",
                  f"{n} recordings in {el / 60:.1f} min: {60 * n / el:.1f} recordings/min "
                  f"(CPU {cpu / n:.2f} s per recording; load average {l0:.1f} before, {l1:.1f} after)"]
        js = os.path.join(args.work, "findings.json")
        sh([FLEET, "analyze", "--db", db, "--json", js, "--quiet"])
        sh([FLEET, "report", "--db", db, "--out", os.path.join(args.work, "report")], capture_output=True)
        with open(js) as f:
            res = json.load(f)
        s = score(fleet_dir, res["findings"])
        st_ok = sum(x[-1] for x in s["steps"])
        dr_ok = sum(x[2] for x in s["drifts"])
        fe = s["fleet_effect"]
        lines += ["", "## Decisions against the truth", "",
                  "| | result |", "|---|---|",
                  f"| steps found within one recording of their day | {st_ok} of {len(s['steps'])} |",
                  f"| drifting robots flagged | {dr_ok} of {len(s['drifts'])} "
                  f"({sum('drift' in x[3] for x in s['drifts'])} as drift, "
                  f"{sum(x[3] == ['step'] for x in s['drifts'])} as a step only) |",
                  f"| robots with constant truth flagged (false alarms) | {len(s['false'])} of {s['constant']} |",
                  f"| robots with the latency (constant parameters) flagged for drift or step | "
                  f"{len(s['effect_robot_flags'])} of {s['effect_robots']} |",
                  f"| fleet-wide latency: robots found | {fe['found']} of {fe['true']}, {len(fe['extra'])} others; "
                  f"onset within one recording for {fe['onset_within_one']} |",
                  f"| trend tests (family-wise alpha {res['alpha']}) | {res['tests']} |", ""]
        for x in s["steps"]:
            if not x[-1]:
                lines.append(f"- step missed: {x}")
        for x in s["drifts"]:
            if not x[2]:
                lines.append(f"- drift missed: {x}")
        for x in s["false"] + s["effect_robot_flags"]:
            lines.append(f"- flagged: {x}")
        lines += [f"- fleet-wide: {w}" for w in fe["findings"]]

    # throughput on a subset
    sub = os.path.join(fleet_dir, "subset.yaml")  # beside fleet.yaml: the same relative paths
    with open(fy) as f:
        keep = [ln for ln in f if not ln.startswith("  ")]
    with open(fy) as f:
        robots = [ln for ln in f if ln.startswith("  ")][:args.subset]
    with open(sub, "w") as f:
        f.writelines(keep + robots)
    lines += ["", f"## Throughput ({args.subset} robots, the first of the fleet; every run on an empty database)", "",
              "CPU cores used = the run's CPU time (client, workers, agvcal) over its wall time.", "",
              "| round | cluster | recordings | minutes | recordings/min | CPU s per recording | CPU cores used | load before, after |",
              "|---|---|---|---|---|---|---|---|"]
    dbs = []
    rates = {}
    configs = [("LocalCluster, 1 worker", {"workers": 1}), ("LocalCluster, 2 workers", {"workers": 2})]
    if not args.skip_netns:
        configs.append(("2 workers in network namespaces, TCP", {"netns": 2}))
    for rnd in range(args.repeat):
        order = configs[rnd % len(configs):] + configs[:rnd % len(configs)]  # rotate the order
        for label, cfg in order:
            db = os.path.join(args.work, f"sub-{len(dbs)}.sqlite")
            if os.path.exists(db):
                os.remove(db)
            if "netns" in cfg:
                ns = Netns(cfg["netns"], os.getpid() % 10000)
                try:
                    ns.start(args.work, args.nice)
                    c0 = ns.cpu()
                    el, l0, l1, cpu = run_fleet(sub, db, scheduler="tcp://10.77.0.1:8786", nice=args.nice,
                                                prefix=("ip", "netns", "exec", ns.hub))
                    cpu += ns.cpu() - c0
                finally:
                    ns.close()
            else:
                el, l0, l1, cpu = run_fleet(sub, db, workers=cfg["workers"], nice=args.nice)
            n = count(db)
            rates.setdefault(label, []).append((60 * n / el, cpu / el))
            lines.append(f"| {rnd + 1} | {label} | {n} | {el / 60:.2f} | {60 * n / el:.1f} | {cpu / n:.2f} | "
                         f"{cpu / el:.2f} | {l0:.1f}, {l1:.1f} |")
            dbs.append(db)
    import statistics
    base = statistics.median(r for r, _ in rates[configs[0][0]])
    lines += ["", "| cluster | median recordings/min | speed-up over 1 worker | median CPU cores used |",
              "|---|---|---|---|"]
    for label, _ in configs:
        med = statistics.median(r for r, _ in rates[label])
        lines.append(f"| {label} | {med:.1f} | {med / base:.2f} | {statistics.median(c for _, c in rates[label]):.2f} |")
    from agvcal_fleet import db as dbmod
    rows = []
    for d in dbs:
        x = dbmod.Database(d)
        rows.append(x.result_rows())
        x.close()
    lines += ["", "rows identical across the runs: " + ("yes" if all(r == rows[0] for r in rows) else "NO")]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
