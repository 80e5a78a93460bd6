#!/usr/bin/env python3
"""A soak of `flyarena serve` in real time, next to hostile traffic on the same ports:

    python3 scripts/soak-serve.py --minutes 10 --out out/soak      # docs/serve.md, "Soak"

- five vehicles flown from outside (scenarios/fleet-4.yaml's four and a fifth, `echo`), each by
  the reference controller written from the paper (tests/acceptance/clients/fig6_controller.py,
  through the bridge), flying Fig. 6 over and over for the whole run;
- `echo`'s controller goes silent for 3 s in the middle of the run and then answers again: its
  receiver's failsafe must engage, and its commands be applied again after it;
- a hostile sender on the command port at RATE datagrams/s (default 5,000): random bytes,
  truncated and oversized datagrams, well-formed commands for vehicle ids nobody flies, commands
  for the flown vehicles with sequence numbers long past (replayed, reordered), NatNet messages
  the server does not know, and a registration flood (NatNet connects from 64 sockets).

Asserted at the end (exit 1 and the failing line otherwise):
- every requirement of the four well-behaved flights passes (the serve JSON's rows), and none of
  them was ever failed safe;
- every hostile datagram is accounted for by the server's counts: refused, or dropped as stale
  by the receiver, or dropped by the kernel at a full socket buffer (/proc/net/udp counts it);
- `echo` was failed safe and flew again;
- the server printed no line per packet;
- its resident memory is flat: at the end it is within 4 MB of what it was 2 s into the flight
  (the server runs with `--no-rrd` and no `--log`, so it keeps no trajectory; nothing else may
  grow with the flight or the traffic).
Measured and printed: physics ticks that began more than one physics period late, per 10⁵
ticks, the largest lag, the resident memory 2 s into the flight and at its end. The server is
`$FLYARENA`, else `flyarena` on the PATH; the controllers need `pip install natnet==0.3.0`.
Loopback only; every process started is stopped.
"""
import argparse
import json
import os
import random
import shutil
import signal
import socket
import struct
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONTROLLER = os.path.join(ROOT, "tests", "acceptance", "clients", "fig6_controller.py")
CYCLE_S = 41.0  # Fig. 6's plan: take-off 3 s, hover 6 + 5 s, settle 4 s, yaw 20 s, land 3 s
# (name, home N E in m, yaw0 in deg) as in scenarios/fleet-4.yaml, and the fifth
FLEET = [("alpha", 0, 0, 0), ("bravo", 0, 2, 0), ("charlie", 2, 0, 0), ("delta", 2, 2, 90), ("echo", 4, 0, 0)]
SERVER_BUF = 2048  # the server reads at most this many bytes of a datagram
NATNET_KNOWN = {0, 2, 4, 6, 9, 10}  # connect, request, model def, frame, disconnect, keep-alive


def scenario(cycles):
    """fleet-4 with every vehicle flown from outside, `echo` added, the plan repeated."""
    text = open(os.path.join(ROOT, "scenarios", "fleet-4.yaml")).read()
    head, rest = text.split("plan:\n")
    plan, req = rest.split("requirements:\n")
    head = head.replace("name: fleet-4", "name: soak")
    for name, *_ in FLEET[:4]:
        head = head.replace(f"  - name: {name}\n", f"  - name: {name}\n    station: external\n")
    head += f"  - name: echo\n    station: external\n    home_m: [4, 0]\n"
    return head + "plan:\n" + plan * cycles + "requirements:\n" + req


def free_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def udp_drops(port):
    """The kernel's count of datagrams dropped at the socket bound to 127.0.0.1:`port` (its
    receive buffer was full), from /proc/net/udp."""
    try:
        for line in open("/proc/net/udp").readlines()[1:]:
            f = line.split()
            if f[1] == "0100007F:%04X" % port:
                return int(f[-1])
    except OSError:
        pass
    return None


def rss_kb(pid):
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def refused(b):
    """What the server counts as refused, from the packet layouts (docs/serve.md), not its code."""
    b = b[:SERVER_BUF]
    if b[:4] == b"FAOF":
        return True  # the hostile sender's offset reports are all malformed or for unknown ids
    if b[:4] == b"FACM":
        n = b[6] if len(b) > 6 else 0
        ok = len(b) >= 12 and b[4] == 1 and 4 <= n <= 12 and len(b) == 12 + n and b[7] == 0
        return not ok or not 1 <= b[5] <= len(FLEET)
    if len(b) < 4:
        return True
    mid, n = struct.unpack_from("<HH", b)
    return len(b) < 4 + n or mid not in NATNET_KNOWN


