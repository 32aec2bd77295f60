#!/usr/bin/env python3
"""deploy/ against the code (issue #8): the compose file, the Kubernetes manifests and the systemd units parse; every
flag they pass exists in `mvbrdf SUBCOMMAND --help`; ports agree (Service, containerPort, probes, compose, the
server's listen address, EXPOSE); probes ask the gRPC health service; image names and Dockerfile targets agree;
the Dockerfile's runtime packages exist in Debian's package lists and provide every library `ldd mvbrdf` names;
every server config JSON has only ServerConfig fields and `mvbrdf server --config` starts on it.

Usage: deploy_manifests_test.py MVBRDF_BINARY WORK_DIR"""

import json
import os
import re
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import deploy_lib as d  # noqa: E402

binary, work = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)

flags = {sub: d.help_flags(binary, sub) for sub in ("server", "worker", "health")}
docs = d.k8s_documents()
comp = d.compose()
check = d.check

# ---- every command in deploy/ ---------------------------------------------------------------------------------
commands = []  # (where, mvbrdf argv)
pod_specs = []  # (where, kind, pod spec)
for fname, doc in docs:
    if doc["kind"] in ("Deployment", "StatefulSet"):
        spec = doc["spec"]["template"]["spec"]
        pod_specs.append((f"{fname}:{doc['metadata']['name']}", doc["kind"], spec))
        for c in spec["containers"]:
            commands.append((f"{fname}:{c['name']} args", list(c.get("command", [])) + list(c["args"])))
            for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
                if "exec" in c.get(probe, {}):
                    commands.append((f"{fname}:{c['name']} {probe}", d.mvbrdf_argv(c[probe]["exec"]["command"])))
for name, svc in comp["services"].items():
    commands.append((f"compose {name} command", list(svc["command"])))
    if "healthcheck" in svc:
        test = svc["healthcheck"]["test"]
        check(f"compose {name}: healthcheck is CMD form", test[0] == "CMD", str(test))
        commands.append((f"compose {name} healthcheck", d.mvbrdf_argv(test[1:])))
units = {u: d.systemd_unit(u) for u in ("mvbrdf-server.service", "mvbrdf-worker@.service")}
for u, unit in units.items():
    commands.append((f"systemd {u} ExecStart", d.mvbrdf_argv(d.systemd_exec_start(unit))))

for where, argv in commands:
    sub = argv[0]
    check(f"{where}: subcommand '{sub}' is server, worker or health", sub in flags, str(argv))
    if sub not in flags:
        continue
    unknown = [a.split("=")[0] for a in argv[1:] if a.startswith("--") and a.split("=")[0] not in flags[sub]]
    check(f"{where}: every flag is in `mvbrdf {sub} --help`", not unknown, f"unknown: {unknown}")

# ---- ports -------------------------------------------------------------------------------------------------------
config_k8s = d.k8s_server_config(docs)
port = d.port_of(config_k8s["listenAddress"])
service = d.k8s_find(docs, "Service", "mvbrdf-server")
sts = d.k8s_find(docs, "StatefulSet", "mvbrdf-server")
server_container = sts["spec"]["template"]["spec"]["containers"][0]
container_ports = {p["name"]: p["containerPort"] for p in server_container["ports"]}
check("k8s: the server container's port is the config's listen port", list(container_ports.values()) == [port],
      f"{container_ports} vs {port}")
for p in service["spec"]["ports"]:
    target = p["targetPort"]
    target = container_ports.get(target) if isinstance(target, str) else target
    check(f"k8s Service port {p['name']}: targetPort is the container port", target == port, f"{target} vs {port}")
    check(f"k8s Service port {p['name']}: port is the listen port (workers use it)", p["port"] == port)
check("k8s Service selects the server pods",
      all(sts["spec"]["template"]["metadata"]["labels"].get(k) == v for k, v in service["spec"]["selector"].items()))
check("k8s: the StatefulSet's serviceName is the Service", sts["spec"]["serviceName"] == "mvbrdf-server")

