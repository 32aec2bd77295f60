# readme_names_test.py MVBRDF WORKDIR [README]: every backquoted name in the `DIR/result.json` row of README.md's
# outputs table is a name result.json really has (issue #20: the README said `light_configurations`, `kd_rmse`
# where the JSON says `lightConfigurations`, `kdRmse`). A small synthetic run writes a real result.json; a name
# passes when it is a key (at any depth) or a string value (a flag such as `tiny`) of it. Proto3 JSON leaves out
# fields that are zero or empty in this run: such a name must then be the JSON name (lowerCamelCase) of a field
# of proto/mvbrdf/v1/run_report.proto, and is listed as "not in this run". Exit 1 naming every name that is neither.
import json, os, re, shutil, subprocess, sys

binary, work = sys.argv[1], sys.argv[2]
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
readme = sys.argv[3] if len(sys.argv) > 3 else os.path.join(root, "README.md")

row = [line for line in open(readme, encoding="utf-8") if line.startswith("| `DIR/result.json` |")]
assert len(row) == 1, "README.md: expected one outputs-table row for `DIR/result.json`, found %d" % len(row)
names = [n for n in re.findall(r"`([^`]+)`", row[0].split("|")[2])]
assert names, "no backquoted names in the result.json row"

shutil.rmtree(work, ignore_errors=True)  # a fresh run every time (outputs refuse a used --out)
os.makedirs(work, exist_ok=True)
env = dict(os.environ, LP_NUM_THREADS=os.environ.get("LP_NUM_THREADS", "2"))
def run(*args):
    p = subprocess.run([binary, *args], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if p.returncode != 0:
        sys.exit("mvbrdf %s: exit %d\n%s" % (args[0], p.returncode, p.stdout[-2000:]))
bundle, out = os.path.join(work, "bundle"), os.path.join(work, "run")
run("synth", "--preset", "actor", "--cameras", "4", "--frames", "6", "--width", "160", "--height", "120",
    "--exposure", "2", "--out", bundle)
scene = json.load(open(os.path.join(bundle, "scene.json")))
for key in ("materialSeeds", "segmentationPath", "segmentMaterials"):  # automatic k (clusters' flags)
    scene.pop(key, None)
json.dump(scene, open(os.path.join(bundle, "scene_auto.json"), "w"))
subprocess.run(["rm", "-rf", out])
run("run", os.path.join(bundle, "scene_auto.json"), "--out", out, "--direct", "--atlas", "128", "--no-powell",
    "--candidates", "C;NE,NW,SE,SW")
result = json.load(open(os.path.join(out, "result.json")))

keys, values = set(), set()
def walk(v):
    if isinstance(v, dict):
        for k, x in v.items():
            keys.add(k)
            walk(x)
    elif isinstance(v, list):
        for x in v:
            walk(x)
    elif isinstance(v, str):
        values.add(v)
walk(result)

proto = open(os.path.join(root, "proto", "mvbrdf", "v1", "run_report.proto"), encoding="utf-8").read()
proto = proto[:proto.index("message MaterialComparison")]  # RunReport and its rows, not evaluate's kdRmse etc.
def camel(n):
    p = n.split("_")
    return p[0] + "".join(x.capitalize() for x in p[1:])
proto_names = {camel(m) for m in re.findall(r"^\s*(?:repeated |optional )?[\w.]+ (\w+) = \d+;", proto, re.M)}

bad = []
for n in names:
    if n in keys or n in values:
        print("ok   %s" % n)
    elif n in proto_names:
        print("ok   %s (not in this run: zero or empty; a run_report.proto JSON name)" % n)
    else:
        bad.append(n)
        print("FAIL %s: neither in result.json nor a JSON name of run_report.proto" % n)
print("%d names, %d wrong" % (len(names), len(bad)))
sys.exit(1 if bad else 0)
