"""A reference external controller for `flyarena serve --lockstep` (the README's tour runs it,
and the tests): the paper's
cascaded controller (1)-(5) written from the paper, not from flyarena's code, flying Fig. 6
(take off to 1 m, hover, average the measured roll and pitch, yaw 360 deg on the spot, land)
through the bridge. It reads NatNet frames (Z-up, as any lab client would) and flyarena's
requests on one socket, so that it has seen every pose sent before each request.

usage: fig6_controller.py COMMAND_PORT VEHICLE_ID [--home N E] [--yaw0-deg D] [--cycles K]
                         [--silent S1 S2]
--home and --yaw0-deg: where the vehicle sits on the floor (m, NED) and its heading (the
scenario's `home_m` and `yaw0_deg`); --cycles: fly the plan K times in a row (a scenario whose
plan is Fig. 6's repeated K times); --silent: send nothing from simulated time S1 to S2 (s), then
answer again. Prints a JSON summary of what it did."""
import json
import math
import socket
import struct
import sys

import handshake

from natnet.data_frame import DataFrame
from natnet.packet_buffer import PacketBuffer
from natnet.version import Version

port, vehicle = int(sys.argv[1]), int(sys.argv[2])
opts = sys.argv[3:]


def opt(name, n, default):
    if name not in opts:
        return default
    i = opts.index(name)
    return [float(x) for x in opts[i + 1:i + 1 + n]]


HOME = opt("--home", 2, [0.0, 0.0])
YAW0 = math.radians(opt("--yaw0-deg", 1, [0.0])[0])
CYCLES = int(opt("--cycles", 1, [1])[0])
SILENT = opt("--silent", 2, None)
G = 9.81
# the X3D and flyarena's default gains and radio (docs/scenarios.md, Scenario reference)
MASS, T_MAX = 0.68, 24.0
K_X, K_V, K_ATT = (1.0, 1.0, 1.0), (2.0, 2.0, 3.0), (6.0, 6.0, 3.0)
MAX_TILT = math.radians(20.0)
RATE_SCALE = math.radians(1.5)  # rad/s per count
CUTOFF_HZ = 15.0
# Fig. 6's plan (scenarios/fig6-roll-pitch-offsets.yaml): take-off 3 s, hover 6 s then average 5 s,
# settle 4 s then yaw 360 deg in 20 s, land 3 s
T_TAKEOFF, T_AVG0, T_AVG1, T_SPIN0, T_SPIN1, T_LAND1 = 3.0, 9.0, 14.0, 18.0, 38.0, 41.0
ALT = 1.0


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def apply(a, v):
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]


def quat_to_matrix(w, x, y, z):
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]


def euler_zyx(r):
    """(roll, pitch, yaw) of C_b^n = Rz(yaw) Ry(pitch) Rx(roll)."""
    return math.atan2(r[2][1], r[2][2]), -math.asin(max(-1.0, min(1.0, r[2][0]))), math.atan2(r[1][0], r[0][0])


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return [[1, 0, 0], [0, c, -s], [0, s, c]]


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return [[c, 0, s], [0, 1, 0], [-s, 0, c]]


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def count(x):
    """Round half away from zero (as the radio does), clamp to 0..255."""
    return int(max(0.0, min(255.0, math.floor(x + 0.5) if x >= 0 else math.ceil(x - 0.5))))


def min_jerk(h, T, tau):
    s = max(0.0, min(1.0, tau / T))
    p = h * (10 * s**3 - 15 * s**4 + 6 * s**5)
    v = h * (30 * s**2 - 60 * s**3 + 30 * s**4) / T if 0 < tau < T else 0.0
    a = h * (60 * s - 180 * s**2 + 120 * s**3) / T**2 if 0 < tau < T else 0.0
    return p, v, a


def reference(t):
    """Position, velocity, acceleration (NED), yaw, yaw rate, motors off: Fig. 6 from home."""
    if t < CYCLES * T_LAND1:
        t = t % T_LAND1
    else:
        t = T_LAND1
    p, v, a, yaw, yaw_rate, off = fig6(t)
    return [p[0] + HOME[0], p[1] + HOME[1], p[2]], v, a, wrap(yaw + YAW0), yaw_rate, off


def fig6(t):
    if t < T_TAKEOFF:
        p, v, a = min_jerk(ALT, T_TAKEOFF, t)
        return [0, 0, -p], [0, 0, -v], [0, 0, -a], 0.0, 0.0, False
    if t < T_SPIN0:
        return [0, 0, -ALT], [0, 0, 0], [0, 0, 0], 0.0, 0.0, False
    if t < T_SPIN1:
        rate = 2 * math.pi / (T_SPIN1 - T_SPIN0)
        return [0, 0, -ALT], [0, 0, 0], [0, 0, 0], rate * (t - T_SPIN0), rate, False
    if t < T_LAND1:
        p, v, a = min_jerk(ALT + 0.05, T_LAND1 - T_SPIN1, t - T_SPIN1)
        return [0, 0, -ALT + p], [0, 0, v], [0, 0, a], 0.0, 0.0, False
    return [0, 0, 0.05], [0, 0, 0], [0, 0, 0], 0.0, 0.0, True


