#!/usr/bin/env python3
"""A flight written as a PX4 log (ULog) by the independent ULog writer of `pyulog` (PyPI,
`ULog.write_ulog`; `.ci/run` installs pyulog==1.2.1), in PX4's topics, frames and units, for the
tests that `identify` reads PX4 logs as it reads the CSV:

    python3 scripts/to-ulog.py nanobench data/nanobench/dataset/B3_figure8_medium_rep2.csv OUT.ulg
    cargo run --release -- identify OUT.ulg --mapping mappings/px4-crazyflie.yaml --with body_offset
    python3 scripts/to-ulog.py flyarena flight.csv OUT.ulg     # a log of `flyarena run --log`

Topics (uORB message definitions; NED world, FRD body, SI units, quaternions w, x, y, z):
- vehicle_visual_odometry  VehicleOdometry: timestamp_sample is the mocap's capture time (the
                           row's), timestamp the time PX4 would have published it, 5 ms later,
                           so that a reader taking `timestamp` finds a 5 ms delay that is not in
                           the data; pose_frame 1 (NED); a row without a pose is no message
- sensor_combined          SensorCombined: gyro_rad (rad/s), accelerometer_m_s2 (m/s²), the
                           accelerometer sampled with the gyro (relative timestamp 0)
- actuator_motors          ActuatorMotors: control = PWM/65535 of each motor (NanoBench only)
- battery_status           BatteryStatus: voltage_v (NanoBench only)
The NanoBench CSV is z-up/FLU (docs/nanobench.md): turned by π about x (y and z negated, the
quaternion's y and z too), which is also what the CSV mapping does, so both routes see the same
numbers up to PX4's float32. A flyarena log (`run --log`) is already NED/FRD.
"""
import csv
import sys

import numpy as np
from pyulog import ULog

G = 9.81  # flyarena's g (vehicle::params::GRAVITY): the CSV mapping scales g by the same number
PUBLISH_LATENCY_US = 5000

# (name, [(type, array size, field)]) in the order PX4 declares them (no padding needed: pyulog
# writes each field packed, as PX4's logger does)
FORMATS = {
    "vehicle_visual_odometry": [("uint64_t", 0, "timestamp"), ("uint64_t", 0, "timestamp_sample"), ("uint8_t", 0, "pose_frame"),
                                ("float", 3, "position"), ("float", 4, "q"), ("uint8_t", 0, "velocity_frame"), ("float", 3, "velocity"),
                                ("float", 3, "angular_velocity"), ("float", 3, "position_variance"), ("float", 3, "orientation_variance"),
                                ("float", 3, "velocity_variance"), ("uint8_t", 0, "reset_counter"), ("int8_t", 0, "quality")],
    "sensor_combined": [("uint64_t", 0, "timestamp"), ("float", 3, "gyro_rad"), ("uint32_t", 0, "gyro_integral_dt"),
                        ("int32_t", 0, "accelerometer_timestamp_relative"), ("float", 3, "accelerometer_m_s2"),
                        ("uint32_t", 0, "accelerometer_integral_dt"), ("uint8_t", 0, "accelerometer_clipping"), ("uint8_t", 0, "gyro_clipping"),
                        ("uint8_t", 0, "accel_calibration_count"), ("uint8_t", 0, "gyro_calibration_count")],
    "actuator_motors": [("uint64_t", 0, "timestamp"), ("uint64_t", 0, "timestamp_sample"), ("uint16_t", 0, "reversible_flags"),
                        ("float", 12, "control")],
    "battery_status": [("uint64_t", 0, "timestamp"), ("bool", 0, "connected"), ("float", 0, "voltage_v"), ("float", 0, "current_a")],
}
NUMPY = {"uint64_t": np.uint64, "uint32_t": np.uint32, "int32_t": np.int32, "uint16_t": np.uint16, "uint8_t": np.uint8, "int8_t": np.int8,
         "float": np.float32, "bool": np.bool_}


def read_nanobench(path):
    """Rows of (t µs, pose or None, gyro, accel, motors u, battery V) from a NanoBench CSV."""
    rows = list(csv.DictReader(open(path, newline="")))
    t0 = float(rows[0]["t"])
    out = []
    for r in rows:
        t = round((float(r["t"]) - t0) * 1e6) + 1_000_000  # µs since "boot", 1 s before the log
        pose = None
        if all(r[k] not in ("", "nan", "NaN") for k in ("px", "py", "pz", "qx", "qy", "qz", "qw")):
            p = [float(r[k]) for k in ("px", "py", "pz")]
            qx, qy, qz, qw = (float(r[k]) for k in ("qx", "qy", "qz", "qw"))
            pose = ([p[0], -p[1], -p[2]], [qw, qx, -qy, -qz])
        gyro = [float(r["imu_gyro_x"]), -float(r["imu_gyro_y"]), -float(r["imu_gyro_z"])]
        acc = [G * float(r["imu_acc_x"]), -G * float(r["imu_acc_y"]), -G * float(r["imu_acc_z"])]
        motors = [float(r[f"motor_motor_m{k}"]) / 65535.0 for k in range(1, 5)]
        out.append((t, pose, gyro, acc, motors, float(r["pwr_pm_vbat"])))
    return out


