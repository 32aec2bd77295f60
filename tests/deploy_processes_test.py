#!/usr/bin/env python3
"""deploy/ as processes (issue #8): a `mvbrdf server` and two `mvbrdf worker`s started with the very arguments,
config and environment of the Kubernetes manifests (then of the compose file, then of the systemd units with
deploy/systemd/worker.env), read from the files, with in-container
paths and the service host replaced by local ones and tokens and TLS made here by deploy/make-secrets (openssl).
A client submits a tiny synthetic job with a client token over TLS and watches it succeed; the probes' own health
command must say SERVING.

Usage: deploy_processes_test.py MVBRDF_BINARY WORK_DIR"""

import json
import os
import re
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import deploy_lib as d  # noqa: E402

binary, work = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
check = d.check
secrets = d.make_secrets(os.path.join(work, "secrets"))
scene_dir = os.path.join(work, "scene")
r = subprocess.run([binary, "synth", "--cameras", "2", "--frames", "3", "--width", "64", "--height", "48",
                    "--out", scene_dir], capture_output=True, text=True)
check("synth: a tiny scene (2 cameras, 3 frames, 64x48)", r.returncode == 0, r.stderr[-1000:])


def k8s_layout():
    """Server argv/config, worker argv/env and the probe commands of deploy/k8s, with the files each mount holds."""
    docs = d.k8s_documents()
    sts = d.k8s_find(docs, "StatefulSet", "mvbrdf-server")
    server = sts["spec"]["template"]["spec"]["containers"][0]
    worker = d.k8s_find(docs, "Deployment", "mvbrdf-worker")["spec"]["template"]["spec"]["containers"][0]
    config = d.k8s_server_config(docs)
    probes = [d.mvbrdf_argv(server[p]["exec"]["command"]) if "exec" in server[p] else ["grpc", server[p]["grpc"]]
              for p in ("readinessProbe", "livenessProbe") if p in server]
    # What the Secrets' keys are here (the Secret volume mounts of server.yaml and worker.yaml).
    files = {"/etc/mvbrdf/tls/ca.crt": "ca.crt", "/etc/mvbrdf/tls/tls.crt": "tls.crt",
             "/etc/mvbrdf/tls/tls.key": "tls.key", "/etc/mvbrdf/tokens/tokens": "tokens",
             "/etc/mvbrdf/token/token": "worker.token"}
    env = {e["name"]: e["value"] for e in worker.get("env", [])}
    return dict(server_argv=list(server["args"]), config_path=d.flag_value(server["args"], "--config"), config=config,
                worker_argv=list(worker["args"]), worker_env=env, probes=probes, files=files,
                service_host="mvbrdf-server")


def compose_layout():
    comp = d.compose()
    server, worker = comp["services"]["server"], comp["services"]["worker"]
    config = json.load(open(os.path.join(d.DEPLOY, "compose", "server.json")))
    config_target = server["configs"][0]["target"]
    files = {f"/run/secrets/{name}": os.path.basename(spec["file"]) for name, spec in comp["secrets"].items()}
    return dict(server_argv=list(server["command"]), config_path=config_target, config=config,
                worker_argv=list(worker["command"]), worker_env={k: str(v) for k, v in
                                                                 worker.get("environment", {}).items()},
                probes=[d.mvbrdf_argv(server["healthcheck"]["test"][1:])], files=files, service_host="mvbrdf-server")


def systemd_layout():
    server_unit = d.systemd_unit("mvbrdf-server.service")
    worker_unit = d.systemd_unit("mvbrdf-worker@.service")
    server_argv = d.mvbrdf_argv(d.systemd_exec_start(server_unit))
    env_file = os.path.join(d.SYSTEMD, "worker.env")  # what /etc/mvbrdf/worker.env holds
    worker_argv = lambda i: d.mvbrdf_argv(d.systemd_exec_start(worker_unit, f"w{i}", env_file))  # noqa: E731
    config = json.load(open(os.path.join(d.SYSTEMD, "server.json")))
    files = {f"/etc/mvbrdf/secrets/{f}": f for f in ("ca.crt", "tls.crt", "tls.key", "tokens", "worker.token")}
    server_host = d.host_of(worker_argv(0)[worker_argv(0).index("--server") + 1])
    return dict(server_argv=server_argv, config_path=d.flag_value(server_argv, "--config"), config=config,
                worker_argv=worker_argv, worker_env={}, probes=[], files=files, service_host=server_host)


