#!/usr/bin/env bash
# Rewrites fuzz/seeds/serve_packet/ from the datagrams real clients send to `flyarena serve`:
# records loopback UDP with tcpdump while the serve tests run the PyPI NatNet client, the
# motioncapture (libmotioncapture) client and the reference controller against the server, then
# keeps what a client sent to the command port (flyarena's FACM/FAOF packets, NatNet requests),
# at most 40 distinct packets of each kind. Needs root (tcpdump) and the CI's Python clients.
#   fuzz/capture-packets.sh
set -euo pipefail
cd "$(dirname "$0")/.."
pcap=$(mktemp --suffix=.pcap)
trap 'kill "$dump" 2>/dev/null || true; rm -f "$pcap"' EXIT
tcpdump -i lo -w "$pcap" -s 4096 udp 2>/dev/null &
dump=$!
sleep 1
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/flyarena-target}" cargo test --release --test acceptance serve:: >/dev/null
sleep 1
kill "$dump"; wait "$dump" 2>/dev/null || true
rm -rf fuzz/seeds/serve_packet && mkdir -p fuzz/seeds/serve_packet
python3 - "$pcap" fuzz/seeds/serve_packet <<'PY'
import hashlib, struct, sys
b = open(sys.argv[1], "rb").read()
link = struct.unpack("<I", b[20:24])[0]
l2 = {0: 4, 1: 14, 113: 16}[link]  # null/loopback, Ethernet, Linux cooked
# NatNet message ids a client sends: connect, model def, request, frame, keepalive, disconnect
client_ids = {0, 2, 4, 6, 10, 12}
off, kept = 24, {}
while off + 16 <= len(b):
    incl = struct.unpack("<I", b[off + 8:off + 12])[0]
    ip = b[off + 16 + l2:off + 16 + incl]
    off += 16 + incl
    if len(ip) < 28 or ip[0] >> 4 != 4 or ip[9] != 17:
        continue
    p = ip[(ip[0] & 15) * 4 + 8:]
    if p[:4] in (b"FACM", b"FAOF"):
        kind = p[:4].decode()
    elif len(p) >= 4 and struct.unpack("<H", p[:2])[0] in client_ids:
        kind = "natnet%d" % struct.unpack("<H", p[:2])[0]
    else:
        continue
    if p not in kept and sum(k == kind for k in kept.values()) < 40:
        kept[p] = kind
for p, kind in kept.items():
    open("%s/%s-%s" % (sys.argv[2], kind, hashlib.sha1(p).hexdigest()[:12]), "wb").write(p)
print("%d packets" % len(kept))
PY
