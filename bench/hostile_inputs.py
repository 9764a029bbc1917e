#!/usr/bin/env python3
"""Runs every class of hostile input through agvcal and counts the outcomes (docs/bad-input.md).

  bench/hostile_inputs.py [--bin BUILD] [--only SUBSTRING] [--markdown]

Each case makes a damaged input from the samples (logs/forklift_demo.log, config/robots/*.yaml),
runs one agvcal command with a time limit, and sorts the outcome into one of
  ok              the documented exit status and the expected words on stderr
  crash           a signal, or exit 1 (internal error)
  hang            still running at the time limit
  silently wrong  exit 0 where the input is unusable, or exit 0 with the damage not named
  partial         a result file (or its .partial) left by a command that failed
  unclear         a failure whose message lacks the cause (or another non-zero exit status)
and prints one row per case and the counts. Exit status 0 when every case is ok.

A case is a row of CASES: class, name, a function making the inputs in a scratch folder and
returning the command, the expected exit status, the words stderr must hold and, for result
paths, a check afterwards that nothing was destroyed. Live faults (a process of the group killed,
a scanner that stalls) run a short script on a private bus instead of one command; the e2e tests
cover more of them (group_kill, group_hostile, group_full_disk).
"""
import argparse
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
import time

SRC = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LOG = os.path.join(SRC, 'logs/forklift_demo.log')
ROBOT = os.path.join(SRC, 'config/robots/forklift.yaml')
DUAL_LOG = os.path.join(SRC, 'logs/dual_steer_demo.log')
DUAL_ROBOT = os.path.join(SRC, 'config/robots/dual_steer_agv.yaml')
TIME_LIMIT_S = 120


# --- lcm-logger recordings ---------------------------------------------------------------------

def read_events(path):
    """[(event_number, timestamp, channel bytes, data bytearray)] of a recording."""
    data = open(path, 'rb').read()
    events, pos = [], 0
    while pos + 28 <= len(data):
        _, number, stamp, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        channel = data[pos + 28:pos + 28 + channel_len]
        events.append([number, stamp, channel, bytearray(data[pos + 28 + channel_len:pos + 28 + channel_len + data_len])])
        pos += 28 + channel_len + data_len
    return events


def event_bytes(event):
    number, stamp, channel, data = event
    return struct.pack('>IqqII', 0xEDA1DA01, number, stamp, len(channel), len(data)) + bytes(channel) + bytes(data)


def write_events(path, events):
    with open(path, 'wb') as out:
        for event in events:
            out.write(event_bytes(event))


def nth(events, channel, n):
    """The n-th (1-based) event on channel."""
    return [e for e in events if e[2] == channel.encode()][n - 1]


def add_to_stamp(data, delta):
    """Adds delta (us) to an lcm message's utime (the int64 after the 8-byte type hash)."""
    struct.pack_into('>q', data, 8, struct.unpack_from('>q', data, 8)[0] + delta)


def command_setpoint_offsets(data):
    """Offsets of wheel_speed[0] and steer[0] in an encoded drive_command_t (mode 1)."""
    pos = 8 + 8 + 8 + 1 + 24
    (num,) = struct.unpack_from('>i', data, pos)
    pos += 4
    for _ in range(num):
        (n,) = struct.unpack_from('>i', data, pos)
        pos += 4 + n
    return pos, pos + 8 * num


def all_scans_nan(data):
    pos = 8 + 8 + 24
    (n,) = struct.unpack_from('>i', data, pos)
    for i in range(n):
        struct.pack_into('>f', data, pos + 4 + 4 * i, math.nan)


def torn_and_appended(src, dst, torn_event, resumed_event, torn_bytes):
    """A logger killed `torn_bytes` into event `torn_event`, restarted with -a at `resumed_event`."""
    data = open(src, 'rb').read()
    starts, pos = [], 0
    while pos + 28 <= len(data):
        starts.append(pos)
        _, _, _, channel_len, data_len = struct.unpack('>IqqII', data[pos:pos + 28])
        pos += 28 + channel_len + data_len
    cut = starts[torn_event] + torn_bytes
    open(dst, 'wb').write(data[:cut] + data[starts[resumed_event]:])


def edit_robot(src, dst, old, new):
    text = open(src).read()
    assert old in text, (src, old)
    open(dst, 'w').write(text.replace(old, new))


