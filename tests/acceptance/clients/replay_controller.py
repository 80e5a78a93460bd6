"""An external controller for `flyarena serve --lockstep` that replays given radio frames: it
answers each request (FARQ) for radio period k with frames[k], sends a duplicate of every 10th
command and, after every 10th from the 7th on, the previous one again (out of order), and counts
the telemetry it receives. Test helper for tests/acceptance/serve.rs; usage:
replay_controller.py COMMAND_PORT VEHICLE_ID FRAMES.json (a list of channel-count lists)."""
import json
import socket
import struct
import sys

import handshake

port, vehicle, path = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
frames = json.load(open(path))
sock, server = handshake.connect(port)


def command(k):
    f = frames[k]
    return b"FACM" + bytes([1, vehicle, len(f), 0]) + struct.pack("<I", k) + bytes(f)


sent = {"commands": 0, "duplicates": 0, "out_of_order": 0}
sock.sendto(command(0), server)  # registers (before the flight: answers no request)
requests, telemetry, last = 0, 0, -1
sock.settimeout(10.0)
while last < len(frames) - 1:
    data, _ = sock.recvfrom(65536)
    if data[:4] == b"FATM":
        telemetry += 1
    elif data[:4] == b"FARQ":
        requests += 1
        k = struct.unpack_from("<I", data, 8)[0]
        last = k
        sock.sendto(command(k), server)
        sent["commands"] += 1
        if k % 10 == 5:
            sock.sendto(command(k), server)
            sent["duplicates"] += 1
        if k % 10 == 7:
            sock.sendto(command(k - 1), server)
            sent["out_of_order"] += 1
print(json.dumps({"requests": requests, "telemetry": telemetry, "sent": sent}))
