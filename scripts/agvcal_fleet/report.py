"""`agvcal-fleet report`: the analysis as HTML pages with SVG plots.

DIR/index.html   the fleet at a glance: robots that need attention and why (strongest
                 evidence per robot against the alarm threshold, a timeline of their
                 recordings with the changes marked), fleet-wide effects, failed recordings,
                 every robot in a table
DIR/robots/ID.html  per robot: findings, each parameter's trend (calibrations with their
                 sigmas, the fitted model and its 2-sigma band), effects over time, the
                 recordings with their exit statuses and held-out verdicts
Every page carries a small script that, opened with `#check`, checks its own layout (no
horizontal overflow, every image loaded, no text overflowing its box) and writes the
findings into the page (element #layout-check), for the headless-browser test.
"""
import html
import math
import os
import re

from . import analyze as an
from . import stats
from . import svg

# The reports' one stylesheet, the C++ reports' too (their pages embed it at build time).
STYLE_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "libcalib", "src", "io",
                          "report_style.css")


def css():
    with open(STYLE_FILE, encoding="utf-8") as f:
        return f.read()


CHECK_JS = """
window.addEventListener('load', function () {
  if (location.hash !== '#check') return;
  var problems = [], W = document.documentElement.clientWidth;
  if (document.documentElement.scrollWidth > W + 1)
    problems.push('page wider than the window: ' + document.documentElement.scrollWidth + ' > ' + W);
  var imgs = document.querySelectorAll('img');
  imgs.forEach(function (im) {
    if (!im.complete || im.naturalWidth === 0) problems.push('image not loaded: ' + im.getAttribute('src'));
    var r = im.getBoundingClientRect();
    if (r.right > W + 1) problems.push('image beyond the right edge: ' + im.getAttribute('src'));
    if (r.width < 50 || r.height < 20) problems.push('image too small: ' + im.getAttribute('src'));
  });
  document.querySelectorAll('td, th, p, h1, h2, h3, li').forEach(function (el) {
    if (el.scrollWidth > el.clientWidth + 1)
      problems.push('text overflows its box: ' + el.textContent.slice(0, 60));
  });
  var pre = document.createElement('pre');
  pre.id = 'layout-check';
  pre.textContent = JSON.stringify({images: imgs.length, width: W, problems: problems});
  document.body.appendChild(pre);
});
"""


def e(s):
    return html.escape(str(s))


def slug(rid):
    return re.sub(r"[^A-Za-z0-9._-]", "_", rid)


def provenance(db_url):
    """What produced the pages, in the C++ reports' words (their provenance table): the command
    (the database's password left out), where it ran, the database, the agvcal version, the date."""
    import datetime
    import shlex
    import subprocess
    import sys
    from .db import _redact
    from .runner import find_agvcal
    try:
        r = subprocess.run([find_agvcal(None), "--version"], capture_output=True, text=True, timeout=30)
        version = r.stdout.strip().split(" ", 1)[1] if r.returncode == 0 and " " in r.stdout.strip() else "unknown"
    except Exception:  # no agvcal: the pages are still written, saying so
        version = "unknown (no agvcal binary found)"
    return {"command": "agvcal-fleet " + " ".join(shlex.quote(_redact(w)) for w in sys.argv[1:]),
            "directory": os.getcwd(), "database": _redact(db_url), "agvcal_version": version,
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")}


def page(title, body, depth=0, verdict="", prov=None):
    """A page as the C++ reports make theirs (io/report_page.cc): the title, one sentence a person
    acts on, what produced the page, then the body."""
    up = "../" * depth
    top = f"<h1>{e(title)}</h1>\n"
    if verdict:
        top += f"<p class=\"verdict\">{e(verdict)}</p>\n"
    if prov:
        top += ("<div class=\"tablewrap provenance\"><table>\n" +
                "".join(f"<tr><th>{e(k)}</th><td>{e(v)}</td></tr>\n" for k, v in prov.items()) + "</table></div>\n")
    return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{e(title)}</title><style>{css()}</style><script>{CHECK_JS}</script></head>"
            f"<body>{top}{body}<p class=\"muted small\">agvcal-fleet report · <a href=\"{up}index.html\">fleet</a></p>"
            f"</body></html>\n")