probes = {p: server_container.get(p) for p in ("startupProbe", "readinessProbe", "livenessProbe")}
check("k8s server: readiness and liveness probes exist", probes["readinessProbe"] and probes["livenessProbe"])
tls_on = "tlsCertFile" in config_k8s
for name, probe in probes.items():
    if not probe:
        continue
    if "grpc" in probe:
        check(f"k8s server {name}: native gRPC probe on the listen port", probe["grpc"]["port"] == port)
        check(f"k8s server {name}: native gRPC probe only without TLS (it cannot speak TLS)", not tls_on)
    else:
        argv = d.mvbrdf_argv(probe["exec"]["command"])
        check(f"k8s server {name}: runs `mvbrdf health` (grpc.health.v1)", argv[0] == "health", str(argv))
        check(f"k8s server {name}: asks the listen port", d.port_of(d.flag_value(argv, "--server")) == port)
        check(f"k8s server {name}: speaks TLS when the server does",
              not tls_on or d.flag_value(argv, "--tls-ca") is not None)
        # Kubernetes' timeoutSeconds defaults to 1 s: the command's own --timeout must end first.
        check(f"k8s server {name}: the command's --timeout ends before the probe's timeoutSeconds",
              int(d.flag_value(argv, "--timeout") or 5) < probe.get("timeoutSeconds", 1))

for where, kind, spec in pod_specs:
    for c in spec["containers"]:
        argv = list(c["args"])
        if argv[0] == "worker":
            address = d.flag_value(argv, "--server")
            check(f"{where}: the worker's --server is the Service and its port",
                  d.host_of(address) == service["metadata"]["name"] and d.port_of(address) == port, address)

config_compose = json.load(open(os.path.join(d.DEPLOY, "compose", "server.json")))
cport = d.port_of(config_compose["listenAddress"])
srv = comp["services"]["server"]
check("compose: the server publishes its listen port", any(str(p).split(":")[-1] == str(cport) for p in srv["ports"]))
hc = d.mvbrdf_argv(srv["healthcheck"]["test"][1:])
check("compose: the healthcheck runs `mvbrdf health` on the listen port",
      hc[0] == "health" and d.port_of(d.flag_value(hc, "--server")) == cport)
check("compose: the healthcheck's --timeout ends before its timeout",
      int(d.flag_value(hc, "--timeout") or 5) < int(str(srv["healthcheck"].get("timeout", "30s")).rstrip("s")))
aliases = srv.get("networks", {}).get("default", {}).get("aliases", []) + ["server"]
for name, svc in comp["services"].items():
    if svc["command"][0] == "worker":
        address = d.flag_value(svc["command"], "--server")
        check(f"compose {name}: --server names the server service and its port",
              d.host_of(address) in aliases and d.port_of(address) == cport, address)
        check(f"compose {name}: waits for the server to be healthy",
              svc.get("depends_on", {}).get("server", {}).get("condition") == "service_healthy")
check("compose: the server's data is on a named volume",
      any(v.split(":")[0] in comp.get("volumes", {}) and v.split(":")[1] == config_compose["dataDir"]
          for v in srv["volumes"]))
check("compose: workers can be scaled (deploy.replicas, no container_name, no host port)",
      "replicas" in comp["services"]["worker"].get("deploy", {}) and "container_name" not in comp["services"]["worker"]
      and "ports" not in comp["services"]["worker"])

dockerfile = open(os.path.join(d.DEPLOY, "Dockerfile")).read()
expose = [int(p) for p in re.findall(r"^EXPOSE (\d+)", dockerfile, re.M)]
check("Dockerfile: EXPOSE is the listen port", expose == [port] and cport == port, f"{expose}")

systemd_config = json.load(open(os.path.join(d.SYSTEMD, "server.json")))
worker_env = dict(line.split("=", 1) for line in open(os.path.join(d.SYSTEMD, "worker.env"))
                  if "=" in line and not line.startswith("#"))
check("systemd: worker.env's MVBRDF_SERVER port is the server's listen port",
      d.port_of(worker_env["MVBRDF_SERVER"].strip()) == d.port_of(systemd_config["listenAddress"]))
