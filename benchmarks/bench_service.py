"""Load test of `turbgen serve` (loopback only, bounded): 50 concurrent clients mixing duplicate
submissions and status polls. Checks: no 5xx, one computation per distinct config; prints the
p50/p95/max latency of GET /runs/<id>.

    python benchmarks/bench_service.py [--clients 50] [--polls 20]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

import numpy as np

GRID = {"nt": 256, "ny": 8, "nz": 8, "x_m": [0.0, 50.0]}


def _request(url, method="GET", body=None, timeout_s=30.0):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(url, data=data, method=method, headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=timeout_s) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--polls", type=int, default=20, help="status requests per client")
    ap.add_argument("--configs", type=int, default=3, help="distinct run configs the clients share")
    args = ap.parse_args()
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    url = f"http://127.0.0.1:{port}"
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-c", "from turbgen.cli import main; main()", "serve", "--port", str(port),
               "--root", os.path.join(tmp, "root"), "--workers", "2", "--max-queue", "64"]  # fmt: skip
        server = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            deadline = time.monotonic() + 60
            while True:
                try:
                    if _request(url + "/health")[0] == 200:
                        break
                except OSError:
                    pass
                if time.monotonic() > deadline or server.poll() is not None:
                    sys.exit("turbgen serve did not start")
                time.sleep(0.2)
            latencies, statuses, ids, lock = [], [], set(), threading.Lock()

            def client(i):
                cfg = {"model": "mann", "seed": 1000 + i % args.configs, "U_m_s": 10.0, "grid": GRID}
                st, out = _request(url + "/runs", "POST", cfg)
                with lock:
                    statuses.append(st)
                if out is None:
                    return
                with lock:
                    ids.add(out["id"])
                for _ in range(args.polls):
                    t0 = time.perf_counter()
                    st, _ = _request(url + f"/runs/{out['id']}")
                    dt = time.perf_counter() - t0
                    with lock:
                        latencies.append(dt)
                        statuses.append(st)
                    time.sleep(0.05)

            t0 = time.perf_counter()
            threads = [threading.Thread(target=client, args=(i,)) for i in range(args.clients)]
            for t in threads:
                t.start()
            for t in threads:
                t.join(300)
            wall = time.perf_counter() - t0
            _, health = _request(url + "/health")
        finally:
            server.kill()
            server.wait(30)
    lat = np.array(latencies) * 1e3
    n5xx = sum(1 for s in statuses if s >= 500)
    print(f"turbgen serve load test: {args.clients} clients, {len(statuses)} requests in {wall:.1f} s "
          f"({args.configs} distinct configs)")
    print(f"  status codes: {dict(sorted((s, statuses.count(s)) for s in set(statuses)))}; 5xx: {n5xx}")
    print(f"  computations: {health['computations']} for {len(ids)} distinct run ids")
    print(f"  GET /runs/<id> latency: p50 {np.percentile(lat, 50):.1f} ms, p95 {np.percentile(lat, 95):.1f} ms, "
          f"max {lat.max():.1f} ms (n = {lat.size})")
    if n5xx or health["computations"] != len(ids) or len(ids) != args.configs:
        sys.exit("FAILED: 5xx responses or duplicate computations")


if __name__ == "__main__":
    main()
