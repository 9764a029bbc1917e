#!/usr/bin/env python3
"""The contract in the repository: docs/spec/ holds the four spec files (messages, robot file,
command line and result files, effects), byte for byte those of the shared contract
(../shared/spec beside the checkout), so that a clone reads the same contract the code follows.
Exit 77 (skipped) where the shared contract is not beside the checkout (a plain clone).

usage: check_spec_copy.py SOURCE_DIR   (ctest: spec_copy)"""
import filecmp
import os
import sys

NAMES = ["cli.md", "effects.md", "messages.md", "robot.md"]


def main():
    src = os.path.abspath(sys.argv[1])
    ours = os.path.join(src, "docs", "spec")
    missing = [n for n in NAMES if not os.path.isfile(os.path.join(ours, n))]
    if missing:
        print("docs/spec lacks %s" % ", ".join(missing))
        return 1
    shared = os.path.join(src, "..", "shared", "spec")
    if not os.path.isdir(shared):
        print("skipped: %s not found (docs/spec holds the contract)" % shared)
        return 77
    theirs = sorted(n for n in os.listdir(shared) if n.endswith(".md"))
    problems = [n for n in theirs if n not in NAMES]
    problems += [n for n in NAMES if n not in theirs]
    problems += [n for n in NAMES if n in theirs and not filecmp.cmp(os.path.join(ours, n), os.path.join(shared, n),
                                                                     shallow=False)]
    for n in problems:
        print("docs/spec/%s differs from ../shared/spec/%s (copy it over: cp ../shared/spec/*.md docs/spec/)" % (n, n))
    print("%d spec files compared, %d differ" % (len(NAMES), len(problems)))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