def fleet_verdict(robots, attention, by_robot):
    if not attention:
        return (f"No robot needs attention: the calibrations of all {len(robots)} robots are constant within their "
                "sigmas, no effect persists and no recording failed; nothing to do.")
    named = "; ".join(f"{rid} ({', '.join(sorted({f['kind'].replace('_', '-') for f in by_robot[rid]}))})"
                      for rid in attention[:6])
    more = f" and {len(attention) - 6} more" if len(attention) > 6 else ""
    return (f"{len(attention)} of {len(robots)} robots need attention: {named}{more}. Open each robot's page for "
            "the evidence, then recalibrate it or look for what changed on it.")


def robot_verdict(rid, findings):
    if not findings:
        return f"{rid} needs nothing: its calibrations are constant within their sigmas and no effect persists."
    first = findings[0]
    return (f"{rid} needs attention: {first['why']}" + (f" (and {len(findings) - 1} more finding"
            f"{'s' * (len(findings) > 2)} below)" if len(findings) > 1 else "") +
            ". Recalibrate it, or look for what changed on it at that date.")


def kind_badge(kind):
    label = {"fleet_effect": "fleet-wide", "heldout": "held-out"}.get(kind, kind)
    return f'<span class="kind {e(kind)}">{e(label)}</span>'


def day_of(utime):
    return utime / an.DAY_US if utime is not None else None


def write_file(path, text):
    tmp = path + ".partial"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