def read_flyarena(path):
    """Rows from a flyarena flight log (`run --log`): NED/FRD already, no motors or battery."""
    out = []
    for r in csv.DictReader(open(path, newline="")):
        t = round(float(r["t_s"]) * 1e6) + 1_000_000
        pose = None
        if r["mocap_valid"] == "1":
            pose = ([float(r[k]) for k in ("pos_n_m", "pos_e_m", "pos_d_m")], [float(r[k]) for k in ("q_w", "q_x", "q_y", "q_z")])
        gyro = [float(r[f"gyro_{a}_rad_s"]) for a in "xyz"]
        acc = [float(r[f"acc_{a}_m_s2"]) for a in "xyz"]
        out.append((t, pose, gyro, acc, None, None))
    return out


def columns(name, n):
    """The flattened field names of a topic's format, and their numpy types."""
    cols = []
    for typ, size, field in FORMATS[name]:
        for k in range(size) if size else [None]:
            cols.append((field if k is None else f"{field}[{k}]", typ))
    return cols


def data_set(ulog, name, msg_id, values):
    """A ULog.Data of topic `name` (instance 0) holding `values` (flattened name → list)."""
    fmt = ULog.MessageFormat.__new__(ULog.MessageFormat)
    fmt.name, fmt.fields = name, FORMATS[name]
    ulog._message_formats[name] = fmt
    d = ULog.Data.__new__(ULog.Data)
    d.multi_id, d.msg_id, d.name = 0, msg_id, name
    cols = columns(name, 0)
    d.field_data = [ULog._FieldData(c, t) for c, t in cols]
    d.timestamp_idx = 0
    n = len(values["timestamp"])
    d.data = {c: np.asarray(values.get(c, [0] * n), dtype=NUMPY[t]) for c, t in cols}
    ulog._data_list.append(d)


def main():
    kind, src, dst = sys.argv[1:4]
    rows = read_nanobench(src) if kind == "nanobench" else read_flyarena(src)
    ulog = ULog(None)
    ulog._file_version = 1
    ulog._start_timestamp = rows[0][0]
    ulog._msg_info_dict["sys_name"] = "PX4"
    ulog._msg_info_dict_types["sys_name"] = "char[3]"
    odo = {"timestamp": [], "timestamp_sample": [], "pose_frame": [], **{f"position[{k}]": [] for k in range(3)}, **{f"q[{k}]": [] for k in range(4)}}
    nan = float("nan")
    for k in range(3):
        for f in ("velocity", "angular_velocity", "position_variance", "orientation_variance", "velocity_variance"):
            odo[f"{f}[{k}]"] = []
    imu = {"timestamp": [], **{f"gyro_rad[{k}]": [] for k in range(3)}, **{f"accelerometer_m_s2[{k}]": [] for k in range(3)}}
    mot = {"timestamp": [], "timestamp_sample": [], **{f"control[{k}]": [] for k in range(12)}}
    bat = {"timestamp": [], "connected": [], "voltage_v": []}
    for t, pose, gyro, acc, motors, vbat in rows:
        if pose is not None:
            odo["timestamp"].append(t + PUBLISH_LATENCY_US)
            odo["timestamp_sample"].append(t)
            odo["pose_frame"].append(1)
            for k in range(3):
                odo[f"position[{k}]"].append(pose[0][k])
                for f in ("velocity", "angular_velocity", "position_variance", "orientation_variance", "velocity_variance"):
                    odo[f"{f}[{k}]"].append(nan)
            for k in range(4):
                odo[f"q[{k}]"].append(pose[1][k])
        imu["timestamp"].append(t)
        for k in range(3):
            imu[f"gyro_rad[{k}]"].append(gyro[k])
            imu[f"accelerometer_m_s2[{k}]"].append(acc[k])
        if motors is not None:
            mot["timestamp"].append(t)
            mot["timestamp_sample"].append(t)
            for k in range(12):
                mot[f"control[{k}]"].append(motors[k] if k < len(motors) else nan)
            bat["timestamp"].append(t)
            bat["connected"].append(True)
            bat["voltage_v"].append(vbat)
    data_set(ulog, "vehicle_visual_odometry", 0, odo)
    data_set(ulog, "sensor_combined", 1, imu)
    if mot["timestamp"]:
        data_set(ulog, "actuator_motors", 2, mot)
        data_set(ulog, "battery_status", 3, bat)
    ulog.write_ulog(dst)


if __name__ == "__main__":
    main()
