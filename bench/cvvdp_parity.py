#!/usr/bin/env python3
"""ColorVideoVDP in blurlab against the authors' `cvvdp` Python package (PyTorch), on the
clips and references a `blurlab predict` run cached in a stimulus set.

Not part of CI (it needs PyTorch): run once, in an environment with `pip install cvvdp`:

    python bench/cvvdp_parity.py SET [SCORES.json]

For each sequence in the set's score cache (`SET/observer/scores-*.json`, the first one
unless named), it reads the same 8-bit frames blurlab judged (the clip of the sequence's
PNGs and the cached reference frames), builds the same display (pixels per degree, peak
luminance, contrast, ambient light, reflectivity 0.005, sRGB), holds each test frame for
the reference's sub-frames as blurlab does, runs `pycvvdp.cvvdp.predict` on the CPU and
prints both JODs per eye and the largest difference as JSON.
"""

import glob
import hashlib
import json
import os
import sys

import numpy as np
import torch
from PIL import Image

import pycvvdp


def read_rgb(path):
    return np.asarray(Image.open(path).convert("RGB"))


def main():
    set_dir = sys.argv[1]
    caches = sorted(glob.glob(os.path.join(set_dir, "observer", "scores-*.json")))
    cache_path = sys.argv[2] if len(sys.argv) > 2 else caches[0]
    cache = json.load(open(cache_path))
    s = cache["settings"]
    index = json.load(open(os.path.join(set_dir, "index.json")))
    folders = {e["id"]: e["folder"] for e in index["sequences"]}
    first, end = s["clip"]
    sub = s["sub_frames"]
    kind = s["reference"]
    if s.get("eye_movement", "fixation") != "fixation":
        sys.exit(f"{cache_path}: eye movement {s['eye_movement']}: only a fixating eye's scores are checked here")
    if kind in ("eye", "sharp"):
        ref_folder = f"{kind}-{s['reference_spp']}spp-{sub}sub-f{first}-{end}"
    else:
        ref_folder = f"shutter-{s['reference_spp']}spp-f{first}-{end}"
    torch.set_num_threads(os.cpu_count())
    rows = []
    for sid, entry in sorted(cache["scores"].items()):
        # blurlab-observer-scores/1 holds each eye's JOD; /2 and /3 an object with them.
        eyes_rust = entry["eyes"] if isinstance(entry, dict) else entry
        folder = os.path.join(set_dir, folders[sid])
        manifest = json.load(open(os.path.join(folder, "manifest.json")))
        frames = [read_rgb(os.path.join(folder, f["png"])) for f in manifest["frames"][first:end]]
        parts = sid.split("-")
        stereo = parts[-1] == "stereo"
        m, sp, t = parts[0][1:], parts[1][1:], parts[2][1:]
        key = f"M{m}-S{sp}" + (f"-T{t}" if kind == "shutter" else "") + ("-stereo" if stereo else "")
        ref_dir = os.path.join(set_dir, "observer", "reference", ref_folder, key)
        stamp = os.path.join(ref_dir, "reference.json")
        if isinstance(entry, dict) and "reference_sha256" in entry:
            with open(stamp, "rb") as f:
                if hashlib.sha256(f.read()).hexdigest() != entry["reference_sha256"]:
                    sys.exit(f"{stamp}: not the reference {sid} was judged against; predict again first")
        reference = [
            read_rgb(os.path.join(ref_dir, f"frame-{f:04d}-{k:02d}.png")) for f in range(first, end) for k in range(sub)
        ]
        test = [fr for fr in frames for _ in range(sub)]
        eyes = 2 if stereo else 1
        width = test[0].shape[1] // eyes
        height = test[0].shape[0]
        photometry = pycvvdp.vvdp_display_photo_eotf(
            Y_peak=s["peak_luminance"],
            contrast=s["peak_luminance"] / s["black_level"],
            source_colorspace="sRGB",
            E_ambient=s["ambient_lux"],
            k_refl=0.005,
        )
        geometry = pycvvdp.vvdp_display_geometry([width, height], ppd=s["pixels_per_degree"])
        metric = pycvvdp.cvvdp(
            display_photometry=photometry, display_geometry=geometry, device=torch.device("cpu"), quiet=True
        )
        eyes_py = []
        for e in range(eyes):
            crop = lambda f: f[:, e * width : (e + 1) * width, :]
            tv = np.stack([crop(f) for f in test])
            rv = np.stack([crop(f) for f in reference])
            fps = s["fps"] * sub if len(tv) > 1 else 0
            q, _ = metric.predict(tv, rv, dim_order="FHWC", frames_per_second=fps)
            eyes_py.append(float(q))
        rows.append({"id": sid, "blurlab": eyes_rust, "cvvdp": eyes_py})
        print(sid, eyes_rust, eyes_py, file=sys.stderr)
    worst = max(abs(a - b) for r in rows for a, b in zip(r["blurlab"], r["cvvdp"]))
    print(
        json.dumps(
            {
                "cache": cache_path,
                "settings": s,
                "cvvdp_version": getattr(pycvvdp, "__version__", "unknown"),
                "torch": torch.__version__,
                "rows": rows,
                "max_abs_difference_jod": worst,
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