def fifo(path):
    os.mkfifo(path)
    return path


# --- the cases ----------------------------------------------------------------------------------
# make(tmp) returns (command, expected exit status, [words stderr must hold]).

def solve(robot, log, tmp):
    return ['solve', robot, log, '--quiet', '--out', os.path.join(tmp, 'RESULT.json')]


def case_stream_stamp(channel, n):
    def make(tmp):
        events = read_events(LOG)
        add_to_stamp(nth(events, channel, n)[3], 1 << 23)
        write_events(os.path.join(tmp, 'in.log'), events)
        return solve(ROBOT, os.path.join(tmp, 'in.log'), tmp), 0, [f'({channel}): stamp 8.', 'dropped alone']
    return make


def case_wheel_jump(tmp):
    events = read_events(LOG)
    data = nth(events, 'WHEELS', 2700)[3]
    # The drive wheel's position: after hash, utime, num_wheels, one name.
    (n,) = struct.unpack_from('>i', data, 8 + 8 + 4)
    at = 8 + 8 + 4 + 4 + n
    struct.pack_into('>d', data, at, struct.unpack_from('>d', data, at)[0] + 100.0)
    write_events(os.path.join(tmp, 'in.log'), events)
    return solve(ROBOT, os.path.join(tmp, 'in.log'), tmp), 0, ["wheel 'drive' position jumps"]


def case_command(value, which):
    def make(tmp):
        events = read_events(LOG)
        data = nth(events, 'DRIVE_CMD', 300)[3]
        speed_at, steer_at = command_setpoint_offsets(data)
        struct.pack_into('>d', data, speed_at if which == 'speed' else steer_at, value)
        write_events(os.path.join(tmp, 'in.log'), events)
        # Only the commands are read: `info` does not convert; diagnose's reader does (as solve's).
        return ['diagnose', ROBOT, os.path.join(tmp, 'in.log'), '--out', os.path.join(tmp, 'REPORT.json')], 0, \
            ['(DRIVE_CMD): wheel \'drive\'', 'dropped']
    return make


def case_scan_int64_max(tmp):
    events = read_events(LOG)
    struct.pack_into('>q', nth(events, 'SCAN', 300)[3], 8, 2**63 - 1)
    write_events(os.path.join(tmp, 'in.log'), events)
    return solve(ROBOT, os.path.join(tmp, 'in.log'), tmp), 2, ['(SCAN)', 'utime 9223372036854775807 us is beyond']


def case_channel_bytes(json_flag):
    def make(tmp):
        events = read_events(LOG)
        events.append([len(events), events[-1][1] + 1, b'\x1b[2J\xff\xfe', bytearray(16)])
        write_events(os.path.join(tmp, 'in.log'), events)
        return ['info', os.path.join(tmp, 'in.log')] + (['--json'] if json_flag else []), 0, []
    return make


def case_dual_swapped(command):
    def make(tmp):
        edit_robot(DUAL_ROBOT, os.path.join(tmp, 'robot.yaml'), '{a1: front_left, a2: rear_right}',
                   '{a1: rear_right, a2: front_left}')
        return [command, os.path.join(tmp, 'robot.yaml'), DUAL_LOG, '--quiet'], 2, \
            ['robot.yaml', 'wheels', 'do not fit this drive']
    return make


def case_robot_value(old, new, words):
    def make(tmp):
        edit_robot(ROBOT, os.path.join(tmp, 'robot.yaml'), old, new)
        return solve(os.path.join(tmp, 'robot.yaml'), LOG, tmp), 2, ['robot.yaml'] + words
    return make


def case_no_lidar2d(tmp):
    edit_robot(ROBOT, os.path.join(tmp, 'robot.yaml'), 'lidar2d: {channel: SCAN, x: 1.60, y: 0.0, yaw: 0.0}\n', '')
    # Without IMU and 3D lidar too, so that only the 2D lidar can serve.
    text = ''.join(line for line in open(os.path.join(tmp, 'robot.yaml'))
                   if not line.startswith(('imu:', 'lidar3d:', '          body:')))
    open(os.path.join(tmp, 'robot.yaml'), 'w').write(text)
    return solve(os.path.join(tmp, 'robot.yaml'), LOG, tmp), 2, ['robot.yaml', 'no 2D lidar in the robot file', '580 scans']


def case_log_directory(tmp):
    return solve(ROBOT, tmp, tmp), 2, ['is a directory']