server_exec = d.systemd_exec_start(units["mvbrdf-server.service"])
check("systemd: the server's --data is its StateDirectory",
      d.flag_value(server_exec, "--data") == "/var/lib/" + d.unit_values(units["mvbrdf-server.service"], "Service",
                                                                          "StateDirectory")[0])

# ---- images and targets --------------------------------------------------------------------------------------------
targets = set(re.findall(r"^FROM \S+ AS (\S+)", dockerfile, re.M))
check("Dockerfile: build, runtime and gpu stages", {"build", "runtime", "gpu"} <= targets, str(targets))
check("Dockerfile: ENTRYPOINT mvbrdf, a non-root USER, the data VOLUME",
      'ENTRYPOINT ["mvbrdf"]' in dockerfile and re.search(r"^USER 10001", dockerfile, re.M)
      and 'VOLUME ["/var/lib/mvbrdf"]' in dockerfile)
check("Dockerfile gpu: NVIDIA_DRIVER_CAPABILITIES=graphics,compute,utility",
      "NVIDIA_DRIVER_CAPABILITIES=graphics,compute,utility" in dockerfile)
image_of_target = {"runtime": "mvbrdf", "gpu": "mvbrdf-gpu"}
images = {}
for where, kind, spec in pod_specs:
    for c in spec["containers"]:
        images[where] = c["image"]
for name, svc in comp["services"].items():
    images[f"compose {name}"] = svc["image"]
    if "build" in svc:
        check(f"compose {name}: build target exists and matches the image name",
              svc["build"]["target"] in targets and svc["image"].split(":")[0] == image_of_target[svc["build"]["target"]])
for where, image in images.items():
    check(f"{where}: image is mvbrdf or mvbrdf-gpu", image.split(":")[0] in image_of_target.values(), image)
    gpu = "--egl" in str(images) and image.startswith("mvbrdf-gpu")
for where, kind, spec in pod_specs:
    for c in spec["containers"]:
        egl = d.flag_value(list(c["args"]), "--egl")
        limits = c.get("resources", {}).get("limits", {})
        if c["image"].startswith("mvbrdf-gpu"):
            check(f"{where}: GPU worker: --egl device, nvidia.com/gpu limit, runtimeClassName nvidia",
                  egl == "device" and "nvidia.com/gpu" in limits and spec.get("runtimeClassName") == "nvidia")
        elif c["args"][0] == "worker":
            check(f"{where}: CPU worker: --egl surfaceless or auto, no GPU", egl in ("surfaceless", "auto", None)
                  and "nvidia.com/gpu" not in limits)
kust = __import__("yaml").safe_load(open(os.path.join(d.K8S, "kustomization.yaml")))
check("kustomization: lists every manifest but worker-gpu.yaml",
      set(kust["resources"]) == {f for f in os.listdir(d.K8S) if f.endswith(".yaml")} - {"kustomization.yaml",
                                                                                          "worker-gpu.yaml"})
check("kustomization: its image entries name the images used",
      {i["name"] for i in kust["images"]} == {i.split(":")[0] for i in images.values()})

# ---- server and workers: the rest of the shape -------------------------------------------------------------------------
check("k8s: the StatefulSet has exactly 1 replica (one SQLite writer)", sts["spec"]["replicas"] == 1)
claims = {t["metadata"]["name"] for t in sts["spec"]["volumeClaimTemplates"]}
mounts = {m["name"]: m["mountPath"] for m in server_container["volumeMounts"]}
check("k8s: a PersistentVolumeClaim template is mounted at the config's dataDir",
      any(mounts.get(c) == config_k8s["dataDir"] for c in claims), f"{claims} {mounts}")
hpa = d.k8s_find(docs, "HorizontalPodAutoscaler", "mvbrdf-worker")
check("k8s: the HPA scales the worker Deployment on CPU",
      hpa["spec"]["scaleTargetRef"]["name"] == "mvbrdf-worker" and hpa["spec"]["metrics"][0]["resource"]["name"] == "cpu")
