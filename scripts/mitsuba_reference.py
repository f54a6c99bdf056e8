#!/usr/bin/env python3
"""Renders a scene exported by tests/independent_reference.rs with Mitsuba 3,
the independent renderer the reference path tracer is checked against.

    mitsuba_reference.py SCENE.json OUT_PREFIX

SCENE.json (written by the test) names binary PLY meshes in world space
with vertex normals, one per instance, with its material as a Mitsuba BSDF and emitter:

    {"width": W, "height": H, "spp": N, "seeds": [s0, s1, ...],
     "max_bounces": B,
     "camera": {"origin": [..], "target": [..], "up": [..], "yfov_deg": F},
     "shapes": [{"ply": "mesh0.ply", "twosided": bool,
                 "bsdf": {"diffuse": [r, g, b]} | {"dielectric": ior}
                       | {"rough_dielectric": {"ior": ior, "alpha": A}}
                       | {"diffuse_texture": "textureN.exr"}
                       | {"schlick_metal": {"base_color": [r, g, b], "roughness": R}}
                       | {"blend_metal": {"base_color": [r, g, b], "roughness": R,
                                          "metallic": M}},
                 "emission": [r, g, b] | null,
                 "absorption": [r, g, b] | null}, ...],
     "lights": [{"point": {"position": [..], "intensity": [..]}}
              | {"spot": {"position": [..], "direction": [..], "intensity": [..],
                          "cutoff_deg": C, "beam_width_deg": B}}
              | {"directional": {"direction": [..], "irradiance": [..]}}, ...],
     "environment": {"constant": [r, g, b]} | {"map": "env.exr", "scale": S}
                  | null}

(an absorption: the coefficient (1/m) of the purely absorbing medium
inside a closed dielectric; a point light's intensity in W/sr, falling off
with the inverse square; a
spot light's the same inside its cone around "direction", Mitsuba's falloff
from the beam width to the cutoff, both half angles in degrees; a
directional light's irradiance on a surface facing it, "direction" the way
its light travels; a constant environment's radiance; an equirectangular
map, linear RGB, already on the lattice of Mitsuba's envmap: rows at
v = y/(H - 1)).

and writes OUT_PREFIX_<k>.f32 per seed: H x W x 3 little-endian float32,
row 0 at the top, linear RGB.

The conventions are stereocache's (docs/ARCHITECTURE.md "Integrator",
"Checked against Mitsuba 3"): a box pixel filter (the reference jitters
uniformly inside the pixel), paths of at most B scattering events (Mitsuba's max_depth counts
segments: B + 1), no Russian roulette before that depth, vacuum outside
dielectrics (Mitsuba's default exterior is air, 1.000277), and a symmetric
pinhole looking down the camera's -Z with +Y up.
"""
import json
import os
import sys

import numpy as np
import mitsuba as mi


