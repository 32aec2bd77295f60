#!/usr/bin/python3
"""Many jobs from many clients at once on loopback (issue #7).

Starts `mvbrdf server` and N `mvbrdf worker` processes, then C client threads
that each submit J small jobs at once (real `mvbrdf submit` processes, real
bundles, a real gRPC channel) and follow every job with its own
`mvbrdf watch` stream until it ends. Measures each job's latency (submit
started -> watch saw it end), the throughput, and the server's resident
memory (sampled every 100 ms, and VmHWM at the end). Then checks that
nothing was lost: every job succeeded, each client lists exactly its own
jobs, the database passes PRAGMA integrity_check.

Writes a JSON summary to --json (and stdout). Exit status 1 when a check
fails (so the test that runs a small load fails), 0 otherwise.
Used by tests/cli_load_test.sh (small) and scripts/bench-load (50 jobs).
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import threading
import time


def percentile(values, q):
    ordered = sorted(values)
    if not ordered:
        return 0.0
    k = (len(ordered) - 1) * q
    lo, hi = int(k), min(int(k) + 1, len(ordered) - 1)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (k - lo)


def rss_kib(pid, field="VmRSS"):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--jobs", type=int, default=50, help="jobs in all")
    ap.add_argument("--clients", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scenes", type=int, default=2, help="distinct sequences (the rest hit the Sample cache)")
    ap.add_argument("--max-server-mib", type=float, default=0, help="fail when the server's peak RSS is above")
    ap.add_argument("--json", default="")
    args = ap.parse_args()
    if args.jobs % args.clients:
        sys.exit("--jobs must be a multiple of --clients")
    work = os.path.abspath(args.work)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    env = dict(os.environ, LP_NUM_THREADS=os.environ.get("LP_NUM_THREADS", "2"))

    scenes = []
    for s in range(args.scenes):
        out = os.path.join(work, f"scene{s}")
        subprocess.run([args.bin, "synth", "--cameras", "2", "--frames", "4", "--width", "96", "--height", "72",
                        "--actor-segments", str(8 + 2 * s), "--out", out], check=True, env=env,
                       stdout=subprocess.DEVNULL)
        scenes.append(os.path.join(out, "scene.json"))

    log = open(os.path.join(work, "server.log"), "w")
    server = subprocess.Popen([args.bin, "server", "--listen", "127.0.0.1:0", "--data", os.path.join(work, "data"),
                               "--max-jobs-per-client", str(args.jobs)], stdout=log, stderr=subprocess.STDOUT,
                              env=env)
    address = None
    for _ in range(100):
        m = re.search(r"listening on ([0-9.:]+)", open(os.path.join(work, "server.log")).read())
        if m:
            address = m.group(1)
            break
        time.sleep(0.1)
    if address is None:
        server.kill()
        sys.exit("the server did not start")
    workers = [subprocess.Popen([args.bin, "worker", "--server", address, "--name", f"w{i}", "--cache",
                                 os.path.join(work, f"cache{i}"), "--egl", "surfaceless", "--wait", "1"],
                                stdout=open(os.path.join(work, f"w{i}.log"), "w"), stderr=subprocess.STDOUT, env=env)
               for i in range(args.workers)]

    samples = []
    sampling = threading.Event()

    def sample_memory():
        while not sampling.is_set():
            samples.append((time.monotonic(), rss_kib(server.pid)))
            time.sleep(0.1)

    sampler = threading.Thread(target=sample_memory)
    sampler.start()

    per_client = args.jobs // args.clients
    results = []  # (client, job id, latency s, exit code)
    lock = threading.Lock()
    failures = []

    def client(c):
        name = f"client{c}"
        pending = []
        for j in range(per_client):
            scene = scenes[(c * per_client + j) % len(scenes)]
            atlas = "64" if (c + j) % 2 == 0 else "96"
            t0 = time.monotonic()
            sub = subprocess.run([args.bin, "submit", scene, "--server", address, "--client", name, "--atlas", atlas,
                                  "--no-powell"], capture_output=True, text=True, env=env)
            if sub.returncode != 0:
                with lock:
                    failures.append(f"{name}: submit exit {sub.returncode}: {sub.stderr.strip()}")
                continue
            job = sub.stdout.strip().splitlines()[-1]
            watch = subprocess.Popen([args.bin, "watch", job, "--server", address, "--client", name],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
            pending.append((job, t0, watch))
        for job, t0, watch in pending:
            _, err = watch.communicate()
            latency = time.monotonic() - t0
            with lock:
                results.append((name, job, latency, watch.returncode))
                if watch.returncode != 0:
                    failures.append(f"{name}: job {job} watch exit {watch.returncode}: {err.strip()[-300:]}")

    start = time.monotonic()
    threads = [threading.Thread(target=client, args=(c,)) for c in range(args.clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.monotonic() - start

    # Nothing lost, nothing duplicated, nothing crossed between clients.
    listed = 0
    for c in range(args.clients):
        name = f"client{c}"
        out = subprocess.run([args.bin, "jobs", "--server", address, "--client", name, "--json"], capture_output=True,
                             text=True, env=env)
        jobs = json.loads(out.stdout).get("jobs", []) if out.returncode == 0 else []
        mine = {r[1] for r in results if r[0] == name}
        ids = [j["id"] for j in jobs]
        listed += len(ids)
        if sorted(ids) != sorted(mine) or len(ids) != per_client:
            failures.append(f"{name}: lists {len(ids)} jobs, submitted {per_client} ({len(mine)} watched)")
        for j in jobs:
            if j.get("state") != "SUCCEEDED":
                failures.append(f"{name}: job {j['id']} is {j.get('state')}: {j.get('error', '')}")
    peak_kib = rss_kib(server.pid, "VmHWM")
    sampling.set()
    sampler.join()
    for w in workers:
        w.terminate()
    for w in workers:
        w.wait(timeout=60)
    server.terminate()
    server.wait(timeout=60)
    integrity = subprocess.run(["sqlite3", os.path.join(work, "data", "state.db"), "PRAGMA integrity_check"],
                               capture_output=True, text=True).stdout.strip()
    if integrity != "ok":
        failures.append(f"integrity_check: {integrity}")
    peak_mib = peak_kib / 1024.0
    if args.max_server_mib and peak_mib > args.max_server_mib:
        failures.append(f"server peak RSS {peak_mib:.0f} MiB is above the bound {args.max_server_mib:.0f} MiB")
    # Memory after the first quarter against the end: bounded means no growth with the job count.
    quarter = [kib for t, kib in samples if t - start >= wall / 4]
    latencies = [r[2] for r in results if r[3] == 0]
    summary = {
        "jobs": args.jobs, "clients": args.clients, "workers": args.workers, "distinct_scenes": args.scenes,
        "succeeded": sum(1 for r in results if r[3] == 0), "listed": listed,
        "wall_seconds": round(wall, 2),
        "throughput_jobs_per_minute": round(60.0 * len(latencies) / wall, 2) if wall > 0 else 0,
        "latency_seconds": {
            "p50": round(percentile(latencies, 0.50), 2), "p90": round(percentile(latencies, 0.90), 2),
            "p99": round(percentile(latencies, 0.99), 2), "max": round(max(latencies, default=0), 2),
            "mean": round(statistics.mean(latencies), 2) if latencies else 0},
        "server_rss_mib": {
            "peak": round(peak_mib, 1),
            "after_first_quarter_min": round(min(quarter, default=0) / 1024.0, 1),
            "after_first_quarter_max": round(max(quarter, default=0) / 1024.0, 1),
            "end": round((samples[-1][1] if samples else 0) / 1024.0, 1)},
        "integrity_check": integrity,
        "failures": failures,
    }
    text = json.dumps(summary, indent=2)
    print(text)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            f.write(text + "\n")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