def command(vid, seq, counts):
    return b"FACM" + bytes([1, vid, len(counts), 0]) + struct.pack("<I", seq) + bytes(counts)


def hostile(port, rate, launch, stop, speed, rng):
    """Sends until `stop` (wall clock); returns the counts by kind and the datagrams the server
    must refuse, and the stale commands it must drop. The flight began after `launch` (the
    controllers' start), within 8 s of it."""
    target = ("127.0.0.1", port)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 20)
    flood = []
    kinds = {}
    must_refuse = stale = sent = 0
    t0 = time.monotonic()
    while time.monotonic() < stop:
        due = t0 + sent / rate
        now = time.monotonic()
        if due > now:
            time.sleep(due - now)
        k = rng.randrange(8)
        if k == 0:  # random bytes
            kind, b = "random", rng.randbytes(rng.randrange(0, 600))
        elif k == 1:  # a command cut short
            kind, b = "truncated", command(rng.randrange(1, 6), rng.randrange(1 << 32), [128] * 8)[: rng.randrange(0, 19)]
        elif k == 2:  # more than the server reads
            kind, b = "oversized", (b"FACM" if rng.random() < 0.5 else b"") + rng.randbytes(rng.randrange(SERVER_BUF + 1, 9000))
        elif k == 3:  # a well-formed command for a vehicle nobody flies
            kind, b = "unknown-vehicle", command(rng.choice([0] + list(range(6, 256))), rng.randrange(1 << 32), [128] * 8)
        elif k == 4:  # a flown vehicle's command with a sequence number long past
            # the radio period now if the flight began at `launch`; 8 s of wall clock behind it
            # is long past whenever the flight began (the controllers register within 1–2 s)
            k_now = int((time.monotonic() - launch) * speed * 50)
            margin = int(8 * speed * 50)
            if k_now < margin + 100:
                continue
            kind, b = "stale", command(rng.randrange(1, 6), rng.randrange(0, k_now - margin), [255] * 8)
        elif k == 5:  # a NatNet message id the server does not know
            mid = rng.choice([m for m in range(0, 200) if m not in NATNET_KNOWN])
            kind, b = "natnet-unknown", struct.pack("<HH", mid, 0)
        elif k == 6:  # a malformed offset report
            kind, b = "bad-offset", b"FAOF" + bytes([1, rng.randrange(6, 256), 0, 0]) + rng.randbytes(rng.choice([16, 24, 40]))
        else:  # the registration flood: connects from 64 sockets
            if len(flood) < 64:
                f = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                f.bind(("127.0.0.1", 0))
                f.setblocking(False)
                flood.append(f)
            kind = "connect-flood"
            rng.choice(flood).sendto(struct.pack("<HH", 0, 5) + b"Ping\0", target)
            kinds[kind] = kinds.get(kind, 0) + 1
            sent += 1
            continue
        try:
            s.sendto(b, target)
        except OSError:
            continue  # e.g. ECONNREFUSED reported from an earlier datagram: not sent
        kinds[kind] = kinds.get(kind, 0) + 1
        sent += 1
        if kind == "stale":
            stale += 1
        elif refused(b):
            must_refuse += 1
        else:  # random bytes that happen to be a NatNet request (about one in a million)
            kinds["valid-by-chance"] = kinds.get("valid-by-chance", 0) + 1
    for f in flood:
        f.close()
    s.close()
    return kinds, must_refuse, stale, sent, time.monotonic() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--minutes", type=float, default=10.0, help="simulated minutes (whole Fig. 6 cycles of 41 s)")
    ap.add_argument("--speed", type=float, default=1.0, help="simulated seconds per second (1: real time)")
    ap.add_argument("--rate", type=float, default=5000.0, help="hostile datagrams per second")
    ap.add_argument("--out", default="out/soak", help="output folder (the scenario, the serve JSON)")
    ap.add_argument("--seed", type=int, default=1, help="the hostile sender's random choices")
    a = ap.parse_args()
    # a stop from outside (SIGTERM, a test's timeout) stops what this started too
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    flyarena = os.environ.get("FLYARENA") or shutil.which("flyarena")
    if not flyarena:
        sys.exit("no flyarena: set $FLYARENA or put it on the PATH (cargo install --path .)")
    cycles = max(1, round(a.minutes * 60 / CYCLE_S))
    os.makedirs(a.out, exist_ok=True)
    yaml = os.path.join(a.out, "soak.yaml")
    open(yaml, "w").write(scenario(cycles))
    port, data_port = free_port(), free_port()
    duration = cycles * CYCLE_S / a.speed
    silent = (cycles // 2 * CYCLE_S + 12.0, cycles // 2 * CYCLE_S + 15.0)  # echo's silence, hovering
    server = subprocess.Popen(
        [flyarena, "serve", yaml, "--command-port", str(port), "--data-port", str(data_port), "--no-rrd",
         "--out", a.out, "--wait-s", "60", "--speed", str(a.speed), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    controllers = []
    launch = time.monotonic()
    try:
        for i, (name, n, e, yaw) in enumerate(FLEET):
            args = [sys.executable, CONTROLLER, str(port), str(i + 1), "--home", str(n), str(e), "--yaw0-deg", str(yaw),
                    "--cycles", str(cycles)]
            if name == "echo":
                args += ["--silent", str(silent[0]), str(silent[1])]
            controllers.append(subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        # the flight starts when every controller has registered; the hostile sender starts then
        # (what it sends before would be taken as registrations, which is not what it tests)
        time.sleep(3.0)
        start = time.monotonic()
        rss, drops = [], [0]
        import threading

        def sample():
            while server.poll() is None:
                rss.append((time.monotonic() - start, rss_kb(server.pid)))
                drops[0] = udp_drops(port) or drops[0]
                time.sleep(0.5)

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        # the flight began after `launch` and ends after launch + duration: the hostile sender
        # stops before, so that the server reads all it sent
        kinds, must_refuse, stale, sent, wall = hostile(port, a.rate, launch, launch + duration - 2.0, a.speed,
                                                        random.Random(a.seed))
        out, err = server.communicate(timeout=duration + 120)
        got = [json.loads(c.communicate(timeout=60)[0] or "null") for c in controllers]
    finally:
        for p in [server] + controllers:
            if p.poll() is None:
                p.kill()
                p.wait()
    summary = json.load(open(os.path.join(a.out, "soak.serve.json")))
    net = summary["serve"]
    rows = summary["requirements"]
    stats = {c["vehicle"]: c["stats"] for c in net["commands"]}
    rss = [(t, kb) for t, kb in rss if kb]
    first = next((kb for t, kb in rss if t >= 2.0), rss[0][1] if rss else 0)
    end = rss[-1][1] if rss else 0
    dropped = sum(stats[v]["out_of_order"] + stats[v]["duplicates"] for v in stats)
    late = net["late_ticks"] * 1e5 / max(1, net["ticks"])
    report = {
        "simulated_s": cycles * CYCLE_S, "speed": a.speed, "hostile": kinds, "hostile_sent": sent,
        "hostile_rate_hz": round(sent / wall), "refused": net["rejected"], "refused_expected": must_refuse,
        "stale_dropped": dropped, "stale_sent": stale, "clients": len(net["clients"]),
        "clients_refused": net["clients_refused"], "ticks": net["ticks"], "late_per_1e5": round(late, 1),
        "max_lag_ms": round(net["max_lag_ms"], 2), "kernel_drops": drops[0], "rss_kb_2s": first,
        "rss_kb_end": end,
        "echo": stats["echo"], "echo_controller": got[4], "server_stderr_lines": len(err.splitlines()),
        "exit": server.returncode,
    }
    print(json.dumps(report, indent=1))
    fails = []
    for r in rows:
        if r["vehicle"] != "echo" and r["asserted"] and not r["pass"]:
            fails.append(f"{r['vehicle']} {r['id']} {r['what']}: {r['measured']} (limit {r['limit']})")
    # each datagram the hostile sender sent was refused or dropped as stale, or never reached
    # the server (the kernel dropped it at the full socket buffer, which it counts)
    lost = (must_refuse - net["rejected"]) + (stale - dropped)
    if net["rejected"] > must_refuse or dropped > stale or lost > drops[0]:
        fails.append(f"refused {net['rejected']} of {must_refuse} datagrams to refuse, dropped {dropped} of {stale} "
                     f"stale commands; the kernel dropped {drops[0]} datagrams")
    for name, *_ in FLEET[:4]:
        # a controller that answers every request on loopback is never failed safe: a stale
        # command that took its requests away would be
        if stats[name]["failsafe"] > 0:
            fails.append(f"{name} was failed safe: {stats[name]}")
    if stats["echo"]["failsafe"] == 0 or not (got[4] and got[4]["resumed"] > 0):
        fails.append(f"echo was not failed safe and flown again: {stats['echo']} {got[4]}")
    if len(err.splitlines()) > 20:
        fails.append(f"the server printed {len(err.splitlines())} lines")
    # no trajectory is kept (no recording, no log): nothing may grow with the flight or the traffic
    if end > first + 4096:
        fails.append(f"resident memory {first} kB 2 s into the flight, {end} kB at its end")
    for f in fails:
        print("FAIL:", f)
    sys.exit(1 if fails else 0)


if __name__ == "__main__":
    main()
