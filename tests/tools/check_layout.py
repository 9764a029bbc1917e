#!/usr/bin/env python3
"""The shape of libcalib (docs/architecture.md), checked on every test run:
  - every source and header sits in a subdomain folder, public headers mirrored in
    include/calib/<subdomain>/ and sources (with private headers) in src/<subdomain>/;
  - a subdomain includes only the subdomains below it (LAYERS), so there are no cycles;
  - the generated LCM message types (agvcal/*.hpp) appear only at the bus edge (EDGE):
    the domain takes plain structs;
  - no function in libcalib is longer than MAX_FUNCTION_LINES, no file longer than MAX_FILE_LINES,
    and no class longer than MAX_CLASS_LINES: its declaration and the out-of-line definitions of its
    members (`Name::Member(...) {...}`) together, wherever they stand.
Usage: check_layout.py SOURCE_DIR   (exit 1 with one line per violation)"""
import os
import re
import sys

# Each subdomain and the subdomains it may include (besides itself). The order of this
# table is the layering: a subdomain lists only subdomains above it in the table.
LAYERS = {
    'core': [],                                          # se2, errors, robot file, kinematics, statistics
    'io': ['core'],                                      # recordings, messages, text and cloud files
    'match': ['core', 'io'],                             # de-skew, PL-ICP, the matching pipeline
    'ground': ['core', 'io'],                            # the 3D lidar's mount from the floor
    'sim': ['core', 'io'],                               # world, simulator, sim config
    'import': ['core', 'io'],                            # datasets recorded elsewhere -> recordings
    'devices': ['core', 'io'],                           # CANopen, SICK CoLa, device clocks
    'calibrate': ['core', 'io', 'match'],                # closed form, interval model, solver, held-out
    'diagnose': ['core', 'io', 'match', 'calibrate'],    # the sim-to-real mismatch
    'live': ['core', 'io', 'match', 'calibrate', 'sim'],  # commander, safety, catch-up, dashboard model
}
# Where lcm-gen's message types may be included: the conversions (io) and the folders whose
# job is to produce or consume the wire format itself. The domain never sees a message.
EDGE = {'io', 'import', 'devices', 'sim', 'live'}
MAX_FUNCTION_LINES = 120
MAX_FILE_LINES = 800
MAX_CLASS_LINES = 300



def subdomain_files(lib):
    for top, prefix in (('include/calib', 'calib/'), ('src', '')):
        base = os.path.join(lib, top)
        for dirpath, _, files in os.walk(base):
            for name in files:
                if name.endswith(('.h', '.cc')):
                    path = os.path.join(dirpath, name)
                    yield top, os.path.relpath(path, base), path


def function_lengths(path):
    """(first line, length, signature) of each function body opened at namespace or class level."""
    for first, length, signature, _ in blocks(path, 'function'):
        yield first, length, signature


def class_parts(path):
    """(name, first line, length) of each class declaration and each out-of-line member definition."""
    for first, length, _, name in blocks(path, 'class'):
        if name:
            yield name, first, length
    for first, length, _, owner in blocks(path, 'function'):
        if owner:
            yield owner, first, length


def blocks(path, wanted):
    """(first line, length, signature, name) of each block of kind `wanted`: a function opened at
    namespace or class level (name: the outermost class it is qualified by, `A` of `A::B::f(`, or
    None), or a class or struct (name: its own)."""
    lines = open(path, encoding='utf-8').read().split('\n')
    stack, start, classes = [], None, []
    for i, line in enumerate(lines):
        code = re.sub(r'//.*', '', line)
        code = re.sub(r'"([^"\\]|\\.)*"', '""', code)
        code = re.sub(r"'([^'\\]|\\.)*'", "''", code)
        context = ' '.join(x.strip() for x in lines[max(0, i - 4):i + 1])
        for ch in code:
            if ch == '{':
                at_top = all(kind in ('namespace', 'class') for kind in stack)
                if re.search(r'\bnamespace\b[^;]*$', code.split('{')[0]) or re.match(r'\s*namespace\b', line):
                    kind = 'namespace'
                elif re.match(r'\s*(struct|class|enum)\b', line) or re.search(r'\b(struct|class)\s+\w+[^()]*\{', code):
                    kind = 'class'
                    named = re.search(r'\b(?:struct|class)\s+(\w+)', ' '.join(x.strip() for x in lines[max(0, i - 2):i + 1]))
                    classes.append((i, len(stack), named.group(1) if named and 'enum' not in code else None))
                elif at_top and '(' in context:
                    owner = re.findall(r'\b(\w+)(?:<[^<>]*>)?::(?:\w+(?:<[^<>]*>)?::)*~?\w+\s*\(', context)
                    kind, start = 'function', (i, len(stack), line.strip(), owner[-1] if owner else None)
                else:
                    kind = 'block'
                stack.append(kind)
            elif ch == '}':
                kind = stack.pop() if stack else None
                if kind == 'function' and start and len(stack) == start[1]:
                    if wanted == 'function':
                        yield start[0] + 1, i - start[0] + 1, start[2], start[3]
                    start = None
                elif kind == 'class' and classes and classes[-1][1] == len(stack):
                    first, _, name = classes.pop()
                    if wanted == 'class':
                        yield first + 1, i - first + 1, '', name


