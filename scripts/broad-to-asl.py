#!/usr/bin/env python3
"""Writes a BROAD trial (HDF5: real OptiTrack + IMU, one clock) as the files a lab has: an ASL
(EuRoC) folder, and an IMU CSV beside a TUM pose file.

    python3 scripts/broad-to-asl.py data/broad/15_undisturbed_fast_translation_A.hdf5 OUT

OUT/mav0/imu0/data.csv     ASL IMU CSV: timestamp [ns], w_RS_S_x..z [rad/s], a_RS_S_x..z [m/s^2]
OUT/mav0/vicon0/data.csv   ASL pose CSV: timestamp [ns], p_RS_R_x..z [m], q_RS_w, q_RS_x..z
OUT/imu.csv                t [s], gx, gy, gz [rad/s], ax, ay, az [m/s^2]
OUT/poses.tum              TUM: t [s] x y z qx qy qz qw

BROAD's authors resampled both streams onto one clock of 285.714 Hz and aligned the optical body
to the IMU (README of ../shared/data/broad); row i is at i/fs s. The IMU's stamps here start at
`--imu-epoch` seconds, the poses' at `--pose-epoch` (both 0 by default: one clock, as the data
is); rows where OptiTrack lost the body (NaN) are left out of the pose files, as a mocap leaves
them out. Nothing else is changed: mounts and clock offsets are injected by `flyarena trials
--injected`, not here. Needs h5py and numpy.
"""
import argparse
import os
import sys

import h5py
import numpy as np


def stamps_ns(n, fs, epoch_s):
    """Row i's stamp, epoch + i/fs, in integer nanoseconds."""
    return [int(round(epoch_s * 1e9)) + int(round(i * 1e9 / fs)) for i in range(n)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("hdf5")
    ap.add_argument("out")
    ap.add_argument("--imu-epoch", type=float, default=0.0, help="the IMU clock's reading at the first row (s)")
    ap.add_argument("--pose-epoch", type=float, default=0.0, help="the mocap clock's reading at the first row (s)")
    a = ap.parse_args()
    h = h5py.File(a.hdf5, "r")
    fs = float(h.attrs["sampling_rate"])
    gyr, acc = h["imu_gyr"][:], h["imu_acc"][:]
    quat, pos = h["opt_quat"][:], h["opt_pos"][:]
    n = len(gyr)
    if not (np.isfinite(gyr).all() and np.isfinite(acc).all()):
        sys.exit(f"{a.hdf5}: the IMU holds values that are not finite")
    ti, tp = stamps_ns(n, fs, a.imu_epoch), stamps_ns(n, fs, a.pose_epoch)
    seen = np.isfinite(quat).all(axis=1) & np.isfinite(pos).all(axis=1)
    os.makedirs(os.path.join(a.out, "mav0", "imu0"), exist_ok=True)
    os.makedirs(os.path.join(a.out, "mav0", "vicon0"), exist_ok=True)
    r = repr
    with open(os.path.join(a.out, "mav0", "imu0", "data.csv"), "w") as f:
        f.write("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n")
        for i in range(n):
            f.write(f"{ti[i]},{r(float(gyr[i,0]))},{r(float(gyr[i,1]))},{r(float(gyr[i,2]))},"
                    f"{r(float(acc[i,0]))},{r(float(acc[i,1]))},{r(float(acc[i,2]))}\n")
    with open(os.path.join(a.out, "mav0", "vicon0", "data.csv"), "w") as f:
        f.write("#timestamp [ns], p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n")
        for i in np.flatnonzero(seen):
            p, q = pos[i], quat[i]
            f.write(f"{tp[i]},{r(float(p[0]))},{r(float(p[1]))},{r(float(p[2]))},"
                    f"{r(float(q[0]))},{r(float(q[1]))},{r(float(q[2]))},{r(float(q[3]))}\n")
    sec = lambda ns: f"{ns // 10**9}.{ns % 10**9:09d}"
    with open(os.path.join(a.out, "imu.csv"), "w") as f:
        f.write("t,gx,gy,gz,ax,ay,az\n")
        for i in range(n):
            f.write(f"{sec(ti[i])},{r(float(gyr[i,0]))},{r(float(gyr[i,1]))},{r(float(gyr[i,2]))},"
                    f"{r(float(acc[i,0]))},{r(float(acc[i,1]))},{r(float(acc[i,2]))}\n")
    with open(os.path.join(a.out, "poses.tum"), "w") as f:
        f.write("# t x y z qx qy qz qw (BROAD's OptiTrack body, ENU world)\n")
        for i in np.flatnonzero(seen):
            p, q = pos[i], quat[i]
            f.write(f"{sec(tp[i])} {r(float(p[0]))} {r(float(p[1]))} {r(float(p[2]))} "
                    f"{r(float(q[1]))} {r(float(q[2]))} {r(float(q[3]))} {r(float(q[0]))}\n")
    print(f"{a.out}: {n} IMU samples at {fs:.3f} Hz, {int(seen.sum())} poses ({n - int(seen.sum())} not seen)")


if __name__ == "__main__":
    main()
