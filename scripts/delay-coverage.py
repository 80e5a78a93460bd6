#!/usr/bin/env python3
"""The closed-loop mocap delay as `identify --px4` fits it, measured against the truth over a grid
of flights (docs/px4.md, "How far to trust EKF2_EV_DELAY"):

    python3 scripts/delay-coverage.py --seeds 30 --out out/delay-coverage

Each cell is one vehicle (a Crazyflie 2.1 or the X3D), one flight plan (gentle: slow waypoints
at 0.5 m/s; aggressive: calibration circles of 2 s, waypoints at 2 m/s and 3 m/s², a yaw spin),
one marker noise (0.1, 0.2, 0.5, 1 mm per marker and axis) and one undeclared mocap delay (0, 5,
10, 30 ms), flown closed loop: the station flies on the noisy, late poses, as on a rig. Every
flight also has rotor drag the model lacks. Each is identified with the delay forced into the
model (`--with mocap_delay`, as `--px4` does), and the cell reports the mean error of the delay
(its bias), the spread of the estimates, the median 95 % half-width and how many intervals hold
the true delay. Seeds differ from cell to cell (seed = 1000·cell + i), so cells are independent.

`--loop out` keeps the marker noise out of the loop (`mocap.noise_in_loop: false`: the station
flies on noise-free poses while the log records noisy ones), the controlled experiment that
separates the noise's feedback through the controller from the noise in the measurement.
`--imu quiet` makes the IMU almost noise-free (0.003 °/s, 0.0005 m/s²), `--smoothing-ms` sets
identify's smoothing σ, and `--vehicles`, `--plans`, `--noise-mm`, `--delay-ms` pick a part of
the grid (each cell keeps its seeds, so a part flies the same flights as the whole grid). The last
line gives the errors in units of their own σ (half-width / 1.96): a mean near 0 and a spread
near 1 is an honest interval.

It runs `flyarena` from the PATH (`cargo install --path .`), or the binary in $FLYARENA.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

VEHICLES = {"crazyflie": "model: { preset: crazyflie21 }", "x3d": ""}
PLANS = {
    "gentle": """plan:
  - idle: { duration_s: 1 }
  - takeoff: { altitude_m: 1.0, duration_s: 3 }
  - hover: { duration_s: 5 }
  - waypoint: { pos_m: [1, 0, -1.0], speed_m_s: 0.5, accel_m_s2: 0.5, hold_s: 2 }
  - waypoint: { pos_m: [1, 1, -1.0], speed_m_s: 0.5, accel_m_s2: 0.5, hold_s: 2 }
  - waypoint: { pos_m: [0, 1, -1.2], speed_m_s: 0.5, accel_m_s2: 0.5, hold_s: 2 }
  - waypoint: { pos_m: [0, 0, -1.0], speed_m_s: 0.5, accel_m_s2: 0.5, hold_s: 2 }
  - land: { duration_s: 3 }
""",
    "aggressive": """plan:
  - idle: { duration_s: 1 }
  - takeoff: { altitude_m: 1.0, duration_s: 3 }
  - hover: { duration_s: 2 }
  - calibrate_gyro: { settle_s: 1, radius_m: 0.5, period_s: 2.0, turns: 3 }
  - waypoint: { pos_m: [2, 0, -1.0], speed_m_s: 2.0, accel_m_s2: 3.0, hold_s: 1 }
  - waypoint: { pos_m: [2, 2, -1.5], speed_m_s: 2.0, accel_m_s2: 3.0, hold_s: 1 }
  - waypoint: { pos_m: [0, 0, -1.0], speed_m_s: 2.0, accel_m_s2: 3.0, hold_s: 1 }
  - yaw_spin: { settle_s: 1, angle_deg: 360, duration_s: 4 }
  - land: { duration_s: 3 }
""",
}
NOISE_MM = [0.1, 0.2, 0.5, 1.0]
DELAY_MS = [0, 5, 10, 30]


IMU = {
    "default": "{ gyro_noise_deg_s: 0.3, accel_noise_m_s2: 0.05 }",
    "quiet": "{ gyro_noise_deg_s: 0.003, accel_noise_m_s2: 0.0005 }",
}


def scenario(vehicle, plan, noise_mm, delay_ms, seed, in_loop, imu="default"):
    return f"""name: delay-{vehicle}-{plan}-{noise_mm}-{delay_ms}-{seed}
seed: {seed}
mocap: {{ noise_mm: {noise_mm}, noise_in_loop: {str(in_loop).lower()} }}
calibration: {{ apply: false }}
vehicles:
  - name: v
    home_m: [-2, 0]
    {VEHICLES[vehicle]}
    imu: {IMU[imu]}
    undeclared: {{ mocap_delay_ms: {delay_ms}, rotor_drag_per_s: [0.3, 0.3] }}
