#!/usr/bin/env python3
"""The straight-flight yaw (6)-(9) of an attitude-mode vehicle against its onboard level.

Flies `scenarios/yaw-attitude-mode.yaml` as 100-run sweeps (marker yaw uniform in +-8 deg,
accelerometer bias uniform in +-10 mg on x and y) for each gyro noise and trim setting, and prints
one table row per case: the straight-flight yaw error's median, p95 and max, how many runs are
within 0.5 deg, and, without the trim and without gyro noise, the ratio of the signed error to
the closed form -atan(S*b_y/g) (S = 101.8 for this profile, the level error growing at k_a).
Run from the checkout after `cargo build --release`:

    python3 scripts/attitude-level.py

FLYARENA overrides the binary (default: $CARGO_TARGET_DIR/release/flyarena, else
target/release/flyarena). Standard library only; writes into a fresh temporary folder.
"""
import csv, math, os, pathlib, statistics, subprocess, tempfile

BIN = os.environ.get("FLYARENA", str(pathlib.Path(os.environ.get("CARGO_TARGET_DIR", "target")) / "release" / "flyarena"))
BASE = pathlib.Path("scenarios/yaw-attitude-mode.yaml").read_text()
G = 9.81
BIAS = 10e-3 * G
CASES = [  # (gyro noise per 1 kHz sample, deg/s; hover trim)
    (0.0, False), (0.5, False), (0.0, True), (0.05, True), (0.1, True), (0.5, True)]


def slope():
    """LS slope of E = g*(t^2/2 + k_a*t^3/6) against N(t) on the trapezoid (6 m, 0.75 m/s, 0.5 m/s^2)."""
    l, v, a, ka = 6.0, 0.75, 0.5, 0.2
    ta, tc = v / a, (l - v * v / a) / v
    total = 2 * ta + tc
    n, e = [], []
    for k in range(int(total / 0.005)):
        t = k * 0.005
        n.append(0.5 * a * t * t if t < ta else 0.5 * v * ta + v * (t - ta) if t < ta + tc else l - 0.5 * a * (total - t) ** 2)
        e.append(G * (t * t / 2 + ka * t ** 3 / 6))
    mn, me = statistics.fmean(n), statistics.fmean(e)
    return sum((x - mn) * (y - me) for x, y in zip(n, e)) / sum((x - mn) ** 2 for x in n)


def sweep(folder, noise, trim):
    text = BASE.replace("gyro_noise_deg_s: 0.5", f"gyro_noise_deg_s: {noise}").replace("seed: 11\n", f"seed: 11\ncalibration: {{ hover_trim: {str(trim).lower()} }}\n")
    text += f'    - {{ field: "vehicles[0].imu.accel_bias_m_s2[0]", uniform: [{-BIAS}, {BIAS}] }}\n'
    text += f'    - {{ field: "vehicles[0].imu.accel_bias_m_s2[1]", uniform: [{-BIAS}, {BIAS}] }}\n'
    path = folder / f"n{noise}-{trim}.yaml"
    path.write_text(text)
    out = folder / path.stem
    subprocess.run([BIN, "sweep", str(path), "--quiet", "--out", str(out)], check=False, stdout=subprocess.DEVNULL)
    with open(next(out.glob("*.sweep.csv"))) as f:
        return list(csv.DictReader(f))


def main():
    s = slope()
    print(f"closed form: yaw error = -atan({s:.1f} * b_y/g) without the trim")
    print("| gyro noise (deg/s per 1 kHz sample) | hover trim | median | p95 | max | within 0.5 deg | signed error / closed form (median) |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for noise, trim in CASES:
            rows = sweep(pathlib.Path(d), noise, trim)
            err = sorted(float(r["yaw_ls_err_deg"]) for r in rows)
            ratio = "-"
            if not trim:
                rs = [float(r["yaw_ls_signed_err_deg"]) / -math.degrees(math.atan(s * float(r["vehicles[0].imu.accel_bias_m_s2[1]"]) / G)) for r in rows]
                ratio = f"{statistics.median(rs):.2f}"
            p95 = err[int(math.ceil(0.95 * len(err))) - 1]
            within = sum(e <= 0.5 for e in err)
            print(f"| {noise} | {'yes' if trim else 'no'} | {statistics.median(err):.2f} deg | {p95:.2f} deg | {err[-1]:.2f} deg | {within} of {len(err)} | {ratio} |")


if __name__ == "__main__":
    main()
