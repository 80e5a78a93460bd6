"""The start of every test controller: a UDP socket on loopback, and NatNet's connect sent until
the server info comes back (the server may still be starting)."""
import socket
import struct
import sys


def connect(port):
    """A socket registered with `flyarena serve` on `port`, and the server's address."""
    server = ("127.0.0.1", port)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.1)
    for _ in range(300):
        sock.sendto(struct.pack("<HH", 0, 5) + b"Ping\0", server)
        try:
            data, _ = sock.recvfrom(65536)
            if struct.unpack_from("<H", data)[0] == 1:
                return sock, server
        except socket.timeout:
            pass
    sys.exit("no server info")
