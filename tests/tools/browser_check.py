#!/usr/bin/env python3
"""Renders report pages (index.html of `agvcal diagnose|solve|ground|recal --report DIR`, and the pages
of `agvcal-fleet report --out DIR`) in headless Chromium at 1024 px and fails on what a reader would see broken: a page wider than the window
(document.documentElement.scrollWidth > 1024) or an image that does not load (naturalWidth 0).
Without a browser too: each page opens with a verdict sentence and its provenance and shows no
internal notes of the diagnosis (content_problems).
With --screenshots OUT it also writes OUT/<name>.png of each page's top at 1024 px.
Usage: browser_check.py [--screenshots OUT] NAME=PATH...
PATH is a report folder (its index.html) or one page (a .html file). A NAME that starts with
"fleet" is an agvcal-fleet page: its provenance names the database instead of a recording.
Exit status: 0 every page fine; 1 a page is broken; 77 no Chromium (the test is skipped)."""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

WIDTH = 1024
CHECK = """<script>
window.addEventListener('load', function () {
  var broken = [];
  document.querySelectorAll('img').forEach(function (img) {
    if (!img.complete || img.naturalWidth === 0) broken.push(img.getAttribute('src'));
  });
  var r = {scrollWidth: document.documentElement.scrollWidth, innerWidth: window.innerWidth,
           height: document.documentElement.scrollHeight, images: document.images.length, broken: broken};
  var out = document.createElement('pre');
  out.id = 'agvcal-check';
  out.textContent = 'AGVCAL-' + 'CHECK' + JSON.stringify(r) + 'AGVCAL-' + 'END';
  document.body.appendChild(out);
});
</script>
"""


# The diagnosis's bookkeeping, which belongs in REPORT.json and --verbose, never on a page: the
# actuation fit's log-SSE note, the region test's figures (zeros where it never ran), note lines.
INTERNAL_NOTES = [r"log SSE", r"per correlation time", r"boxes of the route \(x 0 \.\. 0, y 0 \.\. 0", r"(^|\n)note: "]
PROVENANCE_KEYS = ["command", "directory", "robot_name", "robot_file", "recording", "recording_sha256",
                   "agvcal_version", "date"]
# The fleet's pages (agvcal-fleet report) stand on a database, not on one recording.
FLEET_PROVENANCE_KEYS = ["command", "directory", "database", "agvcal_version", "date"]


def content_problems(name, html, keys=PROVENANCE_KEYS):
    """What the page says, without a browser: a verdict sentence right under the title, the run's
    provenance (enough to rerun the command on the same bytes), no internal notes."""
    problems = []
    if not re.search(r"</h1>\n<p class=\"verdict\">[^<]{30,}</p>", html):
        problems.append(f"{name}: no verdict sentence under the title")
    for key in keys:
        if not re.search(r"<th>%s</th><td>[^<]+</td>" % key, html):
            problems.append(f"{name}: provenance lacks {key}")
    sha = re.search(r"<th>recording_sha256</th><td>([^<]*)</td>", html)
    if sha and not re.fullmatch(r"[0-9a-f]{64}", sha.group(1)):
        problems.append(f"{name}: recording_sha256 is {sha.group(1)!r}")
    for pattern in INTERNAL_NOTES:
        m = re.search(pattern, html)
        if m:
            problems.append(f"{name}: internal note on the page: ...{html[max(0, m.start() - 60):m.end() + 60]!r}...")
    return problems


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def run(browser, args, profile):
    cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
           "--user-data-dir=" + profile, "--virtual-time-budget=10000"] + args
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


def page_of(path):
    """A report folder's index.html, or the page itself."""
    return path if path.endswith(".html") else os.path.join(path, "index.html")


def provenance_keys(name):
    return FLEET_PROVENANCE_KEYS if name.startswith("fleet") else PROVENANCE_KEYS


def check(browser, name, path, profile):
    """The page's measurements, or a list of problems."""
    page = page_of(path)
    if not os.path.exists(page):
        return [f"{name}: {page} missing"]
    html = open(page, encoding="utf-8").read()
    probe = os.path.join(os.path.dirname(page), ".browser-check.html")
    with open(probe, "w", encoding="utf-8") as f:
        f.write(html.replace("</body>", CHECK + "</body>"))
    try:
        r = run(browser, [f"--window-size={WIDTH},800", "--dump-dom", "file://" + os.path.abspath(probe)], profile)
    finally:
        os.remove(probe)
    m = re.search(r"AGVCAL-CHECK(\{.*?\})AGVCAL-END", r.stdout, re.S)
    if not m:
        return [f"{name}: Chromium gave no measurement (exit {r.returncode}): {r.stderr.strip()[-300:]}"]
    got = json.loads(m.group(1))
    problems = []
    if got["scrollWidth"] > WIDTH:
        problems.append(f"{name}: page is {got['scrollWidth']} px wide at a {WIDTH} px window (runs off the right)")
    if got["images"] == 0:
        problems.append(f"{name}: no image on the page")
    for src in got["broken"]:
        problems.append(f"{name}: image {src} does not load")
    print(f"{name}: {got['images']} images, width {got['scrollWidth']} px, height {got['height']} px"
          + (" -- " + "; ".join(problems) if problems else " -- fine"))
    return problems


def screenshot(browser, name, path, out, profile):
    png = os.path.join(out, name + ".png")
    page = "file://" + os.path.abspath(page_of(path))
    r = run(browser, [f"--window-size={WIDTH},1300", "--screenshot=" + os.path.abspath(png), page], profile)
    if r.returncode != 0 or not os.path.exists(png):
        return [f"{name}: no screenshot (exit {r.returncode}): {r.stderr.strip()[-300:]}"]
    print(f"{name}: {png} ({os.path.getsize(png) // 1024} kB)")
    return []


def main(argv):
    shots = None
    if len(argv) > 2 and argv[1] == "--screenshots":
        shots = argv[2]
        argv = argv[:1] + argv[3:]
    pages = [a.split("=", 1) for a in argv[1:]]
    if not pages or any(len(p) != 2 for p in pages):
        print(__doc__, file=sys.stderr)
        return 2
    problems = []
    for name, path in pages:
        page = page_of(path)
        if os.path.exists(page):
            problems += content_problems(name, open(page, encoding="utf-8").read(), provenance_keys(name))
    browser = chromium()
    if not browser:
        if problems:
            for p in problems:
                print("FAIL " + p)
            return 1
        print("SKIP: no chromium on PATH (scripts/setup.sh installs it; CI has it)")
        return 77
    with tempfile.TemporaryDirectory() as profile:
        for name, folder in pages:
            problems += check(browser, name, folder, profile)
            if shots:
                os.makedirs(shots, exist_ok=True)
                problems += screenshot(browser, name, folder, shots, profile)
    for p in problems:
        print("FAIL " + p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
