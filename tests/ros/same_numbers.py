#!/usr/bin/env python3
"""Exit 0 when two RESULT.json files hold the same numbers within a relative tolerance
(absolute below 1e-12); keys naming the recording ("log", "source") and the run ("provenance")
are not compared.

    same_numbers.py A.json B.json TOLERANCE
"""
import json
import sys

SKIP = {"log", "source", "recording", "provenance"}


def compare(a, b, tol, path, problems):
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key in SKIP:
                continue
            if key not in a or key not in b:
                problems.append(f"{path}.{key}: only in one")
            else:
                compare(a[key], b[key], tol, f"{path}.{key}", problems)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, tol, f"{path}[{i}]", problems)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if abs(a - b) > max(tol * max(abs(a), abs(b)), 1e-12):
            problems.append(f"{path}: {a} vs {b}")
    elif a != b:
        problems.append(f"{path}: {a!r} vs {b!r}")


def main():
    a, b = (json.load(open(p)) for p in sys.argv[1:3])
    problems = []
    compare(a, b, float(sys.argv[3]), "", problems)
    for p in problems[:20]:
        print(p, file=sys.stderr)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