def write(out, robots, result, db, prov=None):
    os.makedirs(os.path.join(out, "robots"), exist_ok=True)
    findings = result["findings"]
    by_robot = {}
    for f in findings:
        by_robot.setdefault(f["robot_id"], []).append(f)
    attention = [rid for rid in robots if rid in by_robot]
    runs = db.query_dicts("SELECT * FROM runs ORDER BY started_utc DESC")
    all_days = [r.day for rob in robots.values() for r in rob["recordings"] if r.day is not None]
    xlo, xhi = (min(all_days), max(all_days)) if all_days else (0, 1)

    # -- overview plots -------------------------------------------------------------------
    write_file(os.path.join(out, "evidence.svg"), evidence_svg(robots, result))
    if attention:
        write_file(os.path.join(out, "timeline.svg"), timeline_svg(robots, attention, by_robot, xlo, xhi))
    fleet_fx = [f for f in findings if f["kind"] == "fleet_effect"]
    for i, f in enumerate(fleet_fx):
        write_file(os.path.join(out, f"fleet_effect_{i}.svg"), fleet_effect_svg(robots, f, xlo, xhi))

    # -- index ----------------------------------------------------------------------------
    n_rec = sum(len(r["recordings"]) for r in robots.values())
    n_fail = sum(1 for rob in robots.values() for r in rob["recordings"] if r.solve_exit != 0 or r.diag_exit != 0)
    b = [f"<p>{len(robots)} robots, {n_rec} recordings from {an.date(xlo * an.DAY_US)} to "
         f"{an.date(xhi * an.DAY_US)}; {n_fail} failed. <b>{len(attention)} robot"
         f"{'s' * (len(attention) != 1)} need attention.</b> {result['tests']} trend tests "
         f"(drift and step for every robot and parameter with at least the minimum number of "
         f"calibrations) at a family-wise false-alarm rate of {result['alpha']:g} over the whole fleet.</p>"]
    if runs:
        r = runs[0]
        b.append(f"<p class=\"small muted\">Last run {e(r['run_id'])} ({e(r['status'])}): "
                 f"{r['submitted']} recordings processed on {e(r['scheduler'])} "
                 f"({r['workers'] or '?'} workers), {r['skipped']} skipped as done, {r['failed']} failed"
                 f"{', %d lost' % r['lost'] if r['lost'] else ''}, {r['elapsed_s'] or 0:.0f} s.</p>")
    if fleet_fx:
        b.append("<h2>Fleet-wide effects</h2>")
        for i, f in enumerate(fleet_fx):
            links = ", ".join(f'<a href="robots/{slug(x)}.html">{e(x)}</a>' for x in f["detail"]["robots"])
            b.append(f"<p>{kind_badge('fleet_effect')} {e(f['why'])}.<br><span class=\"small\">Robots: {links}</span></p>")
            b.append(img(f"fleet_effect_{i}.svg", PLOT_HEIGHT, f"{f['subject']} over the fleet"))
    b.append("<h2>Robots that need attention</h2>")
    if attention:
        b.append(img("evidence.svg", evidence_height(list(robots)), "strongest evidence per robot"))
        b.append(img("timeline.svg", timeline_height(len(attention)), "timeline of the robots that need attention"))
        b.append('<table class="fixed"><tr><th style="width:13%">robot</th><th style="width:9%">drive</th>'
                 '<th style="width:11%">finding</th><th>why</th></tr>')
        for rid in attention:
            rows = by_robot[rid]
            for j, f in enumerate(rows):
                who = (f'<a href="robots/{slug(rid)}.html">{e(rid)}</a>' if j == 0 else "")
                drive = e(robots[rid]["drive"] or "?") if j == 0 else ""
                b.append(f"<tr><td>{who}</td><td>{drive}</td><td>{kind_badge(f['kind'])}</td><td>{e(f['why'])}</td></tr>")
        b.append("</table>")
    else:
        b.append('<p class="ok">None: every robot\'s parameters are constant within their sigmas, no '
                 'effect persists, no recording failed.</p>')
        b.append(img("evidence.svg", evidence_height(list(robots)), "strongest evidence per robot"))
    failed = [(rid, r) for rid, rob in robots.items() for r in rob["recordings"]
              if r.solve_exit != 0 or r.diag_exit != 0]
    if failed:
        b.append("<h2>Failed recordings</h2><table class=\"fixed\"><tr><th style=\"width:13%\">robot</th>"
                 "<th style=\"width:30%\">recording</th><th style=\"width:12%\">exit (solve / diagnose)</th><th>message</th></tr>")
        for rid, r in failed:
            msg = r.solve_message if r.solve_exit != 0 else r.diag_message
            b.append(f"<tr><td><a href=\"robots/{slug(rid)}.html\">{e(rid)}</a></td><td>{e(os.path.basename(r.path))}</td>"
                     f"<td>{e(r.solve_exit)} / {e(r.diag_exit)}</td><td>{e(msg or '')}</td></tr>")
        b.append("</table>")
    b.append("<h2>All robots</h2><table class=\"fixed\"><tr><th style=\"width:14%\">robot</th><th style=\"width:10%\">drive</th>"
             "<th style=\"width:11%\">recordings</th><th style=\"width:13%\">latest</th>"
             "<th style=\"width:17%\">latest held-out check</th><th>status</th></tr>")
    for rid, rob in robots.items():
        recs = rob["recordings"]
        dated = [r for r in recs if r.utime is not None]
        latest = an.date(dated[-1].utime) if dated else "?"
        ho = next((r.heldout["heldout_verdict"] for r in reversed(recs) if r.heldout.get("heldout_verdict")), "")
        kinds = sorted({f["kind"] for f in by_robot.get(rid, [])})
        status = " ".join(kind_badge(k) for k in kinds) if kinds else '<span class="ok">ok</span>'
        b.append(f"<tr><td><a href=\"robots/{slug(rid)}.html\">{e(rid)}</a></td><td>{e(rob['drive'] or '?')}</td>"
                 f"<td>{len(recs)}</td><td>{latest}</td><td>{e(ho.replace('_', ' '))}</td><td>{status}</td></tr>")
    b.append("</table>")
    b.append(f"<p class=\"small muted\">Noise scale per drive and parameter (the sigmas are widened by it when "
             f"the fleet's scatter says they are optimistic): "
             f"{e(', '.join(f'{k} {v:.2f}' for k, v in sorted(result['scales'].items())))}.</p>")
    write_file(os.path.join(out, "index.html"), page("Fleet calibration report", "\n".join(b), 0,
                                                     fleet_verdict(robots, attention, by_robot), prov))

    # -- robot pages ----------------------------------------------------------------------
    for rid, rob in robots.items():
        write_robot(out, rid, rob, by_robot.get(rid, []), result, prov)