def case_all_nan_scans(tmp):
    events = read_events(LOG)
    for e in events:
        if e[2] == b'SCAN':
            all_scans_nan(e[3])
    write_events(os.path.join(tmp, 'in.log'), events)
    return solve(ROBOT, os.path.join(tmp, 'in.log'), tmp), 2, ['none of the 580 scans has a return']


def case_trailing_space(tmp):
    events = read_events(LOG)
    for e in events:
        if e[2] == b'SCAN':
            e[2] = b'SCAN '
    write_events(os.path.join(tmp, 'in.log'), events)
    return solve(ROBOT, os.path.join(tmp, 'in.log'), tmp), 2, ['SCAN\\x20']


def case_big_std(tmp):
    with open(os.path.join(tmp, 'robot.yaml'), 'w') as out:
        out.write(open(ROBOT).read() + 'std:\n')
        for i in range(2_500_000):
            out.write(f'  k{i}: 0.001\n')
    return solve(os.path.join(tmp, 'robot.yaml'), LOG, tmp), 2, ['larger than 1048576 bytes']


def case_yaml_text(text, words, what='robot'):
    def make(tmp):
        with open(os.path.join(tmp, 'file.yaml'), 'w') as out:
            out.write(text)
        if what == 'robot':
            return solve(os.path.join(tmp, 'file.yaml'), LOG, tmp), 2, words
        return ['simulate', os.path.join(tmp, 'file.yaml'), os.path.join(tmp, 'out.log')], 2, words
    return make


def case_device_robot(tmp):
    return solve('/dev/zero', LOG, tmp), 2, ['/dev/zero', 'not a regular file']


def case_fifo_log(tmp):
    return ['info', fifo(os.path.join(tmp, 'fifo.log'))], 2, ['fifo.log', 'no writer']


def case_fifo_log_solve(tmp):
    return solve(ROBOT, fifo(os.path.join(tmp, 'fifo.log')), tmp), 2, ['fifo.log', 'read more than once']


def case_fifo_robot(tmp):
    return solve(fifo(os.path.join(tmp, 'fifo.yaml')), LOG, tmp), 2, ['fifo.yaml', 'no writer']


def case_piped_log(tmp):
    path = fifo(os.path.join(tmp, 'piped.log'))
    threading.Thread(target=lambda: shutil.copyfileobj(open(LOG, 'rb'), open(path, 'wb')), daemon=True).start()
    return ['info', path], 0, []


def case_torn_appended(tmp):
    # Killed 1000 bytes into the 250th scan (2.9 kB), restarted 400 events later.
    scans = [i for i, e in enumerate(read_events(LOG)) if e[2] == b'SCAN']
    torn_and_appended(LOG, os.path.join(tmp, 'in.log'), scans[249], scans[249] + 400, 1000)
    return solve(ROBOT, os.path.join(tmp, 'in.log'), tmp), 0, ['skipped (a torn event', 'lacks what was logged between']


def case_torn_end(tmp):
    data = open(LOG, 'rb').read()
    open(os.path.join(tmp, 'in.log'), 'wb').write(data[:-100])
    return solve(ROBOT, os.path.join(tmp, 'in.log'), tmp), 0, ['skipped', 'cut short', 'lacks what was logged after']


# --- result paths: an output option must never destroy an input or a user's file -------------
# make(tmp) may return a fourth element: check() after the run, the outcome when the damage
# happened anyway (the recording overwritten, the user's file gone), else None.

def sha(path):
    import hashlib
    return hashlib.sha256(open(path, 'rb').read()).hexdigest()


def unchanged(path, digest, outcome='silently wrong'):
    return lambda: None if os.path.isfile(path) and sha(path) == digest else outcome


def case_out_is_input(link):
    def make(tmp):
        log = os.path.join(tmp, 'run.log')
        shutil.copyfile(LOG, log)
        out = log
        if link == 'hard':
            out = os.path.join(tmp, 'hard.json')
            os.link(log, out)
        elif link == 'symbolic':
            out = os.path.join(tmp, 'link.json')
            os.symlink(log, out)
        return ['solve', ROBOT, log, '--quiet', '--out', out], 2, ['is the input'], unchanged(log, sha(LOG))
    return make


