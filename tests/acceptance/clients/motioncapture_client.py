"""Receives `flyarena serve` with libmotioncapture's Python binding (`motioncapture` on PyPI, its
`optitrack` backend, as Crazyswarm2 uses it) and prints, as JSON, the poses of every frame it
got, frame by frame in the order received. Test helper for tests/acceptance/serve.rs; usage:
motioncapture_client.py COMMAND_PORT FRAMES"""
import json
import sys

import motioncapture

port, n = int(sys.argv[1]), int(sys.argv[2])
mc = motioncapture.connect("optitrack", {"hostname": "127.0.0.1", "port_command": str(port)})
frames = []
for _ in range(n):
    mc.waitForNextFrame()
    frame = []
    for name, body in mc.rigidBodies.items():
        q = body.rotation
        frame.append([name, [float(x) for x in body.position], [q.x, q.y, q.z, q.w]])
    frames.append(frame)
print(json.dumps({"frames": frames}))