def size_problems(lib):
    """Files over MAX_FILE_LINES, classes over MAX_CLASS_LINES (declaration and out-of-line members,
    summed by the class's name over the library: the names of classes are not reused)."""
    problems, declared, size, where = [], set(), {}, {}
    for _, _, path in subdomain_files(lib):
        count = len(open(path, encoding='utf-8').read().rstrip('\n').split('\n'))
        if count > MAX_FILE_LINES:
            problems.append(f'{path}: a file of {count} lines (at most {MAX_FILE_LINES})')
        for name, first, length in class_parts(path):
            size[name] = size.get(name, 0) + length
            where.setdefault(name, f'{path}:{first}')
    for _, _, path in subdomain_files(lib):
        for first, length, _, name in blocks(path, 'class'):
            if name:
                declared.add(name)
    for name in sorted(declared):
        if size.get(name, 0) > MAX_CLASS_LINES:
            problems.append(f'{where[name]}: class {name} of {size[name]} lines with its members (at most '
                            f'{MAX_CLASS_LINES})')
    return problems


def main():
    lib = os.path.join(sys.argv[1], 'libcalib')
    problems = []
    for layer, below in LAYERS.items():
        for other in below:
            if list(LAYERS).index(other) >= list(LAYERS).index(layer):
                problems.append(f'LAYERS: {layer} lists {other}, which is not above it in the table')
    include_re = re.compile(r'#include\s+"([^"]+)"')
    for top, rel, path in subdomain_files(lib):
        parts = rel.split('/')
        if len(parts) < 2 or parts[0] not in LAYERS:
            problems.append(f'{path}: not in a subdomain folder ({", ".join(LAYERS)})')
            continue
        own = parts[0]
        for number, line in enumerate(open(path, encoding='utf-8'), 1):
            m = include_re.match(line.strip())
            if not m:
                continue
            target = m.group(1)
            if target.startswith('agvcal/'):
                if own not in EDGE:
                    problems.append(f'{path}:{number}: {own} includes the message type {target}; '
                                    f'messages stop at the edge ({", ".join(sorted(EDGE))})')
                continue
            inc = target[len('calib/'):] if target.startswith('calib/') else target
            other = inc.split('/')[0]
            if other not in LAYERS:
                continue  # a system or third-party header in quotes
            if other != own and other not in LAYERS[own]:
                problems.append(f'{path}:{number}: {own} includes {target}: {own} may include only '
                                f'{", ".join(LAYERS[own]) or "nothing of the others"}')
        if os.environ.get('AGVCAL_LAYOUT_SKIP_LENGTH') != '1':
            for first, length, signature in function_lengths(path):
                if length > MAX_FUNCTION_LINES:
                    problems.append(f'{path}:{first}: a function of {length} lines (at most '
                                    f'{MAX_FUNCTION_LINES}): {signature[:80]}')
    if os.environ.get('AGVCAL_LAYOUT_SKIP_LENGTH') != '1':
        problems += size_problems(lib)
    public = {rel[:-2] for top, rel, _ in subdomain_files(lib) if top == 'include/calib'}
    for top, rel, path in subdomain_files(lib):
        if top == 'src' and rel.endswith('.cc') and '/pcl/' not in rel:
            folder = rel.split('/')[0]
            # A source's public header, when it has one, is in the mirrored folder.
            stem = rel[:-3]
            if os.path.basename(stem) in {os.path.basename(p) for p in public} and stem not in public:
                problems.append(f'{path}: its header is not in include/calib/{folder}/')
    for p in problems:
        print(p)
    if problems:
        print(f'{len(problems)} layout problem(s) (docs/architecture.md)')
        return 1
    print('libcalib layout: the subdomain layers hold, messages stay at the edge, '
          f'no function over {MAX_FUNCTION_LINES} lines, no file over {MAX_FILE_LINES} and no class over '
          f'{MAX_CLASS_LINES}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
