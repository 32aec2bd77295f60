#!/usr/bin/env bash
# Issue #20 items 5 and 6 (report and console): against the truth of a small
# synthetic actor without material seeds (automatic k):
# - every stage of result.json has its peak memory, in a service and a direct
#   run (the service's gather stage had none: "gather_samples 0 MiB");
# - automatic k's clusters of a few outlier texels are flagged "tiny" (console,
#   result.json, report) and merged, and the run succeeds (it failed naming a
#   2-texel cluster without data); cluster accuracy against the truth;
# - the relit sequence of the report shows the model lit in every frame (half
#   were black: the light circled behind the model);
# - the help names the glossary, the report carries its tooltips.
# Usage: cli_outputs_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
here=$(dirname "$0")
rm -rf "$work"
mkdir -p "$work"
source "$here/lib.sh"

"$bin" synth --cameras 4 --frames 6 --width 160 --height 120 --out "$work/s" >/dev/null || exit 1
python3 - "$work/s/scene.json" "$work/s/scene_auto.json" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
for key in ("materialSeeds", "segmentationPath", "segmentMaterials"):
    d.pop(key, None)
json.dump(d, open(sys.argv[2], "w"), indent=1)
EOF
# json FILE EXPR: prints EXPR of the JSON document `d` in FILE.
json() { python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"; }

check service_run 0 "tiny" -- "$bin" run "$work/s/scene_auto.json" --out "$work/service" --atlas 128 \
  --candidates "C;NE,NW,SE,SW" --no-powell --report
check direct_run 0 "tiny" -- "$bin" run "$work/s/scene_auto.json" --out "$work/direct" --atlas 128 \
  --config NE,NW,SE,SW --no-powell --direct

for run in service direct; do
  r=$work/$run/result.json
  expect "${run}_every_stage_has_peak_memory" \
    test "$(json "$r" 'all(int(s.get("peakRssBytes", 0)) > 0 for s in d["stages"]) and len(d["stages"]) >= 5')" = True
  expect "${run}_gather_stage_present" test "$(json "$r" 'any(s["name"].startswith("gather") for s in d["stages"])')" = True
  expect "${run}_tiny_cluster_flagged_and_empty" \
    test "$(json "$r" 'any("tiny" in c.get("flags", []) and int(c.get("texels", 0)) == 0 for c in d["clusters"])')" = True
  expect "${run}_tiny_cluster_has_no_fit" \
    test "$(json "$r" '{c["name"] for c in d["clusters"] if "tiny" in c.get("flags", [])} & {s["cluster"] for s in d["solvers"]}')" = "set()"
  expect "${run}_warning_names_the_tiny_cluster" \
    test "$(json "$r" 'any("too few texels for a material" in w for w in d.get("warnings", []))')" = True
  # Against the truth: every seen texel is in a real cluster, and the clusters
  # agree with the true materials at least as well as one cluster for all.
  "$bin" evaluate "$work/$run" --truth "$work/s" > "$work/$run/eval.json"
  echo "$run: clusterAccuracy $(json "$work/$run/eval.json" 'd["clusterAccuracy"]'), kdRmse $(json "$work/$run/eval.json" 'd["kdRmse"]')"
  expect "${run}_cluster_accuracy" test "$(json "$work/$run/eval.json" 'd["clusterAccuracy"] >= 0.7')" = True
  expect "${run}_kd_rmse" test "$(json "$work/$run/eval.json" 'd["kdRmse"] < 0.05')" = True
done

check relit_lit_in_every_frame 0 "frames 12" -- python3 "$here/report_relit_check.py" "$work/service/report.html" 0.25
check report_tooltip_e_d 0 'title="E_d (thesis Eq. 6.8)' -- cat "$work/service/report.html"
check report_clusters_table_marks_tiny 0 '<td>tiny</td>' -- cat "$work/service/report.html"
check help_names_glossary 0 "docs/glossary.md" -- "$bin" help
check run_help_names_glossary 0 "terms: docs/glossary.md" -- "$bin" run --help
summary
