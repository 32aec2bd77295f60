"""What tests/deploy_manifests_test.py and tests/deploy_processes_test.py share: reading deploy/ (the compose file,
the Kubernetes manifests, the systemd units) and running the mvbrdf binary with the arguments found there."""

import json
import os
import re
import shlex
import signal
import subprocess
import sys
import time

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEPLOY = os.path.join(ROOT, "deploy")
K8S = os.path.join(DEPLOY, "k8s")
SYSTEMD = os.path.join(DEPLOY, "systemd")

failures = []


def check(name, ok, detail=""):
    """Records one check; prints PASS/FAIL with what was wrong."""
    if ok:
        print(f"PASS {name}")
    else:
        print(f"FAIL {name}" + (f": {detail}" if detail else ""))
        failures.append(name)
    return ok


def finish():
    if failures:
        print(f"{len(failures)} check(s) failed: " + "; ".join(failures))
        sys.exit(1)
    print("all checks passed")


def k8s_documents():
    """Every document of every deploy/k8s/*.yaml but the kustomization, as (file name, dict)."""
    docs = []
    for name in sorted(os.listdir(K8S)):
        if not name.endswith(".yaml") or name == "kustomization.yaml":
            continue
        with open(os.path.join(K8S, name)) as f:
            for doc in yaml.safe_load_all(f):
                if doc:
                    docs.append((name, doc))
    return docs


def k8s_find(docs, kind, name):
    for _, doc in docs:
        if doc["kind"] == kind and doc["metadata"]["name"] == name:
            return doc
    raise KeyError(f"{kind}/{name} not in deploy/k8s")


def compose():
    with open(os.path.join(DEPLOY, "compose.yaml")) as f:
        return yaml.safe_load(f)


def k8s_server_config(docs):
    """The server's JSON config from the ConfigMap."""
    return json.loads(k8s_find(docs, "ConfigMap", "mvbrdf-server-config")["data"]["server.json"])


def systemd_unit(name):
    """A unit file as {section: [(key, value), ...]} with continuation lines joined."""
    sections, section = {}, None
    with open(os.path.join(SYSTEMD, name)) as f:
        text = f.read().replace("\\\n", " ")
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith(("#", ";")):
            continue
        if line.startswith("["):
            section = line.strip("[]")
            sections.setdefault(section, [])
            continue
        key, _, value = line.partition("=")
        sections[section].append((key.strip(), value.strip()))
    return sections


def unit_values(unit, section, key):
    return [v for k, v in unit.get(section, []) if k == key]


def systemd_exec_start(unit, instance="w0", environment_file=None):
    """ExecStart as argv, with ${VAR} from Environment= (then from `environment_file`, as EnvironmentFile= does)
    and %i substituted."""
    env = {}
    for value in unit_values(unit, "Service", "Environment"):
        for item in shlex.split(value):
            k, _, v = item.partition("=")
            env[k] = v
    if environment_file:
        for line in open(environment_file):
            line = line.strip()
            if line and not line.startswith("#") and "=" in line:
                k, _, v = line.partition("=")
                env[k.strip()] = v.strip()
    command = unit_values(unit, "Service", "ExecStart")[0].replace("%i", instance)
    command = re.sub(r"\$\{(\w+)\}", lambda m: env.get(m.group(1), m.group(0)), command)
    return shlex.split(command)


def help_flags(binary, subcommand):
    """The flags `mvbrdf SUBCOMMAND --help` lists."""
    out = subprocess.run([binary, subcommand, "--help"], capture_output=True, text=True, check=True).stdout
    return set(re.findall(r"^  (--[a-z0-9-]+)", out, re.M))


def mvbrdf_argv(command):
    """The mvbrdf arguments of a container command or exec probe: drops a leading 'mvbrdf' or its path."""
    if command and os.path.basename(command[0]) == "mvbrdf":
        return list(command[1:])
    return list(command)


def flag_value(argv, flag):
    for i, a in enumerate(argv):
        if a == flag and i + 1 < len(argv):
            return argv[i + 1]
        if a.startswith(flag + "="):
            return a.split("=", 1)[1]
    return None


def port_of(address):
    return int(address.rsplit(":", 1)[1])


def host_of(address):
    return address.rsplit(":", 1)[0]


def make_secrets(out_dir):
    """deploy/make-secrets into out_dir (openssl: CA, server certificate, tokens)."""
    subprocess.run([os.path.join(DEPLOY, "make-secrets"), out_dir, "mvbrdf-server", "mvbrdf-server.mvbrdf.svc"],
                   check=True, capture_output=True)
    return out_dir


class Process:
    """A child process with its output in a log file; stopped with SIGTERM (then SIGKILL) by its own pid."""

    def __init__(self, argv, log_path, env=None):
        self.argv = argv
        self.log_path = log_path
        self.log = open(log_path, "w")
        self.proc = subprocess.Popen(argv, stdout=self.log, stderr=subprocess.STDOUT, env=env)

    def text(self):
        with open(self.log_path) as f:
            return f.read()

    def wait_for(self, pattern, seconds):
        deadline = time.time() + seconds
        while time.time() < deadline:
            m = re.search(pattern, self.text())
            if m:
                return m
            if self.proc.poll() is not None:
                return re.search(pattern, self.text())
            time.sleep(0.1)
        return None

    def stop(self, seconds=30):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(seconds)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
        return self.proc.returncode


def substitute_paths(value, mapping):
    """Replaces in-container paths by local ones (longest prefix first), in a string or a list of strings."""
    if isinstance(value, list):
        return [substitute_paths(v, mapping) for v in value]
    if not isinstance(value, str):
        return value
    for old in sorted(mapping, key=len, reverse=True):
        if value == old or value.startswith(old + "/"):
            return mapping[old] + value[len(old):]
    return value