config_maps = {doc["metadata"]["name"] for _, doc in docs if doc["kind"] == "ConfigMap"}
secrets = {doc["metadata"]["name"]: doc for _, doc in docs if doc["kind"] == "Secret"}
for where, kind, spec in pod_specs:
    for v in spec.get("volumes", []):
        if "secret" in v:
            check(f"{where}: volume {v['name']} names a Secret of secret.yaml", v["secret"]["secretName"] in secrets)
        if "configMap" in v:
            check(f"{where}: volume {v['name']} names a ConfigMap", v["configMap"]["name"] in config_maps)
    for c in spec["containers"]:
        mounted = [m["mountPath"] for m in c["volumeMounts"]]
        files = [a for a in c["args"] + sum((p["exec"]["command"] for p in
                                             (c.get(k) for k in ("readinessProbe", "livenessProbe", "startupProbe"))
                                             if p and "exec" in p), []) if a.startswith("/etc/mvbrdf/")]
        if c["args"][0] == "server":
            files += [v for k, v in config_k8s.items() if isinstance(v, str) and v.startswith("/")]
        missing = [f for f in files if not any(f.startswith(m + "/") or f == m for m in mounted)]
        check(f"{where}: every file it names is on a mounted volume", not missing, str(missing))
pem = re.compile(r"-----BEGIN [A-Z ]+-----\s*\n\s*[A-Za-z0-9+/=]{40,}")
leaks = [f for root, _, fs in os.walk(d.DEPLOY) for f in fs if pem.search(open(os.path.join(root, f), errors="ignore")
                                                                            .read())]
check("deploy/: no real PEM keys or certificates committed", not leaks, str(leaks))
for name, doc in secrets.items():
    values = doc.get("stringData", {})
    check(f"k8s Secret {name}: placeholder data only",
          all("PLACEHOLDER" in v or re.fullmatch(r"(\s*\w+\s+\w+\s+sha256:(\d)\2{63}\s*)+", v) for v in values.values()))

# ---- systemd -------------------------------------------------------------------------------------------------------
for u, unit in units.items():
    service_keys = dict(unit["Service"])
    for key, value in (("NoNewPrivileges", "yes"), ("ProtectSystem", "strict"), ("PrivateTmp", "yes"),
                       ("Restart", "on-failure"), ("User", "mvbrdf")):
        check(f"systemd {u}: {key}={value}", service_keys.get(key) == value, str(service_keys.get(key)))
    check(f"systemd {u}: ReadWritePaths is set", "ReadWritePaths" in service_keys)
check("systemd server: StateDirectory=mvbrdf, config in /etc/mvbrdf",
      dict(units["mvbrdf-server.service"]["Service"]).get("StateDirectory") == "mvbrdf"
      and d.flag_value(server_exec, "--config").startswith("/etc/mvbrdf/"))
worker_exec = d.systemd_exec_start(units["mvbrdf-worker@.service"], "gpu7")
check("systemd worker@: the instance is the worker's --name", d.flag_value(worker_exec, "--name") == "gpu7")
if shutil.which("systemd-analyze"):
    unit_dir = os.path.join(work, "units")
    os.makedirs(unit_dir)
    for u in units:
        text = open(os.path.join(d.SYSTEMD, u)).read().replace("/usr/local/bin/mvbrdf", binary)
        open(os.path.join(unit_dir, u.replace("@.", "@w0.") if "@" in u else u), "w").write(text)
        if "@" in u:
            open(os.path.join(unit_dir, u), "w").write(text)
    r = subprocess.run(["systemd-analyze", "verify", "--man=no"] +
                       [os.path.join(unit_dir, u.replace("@.", "@w0.")) for u in units], capture_output=True, text=True)
    # Only the units' own problems count (not e.g. the host's other units).
    own = [l for l in r.stderr.splitlines() if "mvbrdf" in l]
    check("systemd-analyze verify: no complaint about the units", not own, "\n".join(own))
