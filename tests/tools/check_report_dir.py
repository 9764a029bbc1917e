#!/usr/bin/env python3
"""Checks a human report folder (`agvcal diagnose|solve|ground|recal --report DIR`): index.html and
summary.txt are there and not empty, every SVG is well-formed XML with an <svg> root and at
least one drawn mark, index.html parses and shows every SVG of the folder, every image it names
exists, no .partial file is left, the tables have a header row and at least one data row, and
each REQUIRED file (and each REQUIRED text of index.html, given as text:WORDS) is there.
Usage: check_report_dir.py DIR [REQUIRED ...]   (exit 1 with one line per problem)"""
import html.parser
import os
import sys
import xml.etree.ElementTree as ET


class Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.images, self.tables, self.rows, self.stack = [], 0, [], []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs).get("src", ""))
        elif tag == "table":
            self.tables += 1
            self.rows.append(0)
        elif tag == "tr" and self.rows:
            self.rows[-1] += 1
        elif tag == "pre":
            self.stack.append("pre")


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder, required = argv[1], argv[2:]
    problems = []
    for name in ("index.html", "summary.txt"):
        path = os.path.join(folder, name)
        if not os.path.isfile(path) or os.path.getsize(path) == 0:
            problems.append(f"{path}: missing or empty")
    files = sorted(os.listdir(folder)) if os.path.isdir(folder) else []
    svgs = [f for f in files if f.endswith(".svg")]
    for f in files:
        if f.endswith(".partial"):
            problems.append(f"{folder}/{f}: a partial file is left")
    for f in svgs:
        try:
            root = ET.parse(os.path.join(folder, f)).getroot()
        except ET.ParseError as e:
            problems.append(f"{folder}/{f}: not well-formed XML: {e}")
            continue
        if not root.tag.endswith("svg"):
            problems.append(f"{folder}/{f}: root is {root.tag}, not svg")
        marks = [e for e in root.iter() if e.tag.split("}")[-1] in ("circle", "polyline")]
        if not marks:
            problems.append(f"{folder}/{f}: draws no data (no circle or polyline)")
    page = Page()
    text = ""
    if os.path.isfile(os.path.join(folder, "index.html")):
        text = open(os.path.join(folder, "index.html"), encoding="utf-8").read()
        page.feed(text)
        if page.stack:
            problems.append(f"{folder}/index.html: has a <pre> block (runs off narrow pages)")
        for src in page.images:
            if not os.path.isfile(os.path.join(folder, src)):
                problems.append(f"{folder}/index.html: image {src} does not exist")
        for f in svgs:
            if f not in page.images:
                problems.append(f"{folder}/{f}: not shown on index.html")
        if page.tables == 0 or any(r < 2 for r in page.rows):
            problems.append(f"{folder}/index.html: {page.tables} tables, rows {page.rows} (a table without data)")
    for r in required:
        if r.startswith("text:"):
            if r[5:] not in text:
                problems.append(f"{folder}/index.html: lacks the text '{r[5:]}'")
        elif r not in files:
            problems.append(f"{folder}/{r}: missing")
    for p in problems:
        print("FAIL " + p)
    print(f"{folder}: {len(svgs)} SVGs, {page.tables} tables, {len(page.images)} images, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
