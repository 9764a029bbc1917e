#!/usr/bin/env python3
"""The command line of every command against its documentation (ctest: cli_options).

Commands: every `agvcal` sub-command (the list `agvcal --help` prints) and every process
(build/agvcal-NAME for each processes/NAME/*_main.cc). For each:
  - `--help` exits 0 with the help on stdout, starting with "usage: COMMAND";
  - `--version` exits 0 and prints "COMMAND VERSION", VERSION being CMake's project version and
    `git describe` of the tree ("0.1.0 (git c7d975a-dirty)"; the build's, so build before checking);
  - an unknown option exits 2 with one line on stderr naming it;
  - every documented option exists and every option is documented.
An option exists when `--help` lists it (the help is generated from the declared options).
An option is documented when a command line shown for that command carries it: in README.md,
docs/*.md and docs/spec/cli.md, a line of a fenced code block (joined across trailing
backslashes) or an inline `code` span, from the command's name ("agvcal solve", "agvcal-sim",
with or without "build/") up to a shell comment, a pipe, "&&", ";" or the next command. --help
and --version are every command's, documented once in README.md.
Every --help ends with the command's exit statuses ("Exit status: 0 ...", docs/spec/cli.md).
Also: the commander's help names every trajectory the code knows for each drive type (the list
its own error message gives for an unknown trajectory).

usage: check_cli.py SOURCE_DIR BUILD_DIR"""
import glob
import os
import re
import subprocess
import sys

SRC, BUILD = (os.path.abspath(p) for p in sys.argv[1:3])
OPTION_RE = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
GENERIC = {"--help", "--version"}
failures = []


def fail(message):
    failures.append(message)
    print("FAIL " + message)


def run(command, *args):
    return subprocess.run(command + list(args), capture_output=True, text=True, timeout=30)


def commands():
    """{name as typed: argv prefix}: the sub-commands agvcal --help lists, and every process."""
    agvcal = os.path.join(BUILD, "agvcal")
    top = run([agvcal], "--help")
    listed = top.stdout.split("\nCommands:\n", 1)[-1] if "\nCommands:\n" in top.stdout else ""
    subs = re.findall(r"^  ([a-z]+) ", listed, re.M)
    if top.returncode != 0 or len(subs) < 5:
        fail("agvcal --help (exit %d) lists no commands:\n%s" % (top.returncode, top.stdout + top.stderr))
    found = {"agvcal": [agvcal]}
    found.update({"agvcal " + s: [agvcal, s] for s in subs})
    for main in sorted(glob.glob(os.path.join(SRC, "processes", "*", "*_main.cc"))):
        folder = os.path.basename(os.path.dirname(main))
        exe = os.path.join(BUILD, "agvcal-" + folder)
        if folder == "agvcal":
            continue
        if os.access(exe, os.X_OK):
            found["agvcal-" + folder] = [exe]
        else:
            fail("%s: not built" % exe)
    return found


def help_options(name, argv):
    """The options --help lists, or None when --help misbehaves."""
    r = run(argv, "--help")
    if r.returncode != 0 or not r.stdout.startswith("usage: " + name):
        fail("%s --help: exit %d, stdout starting %r (expected exit 0 and 'usage: %s')"
             % (name, r.returncode, r.stdout[:60], name))
        return None
    if not re.search(r"^Exit status: 0 ", r.stdout, re.M):
        fail("%s --help: no line 'Exit status: 0 ...' (every help says what its exit statuses mean)" % name)
    options = set()
    for line in r.stdout.split("\nOptions:\n", 1)[-1].splitlines():
        m = re.match(r"^  (?:-\w,)?(--[a-z][a-z0-9-]*)", line)
        if m:
            options.add(m.group(1))
    return options


def build_version(version):
    """The project version and, in a git checkout, git describe of the tree (cmake/version.cmake)."""
    r = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], cwd=SRC, capture_output=True, text=True)
    return "%s (git %s)" % (version, r.stdout.strip()) if r.returncode == 0 and r.stdout.strip() else version