else:
    print("NOTE systemd-analyze is missing: the units are only parsed")

# ---- the Dockerfile's packages -------------------------------------------------------------------------------------------
block = re.search(r"# BEGIN runtime-packages[^\n]*\n(.*?)# END runtime-packages", dockerfile, re.S).group(1)
runtime_pkgs = re.split(r"[\s\\]+", block.split("--no-install-recommends", 1)[1].split("&&", 1)[0])
runtime_pkgs = [p for p in runtime_pkgs if p]
check("Dockerfile: the runtime list is read", len(runtime_pkgs) > 10, str(runtime_pkgs))
missing = [p for p in runtime_pkgs if subprocess.run(["apt-cache", "show", p], capture_output=True).returncode != 0]
check("Dockerfile: every runtime package exists in Debian's package lists (apt-cache show)", not missing, str(missing))
deps = subprocess.run(["apt-cache", "depends", "--recurse", "--no-recommends", "--no-suggests", "--no-conflicts",
                       "--no-breaks", "--no-replaces", "--no-enhances"] + runtime_pkgs,
                      capture_output=True, text=True).stdout
closure = set(re.findall(r"^(?:\s+(?:Pre)?Depends: <?|)([a-z0-9][a-z0-9.+-]*)", deps, re.M)) | set(runtime_pkgs)
closure = {p.split(":")[0] for p in closure}
ldd = subprocess.run(["ldd", binary], capture_output=True, text=True, check=True).stdout
# The image ships the Release binary (the build stage runs a Release build). The sanitizer build's binary links
# libasan and, with its own link flags, more OpenCV modules directly; its libraries say nothing about the image,
# so the two library checks below run against Release binaries only (scripts/test runs this test in Release only,
# label e2e; run by hand in the sanitizer build it skips them).
sanitized = re.search(r"^\s*lib(a|ub|t)san\.so", ldd, re.M) is not None
if sanitized:
    print("note: a sanitizer build's binary: the ldd checks against the Dockerfile run in the Release build only")
    ldd = ""
libs = sorted(set(re.findall(r"=> (/\S+)", ldd)))
# One dpkg -S for every path and its real path: "package[, package]: path" a line.
paths = sorted(set(libs) | {os.path.realpath(lib) for lib in libs})
owners = {}
for line in subprocess.run(["dpkg", "-S"] + paths, capture_output=True, text=True).stdout.splitlines():
    package, _, path = line.partition(": ")
    owners[path.strip()] = package.split(",")[0].split(":")[0].strip()
uncovered = []
for lib in libs:
    owner = owners.get(lib) or owners.get(os.path.realpath(lib))
    if owner is None or owner not in closure:
        uncovered.append(f"{lib} ({owner})")
if not sanitized:
    check(f"Dockerfile: the runtime packages provide all {len(libs)} libraries `ldd mvbrdf` names",
          len(libs) > 50 and not uncovered, "; ".join(uncovered))
needed = subprocess.run(["objdump", "-p", binary], capture_output=True, text=True).stdout if shutil.which(
    "objdump") and not sanitized else ""
direct = []
for so in re.findall(r"NEEDED\s+(\S+)", needed):
    path = re.search(rf"^\s*{re.escape(so)} => (\S+)", ldd, re.M)
    if path:
        owner = owners.get(path.group(1)) or owners.get(os.path.realpath(path.group(1)))
        if owner:
            direct.append(owner)
not_listed = sorted(set(direct) - set(runtime_pkgs) - {"libc6", "libgcc-s1", "libstdc++6"})
if not sanitized:
    check("Dockerfile: every directly linked library's package is listed by name", bool(direct) and not not_listed,
          str(not_listed))
for p in ("libegl-mesa0", "libgl1-mesa-dri", "libgbm1"):
    check(f"Dockerfile: {p} (loaded by EGL at run time, not by ldd) is in the runtime list", p in runtime_pkgs)
