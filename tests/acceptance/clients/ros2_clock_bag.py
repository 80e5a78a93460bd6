"""Writes a ROS 2 bag (MCAP) whose topics run on their own clocks, with the independent ROS 2
writer `mcap-ros2-support` (PyPI). Test helper for tests/acceptance/ros2.rs; usage:
ros2_clock_bag.py OUT.mcap

A synthetic flight (the same truth as the Rust-encoded bag of `props::ros2_fuzz::bag_with`):
x = 0.3 cos 2t, y = 0.3 sin 2t (z-up world) and a slow yaw, over 4 s from t = 1 s.
- /cf/imu       100 Hz, stamped at 1 s + k*10 ms;
- /vicon/cf/pose 50 Hz, the truth at row 2j stamped 5 ms later (its exposure + latency), the
                 pose of row 202 dropped (a frame in which the vehicle was not seen);
- /cf/motors    100 Hz, stamped 3 ms after each IMU message;
- /cf/battery    10 Hz, stamped 7 ms after every tenth IMU message.
The message definitions are those of scripts/nanobench-to-mcap.py.
"""
import importlib.util, math, pathlib, sys
from mcap_ros2.writer import Writer

spec = importlib.util.spec_from_file_location("defs", pathlib.Path(__file__).resolve().parents[3] / "scripts" / "nanobench-to-mcap.py")
defs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(defs)


def stamp(ns):
    return {"sec": ns // 10**9, "nanosec": ns % 10**9}


def main(dst):
    with open(dst, "wb") as out:
        w = Writer(out)
        pose_s = w.register_msgdef("geometry_msgs/msg/PoseStamped", defs.POSE)
        imu_s = w.register_msgdef("sensor_msgs/msg/Imu", defs.IMU)
        arr_s = w.register_msgdef("std_msgs/msg/Float64MultiArray", defs.ARRAY)
        bat_s = w.register_msgdef("sensor_msgs/msg/BatteryState", defs.BATTERY)
        # messages in time order across topics, as a recorder writes them
        msgs = []
        for k in range(400):
            ns = 10**9 + k * 10_000_000
            t = k * 0.01
            if k % 2 == 0 and k != 202:
                z = 0.02 if k < 50 else 0.02 + min(t - 0.5, 1.0)
                qx, qy, qz = 0.01, -0.02, math.sin(t * 0.1)
                qw = math.sqrt(1.0 - qx * qx - qy * qy - qz * qz)
                p = ns + 5_000_000
                msgs.append((p, "/vicon/cf/pose", pose_s, {"header": {"stamp": stamp(p), "frame_id": "vicon"}, "pose": {
                    "position": {"x": 0.3 * math.cos(2 * t), "y": 0.3 * math.sin(2 * t), "z": z},
                    "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}}))
            msgs.append((ns, "/cf/imu", imu_s, {"header": {"stamp": stamp(ns), "frame_id": "cf"},
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}, "orientation_covariance": [-1.0] + [0.0] * 8,
                "angular_velocity": {"x": 0.1, "y": -0.1, "z": 0.05}, "angular_velocity_covariance": [0.0] * 9,
                "linear_acceleration": {"x": 0.1, "y": 0.2, "z": 9.81}, "linear_acceleration_covariance": [0.0] * 9}))
            m = 0.0 if k < 50 else 47000.0
            msgs.append((ns + 3_000_000, "/cf/motors", arr_s, {"layout": {"dim": [{"label": "motor", "size": 4, "stride": 4}], "data_offset": 0}, "data": [m] * 4}))
            if k % 10 == 0:
                b = ns + 7_000_000
                msgs.append((b, "/cf/battery", bat_s, {"header": {"stamp": stamp(b), "frame_id": "cf"}, "voltage": 3.9,
                    "temperature": 0.0, "current": 0.0, "charge": 0.0, "capacity": 0.0, "design_capacity": 0.0, "percentage": 0.0,
                    "power_supply_status": 0, "power_supply_health": 0, "power_supply_technology": 0, "present": True,
                    "cell_voltage": [], "cell_temperature": [], "location": "", "serial_number": ""}))
        for ns, topic, schema, msg in sorted(msgs, key=lambda m: m[0]):
            w.write_message(topic, schema, msg, log_time=ns, publish_time=ns)
        w.finish()


if __name__ == "__main__":
    main(sys.argv[1])
