#!/usr/bin/env python3
"""pyulog's parse of a ULog file, as JSON, for the topics flyarena's ULog reader reads: every
instance of each, every field (NaN as null). The test compares flyarena's parse with it.

    python3 tests/acceptance/clients/ulog_dump.py FILE.ulg > OUT.json
"""
import json
import math
import sys

from pyulog import ULog

READ = ["vehicle_visual_odometry", "vehicle_mocap_odometry", "sensor_combined", "vehicle_imu", "actuator_motors", "actuator_outputs", "battery_status"]


def number(x):
    x = float(x)
    return None if math.isnan(x) else x


u = ULog(sys.argv[1], READ)
out = {}
for d in u.data_list:
    out[f"{d.name}/{d.multi_id}"] = {k: [number(x) for x in v] for k, v in d.data.items() if v.dtype.kind in "iufb"}
json.dump(out, sys.stdout)
