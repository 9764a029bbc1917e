"""agvcal-fleet without a cluster: the statistics on series with a known answer (drift and
step found where they are, the family-wise false-alarm rate on constant fleets, the pooled
noise scale when the sigmas are optimistic), fleet.yaml errors (exit 2, one line naming the
file and the key), the folder-tree form, the schema migration, --help everywhere, and that the
package's modules import each other without a cycle, and that the report's plots have the C++
reports' ticks, its pages their stylesheet and their words for p-values and rates."""
import ast
import math
import os
import random
import sqlite3
import subprocess
import sys
from fractions import Fraction

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fleetlib import AGVCAL, BUILD, SRC, check, finish, fleet, tmpdir  # noqa: E402

from agvcal_fleet import analyze as an  # noqa: E402
from agvcal_fleet import stats  # noqa: E402



# -- the package's import graph ----------------------------------------------------------------
def package_imports(folder):
    """{module: {modules of the same package it imports anywhere in it (also inside functions)}}"""
    mods = {f[:-3] for f in os.listdir(folder) if f.endswith(".py")}
    graph = {}
    for m in mods:
        deps = set()
        for node in ast.walk(ast.parse(open(os.path.join(folder, m + ".py")).read())):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level == 1 or base.split(".")[0] == "agvcal_fleet":
                    sub = base.split(".")[1:] if node.level == 0 else base.split(".")
                    if sub and sub[0]:
                        deps.add(sub[0])
                    else:  # from . import a, b
                        deps |= {a.name for a in node.names}
            elif isinstance(node, ast.Import):
                deps |= {a.name.split(".")[1] for a in node.names
                         if a.name.startswith("agvcal_fleet.")}
        graph[m] = (deps & mods) - {m}
    return graph


def find_cycle(graph):
    """A list of modules that import each other in a circle, or None."""
    state, stack = {}, []

    def visit(m):
        state[m] = "open"
        stack.append(m)
        for d in sorted(graph[m]):
            if state.get(d) == "open":
                return stack[stack.index(d):] + [d]
            if d not in state:
                c = visit(d)
                if c:
                    return c
        state[m] = "done"
        stack.pop()
        return None

    for m in sorted(graph):
        if m not in state:
            c = visit(m)
            if c:
                return c
    return None


graph = package_imports(os.path.join(os.path.dirname(stats.__file__)))
check(len(graph) >= 10 and "analyze" in graph["cli"] and "report" in graph["cli"],
      "import graph of scripts/agvcal_fleet read (cli imports analyze and report)", str(graph))
cycle = find_cycle(graph)
check(cycle is None, "scripts/agvcal_fleet imports without a cycle", " -> ".join(cycle or []))
check(find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"],
      "the cycle check finds a cycle")


# -- the tick rule: the same ticks and labels as the C++ reports' --------------------------------
from agvcal_fleet import svg  # noqa: E402

tick_rng = random.Random(3)
ranges = [(0, 1), (0, 2.5), (0, 10), (-5, 5), (0, 13), (-1, 10), (5, 5), (0, 7200), (1e-6, 3e-6),
          (116.1, 116.45), (116.1, 116.3), (1425.2, 1433.9), (-0.0125, 0.0041), (20000.5, 20049.3),
          (1e-12, 1e-11), (-3e7, 4e7), (0.3, 0.30000001)]
for _ in range(400):
    mag = 10 ** tick_rng.uniform(-7, 5)
    lo = tick_rng.choice([-1, 1]) * mag * tick_rng.uniform(0, 50)
    ranges.append((lo, lo + mag * 10 ** tick_rng.uniform(-4, 1)))
ticks_bin = os.path.join(BUILD, "tests", "svg_ticks")
if check(os.access(ticks_bin, os.X_OK), "the C++ tick rule's printer is built", ticks_bin):
    p = subprocess.run([ticks_bin], input="".join(f"{lo!r} {hi!r}\n" for lo, hi in ranges),
                       capture_output=True, text=True, timeout=60)
    cxx = [[(float(v), lab) for v, lab in (x.split("|") for x in line.split())]
           for line in p.stdout.splitlines()]
    differ = [(r, c, svg.ticks(*r)) for r, c in zip(ranges, cxx) if c != svg.ticks(*r)]
    check(len(cxx) == len(ranges) and not differ,
          f"svg.ticks gives the C++ reports' ticks and labels on {len(ranges)} ranges", str(differ[:3]))
    alike = [c for c in cxx if len({lab for _, lab in c}) < len(c)]
    check(not alike and all(2 <= len(c) <= 6 for c in cxx[8:]),
          "2 to 6 ticks over every range, no two labelled alike", str(alike[:3]))
    check(cxx[9] == [(116.10000000000001, "116.1"), (116.2, "116.2"), (116.3, "116.3"),
                     (116.39999999999999, "116.4")] and svg.ticks(116.1, 116.3)[1][1] == "116.15",
          "labels down to the step's digit", str(cxx[9:11]))