""" + PLANS[plan]


def fly(flyarena, out, job, imu, smoothing_ms):
    cell, (vehicle, plan, noise_mm, delay_ms), seed, in_loop = job
    path = os.path.join(out, f"delay-{vehicle}-{plan}-{noise_mm}-{delay_ms}-{seed}.yaml")
    with open(path, "w") as f:
        f.write(scenario(vehicle, plan, noise_mm, delay_ms, seed, in_loop, imu))
    cmd = flyarena + ["identify", path, "--with", "mocap_delay", "--no-rrd", "--out", out, "--overwrite"]
    if smoothing_ms is not None:
        cmd += ["--smoothing-ms", str(smoothing_ms)]
    run = subprocess.run(cmd, capture_output=True, text=True)
    report = path[: -len(".yaml")] + ".identify.json"
    if run.returncode not in (0, 1) or not os.path.exists(report):
        sys.exit(f"{' '.join(cmd)} failed ({run.returncode}):\n{run.stderr}")
    with open(report) as f:
        effects = json.load(f)["report"]["effects"]
    delay = next(e for e in effects if e["effect"] == "mocap_delay")["params"][0]
    return cell, delay["value"], delay["ci95"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=30, help="flights per cell (default 30)")
    ap.add_argument("--out", default="out/delay-coverage", help="folder for the scenarios and reports")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--loop", choices=["in", "out"], default="in", help="the marker noise in the loop (default) or out")
    ap.add_argument("--imu", choices=sorted(IMU), default="default", help="the IMU's noise (default: 0.3 °/s, 0.05 m/s²)")
    ap.add_argument("--smoothing-ms", type=float, help="identify's smoothing σ (default: identify's own, 20 ms)")
    ap.add_argument("--vehicles", default=",".join(VEHICLES), help="a part of the grid: vehicles (comma-separated)")
    ap.add_argument("--plans", default=",".join(PLANS), help="plans (comma-separated)")
    ap.add_argument("--noise-mm", default=",".join(map(str, NOISE_MM)), help="marker noises (comma-separated)")
    ap.add_argument("--delay-ms", default=",".join(map(str, DELAY_MS)), help="delays (comma-separated)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    flyarena = [os.environ["FLYARENA"]] if "FLYARENA" in os.environ else ["flyarena"]
    cells = [(v, p, n, d) for v in VEHICLES for p in PLANS for n in NOISE_MM for d in DELAY_MS]
    # a part of the grid keeps each cell's index, so its seeds (1000·cell + i) are the grid's
    picked = [
        c
        for c, (v, p, n, d) in enumerate(cells)
        if v in args.vehicles.split(",")
        and p in args.plans.split(",")
        and n in map(float, args.noise_mm.split(","))
        and d in map(int, args.delay_ms.split(","))
    ]
    if not picked:
        sys.exit("no cell of the grid matches --vehicles, --plans, --noise-mm and --delay-ms")
    jobs = [(c, cells[c], 1000 * c + i, args.loop == "in") for c in picked for i in range(1, args.seeds + 1)]
    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda j: fly(flyarena, args.out, j, args.imu, args.smoothing_ms), jobs))
    print("| vehicle | plan | noise (mm) | delay (ms) | bias (ms) | spread (ms) | median ± (ms) | bias / ± | coverage |")
    print("|---|---|---|---|---|---|---|---|---|")
    held = total = 0
    z = []
    for c in picked:
        vehicle, plan, noise_mm, delay_ms = cells[c]
        rows = [(v, h) for k, v, h in results if k == c]
        z += [(v - delay_ms) / (h / 1.96) for v, h in rows]
        errors = [v - delay_ms for v, _ in rows]
        half = statistics.median(h for _, h in rows)
        inside = sum(abs(e) <= h for e, (_, h) in zip(errors, rows))
        held, total = held + inside, total + len(rows)
        bias = statistics.mean(errors)
        print(
            f"| {vehicle} | {plan} | {noise_mm} | {delay_ms} | {bias:+.3f} | {statistics.stdev(errors):.3f} "
            f"| {half:.3f} | {abs(bias) / half:.2f} | {inside}/{len(rows)} |"
        )
    print(f"\nall cells: {held}/{total} intervals hold the true delay ({100 * held / total:.1f} %)")
    print(f"errors over σ (half-width / 1.96): mean {statistics.mean(z):+.3f}, spread {statistics.stdev(z):.3f}")


if __name__ == "__main__":
    main()
