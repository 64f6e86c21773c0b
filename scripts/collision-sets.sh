#!/usr/bin/env bash
# Two sinew-run programs side by side on the structure sets issue 14's collisions are measured on
# (docs/collisions.md, docs/accuracy.md): the demo's seeds, the subcortical subjects, the varied
# subjects, the cortical set, the five sets of "Five structure sets not tried before" and the three
# of "Three structure sets not tried before" (fifty-second session). Models,
# subjects and scenes are made once by BUILD_DIR's tools; every scene then runs with BEFORE and
# AFTER on each backend. Prints, per set and backend, the paired mean ASSD change (after minus
# before, over the regions wholly inside the field of view) and the overlap at the end (report.json's
# independent voxelisation), mean and largest.
# Usage: [SETS="demo subjects varied cortical frontal2 occtemp mixedR medial cerebellum2 parietal frontal3 mixedL"]
#        [BACKENDS="cuda cpu"] [JOBS=4] [THREADS=4] [GPU_JOBS=2] [BEFORE_FORCES=JSON] [AFTER_FORCES=JSON]
#        [BEFORE_SCENE=JSON] [AFTER_SCENE=JSON]
#        bash scripts/collision-sets.sh BUILD_DIR OUT_DIR BEFORE_RUN AFTER_RUN
# AFTER_FORCES (e.g. '{"collision": {"size_share": 4}}') is merged into the after runs' scenes'
# forces (and into each schedule level's overrides of those forces), BEFORE_FORCES into the before
# runs', to compare a parameter's values with one program as both BEFORE and AFTER
# (BEFORE_FORCES='{"collision": {"weight": 0}}': without collisions). AFTER_SCENE's keys (e.g.
# '{"collision_shares": [...]}') replace the after runs' scenes' top-level keys, BEFORE_SCENE's the
# before runs'.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 - "$@" <<'PY'
import json, os, statistics, subprocess, sys
from concurrent.futures import ThreadPoolExecutor

build, out, before, after = sys.argv[1:5]
sets = os.environ.get("SETS", "demo subjects varied cortical frontal2 occtemp mixedR medial cerebellum2 parietal frontal3 "
                      "mixedL").split()
backends = os.environ.get("BACKENDS", "cuda cpu").split()
jobs, threads, gpu_jobs = int(os.environ.get("JOBS", 4)), os.environ.get("THREADS", "4"), int(os.environ.get("GPU_JOBS", 2))
t = "/usr/share/mricron/templates"
app = f"{build}/app"
atlas = ["--atlas", f"{t}/aal.nii.gz", "--labels", f"{t}/aal.nii.txt", "--training", f"{t}/ch2better.nii.gz"]
both = lambda names: ",".join(f"{n}_{s}" for n in names for s in "LR")
structures = {  # None: sinew-build-model's default, the 12 subcortical structures
    "subjects": None, "varied": None,
    "cortical": both(["Insula", "Cuneus", "Lingual", "Precuneus", "Cingulum_Ant", "Temporal_Sup"]),
    "frontal2": both(["Frontal_Sup_Orb", "Frontal_Mid", "Frontal_Mid_Orb", "Frontal_Inf_Orb", "Supp_Motor_Area",
                      "Frontal_Sup_Medial"]),
    "occtemp": both(["Occipital_Sup", "Occipital_Mid", "Occipital_Inf", "Temporal_Mid", "Temporal_Inf",
                     "Temporal_Pole_Mid"]),
    "mixedR": ",".join(f"{n}_R" for n in ["Caudate", "Thalamus", "Insula", "Hippocampus", "ParaHippocampal", "Fusiform",
                                         "Heschl", "Putamen", "Amygdala", "Calcarine", "Temporal_Pole_Sup",
                                         "Cingulum_Post"]),
    "medial": both(["Cingulum_Mid", "Paracentral_Lobule", "Parietal_Inf", "Cingulum_Post", "Calcarine", "Cuneus"]),
    "cerebellum2": both(["Cerebelum_4_5", "Cerebelum_7b", "Cerebelum_9", "Cerebelum_Crus2"]) +
                   ",Vermis_3,Vermis_4_5,Vermis_6,Vermis_7",
    "parietal": both(["Precentral", "Postcentral", "Parietal_Sup", "SupraMarginal", "Angular", "Rolandic_Oper"]),
    "frontal3": both(["Frontal_Sup", "Frontal_Inf_Oper", "Frontal_Inf_Tri", "Rectus", "Olfactory", "Frontal_Med_Orb"]),
    "mixedL": ",".join(f"{n}_L" for n in ["Heschl", "Temporal_Sup", "Temporal_Pole_Sup", "Insula", "Putamen", "Pallidum",
                                         "Caudate", "Thalamus", "Hippocampus", "Amygdala", "ParaHippocampal", "Olfactory"]),
}
model_of = {s: ("sub" if structures.get(s) is None else s) for s in structures}
seeds = {"demo": list(range(1, 13)), "subjects": [int(f"77{i}") for i in range(12)], "varied": list(range(6001, 6031)),
         "cortical": [201, 202, 203, 204, 205, 6001, 6013], "frontal2": [6101, 6102, 6103, 6104],
         "occtemp": [6105, 6106, 6107, 6108], "mixedR": [6109, 6110, 6111, 6112], "medial": [6113, 6114, 6115, 6116],
         "cerebellum2": [6117, 6118, 6119, 6120], "parietal": [6121, 6122, 6123, 6124],
         "frontal3": [6125, 6126, 6127, 6128], "mixedL": [6129, 6130, 6131, 6132]}