def write_robot(out, rid, rob, findings, result, prov=None):
    s = slug(rid)
    d = os.path.join(out, "robots")
    recs = rob["recordings"]
    b = [f"<p>{e(rob['drive'] or '?')} drive, robot file <code>{e(rob['robot_file'])}</code>; "
         f"{len(recs)} recordings.</p>"]
    if findings:
        b.append("<h2>Findings</h2><ul>")
        for f in findings:
            b.append(f"<li>{kind_badge(f['kind'])} {e(f['why'])}</li>")
        b.append("</ul>")
    else:
        b.append('<p class="ok">No finding: constant within the sigmas, no persistent effect.</p>')
    ser = result["series"].get(rid, {})
    dated = [r.day for r in recs if r.day is not None]
    xlo, xhi = (min(dated), max(dated)) if dated else (0, 1)
    if ser:
        b.append("<h2>Parameters</h2><p class=\"small\">Each calibration with its one-sigma bar; the line "
                 "is the model the tests chose (constant, drift or step), the band its 2-sigma range "
                 "(sigmas times the fleet's noise scale).</p>")
    for i, (name, sr) in enumerate(sorted(ser.items())):
        fname = f"{s}_p{i}.svg"
        write_file(os.path.join(d, fname), param_svg(name, sr, findings, xlo, xhi))
        b.append(img(fname, PLOT_HEIGHT, f"{name} over time"))
    keys = sorted({k for r in recs for k in r.effects})
    if keys:
        b.append("<h2>Effects found by the diagnosis</h2>")
        for i, key in enumerate(keys):
            fname = f"{s}_e{i}.svg"
            write_file(os.path.join(d, fname), effect_svg(key, recs, xlo, xhi))
            b.append(img(fname, PLOT_HEIGHT, f"{key} over time"))
    b.append("<h2>Recordings</h2><table class=\"fixed\"><tr><th style=\"width:11%\">date</th><th style=\"width:27%\">file</th>"
             "<th style=\"width:9%\">s, m driven</th><th style=\"width:9%\">solve</th><th style=\"width:16%\">held-out</th>"
             "<th>diagnosis</th></tr>")
    for r in recs:
        solve = "ok" if r.solve_exit == 0 else f"exit {r.solve_exit}"
        ho = r.heldout.get("heldout_verdict") or ""
        if r.heldout.get("heldout_nominal_error_per_m") is not None:
            ho += (f" ({an.fmt_error_per_m(r.heldout['heldout_nominal_error_per_m'])} → "
                   f"{an.fmt_error_per_m(r.heldout['heldout_calibrated_error_per_m'])})")
        if r.diag_exit == 0:
            diag = ", ".join(f"{k} {an.fmt_effect(k, v[an.effect_key_param(k, v)][0])}" for k, v in sorted(r.effects.items())) or "no effect"
        else:
            diag = f"exit {r.diag_exit}: {r.diag_message or ''}"
        if r.solve_exit != 0:
            solve += f": {r.solve_message or ''}"
        dur = f"{r.duration_s:.0f}, {r.distance_m:.1f}" if r.duration_s is not None and r.distance_m is not None else ""
        b.append(f"<tr><td>{an.date(r.utime)}</td><td>{e(os.path.basename(r.path))}</td><td>{dur}</td>"
                 f"<td>{e(solve)}</td><td>{e(ho.replace('_', ' '))}</td><td>{e(diag)}</td></tr>")
    b.append("</table>")
    write_file(os.path.join(d, f"{s}.html"), page(f"{rid}: calibration trends", "\n".join(b), 1,
                                                       robot_verdict(rid, findings), prov))


# -- plots: matplotlib in the reports' look (svg.py) ----------------------------------------
PLOT_HEIGHT = 220  # px, a time plot's


def img(src, height, alt):
    return f'<img src="{e(src)}" width="{svg.WIDTH}" height="{height}" alt="{e(alt)}">'