# -- the pages: the C++ reports' stylesheet and words; robot names on the evidence chart -------
import re  # noqa: E402

from agvcal_fleet import report  # noqa: E402

check(an.fmt_p(8.3e-204) == "p < 1e-12" and an.fmt_p(0.031) == "p = 0.031" and an.fmt_p(3.14e-5) == "p = 3.1e-05",
      "p-values as the C++ outputs write them (calib::PValueText)", an.fmt_p(8.3e-204))
heldout = an.describe({"kind": "heldout", "size": 0.0031, "detail": {"nominal_error_per_m": 0.0149}})
check("14.9 mm/m -> 3.1 mm/m" in heldout, "held-out errors per metre with their unit", heldout)
ids = [f"forklift-{i:02d}" for i in range(12)]
evidence = report.evidence_svg({r: {} for r in ids},
                               {"alpha": 0.05, "series": {"forklift-03": {"wheelbase": {"drift": {"p_adj": 1e-5}}}}})
texts = re.findall(r"<text[^>]*>([^<]*)</text>", evidence) or re.findall(r"<!-- ([^>]*) -->", evidence)
check(all(r in texts for r in ids), "the evidence chart names every robot on its axis", str(texts[:20]))
check(all(lab in texts for _, lab in svg.ticks(0, 13)), "its value axis has the reports' ticks", str(texts))
check(evidence == report.evidence_svg({r: {} for r in ids},
                                      {"alpha": 0.05, "series": {"forklift-03": {"wheelbase": {"drift": {"p_adj": 1e-5}}}}}),
      "the same chart, the same bytes")
out = tmpdir()
solve = subprocess.run([AGVCAL, "solve", os.path.join(SRC, "config", "robots", "diff_robot.yaml"),
                        os.path.join(SRC, "logs", "diff_robot_demo.log"), "--quiet", "--report",
                        os.path.join(out, "solve")], capture_output=True, text=True, timeout=300)
style = re.compile(r"<style>(.*?)</style>", re.S)
cxx_page = open(os.path.join(out, "solve", "index.html"), encoding="utf-8").read() if solve.returncode == 0 else ""
cxx_style = style.search(cxx_page)
fleet_style = style.search(report.page("t", "<p>x</p>"))
check(cxx_style is not None and fleet_style is not None and cxx_style.group(1) == fleet_style.group(1),
      "the fleet's pages and the C++ reports have one stylesheet", solve.stderr[-300:])

rng = random.Random(20)

# -- single series ---------------------------------------------------------------------------
t = [float(i * 7) for i in range(10)]
s = [0.01] * 10
y = [1 + 0.002 * ti + rng.gauss(0, 0.01) for ti in t]  # 0.14 over the span: 14 sigma
d = stats.drift_test(t, y, s)
check(abs(d["slope"] - 0.002) < 4 * d["slope_std"] and d["p"] < 1e-10, "drift: slope within its sigma, p small",
      str(d))
y = [1 + (0.05 if i >= 6 else 0) + rng.gauss(0, 0.01) for i in range(10)]
st = stats.step_test(y, s)
check(st["k"] == 6 and abs(st["size"] - 0.05) < 4 * st["size_std"] and st["splits"] == 7,
      "step: change point at the injected index, size within its sigma, 7 splits counted", str(st))
check(stats.step_test(y[:3], s[:3]) is None, "step: no test with fewer than 4 values")
check(abs(stats.binomial_sf(2, 10, 0.1) - (1 - 0.9 ** 10 - 10 * 0.1 * 0.9 ** 9)) < 1e-12, "binomial tail")
# the fleet-wide test's tails are far below double precision's epsilon: exact rational sums
for k, n in ((3, 7), (30, 200), (5, 40)):
    q = Fraction(1, 10000)
    exact = sum(math.comb(n, i) * q ** i * (1 - q) ** (n - i) for i in range(k, n + 1))
    got = stats.binomial_sf(k, n, 1e-4)
    check(abs(got / float(exact) - 1) < 1e-9, f"binomial tail P(X >= {k}), n {n}, p 1e-4: {got:.6g}", str(float(exact)))
check(stats.binomial_sf(0, 5, 0.5) == 1.0 and stats.binomial_sf(6, 5, 0.5) == 0.0, "binomial tail at the ends")
check(abs(stats.p_two_sided(1.959964) - 0.05) < 1e-6, "two-sided normal p-value")


