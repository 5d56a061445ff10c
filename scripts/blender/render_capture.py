# Renders a small animated scene with Blender Cycles into the files `arena import blender` reads:
#   OUT/noisy/frame_NNNN.exr      multilayer EXR: Combined, Depth, Normal, Vector, DiffDir/Ind/Col,
#                                 GlossDir/Ind/Col, Emit, Env, IndexOB, IndexMA, roughness (an AOV)
#   OUT/reference_a/, reference_b/  the same frames at --reference-spp / 2 samples each, two
#                                 independent seeds: their mean is the reference, their difference
#                                 its noise floor (only Combined is read)
#   OUT/cameras.json              per frame: camera-to-world matrix, projection matrix, sensor facts;
#                                 each render's Cycles settings (renders)
# Run by Blender, not Python:
#   blender -b --factory-startup --python scripts/blender/render_capture.py -- OUT [options]
# Options: --frames N (6) --width W (96) --height H (54) --spp N (1) --reference-spp N (256)
#          --seed N (0). The noisy frames use an animated seed (each frame its own noise).
import argparse
import json
import math
import os
import sys

import bpy
from mathutils import Vector


def parse():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="render_capture.py")
    p.add_argument("out")
    p.add_argument("--frames", type=int, default=6)
    p.add_argument("--width", type=int, default=96)
    p.add_argument("--height", type=int, default=54)
    p.add_argument("--spp", type=int, default=1)
    p.add_argument("--reference-spp", type=int, default=256)
    p.add_argument("--seed", type=int, default=0)
    return p.parse_args(argv)


