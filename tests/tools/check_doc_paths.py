#!/usr/bin/env python3
"""Every repository path a person is pointed to exists: the paths named in the --help texts of
every command (agvcal's sub-commands and the processes) and in README.md, docs/*.md and
config/*/README.md, including their Markdown links. A `build/...` path must exist in the build
folder. Placeholders (<NAME>, NAME.yaml, globs) are skipped, and so are paths outside the
repository (../shared, the contract) and files a command writes (listed below).

usage: check_doc_paths.py SOURCE_DIR BUILD_DIR   (ctest: doc_paths)"""
import glob
import os
import re
import subprocess
import sys

SRC, BUILD = (os.path.abspath(p) for p in sys.argv[1:3])
TOP = "config|docs|scripts|tests|libcalib|processes|bench|logs|lcmtypes|build"
PATH_RE = re.compile(r"(?<![\w./-])((?:%s)/[A-Za-z0-9_./+-]*[A-Za-z0-9_/+-])" % TOP)
LINK_RE = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
# Files and folders commands write (examples of output names, not pointers to read).
WRITTEN = re.compile(r"^(logs/(mine|my|robot|new|out|recording|real|sim)[\w.-]*|docs/[\w-]+\.png)$")


def help_texts():
    agvcal = os.path.join(BUILD, "agvcal")
    usage = subprocess.run([agvcal, "--help"], capture_output=True, text=True)
    text = usage.stdout + usage.stderr
    commands = sorted(set(re.findall(r"^  ([a-z]+) ", text, re.M)))
    assert len(commands) >= 5, "agvcal --help lists no commands:\n" + text
    yield "agvcal --help", text
    print("agvcal commands: " + " ".join(commands))
    for cmd in commands:
        r = subprocess.run([agvcal, cmd, "--help"], capture_output=True, text=True)
        if r.returncode == 0:
            yield "agvcal %s --help" % cmd, r.stdout
    for exe in sorted(glob.glob(os.path.join(BUILD, "agvcal-*"))):
        if os.access(exe, os.X_OK) and os.path.isfile(exe):
            r = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=20)
            yield os.path.basename(exe) + " --help", r.stdout + r.stderr


def docs():
    files = [os.path.join(SRC, "README.md")] + sorted(glob.glob(os.path.join(SRC, "docs", "*.md")))
    files += sorted(glob.glob(os.path.join(SRC, "config", "*", "README.md")))
    for f in files:
        with open(f, encoding="utf-8") as fh:
            yield os.path.relpath(f, SRC), fh.read()


def exists(path, base_dir):
    if path.startswith("build/"):
        return os.path.exists(os.path.join(BUILD, path[len("build/"):]))
    return os.path.exists(os.path.join(SRC, path)) or os.path.exists(os.path.join(base_dir, path))


def main():
    missing = []
    checked = 0
    for where, text in list(help_texts()) + list(docs()):
        base = os.path.dirname(os.path.join(SRC, where)) if where.endswith(".md") else SRC
        for match in PATH_RE.finditer(text):
            path, after = match.group(1), text[match.end():match.end() + 1]
            # Placeholders and patterns: "logs/run-*/", "import_*.cc", "<name>", "NAME.yaml".
            if (WRITTEN.match(path) or after in ("*", "<", "{", "$") or re.search(r"[A-Z]{3,}|\.\.\.", path)
                    or path.endswith(("-", "_"))):
                continue
            checked += 1
            if not exists(path.rstrip("/"), base):
                missing.append("%s: %s" % (where, path))
        if where.endswith(".md"):
            for link in LINK_RE.findall(text):
                if re.match(r"^[a-z]+:", link) or "../shared" in link or "shared/" in link:
                    continue
                checked += 1
                if not os.path.exists(os.path.normpath(os.path.join(base, link))):
                    missing.append("%s: link %s" % (where, link))
    for m in missing:
        print("MISSING " + m)
    print("%d paths checked, %d missing" % (checked, len(missing)))
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