install_deps = open(os.path.join(d.ROOT, "scripts", "install-deps")).read()
build_block = re.search(r"AS build\nRUN apt-get update.*?--no-install-recommends(.*?)&& rm", dockerfile, re.S).group(1)
build_pkgs = [p for p in re.split(r"[\s\\]+", build_block) if p]
extra = [p for p in build_pkgs if not re.search(rf"(^|\s){re.escape(p)}(\s|$)", install_deps) and p != "ca-certificates"]
check("Dockerfile: the build stage's packages are scripts/install-deps packages", not extra, str(extra))

# ---- the server configs against ServerConfig and the binary ---------------------------------------------------------------
proto = open(os.path.join(d.ROOT, "proto", "mvbrdf", "v1", "server_config.proto")).read()
fields = re.findall(r"^\s*(?:optional\s+|repeated\s+)?\w+\s+(\w+)\s*=\s*\d+;", proto, re.M)
camel = {re.sub(r"_(\w)", lambda m: m.group(1).upper(), f) for f in fields} | set(fields)
secrets_dir = d.make_secrets(os.path.join(work, "secrets"))
for where, config, mapping in (
        ("k8s ConfigMap", config_k8s, {"/etc/mvbrdf/tls/tls.crt": f"{secrets_dir}/tls.crt",
                                       "/etc/mvbrdf/tls/tls.key": f"{secrets_dir}/tls.key",
                                       "/etc/mvbrdf/tokens/tokens": f"{secrets_dir}/tokens"}),
        ("compose server.json", config_compose, {"/run/secrets/mvbrdf-tls-crt": f"{secrets_dir}/tls.crt",
                                                 "/run/secrets/mvbrdf-tls-key": f"{secrets_dir}/tls.key",
                                                 "/run/secrets/mvbrdf-tokens": f"{secrets_dir}/tokens"}),
        ("systemd server.json", systemd_config, {"/etc/mvbrdf/secrets": secrets_dir})):
    unknown = sorted(set(config) - camel)
    check(f"{where}: every key is a ServerConfig field", not unknown, str(unknown))
    slug = where.split()[0]
    mapping[config["dataDir"]] = os.path.join(work, f"data-{slug}")
    local = {k: d.substitute_paths(v, mapping) for k, v in config.items()}
    local["listenAddress"] = "127.0.0.1:0"
    path = os.path.join(work, f"{slug}-server.json")
    json.dump(local, open(path, "w"), indent=2)
    server = d.Process([binary, "server", "--config", path], os.path.join(work, f"{slug}-server.log"))
    m = server.wait_for(r"listening on (\S+)", 20)
    if check(f"{where}: `mvbrdf server --config` starts on it (port 0, a temporary data dir)", m, server.text()):
        r = subprocess.run([binary, "health", "--server", m.group(1), "--tls-ca", f"{secrets_dir}/ca.crt",
                            "--tls-server-name", "mvbrdf-server"], capture_output=True, text=True, timeout=30)
        check(f"{where}: `mvbrdf health` over TLS says SERVING", r.returncode == 0 and "SERVING" in r.stdout,
              r.stdout + r.stderr)
        check(f"{where}: the server says TLS and tokens", "TLS, tokens required" in server.text(), server.text())
    rc = server.stop()
    check(f"{where}: the server stops cleanly on SIGTERM", rc == 0, f"exit {rc}")

# ---- kubectl, when it is here: kustomize renders offline ----------------------------------------------------------------
if shutil.which("kubectl"):
    r = subprocess.run(["kubectl", "kustomize", d.K8S], capture_output=True, text=True, timeout=60)
    rendered = list(__import__("yaml").safe_load_all(r.stdout)) if r.returncode == 0 else []
    check("kubectl kustomize deploy/k8s renders every resource in namespace mvbrdf",
          r.returncode == 0 and len(rendered) == sum(1 for f, _ in docs if f != "worker-gpu.yaml")
          and all(x["metadata"].get("namespace") == "mvbrdf" for x in rendered if x["kind"] != "Namespace"),
          r.stderr[-500:])
else:
    print("NOTE kubectl is missing: the `kubectl kustomize` render check is skipped (the rest ran)")

d.finish()
