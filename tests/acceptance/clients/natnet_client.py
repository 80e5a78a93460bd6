"""Receives `flyarena serve` with the `natnet` client from PyPI (unicast) and prints what it got
as JSON: the server info, the rigid-body descriptions, every frame, and how many datagrams the
kernel dropped at the data socket because this process did not read them in time (the `drops`
column of /proc/net/udp; a loaded machine can stall a client for longer than the default
receive buffer lasts at 400 frames/s). Test helper for tests/acceptance/serve.rs; usage:
natnet_client.py COMMAND_PORT SECONDS [GROUP DATA_PORT]"""
import json
import socket
import sys
import time

from natnet import NatNetClient

port, seconds = int(sys.argv[1]), float(sys.argv[2])
group = sys.argv[3] if len(sys.argv) > 4 else None
frames, descriptions = [], []
if group is None:
    client = NatNetClient(server_ip_address="127.0.0.1", local_ip_address="127.0.0.1", command_port=port, use_multicast=False)
else:
    client = NatNetClient(
        server_ip_address="127.0.0.1", local_ip_address="127.0.0.1", multicast_address=group, command_port=port, data_port=int(sys.argv[4]), use_multicast=True
    )
client.on_data_frame_received_event.handlers.append(frames.append)
client.on_data_description_received_event.handlers.append(descriptions.append)
client.connect(timeout=20)
data_socket = client._NatNetClient__data_socket
for option in (getattr(socket, "SO_RCVBUFFORCE", None), socket.SO_RCVBUF):
    try:
        data_socket.setsockopt(socket.SOL_SOCKET, option, 8 << 20)
        break
    except (OSError, TypeError):
        pass


def kernel_drops(port):
    """The datagrams the kernel dropped at the UDP socket bound to `port`."""
    try:
        with open("/proc/net/udp") as table:
            for line in table.readlines()[1:]:
                fields = line.split()
                if int(fields[1].split(":")[1], 16) == port:
                    return int(fields[-1])
    except OSError:
        pass
    return 0


client.request_modeldef()
start = time.time()
while time.time() - start < seconds:
    client.update_sync()
    time.sleep(0.001)
info = client.server_info
dropped = kernel_drops(data_socket.getsockname()[1])
client.shutdown()
print(json.dumps({
    "application": info.application_name,
    "natnet_version": str(info.nat_net_protocol_version),
    "bodies": [[b.name, b.id_num, [list(m.pos) for m in b.markers]] for d in descriptions[:1] for b in d.rigid_bodies],
    "dropped": dropped,
    "frames": [
        {
            "number": f.prefix.frame_number,
            "timestamp": f.suffix.timestamp,
            "stamps": [f.suffix.stamp_camera_mid_exposure, f.suffix.stamp_data_received, f.suffix.stamp_transmit],
            "bodies": [[b.id_num, list(b.pos), list(b.rot), b.tracking_valid] for b in f.rigid_bodies],
        }
        for f in frames
    ],
}))