varied = lambda seed: 6000 < seed < 7000  # scripts/varied_subjects.py's options; below: the default generator

def call(cmd, accept=(0,)):  # a run may stop cleanly (exit 4, counted); making its inputs may not
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode not in accept:
        sys.exit(f"{' '.join(cmd)} failed ({r.returncode}): {r.stderr[-2000:]}")
    return r.returncode

for d in ["models", "subjects", "scenes", "runs"]:
    os.makedirs(f"{out}/{d}", exist_ok=True)
# Models and subjects, side by side.
work = []
for s in {model_of[s] for s in sets if s != "demo"}:
    if not os.path.exists(f"{out}/models/{s}/model.json"):
        names = structures.get(s)
        work.append([f"{app}/sinew-build-model", *atlas, *(["--structures", names] if names else []), "-o", f"{out}/models/{s}", "-q"])
needed = sorted({seed for s in sets if s != "demo" for seed in seeds[s]})
opts = {}
if any(varied(x) for x in needed):
    lines = subprocess.run([sys.executable, "scripts/varied_subjects.py", "6001", "6133"], capture_output=True, text=True,
                           check=True).stdout.splitlines()
    opts = {int(l.split()[0]): l.split()[1:] for l in lines}
for seed in needed:
    if not os.path.exists(f"{out}/subjects/subject-{seed}/image.nii.gz"):
        work.append([f"{app}/sinew-make-subject", "--image", f"{t}/ch2.nii.gz", "--labels", f"{t}/aal.nii.gz", "--seed",
                     str(seed), *(opts[seed] if varied(seed) else []), "-o", f"{out}/subjects/subject-{seed}"])
list(ThreadPoolExecutor(jobs * 2).map(call, work))
scenes = []
work = []
for s in sets:
    for seed in seeds[s]:
        path = f"{out}/scenes/{s}-{seed}.json"
        scenes.append((s, seed, path))
        if os.path.exists(path):
            continue
        if s == "demo":
            work.append([f"{app}/sinew-make-scene", *atlas, "--target", f"{t}/ch2.nii.gz", "--seed", str(seed), "-o", path])
        else:
            subj = f"{out}/subjects/subject-{seed}"
            work.append([f"{app}/sinew-make-scene", "--model", f"{out}/models/{model_of[s]}", "--target",
                         f"{subj}/image.nii.gz", "--ground-truth", f"{subj}/labels.nii.gz", "-o", path])
list(ThreadPoolExecutor(jobs * 2).map(call, work))

forces = {w: json.loads(os.environ.get(f"{w.upper()}_FORCES", "{}")) for w in ("before", "after")}
tops = {w: json.loads(os.environ.get(f"{w.upper()}_SCENE", "{}")) for w in ("before", "after")}
changed = {w: bool(forces[w] or tops[w]) for w in forces}
for which, merged in forces.items():
    for s, seed, path in scenes if changed[which] else []:
        scene = json.load(open(path))
        scene.update(tops[which])
        for force, values in merged.items():
            scene["forces"].setdefault(force, {}).update(values)
            for level in scene.get("schedule", []):  # where a level sets the force, it sets these too
                if force in level.get("forces", {}):
                    level["forces"][force].update(values)
        json.dump(scene, open(f"{path[:-5]}-{which}.json", "w"), indent=1)

def run(args):
    (s, seed, path), backend, which = args
    dest = f"{out}/runs/{s}-{seed}-{backend}-{which}"
    if changed[which]:
        path = f"{path[:-5]}-{which}.json"
    rc = call([before if which == "before" else after, path, "-q", "--backend", backend, "-j", threads, "-o", dest], (0, 4))
    r = json.load(open(f"{dest}/report.json"))
    scored = [x["assd_mm"]["final"] for x in r["structures"]
              if x["assd_mm"].get("final") is not None and x.get("outside_image_share", 0.0) == 0.0]
    return (s, seed, backend, which), (statistics.mean(scored), r["overlaps"]["total_after_mm3"], rc)

results = {}
print("| set | backend | runs | mean ASSD before (mm) | paired mean ASSD, after - before (mm) | better / worse | overlap before -> after, mean (largest) mm^3 | exit 4 before / after |")
print("| --- | --- | ---: | ---: | ---: | --- | --- | --- |", flush=True)
pools = {b: ThreadPoolExecutor(gpu_jobs if b == "cuda" else jobs) for b in backends}
for s in sets:  # a set at a time, its rows printed as soon as its runs are done; the backends side by side
    futures = {(sc, b, w): pools[b].submit(run, (sc, b, w)) for sc in scenes if sc[0] == s for b in backends
               for w in ("before", "after")}
    results.update(f.result() for f in futures.values())
    for backend in backends:
        pairs = [(results[(s, x, backend, "before")], results[(s, x, backend, "after")]) for x in seeds[s]]
        d = [a[0] - b[0] for b, a in pairs]
        ob, oa = [b[1] for b, a in pairs], [a[1] for b, a in pairs]
        print(f"| {s} | {backend} | {len(pairs)} | {statistics.mean(b[0] for b, a in pairs):.4f} | {statistics.mean(d):+.4f} | "
              f"{sum(x < 0 for x in d)} / {sum(x > 0 for x in d)} | "
              f"{statistics.mean(ob):.2f} ({max(ob):.2f}) -> {statistics.mean(oa):.2f} ({max(oa):.2f}) | "
              f"{sum(b[2] == 4 for b, a in pairs)} / {sum(a[2] == 4 for b, a in pairs)} |", flush=True)
    json.dump({"|".join(map(str, k)): v for k, v in results.items()}, open(f"{out}/results.json", "w"))
PY
