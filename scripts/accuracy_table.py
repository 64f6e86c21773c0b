"""Tables for docs/accuracy.md from the report.json of every subject a scripts/accuracy.sh run made.
Usage: python3 scripts/accuracy_table.py OUT_DIR BACKEND SEED..."""
import json
import sys

out, backend, seeds = sys.argv[1], sys.argv[2], sys.argv[3:]
reports = {s: json.load(open(f"{out}/subject-{s}/run-{backend}/report.json")) for s in seeds}
first = next(iter(reports.values()))
names = [x["name"] for x in first["structures"]]
stages = [st["name"] for st in first["stages"]]


def mean(v):
    v = [x for x in v if x is not None]
    return sum(v) / len(v) if v else float("nan")


print(f"### Mean ASSD (mm) per stage, backend {backend} ({first['device']})\n")
print("| subject | " + " | ".join(stages) + " | Dice | worst structure (mm) | worse than after initialisation | total s |")
print("|---" * (len(stages) + 5) + "|")
for s, r in reports.items():
    row = [f"{st['mean_assd_mm']:.3f}" for st in r["stages"]]
    fin = [x["assd_mm"]["final"] for x in r["structures"]]
    ini = [x["assd_mm"]["initial"] for x in r["structures"]]
    worst = max(range(len(fin)), key=lambda i: fin[i])
    worse = sum(1 for a, b in zip(ini, fin) if b > a)
    dice = mean([x["dice"] for x in r["structures"]])
    print(f"| {s} | " + " | ".join(row) + f" | {dice:.3f} | {fin[worst]:.3f} ({names[worst]}) | {worse} | {r['total_seconds']:.1f} |")

print(f"\n### Per structure, mean over subjects {', '.join(seeds)} ({backend})\n")
print("| structure | ASSD model | after initialisation | final | HD95 final | Dice model | Dice final |")
print("|---|---|---|---|---|---|---|")
for i, n in enumerate(names):
    col = lambda f: mean([f(r["structures"][i]) for r in reports.values()])
    print(f"| {n} | {col(lambda x: x['assd_mm']['model']):.3f} | {col(lambda x: x['assd_mm']['initial']):.3f} | "
          f"{col(lambda x: x['assd_mm']['final']):.3f} | {col(lambda x: x['hd95_mm']):.3f} | "
          f"{col(lambda x: x['dice_model']):.3f} | {col(lambda x: x['dice']):.3f} |")
allf = [x["assd_mm"]["final"] for r in reports.values() for x in r["structures"]]
alld = [x["dice"] for r in reports.values() for x in r["structures"]]
print(f"\nOver all {len(allf)} structure segmentations: mean ASSD {mean(allf):.3f} mm, worst {max(allf):.3f} mm, "
      f"mean Dice {mean(alld):.3f}, lowest Dice {min(alld):.3f}.")
stage_seconds = {k: mean([r["stage_seconds"].get(k) for r in reports.values()]) for k in first["stage_seconds"]}
print("\nMean stage times (s): " + ", ".join(f"{k} {v:.2f}" for k, v in stage_seconds.items()) +
      f"; simulation {mean([r['simulation_seconds'] for r in reports.values()]):.2f}; "
      f"whole run {mean([r['total_seconds'] for r in reports.values()]):.2f}.")