def check_version_and_errors(name, argv, version):
    r = run(argv, "--version")
    if r.returncode != 0 or r.stdout != "%s %s\n" % (name, version):
        fail("%s --version: exit %d, %r (expected '%s %s')" % (name, r.returncode, r.stdout, name, version))
    r = run(argv, "--no-such-option")
    lines = r.stderr.splitlines()
    if r.returncode != 2 or len(lines) != 1 or "--no-such-option" not in lines[0] or not lines[0].startswith(name + ":"):
        fail("%s --no-such-option: exit %d, stderr %r (expected exit 2 and one line '%s: ...' naming it)"
             % (name, r.returncode, r.stderr[:300], name))


def shown_command_lines(text):
    """Lines of fenced code blocks (backslash continuations joined) and inline code spans."""
    in_block, pending = False, ""
    for line in text.split("\n"):
        if line.lstrip().startswith("```"):
            in_block, pending = not in_block, ""
            continue
        if in_block:
            if line.endswith("\\"):
                pending += line[:-1] + " "
                continue
            yield pending + line
            pending = ""
        else:
            yield from re.findall(r"`([^`]+)`", line)


def documented_options(names):
    """{command: {option: [doc files]}} from the command lines the docs show."""
    files = [os.path.join(SRC, "README.md")] + sorted(glob.glob(os.path.join(SRC, "docs", "*.md")))
    files.append(os.path.join(SRC, "docs", "spec", "cli.md"))
    command_re = re.compile(r"(?<![\w/.-])(?:build/)?(agvcal(?:-[a-z]+| [a-z]+)?)(?=\s|$)")
    documented = {}
    for path in files:
        with open(path, encoding="utf-8") as f:
            text = f.read()
        for line in shown_command_lines(text):
            for part in re.split(r"\s#|\s\|\s|&&|;", line):
                mentions = [m for m in command_re.finditer(part) if m.group(1) in names]
                for i, m in enumerate(mentions):
                    end = mentions[i + 1].start() if i + 1 < len(mentions) else len(part)
                    for option in OPTION_RE.findall(part[m.end():end]):
                        documented.setdefault(m.group(1), {}).setdefault(option, set()).add(
                            os.path.relpath(path, SRC))
    return documented


def check_trajectories():
    """The commander's help names, per drive type, the trajectories its error message lists."""
    commander = os.path.join(BUILD, "agvcal-commander")
    text = run([commander], "--help").stdout
    robots = {"differential": "diff_robot.yaml", "tricycle": "forklift.yaml", "dual_steer": "dual_steer_agv.yaml"}
    for drive, robot in robots.items():
        r = run([commander], os.path.join(SRC, "config", "robots", robot), "--trajectory", "no-such-trajectory")
        known = re.search(r"known: (.*)$", r.stderr, re.M)
        if r.returncode != 2 or not known:
            fail("agvcal-commander --trajectory no-such-trajectory (%s): exit %d, %r" % (robot, r.returncode, r.stderr))
            continue
        in_code = set(known.group(1).replace(",", " ").split())
        shown = re.search(r"^ +%s:(.*)$" % drive, text, re.M)
        in_help = set(shown.group(1).split()) if shown else set()
        if in_code != in_help:
            fail("agvcal-commander --help, %s: lists %s; the code knows %s"
                 % (drive, sorted(in_help), sorted(in_code)))


def main():
    with open(os.path.join(SRC, "CMakeLists.txt"), encoding="utf-8") as f:
        version = build_version(re.search(r"project\(agvcal VERSION (\S+)", f.read()).group(1))
    found = commands()
    documented = documented_options(set(found))
    for name, argv in sorted(found.items()):
        check_version_and_errors(name, argv, version)
        options = help_options(name, argv)
        if options is None:
            continue
        shown = documented.get(name, {})
        for option, where in sorted(shown.items()):
            if option not in options:
                fail("%s: %s shows %s, which --help does not list" % (name, ", ".join(sorted(where)), option))
        for option in sorted(options - GENERIC - set(shown)):
            fail("%s: %s is not shown with the command in README.md, docs/*.md or docs/spec/cli.md" % (name, option))
        print("%-20s %2d options, %2d shown in the docs" % (name, len(options - GENERIC), len(shown)))
    check_trajectories()
    print("%d commands checked, %d problems" % (len(found), len(failures)))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