def case_write_robot_is_robot(tmp):
    robot = os.path.join(tmp, 'robot.yaml')
    shutil.copyfile(ROBOT, robot)
    return ['solve', robot, LOG, '--quiet', '--write-robot', robot], 2, ['is the input'], \
        unchanged(robot, sha(ROBOT))


def case_out_fifo(tmp):
    path = fifo(os.path.join(tmp, 'result.fifo'))
    got = []
    threading.Thread(target=lambda: got.append(open(path, 'rb').read()), daemon=True).start()

    def check():
        time.sleep(0.2)
        import stat
        if not stat.S_ISFIFO(os.lstat(path).st_mode):
            return 'silently wrong'  # the FIFO replaced by a regular file
        return None if got and got[0].lstrip().startswith(b'{') else 'partial'
    return ['solve', ROBOT, LOG, '--quiet', '--out', path], 0, [], check


def case_user_partial(tmp):
    mine = os.path.join(tmp, 'RESULT.json.partial')
    open(mine, 'w').write('the user\'s own file\n')
    return solve(ROBOT, LOG, tmp), 0, [], unchanged(mine, sha(mine))


def case_report_user_file(tmp):
    report = os.path.join(tmp, 'report')
    os.mkdir(report)
    mine = os.path.join(report, 'my_plot.svg')
    open(mine, 'w').write('<svg/>\n')
    return ['solve', ROBOT, LOG, '--quiet', '--report', report], 2, ['my_plot.svg', 'was not written by agvcal'], \
        unchanged(mine, sha(mine))


# --- live faults: a process group or a bridge on a private bus ---------------------------------

# A live case returns [LIVE, SCRIPT]: bash runs SCRIPT in a private network namespace
# (scripts/netns-run) from the source folder, with $BIN (the build) and $TMP (the case's folder);
# what it prints on stdout and stderr is what is said.
LIVE = 'live'
# waits_for SECONDS CMD...: until CMD succeeds (tried every 0.1 s); false after SECONDS
WAITS_FOR = '''waits_for() { local until=$((SECONDS + $1)); shift
  until "$@" >/dev/null 2>&1; do [ "$SECONDS" -ge "$until" ] && return 1; sleep 0.1; done; }
'''


def case_group_killed_solver(tmp):
    """The group's solver killed (SIGKILL) once the recording holds 1000 wheel states: the group
    restarts it, says so, and ends with a RESULT.json."""
    script = WAITS_FOR + '''exec 1>&2
run=$TMP/run
scripts/agvcal-group --replay logs/forklift_demo.log --robot config/robots/forklift.yaml --speed 2 \\
  --run-dir "$run" & group=$!
wheels() { "$BIN/agvcal-recording" count "$run/recording.log" | grep -qE "WHEELS [0-9]{4}"; }
waits_for 60 wheels || echo "no 1000 wheel states recorded in 60 s"
[ -n "$(supervisorctl -c "$run/supervisord.conf" pid player | grep -E '^[1-9]')" ] ||
  echo "the replay ended before the kill (a loaded machine): the case proves nothing"
kill -KILL "$(supervisorctl -c "$run/supervisord.conf" pid solver)"
wait $group
'''
    result = os.path.join(tmp, 'run', 'RESULT.json')
    return [LIVE, script], 0, ['solver exited; restarting it (1 of 3)'], \
        lambda: None if os.path.exists(result) else 'partial'
    

def case_bridge_stalled(tmp):
    """The scanner stops sending (SIGSTOP to the emulator) for longer than a scan period and then
    goes on: the lidar bridge says it stalled and when data comes again."""
    script = WAITS_FOR + '''exec 1>&2
"$BIN/agvcal-sickemu" logs/forklift_demo.log --port 2111 2>/dev/null & emu=$!
"$BIN/agvcal-lidarbridge" config/bridges/sick_lms1xx.yaml --host 127.0.0.1 --port 2111 2>"$TMP/bridge.err" & bridge=$!
waits_for 30 grep -q "connected to" "$TMP/bridge.err" || echo "the bridge did not connect in 30 s"
kill -STOP $emu
waits_for 10 grep -q "no data for" "$TMP/bridge.err" || echo "nothing said about the stall in 10 s"
kill -CONT $emu
waits_for 10 grep -q "data again" "$TMP/bridge.err" || echo "nothing said when data came again in 10 s"
kill -INT $bridge; wait $bridge; status=$?
kill $emu; wait $emu
cat "$TMP/bridge.err"
exit $status
'''
    return [LIVE, script], 0, ['no data for 2 s on an open connection (the device stalled?)', 'data again after']


