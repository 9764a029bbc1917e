#!/usr/bin/env python3
"""Does the slip's single fit follow the slip injected into one real recording, and do the
intervals set aside stay the same (docs/mismatch-real-injection.md, "Slip sizes on one recording")?

  scripts/mismatch_slip_sizes.py NAME [--build DIR] [--work DIR] [--sizes 0.02,0.1,0.5,1,2]

NAME is a recording of the real-data injection suite (scripts/mismatch_real_injection.py: the
imported recordings under WORK/recordings, its robot from scripts/dataset-robots.bash). The
recording is diagnosed as recorded, then with each longitudinal slip size written in
(scripts/inject_effect.py, the recording's calibrated radii); printed per size: the change of the
slip's single-fit estimate against the recording as recorded, whether it is declared, and how
many intervals changed outlier status (set aside in one report and not in the other)."""
import argparse
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mismatch_real_injection as suite  # noqa: E402


def outliers(rep):
    return {(i["utime_start"], i["utime_end"]): i["outlier"] for i in rep.get("intervals", [])}


def diagnose(build, robot, log, out):
    if not os.path.exists(out):
        r = subprocess.run([os.path.join(build, "agvcal"), "diagnose", robot, log, "--out", out, "--quiet",
                            "--jobs", "1"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            return {"error": f"exit {r.returncode}: {r.stderr.strip()[-160:]}"}
    with open(out) as f:
        return suite.json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("name")
    ap.add_argument("--build", default=os.path.join(suite.HERE, "build"))
    ap.add_argument("--work", default="/tmp/inject_work")
    ap.add_argument("--label", default=None, help="subfolder of --work for the reports (default: from --build)")
    ap.add_argument("--sizes", default="0.02,0.1,0.5,1,2", help="slip sizes, s^2/m")
    ap.add_argument("--injector", default=os.path.join(suite.HERE, "scripts", "inject_effect.py"),
                    help="the injector (another build's version: exact in its speeds)")
    args = ap.parse_args()
    label = args.label or "sizes_" + os.path.abspath(args.build).strip("/").replace("/", "_")
    folder = os.path.join(args.work, label)
    os.makedirs(folder, exist_ok=True)
    robot = suite.dataset_robot(args.name)
    log = os.path.join(args.work, "recordings", args.name + ".log")
    base = diagnose(args.build, robot, log, os.path.join(folder, args.name + ".json"))
    if "error" in base:
        sys.exit(f"{args.name}: as recorded: {base['error']}")
    params = base.get("refitted") or base["calibration"]
    radii = ",".join(f"{params[r + '_radius']['value']:.9g}" for r in suite.read_roles(robot))
    b, _ = suite.estimate(base, "longitudinal_slip")
    base_out = outliers(base)
    print(f"{args.name}, build {args.build}: slip as recorded {b:.4g}, "
          f"{sum(base_out.values())} of {len(base_out)} intervals set aside\n")
    print("| injected slip (s²/m) | change of the single fit ± σ | declared | intervals changing outlier status |")
    print("|---|---|---|---|")
    for size in [float(s) for s in args.sizes.split(",")]:
        out = os.path.join(folder, f"{args.name}.slip_{size:g}.json")
        if not os.path.exists(out):
            injected = out[:-5] + ".log"
            r = subprocess.run([sys.executable, args.injector, log, injected,
                                robot, "slip", f"{size:g}", radii], stderr=subprocess.PIPE, text=True)
            if r.returncode != 0:
                print(f"| {size:g} | not injected: {r.stderr.strip()[-120:]} | - | - |")
                continue
            rep = diagnose(args.build, robot, injected, out)
            os.remove(injected)
        else:
            rep = diagnose(args.build, robot, None, out)
        if "error" in rep:
            print(f"| {size:g} | {rep['error']} | - | - |")
            continue
        v, sd = suite.estimate(rep, "longitudinal_slip")
        now = outliers(rep)
        flips = sum(1 for key, o in now.items() if key in base_out and base_out[key] != o)
        named = "yes" if suite.declared(rep, "longitudinal_slip") else "no"
        print(f"| {size:g} | {v - b:+.4g} ± {sd:.2g} | {named} | {flips} |")


if __name__ == "__main__":
    main()