# -- fleets of fake recordings ----------------------------------------------------------------
def fake_fleet(n_robots, rng, sigma_factor=1.0, drift=None, step=None, m=10):
    """Robots with 6 parameters each, true value constant unless DRIFT / STEP name a robot;
    the reported sigma is the true noise / SIGMA_FACTOR."""
    robots = {}
    for i in range(n_robots):
        recs = []
        for k in range(m):
            r = an.Recording()
            r.sha, r.path, r.utime = f"{i}-{k}", f"r{i}_{k}.log", int((20000 + 7 * k + rng.random()) * an.DAY_US)
            r.day = r.utime / an.DAY_US
            r.solve_exit = r.diag_exit = r.info_exit = 0
            r.solve_message = r.diag_message = r.info_message = ""
            r.heldout, r.effects, r.params = {}, {}, {}
            r.distance_m = r.duration_s = None
            for j in range(6):
                noise = 0.001 * (1 + j)
                true = 0.1 * (j + 1)
                if drift == (i, j):
                    true += 12 * noise * k / (m - 1)
                if step == (i, j) and k >= m // 2:
                    true += 8 * noise
                r.params[f"p{j}"] = (true + rng.gauss(0, noise), noise / sigma_factor, 0.1 * (j + 1))
            recs.append(r)
        robots[f"r{i:03d}"] = {"drive": "differential", "robot_file": "x", "recordings": recs}
    return robots


def trend_findings(res):
    return [f for f in res["findings"] if f["kind"] in ("drift", "step")]


res = an.analyze(fake_fleet(300, rng))
check(not trend_findings(res) and res["tests"] == 3600, "300 constant robots x 6 parameters: no flag (3600 tests)",
      str([f["why"] for f in trend_findings(res)][:3]))
res = an.analyze(fake_fleet(300, rng, sigma_factor=2.0))
sc = max(res["scales"].values())
check(not trend_findings(res) and 1.6 < min(res["scales"].values()) and sc < 2.4,
      f"sigmas 2x optimistic: the pooled noise scale finds it ({min(res['scales'].values()):.2f}-{sc:.2f}), no flag")
fw = sum(bool(trend_findings(an.analyze(fake_fleet(40, rng)))) for _ in range(60))
check(fw <= 3, f"family-wise false alarms on 60 constant fleets of 40 robots at alpha 0.01: {fw} (expected <= 0.6)")
res = an.analyze(fake_fleet(200, rng, drift=(17, 2), step=(101, 4)))
got = {(f["robot_id"], f["subject"], f["kind"]) for f in trend_findings(res)}
check(got == {("r017", "p2", "drift"), ("r101", "p4", "step")}, "among 200 robots: the drift and the step, nothing else",
      str(got))
stp = next(f for f in res["findings"] if f["kind"] == "step")
check(stp["detail"]["change_index"] == 5 and stp["first_sha256"] == "101-5", "the step's first recording at the new level")
dr = next(f for f in res["findings"] if f["kind"] == "drift")
check(abs(dr["size"] - 0.036) < 3 * dr["size_std"], f"the drift's size over the span ({dr['size']:.4f} ± {dr['size_std']:.4f}, true 0.036)")


# -- the report's plots: one stack (matplotlib), legends of what is drawn, units, same bytes ----
class NoRuns:
    def query_dicts(self, sql):
        return []


def plots_of(folder):
    return {os.path.relpath(os.path.join(d, f), folder): open(os.path.join(d, f), encoding="utf-8").read()
            for d, _, files in os.walk(folder) for f in files if f.endswith(".svg")}


small = fake_fleet(8, random.Random(5), drift=(2, 1), step=(5, 3))
for k, r in enumerate(small["r006"]["recordings"]):
    if k >= 5:
        r.effects = {"time_offset": {"offset_s": (0.0025, 0.0002)}}
res = an.analyze(small)
written = []
for run in range(2):
    out = tmpdir()
    report.write(out, small, res, NoRuns())
    written.append(plots_of(out))
plots = written[0]
import xml.etree.ElementTree as ET  # noqa: E402
check(len(plots) >= 8 * 6 + 3 and all("Matplotlib v" in t for t in plots.values()),
      f"all {len(plots)} plots of a report drawn with matplotlib", str([n for n, t in plots.items() if "Matplotlib v" not in t]))
check(all(ET.fromstring(t.encode()) is not None for t in plots.values()), "every plot well-formed XML")
check(written[0] == written[1], "the same fleet, the same plots, byte for byte",
      str([n for n in written[0] if written[0][n] != written[1].get(n)][:3]))


def plot_texts(name):
    return " ".join(re.findall(r"<text[^>]*>([^<]*)</text>", plots[name]))


stepped, drifted, steady = plot_texts("robots/r005_p3.svg"), plot_texts("robots/r002_p1.svg"), plot_texts("robots/r000_p0.svg")
check("step" in stepped and "model: step" in stepped and "drift" not in stepped,
      "a stepping parameter's legend names the step model and the step line", stepped)
