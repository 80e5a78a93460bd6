#!/usr/bin/env python3
"""A NanoBench flight (CSV) written as a ROS 2 bag in MCAP, by the independent ROS 2 writer
`mcap-ros2-support` (PyPI; `.ci/run` installs it), for the test that `identify` reads ROS 2 bags
as it reads the CSV:

    python3 scripts/nanobench-to-mcap.py data/nanobench/dataset/B3_figure8_medium_rep2.csv OUT.mcap
    cargo run --release -- identify OUT.mcap --mapping mappings/ros2-crazyflie.yaml --with body_offset

Topics (REP 103 units and frames: SI, an ENU-like z-up world, an FLU body):
- /vicon/cf/pose  geometry_msgs/msg/PoseStamped   (Vicon position, attitude; a row whose pose
                                                   is empty is a frame in which the vehicle was
                                                   not seen: no message)
- /cf/imu         sensor_msgs/msg/Imu             (gyro rad/s; specific force g × 9.81 m/s²)
- /cf/motors      std_msgs/msg/Float64MultiArray  (the four PWM commands, 0..65535)
- /cf/battery     sensor_msgs/msg/BatteryState    (volts)
Every message is stamped with the row's time (header stamp; log time for the array, which has no
header). The zstd-compressed chunks are the writer's default; `--uncompressed` writes them raw
(the fuzzing corpus wants records a mutation can reach).
"""
import csv, sys
from mcap_ros2.writer import Writer

G = 9.81  # flyarena's g (vehicle::params::GRAVITY): the CSV mapping scales g by the same number

HEADER = """================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec"""
POSE = """std_msgs/Header header
geometry_msgs/Pose pose
""" + HEADER + """
================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w"""
IMU = """std_msgs/Header header
geometry_msgs/Quaternion orientation
float64[9] orientation_covariance
geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance
geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance
""" + HEADER + """
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z"""
ARRAY = """std_msgs/MultiArrayLayout layout
float64[] data
================================================================================
MSG: std_msgs/MultiArrayLayout
std_msgs/MultiArrayDimension[] dim
uint32 data_offset
================================================================================
MSG: std_msgs/MultiArrayDimension
string label
uint32 size
uint32 stride"""
BATTERY = """std_msgs/Header header
float32 voltage
float32 temperature
float32 current
float32 charge
float32 capacity
float32 design_capacity
float32 percentage
uint8 power_supply_status
uint8 power_supply_health
uint8 power_supply_technology
bool present
float32[] cell_voltage
float32[] cell_temperature
string location
string serial_number
""" + HEADER


def main(src, dst, compression=None):
    with open(src, newline="") as f, open(dst, "wb") as out:
        w = Writer(out) if compression is None else Writer(out, compression=compression)
        pose_s = w.register_msgdef("geometry_msgs/msg/PoseStamped", POSE)
        imu_s = w.register_msgdef("sensor_msgs/msg/Imu", IMU)
        arr_s = w.register_msgdef("std_msgs/msg/Float64MultiArray", ARRAY)
        bat_s = w.register_msgdef("sensor_msgs/msg/BatteryState", BATTERY)
        for row in csv.DictReader(f):
            # the CSV's epoch seconds to integer nanoseconds (the stamp a ROS driver writes)
            ns = round(float(row["t"]) * 1e9)
            stamp = {"sec": ns // 10**9, "nanosec": ns % 10**9}
            header = {"stamp": stamp, "frame_id": "vicon"}
            pose = [row[k] for k in ("px", "py", "pz", "qx", "qy", "qz", "qw")]
            if all(c.strip() not in ("", "nan", "NaN") for c in pose):
                p = [float(c) for c in pose]
                w.write_message("/vicon/cf/pose", pose_s, {"header": header, "pose": {
                    "position": {"x": p[0], "y": p[1], "z": p[2]},
                    "orientation": {"x": p[3], "y": p[4], "z": p[5], "w": p[6]}}}, log_time=ns, publish_time=ns)
            g = [float(row[f"imu_gyro_{a}"]) for a in "xyz"]
            a = [float(row[f"imu_acc_{a}"]) * G for a in "xyz"]
            w.write_message("/cf/imu", imu_s, {"header": {"stamp": stamp, "frame_id": "cf"},
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}, "orientation_covariance": [-1.0] + [0.0] * 8,
                "angular_velocity": {"x": g[0], "y": g[1], "z": g[2]}, "angular_velocity_covariance": [0.0] * 9,
                "linear_acceleration": {"x": a[0], "y": a[1], "z": a[2]}, "linear_acceleration_covariance": [0.0] * 9}, log_time=ns, publish_time=ns)
            m = [float(row[f"motor_motor_m{i}"]) for i in range(1, 5)]
            w.write_message("/cf/motors", arr_s, {"layout": {"dim": [{"label": "motor", "size": 4, "stride": 4}], "data_offset": 0}, "data": m}, log_time=ns, publish_time=ns)
            w.write_message("/cf/battery", bat_s, {"header": {"stamp": stamp, "frame_id": "cf"}, "voltage": float(row["pwr_pm_vbat"]),
                "temperature": 0.0, "current": 0.0, "charge": 0.0, "capacity": 0.0, "design_capacity": 0.0, "percentage": 0.0,
                "power_supply_status": 0, "power_supply_health": 0, "power_supply_technology": 0, "present": True,
                "cell_voltage": [], "cell_temperature": [], "location": "", "serial_number": ""}, log_time=ns, publish_time=ns)
        w.finish()


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--uncompressed"]
    if len(args) != 2:
        sys.exit("usage: nanobench-to-mcap.py [--uncompressed] FLIGHT.csv OUT.mcap")
    raw = "--uncompressed" in sys.argv[1:]
    main(*args, compression=__import__("mcap.writer").writer.CompressionType.NONE if raw else None)
