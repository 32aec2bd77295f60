#!/usr/bin/env python3
"""models_table.py MODELS_JSON: the table of scripts/bench-models (Markdown).

Per kind of material (from the MERL names), how often each model wins on
held-out lights and views, the median relative RMSE of each, and what `auto`
gives against the thesis's Phong; then one row per material. Also the rule
with a margin (switch from Phong only for a validation error >= 20 % lower),
which was chosen after seeing this table: shown, not evidence.
"""
import json
import statistics
import sys

KINDS = [
    ("metal", ("chrome", "steel", "alum", "brass", "nickel", "tungsten", "ss440", "hematite", "silver", "gold",
               "black-obsidian")),
    ("metallic paint", ("metallic-paint", "pearl-paint")),
    ("paint", ("paint",)),
    ("fabric", ("fabric", "felt", "nylon", "polyester", "velvet")),
    ("plastic, phenolic, resin", ("plastic", "phenolic", "acrylic", "resin", "polyurethane", "delrin", "teflon",
                                  "pvc", "polyethylene", "rubber")),
    ("wood", ("oak", "cherry", "walnut", "maple", "wood")),
    ("stone, ceramic", ("marble", "granite", "ceramic", "alumina")),
]


def kind(name):
    # "-metallic-paint" before "paint", metals last among the matches by order.
    for label, keys in KINDS:
        if label == "metal" and "paint" in name:
            continue
        if any(k in name for k in keys):
            return label
    return "other"


def main():
    d = json.load(open(sys.argv[1]))
    rows = []
    for m in d["materials"]:
        models = {x["model"]: x for x in m["models"]}
        phong = models["phong"]["heldOutRmse"]
        best_validation = min(models, key=lambda k: models[k]["validationRmse"])
        margin = best_validation
        if models[margin]["validationRmse"] > 0.8 * models["phong"]["validationRmse"]:
            margin = "phong"
        rows.append(dict(name=m["name"], kind=kind(m["name"]), winner=m["winner"], auto=m["auto"],
                         rel={k: v["relativeRmse"] for k, v in models.items()},
                         seconds={k: v["fitSeconds"] for k, v in models.items()},
                         auto_ratio=m["autoHeldOutRmse"] / phong if phong > 0 else 1.0,
                         margin_ratio=models[margin]["heldOutRmse"] / phong if phong > 0 else 1.0))
    names = ["phong", "blinn-phong", "ggx"]
    o = d["observations"]
    print("%d materials; %d training and %d held-out observations (%d lights, %d views)\n" %
          (len(rows), o["training"], o["heldOut"], o["lights"], o["views"]))
    print("| kind | materials | wins phong / blinn-phong / ggx | median relative RMSE phong / blinn-phong / ggx "
          "| auto / Phong RMSE, median (max) |")
    print("|---|---|---|---|---|")
    for label in [k for k, _ in KINDS] + ["other", "all"]:
        group = [r for r in rows if label == "all" or r["kind"] == label]
        if not group:
            continue
        wins = " / ".join(str(sum(r["winner"] == n for r in group)) for n in names)
        rel = " / ".join("%.3f" % statistics.median(r["rel"][n] for r in group) for n in names)
        ratios = [r["auto_ratio"] for r in group]
        print("| %s | %d | %s | %s | %.2f (%.2f) |" % (label, len(group), wins, rel, statistics.median(ratios),
                                                      max(ratios)))
    ratios = [r["auto_ratio"] for r in rows]
    margin = [r["margin_ratio"] for r in rows]
    print("\nauto / Phong held-out RMSE over all: median %.3f, max %.3f (%d of %d materials worse than Phong by more "
          "than 5 %%)" % (statistics.median(ratios), max(ratios), sum(x > 1.05 for x in ratios), len(ratios)))
    print("with a 20 %% validation margin before leaving Phong (chosen after seeing this table): median %.3f, "
          "max %.3f" % (statistics.median(margin), max(margin)))
    fit_seconds = {n: statistics.median(r["seconds"][n] for r in rows) for n in names}
    print("median fit time per material (3 channels): " +
          ", ".join("%s %.3f s" % (n, fit_seconds[n]) for n in names))
    print("\n| material | kind | winner | auto | relative RMSE phong | blinn-phong | ggx |")
    print("|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["kind"], r["name"])):
        print("| %s | %s | %s | %s | %.3f | %.3f | %.3f |" % (r["name"], r["kind"], r["winner"], r["auto"],
                                                            r["rel"]["phong"], r["rel"]["blinn-phong"],
                                                            r["rel"]["ggx"]))


if __name__ == "__main__":
    main()