def time_span(xlo, xhi):
    """The time axis of a robot's or the fleet's plots: its recordings' days with a margin."""
    pad = 0.03 * (xhi - xlo + 1)
    return xlo - pad, xhi + pad


def line_handle(color, label, **style):
    from matplotlib.lines import Line2D
    return Line2D([], [], color=color, label=label, **style)


def patch_handle(color, label, alpha=1.0):
    from matplotlib.patches import Patch
    return Patch(facecolor=color, alpha=alpha, label=label)


def model_fit(sr, k):
    """The model the tests chose, at each calibration's time, times k."""
    t = sr["t"]
    model = sr.get("model", "constant")
    if model == "drift":
        dr = sr["drift"]
        return [(dr["a"] + dr["slope"] * (ti - dr["tw"])) * k for ti in t]
    if model == "step":
        st = sr["step"]
        return [(st["before"] if i < st["k"] else st["after"]) * k for i in range(len(t))]
    m, _ = stats.weighted_mean(sr["y"], sr["s"])
    return [m * k] * len(t)


def param_svg(name, sr, findings, xlo, xhi):
    """One parameter over time: each calibration with its one-sigma bar, the model the tests chose
    (constant, drift or step) and its 2-sigma band, the step or where the drift shows."""
    k, lab = an.param_unit(name)
    t, y, s, f = sr["t"], [v * k for v in sr["y"]], [v * k for v in sr["s"]], sr["scale"]
    model = sr.get("model", "constant")
    fit = model_fit(sr, k)
    lo = [fi - 2 * f * si for fi, si in zip(fit, s)]
    hi = [fi + 2 * f * si for fi, si in zip(fit, s)]
    fig, ax = svg.figure(PLOT_HEIGHT)
    # a step's two sides apart: the model jumps between two recordings, not along a slope
    cut = sr["step"]["k"] if model == "step" else len(t)
    for a, b in ((0, cut), (cut, len(t))):
        if b > a:
            ax.fill_between(t[a:b], lo[a:b], hi[a:b], color="#9ecae1", alpha=0.35, linewidth=0)
            ax.plot(t[a:b], fit[a:b], color="#08519c", linewidth=1.5)
    band = "model's 2σ band" + ("" if f == 1 else f"\n(σ × noise scale {f:.2f})")
    handles = [line_handle("#252525", "calibration ± 1σ", marker="o", markersize=4, linestyle="none"),
               line_handle("#08519c", f"model: {model}", linewidth=1.5), patch_handle("#9ecae1", band, 0.35)]
    if model == "step":
        ax.axvline(0.5 * (t[cut - 1] + t[cut]), color="#d62728", linestyle=(0, (4, 3)), linewidth=1.2)
        handles.append(line_handle("#d62728", "step", linestyle=(0, (4, 3))))
    for fnd in findings:
        if fnd["kind"] == "drift" and fnd["subject"] == name:
            ax.axvline(fnd["first_utime"] / an.DAY_US, color="#ff7f0e", linestyle=(0, (4, 3)), linewidth=1.2)
            handles.append(line_handle("#ff7f0e", "drift significant\nfrom here", linestyle=(0, (4, 3))))
    ax.errorbar(t, y, yerr=s, fmt="none", ecolor="#252525", elinewidth=1)
    tips = {}
    for i, (r, ti, yi, si) in enumerate(zip(sr["recs"], t, y, s)):
        ax.plot([ti], [yi], "o", color="#252525", markersize=5, gid=f"point{i}")
        tips[f"point{i}"] = f"{an.date(r.utime)}: {yi:.5g} ± {si:.2g} {lab}"
    svg.title(ax, name)
    svg.value_axis(ax, *svg.padded(lo + hi + [yi - si for yi, si in zip(y, s)] + [yi + si for yi, si in zip(y, s)]),
                   lab)
    svg.date_axis(ax, *time_span(xlo, xhi))
    svg.legend(ax, handles)
    return svg.to_svg(fig, tips)