def material(name, color, roughness, metallic=0.0, emission=None):
    """A Principled BSDF material that also writes its roughness to the 'roughness' AOV."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Specular"].default_value = 0.5
    if emission is not None:
        bsdf.inputs["Emission"].default_value = (*emission, 1.0)
        bsdf.inputs["Emission Strength"].default_value = 1.0
    aov = nodes.new("ShaderNodeOutputAOV")
    aov.name = "roughness"
    aov.inputs["Value"].default_value = roughness
    return m


def add(mesh_op, name, mat, pass_index, **kwargs):
    mesh_op(**kwargs)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(mat)
    obj.pass_index = pass_index
    return obj


def build_scene(args):
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.object.delete()
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.render.resolution_x = args.width
    scene.render.resolution_y = args.height
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1
    scene.render.use_motion_blur = False  # the Vector pass needs it off
    scene.frame_start, scene.frame_end = 1, args.frames
    scene.render.fps = 30
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 4
    scene.cycles.sample_clamp_indirect = 0
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 1.0
    scene.view_settings.view_transform = "Standard"
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.06, 0.08, 1.0)
    scene.world = world

    add(bpy.ops.mesh.primitive_plane_add, "floor", material("floor", (0.7, 0.7, 0.7), 0.8), 1, size=8)
    add(bpy.ops.mesh.primitive_plane_add, "wall", material("wall", (0.6, 0.2, 0.15), 0.9), 2, size=8,
        location=(0, 3, 4), rotation=(math.pi / 2, 0, 0))
    cube = add(bpy.ops.mesh.primitive_cube_add, "cube", material("cube", (0.2, 0.4, 0.7), 0.5), 3, size=1.0,
               location=(-1.2, 0.5, 0.5))
    add(bpy.ops.mesh.primitive_uv_sphere_add, "sphere", material("metal", (0.9, 0.7, 0.3), 0.15, metallic=1.0), 4,
        radius=0.6, location=(1.0, 0.8, 0.6), segments=32, ring_count=16)
    bpy.ops.object.shade_smooth()
    # The cube moves: an object_moves event at frame 3 (0-based 2) in capture.json.
    cube.keyframe_insert("location", frame=1)
    cube.keyframe_insert("location", frame=2)
    cube.location = (-0.6, 0.3, 0.5)
    cube.keyframe_insert("location", frame=3)
    cube.location = (-0.2, 0.2, 0.5)
    cube.keyframe_insert("location", frame=args.frames)

    bpy.ops.object.light_add(type="AREA", location=(0, -0.5, 3.5))
    light = bpy.context.active_object
    light.data.energy = 300
    light.data.size = 1.5

    bpy.ops.object.camera_add(location=(0, -5, 2.0))
    cam = bpy.context.active_object
    cam.data.lens = 30
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.clip_start, cam.data.clip_end = 0.05, 100.0
    # A pan that rises and accelerates: motion on both axes (a slip of either is visible), and
    # motion to the previous and to the next frame differ.
    for f in range(1, args.frames + 1):
        s = (f - 1) / max(1, args.frames - 1)
        cam.location = (-1.0 + 2.0 * s * s, -5, 1.4 + 1.2 * s * s)
        direction = Vector((0, 0.8, 0.7)) - cam.location
        cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
        cam.keyframe_insert("location", frame=f)
        cam.keyframe_insert("rotation_euler", frame=f)
    for fc in cam.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"
    scene.camera = cam

    layer = scene.view_layers[0]
    for p in ("use_pass_combined", "use_pass_z", "use_pass_normal", "use_pass_vector", "use_pass_diffuse_direct",
              "use_pass_diffuse_indirect", "use_pass_diffuse_color", "use_pass_glossy_direct",
              "use_pass_glossy_indirect", "use_pass_glossy_color", "use_pass_emit", "use_pass_environment",
              "use_pass_object_index", "use_pass_material_index"):
        setattr(layer, p, True)
    aov = layer.aovs.add()
    aov.name = "roughness"
    aov.type = "VALUE"
    scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.exr_codec = "ZIP"
    return scene, cam


def render(scene, folder, samples, animated_seed, seed):
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.seed = seed
    scene.cycles.use_animated_seed = animated_seed
    os.makedirs(folder, exist_ok=True)
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        scene.render.filepath = os.path.join(folder, "frame_%04d.exr" % (f - scene.frame_start))
        bpy.ops.render.render(write_still=True)


def settings(scene):
    """The Cycles settings of the render just made, as cameras.json's "renders" records them:
    `arena import blender` refuses a reference that renders other light than the noisy frames."""
    c = scene.cycles
    return {"samples": c.samples, "seed": c.seed, "animatedSeed": c.use_animated_seed,
            "adaptiveSampling": c.use_adaptive_sampling, "denoising": c.use_denoising,
            "filmTransparent": scene.render.film_transparent,
            "motionBlur": scene.render.use_motion_blur, "filter": c.pixel_filter_type,
            "filterWidth": c.filter_width, "exposure": c.film_exposure,
            "clampDirect": c.sample_clamp_direct, "clampIndirect": c.sample_clamp_indirect,
            "blurGlossy": c.blur_glossy, "causticsReflective": c.caustics_reflective,
            "causticsRefractive": c.caustics_refractive,
            "maxBounces": c.max_bounces, "diffuseBounces": c.diffuse_bounces,
            "glossyBounces": c.glossy_bounces, "transmissionBounces": c.transmission_bounces,
            "volumeBounces": c.volume_bounces, "transparentBounces": c.transparent_max_bounces}


def cameras(scene, cam):
    out = []
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        m = cam.matrix_world
        p = cam.calc_matrix_camera(depsgraph, x=scene.render.resolution_x, y=scene.render.resolution_y)
        out.append({"cameraToWorld": [[m[r][c] for c in range(4)] for r in range(4)],
                    "projection": [[p[r][c] for c in range(4)] for r in range(4)]})
    return out


def main():
    args = parse()
    scene, cam = build_scene(args)
    os.makedirs(args.out, exist_ok=True)
    renders = {}
    render(scene, os.path.join(args.out, "noisy"), args.spp, True, args.seed)
    renders["noisy"] = settings(scene)
    half = max(1, args.reference_spp // 2)
    render(scene, os.path.join(args.out, "reference_a"), half, False, args.seed + 1)
    renders["reference_a"] = settings(scene)
    render(scene, os.path.join(args.out, "reference_b"), half, False, args.seed + 2)
    renders["reference_b"] = settings(scene)
    info = {"producer": "Blender %s (Cycles), scripts/blender/render_capture.py" % bpy.app.version_string,
            "width": args.width, "height": args.height, "frames": args.frames,
            "fps": scene.render.fps / scene.render.fps_base,
            "spp": args.spp, "referenceSpp": 2 * half, "clipStart": cam.data.clip_start,
            "clipEnd": cam.data.clip_end, "cameras": cameras(scene, cam),
            "events": [{"frame": 2, "kind": "object_moves", "what": "cube", "passIndex": 3}],
            "renders": renders}
    with open(os.path.join(args.out, "cameras.json"), "w") as f:
        json.dump(info, f, indent=1)


main()