def run(name, layout):
    root = os.path.join(work, name)
    os.makedirs(os.path.join(root, "files"))
    # Every file a mount would hold, copied from make-secrets' output under a local path.
    mapping = {}
    for target, source in layout["files"].items():
        local = os.path.join(root, "files", target.strip("/").replace("/", "_"))
        shutil.copy(os.path.join(secrets, source), local)
        os.chmod(local, 0o600)
        mapping[target] = local
    config = dict(layout["config"])
    mapping[config["dataDir"]] = os.path.join(root, "data")
    config = {k: d.substitute_paths(v, mapping) for k, v in config.items()}
    listen = config["listenAddress"]
    config["listenAddress"] = "127.0.0.1:0"  # a free port: the manifests' 50051 may be taken here
    config_local = os.path.join(root, "server.json")
    json.dump(config, open(config_local, "w"), indent=2)
    mapping[layout["config_path"]] = config_local
    server_argv = [binary] + d.substitute_paths(layout["server_argv"], mapping)
    check(f"{name}: the server's arguments are the manifest's with local paths",
          server_argv[1] == "server" and d.flag_value(server_argv, "--config") == config_local and
          all(a.startswith(root) for a in server_argv[2:] if a.startswith("/")), str(server_argv))
    server = d.Process(server_argv, os.path.join(root, "server.log"))
    processes = [server]
    try:
        m = server.wait_for(r"listening on (\S+)", 30)
        if not check(f"{name}: the server starts with the manifest's config ({listen} → 127.0.0.1:0)", m,
                     server.text()):
            return
        address = m.group(1)
        check(f"{name}: the server runs with TLS and tokens", "TLS, tokens required" in server.text(), server.text())
        port = d.port_of(listen)

        for probe in layout["probes"]:
            if probe[0] == "grpc":
                check(f"{name}: native gRPC probe on the listen port", probe[1]["port"] == port)
                probe = ["health", "--server", f"127.0.0.1:{port}"]
            argv = [binary] + [a.replace(f":{port}", f":{d.port_of(address)}") for a in
                               d.substitute_paths(probe, mapping)]
            t0 = time.time()
            r = subprocess.run(argv, capture_output=True, text=True, timeout=30)
            check(f"{name}: the probe's command says SERVING ({time.time() - t0:.2f} s)",
                  r.returncode == 0 and r.stdout.strip() == "SERVING", " ".join(argv) + ": " + r.stdout + r.stderr)

        if name == "k8s":
            ca = os.path.join(secrets, "ca.crt")
            for what, argv, codes in (
                    ("without TLS against the TLS port: not SERVING", ["--server", address], (4,)),
                    ("a closed port: unreachable", ["--server", "127.0.0.1:1", "--tls-ca", ca], (4,)),
                    ("an unknown --service: the server does not know it",
                     ["--server", address, "--tls-ca", ca, "--tls-server-name", "mvbrdf-server", "--service", "x.Y"],
                     (3,)),
                    ("no --server: usage", [], (2,))):
                r = subprocess.run([binary, "health", "--timeout", "3"] + argv, capture_output=True, text=True,
                                   timeout=30)
                check(f"mvbrdf health, {what} (exit {codes[0]})", r.returncode in codes and r.stdout.strip() != "SERVING", f"exit {r.returncode}: {r.stderr}")

        for i in range(2):
            mapping_i = dict(mapping)
            mapping_i["/var/cache/mvbrdf"] = os.path.join(root, f"cache{i}")  # each pod has its own emptyDir
            manifest_argv = layout["worker_argv"](i) if callable(layout["worker_argv"]) else layout["worker_argv"]
            argv = [binary] + [a.replace(f"{layout['service_host']}:{port}", address) for a in
                               d.substitute_paths(manifest_argv, mapping_i)]
            check(f"{name}: worker {i}: every path is local, the server is this one",
                  all(a.startswith(root) for a in argv[1:] if a.startswith("/")) and address in argv, str(argv))
            env = dict(os.environ)
            env.update(layout["worker_env"])
            env["XDG_CACHE_HOME"] = os.path.join(root, f"xdg{i}")
            env.pop("MVBRDF_TOKEN", None)
            processes.append(d.Process(argv, os.path.join(root, f"worker{i}.log"), env=env))
        for i, w in enumerate(processes[1:]):
            time.sleep(0.2)
            check(f"{name}: worker {i} (manifest arguments) is running", w.proc.poll() is None, w.text())

        t0 = time.time()
        env = dict(os.environ)
        env.pop("MVBRDF_TOKEN", None)
        token_file = os.path.join(root, "client.token")
        shutil.copy(os.path.join(secrets, "client.token"), token_file)
        r = subprocess.run([binary, "submit", os.path.join(scene_dir, "scene.json"), "--server", address,
                            "--tls-ca", os.path.join(secrets, "ca.crt"), "--tls-server-name", "mvbrdf-server",
                            "--token-file", token_file, "--atlas", "64", "--no-powell", "--watch"],
                           capture_output=True, text=True, timeout=240, env=env)
        seconds = time.time() - t0
        check(f"{name}: submit --watch with a client token over TLS succeeds ({seconds:.1f} s)", r.returncode == 0,
              f"exit {r.returncode}\n{r.stdout[-1500:]}\n{r.stderr[-1500:]}\nserver:\n{server.text()[-1500:]}\n" +
              "\n".join(p.text()[-800:] for p in processes[1:]))
        logs = [w.text() for w in processes[1:]]
        check(f"{name}: both workers registered (TLS, worker token) and they leased the job's tasks",
              all("registered as" in t for t in logs) and any(re.search(r"leased \w+", t) for t in logs),
              "\n".join(t[-500:] for t in logs))
    finally:
        codes = [p.stop(60) for p in reversed(processes)]
        check(f"{name}: server and workers stop cleanly on SIGTERM", all(c == 0 for c in codes), str(codes))


run("k8s", k8s_layout())
run("compose", compose_layout())
run("systemd", systemd_layout())
d.finish()