def effect_svg(key, recs, xlo, xhi):
    """One effect of the diagnosis over time: its size ± 1 sigma where it was found, a hollow
    circle on the zero line where the recording was diagnosed without it."""
    ds = [r for r in recs if r.diag_exit == 0 and r.day is not None]
    param = an.EFFECT_SIZE_PARAM.get(key.split(":")[0])
    xs, ys, es = [], [], []
    for r in ds:
        if key in r.effects:
            v = r.effects[key]
            pp = param if param in v else sorted(v)[0]
            xs.append(r.day)
            ys.append(v[pp][0])
            es.append(v[pp][1] or 0.0)
    k, lab = an.effect_unit(param or "")
    yv, ev = [v * k for v in ys], [er * k for er in es]
    missing = [r.day for r in ds if key not in r.effects]
    fig, ax = svg.figure(PLOT_HEIGHT)
    ax.axhline(0.0, color="#888", linestyle=(0, (2, 3)), linewidth=1)
    handles = []
    if xs:
        ax.errorbar(xs, yv, yerr=ev, fmt="o", color="#6a3d9a", markersize=5, elinewidth=1)
        handles.append(line_handle("#6a3d9a", "found: size ± 1σ", marker="o", markersize=5, linestyle="none"))
    if missing:
        ax.plot(missing, [0.0] * len(missing), "o", markerfacecolor="white", markeredgecolor="#6a3d9a", markersize=5)
        handles.append(line_handle("#6a3d9a", "not found\n(drawn at 0)", marker="o", markerfacecolor="white",
                                   markersize=5, linestyle="none"))
    svg.title(ax, f"{key}: its size when the diagnosis finds it")
    svg.value_axis(ax, *svg.padded(yv + [0.0] + [v + er for v, er in zip(yv, ev)] + [v - er for v, er in zip(yv, ev)]),
                   lab if not param or lab != param else f"{param} (as the diagnosis gives it)")
    svg.date_axis(ax, *time_span(xlo, xhi))
    svg.legend(ax, handles)
    return svg.to_svg(fig)


EVIDENCE_COLORS = {"drift": "#ff7f0e", "step": "#d62728", "none": "#636363"}