def bsdf_of(spec, base):
    if "diffuse_texture" in spec:
        # A linear float texture (glTF's base colour texture decoded from
        # sRGB, times baseColorFactor), bilinear and repeating, as the scene's.
        return {
            "type": "diffuse",
            "reflectance": {
                "type": "bitmap",
                "filename": os.path.join(base, spec["diffuse_texture"]),
                "filter_type": "bilinear",
                "wrap_mode": "repeat",
                "raw": True,
            },
        }
    if "diffuse" in spec:
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": spec["diffuse"]}}
    if "dielectric" in spec:
        return {"type": "dielectric", "int_ior": float(spec["dielectric"]), "ext_ior": 1.0}
    if "rough_dielectric" in spec:
        # GGX with alpha = roughness^2, sampled by visible normals; Mitsuba's
        # Smith term is the separable one (ours: height-correlated).
        d = spec["rough_dielectric"]
        return {
            "type": "roughdielectric",
            "distribution": "ggx",
            "alpha": float(d["alpha"]),
            "int_ior": float(d["ior"]),
            "ext_ior": 1.0,
            "sample_visible": True,
        }
    if "blend_metal" in spec:
        # glTF's mix(dielectric, metal, metallic) with the dielectric's
        # specular layer off (a Lambert of the base colour): linear in
        # metallic, so a blend of the diffuse and the metal below.
        m = spec["blend_metal"]
        return {
            "type": "blendbsdf",
            "weight": float(m["metallic"]),
            "bsdf_0": bsdf_of({"diffuse": m["base_color"]}, base),
            "bsdf_1": bsdf_of(
                {"schlick_metal": {"base_color": m["base_color"], "roughness": m["roughness"]}}, base
            ),
        }
    if "schlick_metal" in spec:
        # glTF's metal: Schlick's Fresnel with F0 = the base colour, GGX with
        # alpha = roughness^2. Mitsuba's principled BSDF at metallic 1 (and
        # no specular tint, sheen or clearcoat) is exactly that lobe, but
        # for its separable Smith term (ours is height-correlated).
        m = spec["schlick_metal"]
        return {
            "type": "principled",
            "base_color": {"type": "rgb", "value": m["base_color"]},
            "metallic": 1.0,
            "roughness": float(m["roughness"]),
            "spec_tint": 0.0,
            "sheen": 0.0,
            "clearcoat": 0.0,
        }
    raise ValueError(f"unknown bsdf {spec}")


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: mitsuba_reference.py SCENE.json OUT_PREFIX")
    path, prefix = sys.argv[1], sys.argv[2]
    cfg = json.load(open(path))
    base = os.path.dirname(os.path.abspath(path))
    mi.set_variant("scalar_rgb")
    cam = cfg["camera"]
    # Media need the volumetric path tracer; its absorbing-only medium
    # (albedo 0) ends a path at a sampled medium event, an unbiased
    # estimate of the Beer-Lambert transmittance we multiply by.
    media = any(sh.get("absorption") is not None for sh in cfg["shapes"])
    scene = {
        "type": "scene",
        "integrator": {
            "type": "volpath" if media else "path",
            "max_depth": int(cfg["max_bounces"]) + 1,
            "rr_depth": int(cfg["max_bounces"]) + 2,
            # Fixed image blocks: a pixel's random stream depends on its
            # block, and Mitsuba's default block size on the core count, so
            # without this the same seeds give other images elsewhere.
            "block_size": 16,
        },
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": float(cam["yfov_deg"]),
            "near_clip": 1e-3,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=cam["origin"], target=cam["target"], up=cam["up"]
            ),
            "film": {
                "type": "hdrfilm",
                "width": int(cfg["width"]),
                "height": int(cfg["height"]),
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
            "sampler": {"type": "independent", "sample_count": int(cfg["spp"])},
        },
    }
    for i, sh in enumerate(cfg["shapes"]):
        bsdf = bsdf_of(sh["bsdf"], base)
        if sh["twosided"]:
            bsdf = {"type": "twosided", "material": bsdf}
        shape = {
            "type": "ply",
            "filename": os.path.join(base, sh["ply"]),
            # Shading normals from the file's vertex normals, interpolated
            # (those of a faceted mesh are its face normals).
            "face_normals": False,
            "bsdf": bsdf,
        }
        if sh.get("absorption") is not None:
            # An rgb value is bounded by 1 here: the largest coefficient
            # goes into the medium's scale.
            sigma = sh["absorption"]
            top = max(sigma)
            if not top > 0.0:
                sys.exit(f"shape {i}: absorption {sigma} is not positive")
            shape["interior"] = {
                "type": "homogeneous",
                "sigma_t": {"type": "rgb", "value": [c / top for c in sigma]},
                "scale": top,
                "albedo": {"type": "rgb", "value": [0.0, 0.0, 0.0]},
            }
        if sh.get("emission") is not None:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": sh["emission"]}}
        scene[f"shape{i}"] = shape
    for i, light in enumerate(cfg.get("lights", [])):
        if "point" in light:
            p = light["point"]
            scene[f"light{i}"] = {
                "type": "point",
                "position": p["position"],
                "intensity": {"type": "rgb", "value": p["intensity"]},
            }
        elif "spot" in light:
            p = light["spot"]
            o = p["position"]
            d = p["direction"]
            # Any up vector not along the axis: the cone is round.
            up = [0.0, 0.0, 1.0] if abs(d[1]) > 0.9 else [0.0, 1.0, 0.0]
            scene[f"light{i}"] = {
                "type": "spot",
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=o, target=[o[k] + d[k] for k in range(3)], up=up
                ),
                "intensity": {"type": "rgb", "value": p["intensity"]},
                "cutoff_angle": float(p["cutoff_deg"]),
                "beam_width": float(p["beam_width_deg"]),
            }
        elif "directional" in light:
            d = light["directional"]
            scene[f"light{i}"] = {
                "type": "directional",
                "direction": d["direction"],
                "irradiance": {"type": "rgb", "value": d["irradiance"]},
            }
        else:
            raise ValueError(f"unknown light {light}")
    env = cfg.get("environment")
    if env is not None and "constant" in env:
        scene["environment"] = {
            "type": "constant",
            "radiance": {"type": "rgb", "value": env["constant"]},
        }
    elif env is not None:
        # Equirectangular, row 0 at +Y, u = 0 at -Z increasing towards +X:
        # Mitsuba's own envmap parameterisation, so no rotation.
        scene["environment"] = {
            "type": "envmap",
            "filename": os.path.join(base, env["map"]),
            "scale": float(env["scale"]),
        }
    scene = mi.load_dict(scene)
    for k, seed in enumerate(cfg["seeds"]):
        img = np.array(mi.render(scene, spp=int(cfg["spp"]), seed=int(seed)), dtype="<f4")
        img[..., :3].tofile(f"{prefix}_{k}.f32")


if __name__ == "__main__":
    main()