# A case marked OPEN is a known gap (docs/bad-input.md says which): run and shown, its outcome
# counted apart ("open"), not failing the run.
OPEN = 'open'
DEEP = 'name: ' + '[' * 200000 + '\n'
LIST = 'name: [' + '1,' * 400000 + '1]\n'
CASES = [
    # class, name, make
    ('recording: stamps', 'WHEELS stamped +8.4 s (one flipped bit)', case_stream_stamp('WHEELS', 1000)),
    ('recording: stamps', 'SCAN stamped +8.4 s', case_stream_stamp('SCAN', 300)),
    ('recording: stamps', 'SCAN stamped INT64_MAX', case_scan_int64_max),
    ('recording: values', 'WHEELS drive position +100 rad', case_wheel_jump),
    ('recording: values', 'DRIVE_CMD wheel_speed NaN', case_command(math.nan, 'speed')),
    ('recording: values', 'DRIVE_CMD wheel_speed -1e300', case_command(-1e300, 'speed')),
    ('recording: values', 'DRIVE_CMD steer +inf', case_command(math.inf, 'steer')),
    ('recording: values', 'all scans NaN', case_all_nan_scans),
    ('recording: framing', 'torn event, logger restarted with -a', case_torn_appended),
    ('recording: framing', 'torn last event', case_torn_end),
    ('recording: framing', 'channel name with control bytes (info)', case_channel_bytes(False)),
    ('recording: framing', 'channel name not UTF-8 (info --json)', case_channel_bytes(True)),
    ('recording: framing', 'SCAN renamed "SCAN " (trailing space)', case_trailing_space),
    ('recording: file', 'LOG is a directory', case_log_directory),
    ('recording: file', 'LOG is a FIFO without a writer (info)', case_fifo_log),
    ('recording: file', 'LOG is a FIFO (solve)', case_fifo_log_solve),
    ('recording: file', 'LOG is a pipe (info <(cat LOG))', case_piped_log),
    ('robot file: values', 'drive_radius 1e-300', case_robot_value('drive_radius: 0.115', 'drive_radius: 1e-300',
                                                                    ['params.drive_radius', 'must be from 0.001'])),
    ('robot file: values', 'lidar2d.x 1e300', case_robot_value('x: 1.60', 'x: 1e300', ['lidar2d.x', 'must be from -100'])),
    ('robot file: values', 'limits.max_speed 1e-300', case_robot_value('max_speed: 0.6', 'max_speed: 1e-300',
                                                                        ['limits.max_speed', 'must be from 0.001'])),
    ('robot file: values', 'no lidar2d (recording has scans)', case_no_lidar2d),
    ('robot file: values', 'dual steer, wheel names swapped (solve)', case_dual_swapped('solve')),
    ('robot file: values', 'dual steer, wheel names swapped (diagnose)', case_dual_swapped('diagnose')),
    ('robot file: size', '50 MB std: map', case_big_std),
    ('robot file: size', '200,000-deep [ nest', case_yaml_text(DEEP, ['nested more than 32 levels'])),
    ('robot file: size', '400,000-element list', case_yaml_text(LIST, ['more than 100000 values'])),
    ('robot file: size', 'sim config: 200,000-deep [ nest', case_yaml_text(DEEP, ['nested more than'], 'sim')),
    ('robot file: file', 'ROBOT.yaml is /dev/zero', case_device_robot),
    ('robot file: file', 'ROBOT.yaml is a FIFO without a writer', case_fifo_robot),
    ('result paths', '--out names the recording', case_out_is_input('same')),
    ('result paths', '--out a hard link to the recording', case_out_is_input('hard')),
    ('result paths', '--out a symbolic link to the recording', case_out_is_input('symbolic')),
    ('result paths', '--write-robot names the robot file', case_write_robot_is_robot),
    ('result paths', '--out a FIFO (a reader waiting)', case_out_fifo),
    ('result paths', "the user's RESULT.json.partial beside --out", case_user_partial),
    ('result paths', "--report into a folder with the user's own file", case_report_user_file),
    ('live faults', 'the group\'s solver killed mid-replay', case_group_killed_solver),
    ('live faults', 'the lidar bridge\'s scanner stalls for a while', case_bridge_stalled),
]