check("model: drift" in drifted and "drift significant" in drifted, "a drifting one's the drift model and where it shows",
      drifted)
check("model: constant" in steady and "step" not in steady and "drift" not in steady,
      "a constant one's legend names only what is drawn", steady)
check(all(u in t for t in (stepped, drifted, steady) for u in ("mm", "date", "UTC")),
      "the trend plots' axes carry their units (mm, the date in UTC)", steady)
check(re.search(r"<title>\d{4}-\d\d-\d\d: [-\d.]+ ± [\d.e-]+ mm</title>", plots["robots/r000_p0.svg"]) is not None,
      "each calibration's date and value as its tooltip")
effect = plot_texts("robots/r006_e0.svg")
check("ms" in effect and "found: size" in effect and "not found" in effect, "the effect's plot: ms, found and not found",
      effect)
timeline = plot_texts("timeline.svg")
check(all(w in timeline for w in ("r002", "r005", "r006", "step", "drift significant", "with", "UTC")),
      "the timeline names the robots, the step, the drift and the recordings with an effect", timeline)

# -- fleet.yaml ----------------------------------------------------------------------------
tmp = tmpdir()
robot = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config", "robots", "diff_robot.yaml")
cases = [
    ("robots: [a, b]\n", "robots"),
    ("fleet: {}\n", "robots"),
    (f"robots:\n  a: {{robot: {robot}}}\n", "robots.a.recordings"),
    ("robots:\n  a: {robot: nosuch.yaml, recordings: '*.log'}\n", "robots.a.robot"),
    (f"robots:\n  a: {{robot: {robot}, recordings: '*.log', colour: red}}\n", "robots.a.colour"),
    ("robots:\n  a: {robot: x\n", "line"),
]
for i, (text, key) in enumerate(cases):
    fy = os.path.join(tmp, f"bad{i}.yaml")
    open(fy, "w").write(text)
    p = fleet("run", fy, "--db", os.path.join(tmp, "x.sqlite"))
    check(p.returncode == 2 and fy in p.stderr and key in p.stderr and p.stderr.count("\n") == 1,
          f"broken fleet.yaml ({key}): exit 2, one line naming the file and the key", p.stderr)
p = fleet("run", os.path.join(tmp, "nosuch.yaml"))
check(p.returncode == 2 and "nosuch.yaml" in p.stderr, "a fleet file that does not exist: exit 2", p.stderr)
p = fleet("run", tmp, "--db", os.path.join(tmp, "x.sqlite"))
check(p.returncode == 2 and "robot.yaml" in p.stderr, "a folder without robots: exit 2", p.stderr)
p = fleet("run", "--workers", "0", os.path.join(tmp, "bad0.yaml"))
check(p.returncode == 2, "--workers 0: exit 2", p.stderr)

from agvcal_fleet import fleetfile  # noqa: E402
tree = os.path.join(tmp, "tree")
for rid in ("site-a/agv-1", "site-a/agv-2"):
    os.makedirs(os.path.join(tree, rid, "2025-01"))
    open(os.path.join(tree, rid, "robot.yaml"), "w").write(open(robot).read())
    for k in range(2):
        open(os.path.join(tree, rid, "2025-01", f"{k}.log"), "w").write("x")
rs = fleetfile.load(tree)
check([(r.robot_id, len(r.recordings)) for r in rs] == [("site-a/agv-1", 2), ("site-a/agv-2", 2)],
      "a folder tree: every folder with a robot.yaml is a robot, its *.log below its recordings", str(rs))

# -- schema ------------------------------------------------------------------------------------
db = os.path.join(tmp, "m.sqlite")
p1, p2 = fleet("migrate", "--db", db), fleet("migrate", "--db", db)
check("applied 1" in p1.stdout and "up to date" in p2.stdout, "migrate creates, then finds it up to date", p1.stdout + p2.stdout)
con = sqlite3.connect(db)
tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
check({"robots", "recordings", "calibrations", "calibration_params", "diagnoses", "diagnosis_effects", "runs",
       "tasks", "findings", "schema_version"} <= tables, "the tables of docs/fleet.md", str(sorted(tables)))
con.execute("UPDATE schema_version SET version = 99")
con.commit()
con.close()
p = fleet("migrate", "--db", db)
check(p.returncode == 2 and "newer" in p.stderr, "a database from a newer tool: exit 2", p.stderr)

for sub in ("", "run", "analyze", "report", "migrate", "synth"):
    p = fleet(*([sub] if sub else []), "--help")
    check(p.returncode == 0 and "usage: agvcal-fleet" in p.stdout, f"agvcal-fleet {sub} --help".replace("  ", " "))
finish()