def evidence_svg(robots, result):
    """Per robot, in the order of the table and named on the axis, the strongest evidence of a
    change: -log10 of the smallest adjusted p-value of its drift and step tests, against the
    threshold -log10(alpha). A bar chart with names, its value axis with the reports' ticks."""
    ids = list(robots)
    vals, kinds = [], []
    for rid in ids:
        best, kind = 1.0, "none"
        for name, sr in result["series"].get(rid, {}).items():
            for k in ("drift", "step"):
                t = sr.get(k)
                if t and t["p_adj"] < best:
                    best, kind = t["p_adj"], k
        vals.append(min(12.0, -math.log10(max(best, 1e-300))))
        kinds.append(kind if best <= result["alpha"] else "none")
    thr = -math.log10(result["alpha"])
    fig, ax = svg.figure(evidence_height(ids), bottom=evidence_height(ids) - 150)
    ax.bar(range(len(ids)), vals, width=0.7, color=[EVIDENCE_COLORS[k] for k in kinds])
    ax.set_xlim(-0.6, max(len(ids), 1) - 0.4)
    ax.set_xticks(range(len(ids)))
    ax.set_xticklabels(ids, rotation=90, fontsize=min(12, max(6, 700 // max(len(ids), 1))))
    ax.set_xlabel("robot, in the order of the table", fontsize=12)
    ax.axhline(thr, color="#d62728", linestyle=(0, (5, 3)), linewidth=1)
    names = {"drift": "a drift", "step": "a step", "none": "no significant\nchange"}
    handles = [patch_handle(EVIDENCE_COLORS[k], names[k]) for k in ("drift", "step", "none") if k in kinds]
    handles.append(line_handle("#d62728", f"alarm threshold\n(alpha {result['alpha']:g})", linestyle=(0, (5, 3))))
    svg.value_axis(ax, 0, 13, "-log10 adjusted p")
    svg.title(ax, "strongest evidence of a change per robot")
    svg.legend(ax, handles)
    return svg.to_svg(fig)


def evidence_height(ids):
    """The evidence chart's height in px: the frame, and room for the longest name written
    upwards with the axis's label under it."""
    return 150 + 45 + 8 * max((len(r) for r in ids), default=0)


def timeline_height(n):
    return svg.TOP + svg.BOTTOM + max(110, 18 * n)


def timeline_svg(robots, attention, by_robot, xlo, xhi):
    """One row per robot that needs attention: its recordings (grey ok, red failed, purple
    with an effect), steps (red bar), drifts from where they show (orange bar)."""
    fig, ax = svg.figure(timeline_height(len(attention)))
    lo, hi = xlo - 1, xhi + 1
    colors = {"ok": "#969696", "failed": "#d62728", "effect": "#6a3d9a"}
    seen, tips = set(), {}
    for i, rid in enumerate(attention):
        for r in robots[rid]["recordings"]:
            if r.day is None:
                continue
            kind = "failed" if (r.solve_exit != 0 or r.diag_exit != 0) else ("effect" if r.effects else "ok")
            seen.add(kind)
            ax.plot([r.day], [i], "o", color=colors[kind], markersize=6)
        for j, f in enumerate(by_robot[rid]):
            gid = f"finding{i}_{j}"
            if f["kind"] == "step" and f["change_utime"]:
                ax.plot([f["change_utime"] / an.DAY_US], [i], marker="|", markersize=16, markeredgewidth=4,
                        color="#d62728", gid=gid)
                seen.add("step")
                tips[gid] = f["why"]
            if f["kind"] == "drift" and f["first_utime"]:
                ax.plot([f["first_utime"] / an.DAY_US, hi], [i, i], color="#ff7f0e", alpha=0.6, linewidth=4,
                        solid_capstyle="butt", gid=gid)
                seen.add("drift")
                tips[gid] = f["why"]
    ax.set_ylim(len(attention) - 0.5, -0.5)  # the first robot on top, as in the table
    ax.set_yticks(range(len(attention)))
    ax.set_yticklabels(attention, fontsize=10)
    ax.yaxis.grid(True, color="#eee")
    ax.set_axisbelow(True)
    names = {"ok": "recording", "failed": "failed recording", "effect": "recording with\nan effect",
             "step": "step", "drift": "drift significant\nfrom here on"}
    handles = [line_handle(colors[k], names[k], marker="o", markersize=6, linestyle="none")
               for k in ("ok", "failed", "effect") if k in seen]
    if "step" in seen:
        handles.append(line_handle("#d62728", names["step"], marker="|", markersize=12, markeredgewidth=3,
                                   linestyle="none"))
    if "drift" in seen:
        handles.append(line_handle("#ff7f0e", names["drift"], alpha=0.6, linewidth=4))
    svg.title(ax, "recordings of the robots that need attention")
    svg.date_axis(ax, lo, hi)
    svg.legend(ax, handles)
    return svg.to_svg(fig, tips)


def fleet_effect_svg(robots, f, xlo, xhi):
    """The share of the fleet's diagnosed recordings, per week, in which the effect was found."""
    key = f["subject"]
    weeks = {}
    for rob in robots.values():
        for r in rob["recordings"]:
            if r.diag_exit == 0 and r.day is not None:
                w = math.floor((r.day - 4) / 7) * 7 + 4  # weeks from Monday
                n, k = weeks.get(w, (0, 0))
                weeks[w] = (n + 1, k + (key in r.effects))
    xs = sorted(weeks)
    share = [100.0 * weeks[w][1] / weeks[w][0] for w in xs]
    fig, ax = svg.figure(PLOT_HEIGHT)
    ax.bar(xs, share, width=6.6, align="edge", color="#6a3d9a", alpha=0.75)
    onset = f["first_utime"] / an.DAY_US
    ax.axvline(onset, color="#d62728", linestyle=(0, (4, 3)), linewidth=1.2)
    svg.value_axis(ax, 0, max(share + [10]) * 1.1, "% of the week's recordings")
    svg.date_axis(ax, xlo - 3, xhi + 4)
    svg.title(ax, f"{key}: share of the week's recordings in which it is found")
    svg.legend(ax, [patch_handle("#6a3d9a", "share, per week", 0.75),
                    line_handle("#d62728", "first found", linestyle=(0, (4, 3)))])
    return svg.to_svg(fig)