OUTCOMES = ['ok', 'crash', 'hang', 'silently wrong', 'partial', 'unclear']


def run_case(agvcal, make):
    tmp = tempfile.mkdtemp(prefix='hostile_')
    try:
        args, want, words, *check = make(tmp)
        start = time.monotonic()
        try:
            if args[0] == LIVE:
                env = dict(os.environ, BIN=os.path.dirname(agvcal), AGVCAL_BIN=os.path.dirname(agvcal), TMP=tmp)
                command = [os.path.join(SRC, 'scripts/netns-run'), 'bash', '-c', args[1]]
                p = subprocess.run(command, cwd=SRC, env=env, capture_output=True, timeout=TIME_LIMIT_S)
            else:
                p = subprocess.run([agvcal] + args, cwd=SRC, capture_output=True, timeout=TIME_LIMIT_S)
            code, err = p.returncode, p.stderr.decode(errors='replace') + p.stdout.decode(errors='replace')[:0]
        except subprocess.TimeoutExpired:
            return 'hang', None, time.monotonic() - start, ''
        seconds = time.monotonic() - start
        lines = err.strip().splitlines()
        # What is said: the line naming the damage (the first expected words), else the last one.
        said = [l for l in lines if words and words[0] in l]
        first = (said or lines or [''])[-1 if not said else 0]
        left = [f for f in os.listdir(tmp) if f.startswith(('RESULT.json', 'REPORT.json', 'out.log'))]
        if code < 0 or code == 1:
            outcome = 'crash'
        elif code != 0 and left:
            outcome = 'partial'
        elif code == 0 and want != 0:
            outcome = 'silently wrong'
        elif code == 0 and not all(w in err for w in words):
            outcome = 'silently wrong'
        elif code != want or not all(w in err for w in words):
            outcome = 'unclear'
        else:
            outcome = 'ok'
        if outcome == 'ok' and code == 0 and args[0] == 'info':
            out = p.stdout
            # info: no raw control byte on the terminal, valid JSON
            if b'\x1b' in out:
                outcome = 'unclear'
            if '--json' in args:
                import json
                try:
                    json.loads(out)
                except ValueError:
                    outcome = 'crash'
        if outcome == 'ok' and args[0] == 'info' and 'piped' in args[1] and b'WHEELS' not in p.stdout:
            outcome = 'partial'
        if outcome == 'ok' and check:
            outcome = check[0]() or 'ok'
        return outcome, code, seconds, first
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main():
    global TIME_LIMIT_S
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--bin', default=os.environ.get('AGVCAL_BIN', os.path.join(SRC, 'build')))
    parser.add_argument('--only', default='')
    parser.add_argument('--skip', action='append', default=[], help='leave out cases whose name holds this')
    parser.add_argument('--time-limit', type=float, default=TIME_LIMIT_S, help='s per case (a hang)')
    parser.add_argument('--markdown', action='store_true', help='the table for docs/bad-input.md')
    args = parser.parse_args()
    TIME_LIMIT_S = args.time_limit
    agvcal = os.path.join(args.bin, 'agvcal')
    counts = dict.fromkeys(OUTCOMES, 0)
    opened = []
    rows = []
    for cls, name, make, *mark in CASES:
        if (args.only and args.only not in name and args.only not in cls) or any(k in name for k in args.skip):
            continue
        outcome, code, seconds, line = run_case(agvcal, make)
        if mark and outcome != 'ok':
            opened.append(name)
            outcome = 'open: ' + outcome
        else:
            counts[outcome] += 1
        rows.append((cls, name, code, seconds, outcome, line))
        if not args.markdown:
            print(f'{outcome:15} exit {code!s:4} {seconds:6.1f} s  {cls}: {name}\n{"":28}{line[:160]}', flush=True)
    if args.markdown:
        print('| class | input | exit | s | outcome | what is said (stderr) |')
        print('|---|---|---|---|---|---|')
        for cls, name, code, seconds, outcome, line in rows:
            said = line.replace('|', '\\|').replace(SRC + '/', '')[:200]
            print(f'| {cls} | {name} | {code} | {seconds:.1f} | {outcome} | {said} |')
    print('\n' + ', '.join(f'{k}: {v}' for k, v in counts.items()) + f'; known open: {len(opened)}')
    return 0 if counts['ok'] == sum(counts.values()) else 1


if __name__ == '__main__':
    sys.exit(main())
