#!/usr/bin/env python3
"""sinew-make-subject options for new subjects that differ from the atlas in many ways at once.

Usage: python3 scripts/varied_subjects.py FIRST_SEED END_SEED
Prints one line per seed: the seed, then its options. Every option is drawn from the seed alone, so
a line is the same on every machine. docs/accuracy.md ("Thirty subjects with every option at once")
ran seeds 6001-6030:

  python3 scripts/varied_subjects.py 6001 6031 | while read seed opts; do
    sinew-make-subject --image $t/ch2.nii.gz --labels $t/aal.nii.gz --seed $seed $opts -o subject-$seed
  done
"""
import random
import sys


def options(seed):
    r = random.Random(seed * 7919)
    o = ["--warp-mm", "%.1f" % r.uniform(3, 8)]
    o += ["--max-rotation-deg", str(r.choice([6, 15, 30, 45, 60]))]
    o += ["--max-translation-mm", "%.0f" % r.uniform(4, 30)]
    lo = r.uniform(0.85, 0.97)
    o += ["--scale-min", "%.2f" % lo, "--scale-max", "%.2f" % (2 - lo + r.uniform(-0.03, 0.03))]
    o += ["--bias", "%.2f" % r.uniform(0.1, 0.6), "--contrast", "%.2f" % r.uniform(0.1, 0.5)]
    o += ["--noise", "%.3f" % r.uniform(0.01, 0.1)]
    spacing = r.choice([None, "1.5,1.5,1.5", "1,1,3", "0.8,0.8,2", "2,2,2", "1.2,1.2,1.2"])
    if spacing:
        o += ["--spacing"] + spacing.split(",")
    axes = r.choice([None, None, "PSL", "LAS", "SRA", "IPR", "ASR"])
    if axes:
        o += ["--axes", axes]
    fov = r.choice([None, None, "1,1,0.6", "0.8,0.8,0.8", "1,0.7,1", "0.9,1,0.75"])
    if fov:
        o += ["--fov"] + fov.split(",")
    tilt = r.choice([0, 0, 0, 15, 30])
    if tilt:
        o += ["--tilt-deg", str(tilt)]
    scale = r.choice([1, 1, 1, 0.01, 1000])
    if scale != 1:
        o += ["--intensity-scale", str(scale)]
    return o


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    for seed in range(int(sys.argv[1]), int(sys.argv[2])):
        print(seed, " ".join(options(seed)))
