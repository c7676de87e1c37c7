#!/usr/bin/env python3
"""Mitsuba 3 peer of `blurlab bench tracer`.

Reads the static benchmark frame that blurlab wrote (scene.json: camera, sphere with its
baked albedo texture, floor, environment map EXR, integrator depth, samples per pixel),
renders it with Mitsuba 3's `path` integrator in the variant scene.json names
(`scalar_rgb`, or `llvm_ad_rgb`, the vectorised JIT one), and writes:

  mitsuba-seed1.exr, mitsuba-seed2.exr   two independently seeded renders at the same spp
  mitsuba.json                           timings and versions

blurlab computes noise (RMS of the difference of the two renders / sqrt 2) and means from
the EXRs itself, with the same code it uses for its own renders.

A scene.json with a "medium" (`blurlab bench media-reference`, issue 27) adds a participating
medium: its density grid as a Mitsuba `.vol` file read by a `gridvolume` (texel centres at
(i + 0.5) / n, trilinear, blurlab's convention too) scaled by the extinction, inside a
null-BSDF `cube` (the box; its bottom face is moved 1 cm under the floor so that it is not
coplanar with the floor, where the clamped grid is never seen), with an isotropic phase and
a constant albedo, rendered by the `volpath` integrator.

Usage: python3 bench/mitsuba_peer.py DIR      (DIR holds scene.json; outputs go there)
Requires: pip install mitsuba
"""

import json
import os
import sys
import time


def main():
    out_dir = sys.argv[1]
    with open(os.path.join(out_dir, "scene.json")) as f:
        desc = json.load(f)

    variant = desc.get("mitsuba_variant", "scalar_rgb")
    if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        # Dr.Jit loads the system's LLVM; Debian's LLVM 19 works (LLVM 15 aborts in
        # Mitsuba's kernels).
        debian = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
        if os.path.exists(debian):
            os.environ["DRJIT_LIBLLVM_PATH"] = debian
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f

    cam = desc["camera"]
    sph = desc["sphere"]
    floor = desc["floor"]
    spp = int(desc["samples_per_pixel"])
    sampler = desc.get("mitsuba_sampler", "independent")

    # Sphere: object frame = blurlab's object frame (rotation matrix, row-major), scaled by
    # the radius and moved to the centre. Mitsuba's sphere uv is (phi / 2 pi, theta / pi)
    # of the local point with theta from +z; blurlab baked its texture in that
    # parametrisation.
    m = sph["rotation"]
    c = sph["centre"]
    r = sph["radius"]
    rot = T(
        [
            [m[0][0], m[0][1], m[0][2], 0.0],
            [m[1][0], m[1][1], m[1][2], 0.0],
            [m[2][0], m[2][1], m[2][2], 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )
    sphere_to_world = T().translate(c) @ rot @ T().scale(r)

    scene = {
        "type": "scene",
        "integrator": {
            "type": "path",
            "max_depth": int(desc["mitsuba_max_depth"]),
            "rr_depth": int(desc["mitsuba_rr_depth"]),
        },
        "sensor": {
            "type": "perspective",
            "fov_axis": "x",
            "fov": float(cam["horizontal_fov_degrees"]),
            "to_world": T().look_at(origin=cam["position"], target=cam["target"], up=cam["up"]),
            "film": {
                "type": "hdrfilm",
                "width": int(cam["width"]),
                "height": int(cam["height"]),
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
            "sampler": {"type": sampler, "sample_count": spp},
        },
        "env": {
            "type": "envmap",
            "filename": desc["environment_exr"],
            "scale": float(desc["environment_scale"]),
        },
        "sphere": {
            "type": "sphere",
            "to_world": sphere_to_world,
            "bsdf": {
                "type": "diffuse",
                "reflectance": {
                    "type": "bitmap",
                    "filename": sph["albedo_exr"],
                    "raw": True,
                    "filter_type": "nearest",
                },
            },
        },
        "floor": {
            "type": "rectangle",
            # Mitsuba's rectangle spans [-1, 1]^2 in z = 0 with normal +z: turn it to +y.
            "to_world": T().translate([0.0, floor["height"], 0.0])
            @ T().rotate([1.0, 0.0, 0.0], -90.0)
            @ T().scale([1.0e4, 1.0e4, 1.0]),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": floor["albedo"]}},
        },
    }

    medium = desc.get("medium")
    if medium is not None:
        lo, size = medium["box_min"], medium["box_size"]
        below = 0.01
        cube_lo = [lo[0], lo[1] - below, lo[2]]
        cube_size = [size[0], size[1] + below, size[2]]
        # Mitsuba's envmap interpolates its texels bilinearly, where blurlab looks the nearest
        # one up; at the default map's horizon (sky 0.86 over ground 0.20 in adjacent rows)
        # that made the image row just above the horizon 9 % darker than blurlab's, the only
        # blocks that disagreed (rms z 4.5 over 720 blocks, every outlier in that band). Each
        # row repeated 8 times keeps the texels' angles and confines the interpolation to a
        # sixteenth of a texel at each edge.
        import numpy as np

        rows = 8
        env = np.array(mi.Bitmap(desc["environment_exr"]), dtype=np.float32)
        env_rows = os.path.join(out_dir, f"environment-rows{rows}.exr")
        mi.Bitmap(np.ascontiguousarray(np.repeat(env, rows, axis=0))).write(env_rows)
        scene["env"]["filename"] = env_rows
        scene["integrator"] = {
            "type": "volpath",
            "max_depth": int(desc["mitsuba_max_depth"]),
            "rr_depth": int(desc["mitsuba_rr_depth"]),
        }
        scene["smoke"] = {
            "type": "cube",
            # Mitsuba's cube spans [-1, 1]^3.
            "to_world": T().translate([cube_lo[i] + 0.5 * cube_size[i] for i in range(3)])
            @ T().scale([0.5 * c for c in cube_size]),
            "bsdf": {"type": "null"},
            "interior": {
                "type": "heterogeneous",
                "albedo": float(medium["albedo"]),
                "scale": float(medium["extinction"]),
                "sigma_t": {
                    "type": "gridvolume",
                    "filename": medium["vol"],
                    "filter_type": "trilinear",
                    "to_world": T().translate(lo) @ T().scale(size),
                },
                "phase": {"type": "isotropic"},
            },
        }

    t0 = time.perf_counter()
    loaded = mi.load_dict(scene)
    load_s = time.perf_counter() - t0
    runs = []
    for seed in (1, 2):
        t0 = time.perf_counter()
        img = mi.render(loaded, spp=spp, seed=seed)
        # The JIT variants return before the kernel has run: wait for it.
        dr.eval(img)
        dr.sync_thread()
        secs = time.perf_counter() - t0
        mi.Bitmap(img).write(os.path.join(out_dir, f"mitsuba-seed{seed}.exr"))
        runs.append(secs)
    w, h = int(cam["width"]), int(cam["height"])
    result = {
        "renderer": f"mitsuba {mi.__version__} {variant} {scene['integrator']['type']}",
        "variant": variant,
        "sampler": sampler,
        "threads": os.cpu_count(),
        "samples_per_pixel": spp,
        "load_seconds": load_s,
        "render_seconds": runs,
        "camera_samples_per_second": w * h * spp / min(runs),
    }
    with open(os.path.join(out_dir, "mitsuba.json"), "w") as f:
        json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