def control(t, pos, vel, c_b_n):
    """(1)-(5): rates p, q, r (rad/s) and thrust (N)."""
    rp, rv, ra, yaw_ref, yaw_rate_ref, off = reference(t)
    if off:
        return (0.0, 0.0, 0.0), 0.0
    roll, pitch, yaw = euler_zyx(c_b_n)
    c_n_b = transpose(c_b_n)
    dx = apply(c_n_b, [rp[i] - pos[i] for i in range(3)])  # (1)
    v_b, vff, aff = apply(c_n_b, vel), apply(c_n_b, rv), apply(c_n_b, ra)
    acc = [aff[i] + K_V[i] * (K_X[i] * dx[i] + vff[i] - v_b[i]) for i in range(3)]  # (2)
    roll_com = max(-MAX_TILT, min(MAX_TILT, math.asin(max(-1.0, min(1.0, acc[1] / (G * math.cos(pitch)))))))
    pitch_com = max(-MAX_TILT, min(MAX_TILT, math.asin(max(-1.0, min(1.0, acc[0] / -G)))))
    e = [K_ATT[0] * (roll_com - roll), K_ATT[1] * (pitch_com - pitch), K_ATT[2] * wrap(yaw_ref - yaw) + yaw_rate_ref]
    sf, cf, st, ct = math.sin(roll), math.cos(roll), math.sin(pitch), math.cos(pitch)
    t_w_inv = [[1, 0, -st], [0, cf, ct * sf], [0, -sf, ct * cf]]  # (4)
    pqr = apply(t_w_inv, e)  # (3)
    f_t = MASS * (acc[2] - G * cf * ct)  # (5)
    return tuple(pqr), max(0.0, min(T_MAX, -f_t))


sock, server = handshake.connect(port)


def send(seq, rates, thrust):
    counts = [count(128 + r / RATE_SCALE) for r in rates] + [count(255 * thrust / T_MAX)] + [0] * 4
    sock.sendto(b"FACM" + bytes([1, vehicle, len(counts), 0]) + struct.pack("<I", seq) + bytes(counts), server)


send(0, (0.0, 0.0, 0.0), 0.0)  # registers; the vehicle sits on the floor until the first request
pos = vel = last = None
c_b_n = None
offset = None  # the hover-averaged (roll, pitch) of the markers
sums, n_avg = [0.0, 0.0], 0
requests, frames = 0, 0
silent, resumed = 0, 0  # requests left unanswered, and answered after the silence
sock.settimeout(10.0)
while True:
    try:
        data, _ = sock.recvfrom(65536)
    except socket.timeout:
        break
    if data[:4] == b"FARQ":
        k = struct.unpack_from("<I", data, 8)[0]
        t = struct.unpack_from("<q", data, 12)[0] * 1e-9
        requests += 1
        if c_b_n is None:
            send(k, (0.0, 0.0, 0.0), 0.0)
            continue
        att = c_b_n
        if offset is not None:  # compensate: C_b^n = C_m^n * R_off^T, R_off = Ry(pitch) Rx(roll)
            att = matmul(c_b_n, transpose(matmul(ry(offset[1]), rx(offset[0]))))
        rates, thrust = control(t, pos, vel, att)
        if SILENT and SILENT[0] <= t < SILENT[1]:
            silent += 1
            continue
        if SILENT and t >= SILENT[1]:
            resumed += 1
        send(k, rates, thrust)
        if t >= CYCLES * T_LAND1:
            sock.settimeout(1.0)  # the run ends within a second of landing
        continue
    if struct.unpack_from("<H", data)[0] != 7:
        continue
    f = DataFrame.read_from_buffer(PacketBuffer(data[4:]), Version(3, 1))
    body = next((b for b in f.rigid_bodies if b.id_num == vehicle), None)
    if body is None:
        continue
    frames += 1
    tc = f.suffix.timestamp
    # Z-up -> NED: (x, -y, -z); the quaternion (x, y, z, w) -> (w, x, -y, -z)
    p = [body.pos[0], -body.pos[1], -body.pos[2]]
    x, y, z, w = body.rot
    c_b_n = quat_to_matrix(w, x, -y, -z)
    if last is not None and tc > last[0]:
        dt = tc - last[0]
        raw = [(p[i] - last[1][i]) / dt for i in range(3)]
        alpha = math.exp(-2 * math.pi * CUTOFF_HZ * dt)
        vel = [vel[i] * alpha + raw[i] * (1 - alpha) for i in range(3)]
    elif vel is None:
        vel = [0.0, 0.0, 0.0]
    last, pos = (tc, p), p
    if T_AVG0 <= tc < T_AVG1:
        r, q, _ = euler_zyx(c_b_n)
        sums[0] += r
        sums[1] += q
        n_avg += 1
    elif tc >= T_AVG1 and offset is None and n_avg > 0:
        offset = (sums[0] / n_avg, sums[1] / n_avg)
        # report it (flyarena's convention: the markers' rotation against the body; no yaw)
        sock.sendto(b"FAOF" + bytes([1, vehicle, 0, 0]) + struct.pack("<ddd", offset[0], offset[1], float("nan")), server)
summary = {"requests": requests, "frames": frames, "offset_deg": [math.degrees(a) for a in offset] if offset else None}
if SILENT:
    summary.update(silent=silent, resumed=resumed)
print(json.dumps(summary))
