"""Opens a shatter EXR frame in Blender (the `bpy` module, or Blender's own Python) and checks
what a compositor sees: the file reads as a multilayer image; the Image node lists the colour
(Combined, Alpha) of the file's main layer and every other pass under the ViewLayer layer, the
denoising passes among them; the Denoise node takes the colour, Denoising Normal and Denoising
Albedo as its inputs; the Cryptomatte node finds both mattes through the header's metadata.

Run by scripts/check_exr_in_blender.sh and by the render tests; usage:
    python check_exr_in_blender.py FRAME.exr
    blender -b --factory-startup --python check_exr_in_blender.py -- FRAME.exr
"""

import sys

import bpy

MAIN_PASSES = {"Combined", "Alpha"}
VIEW_LAYER_PASSES = {
    "Depth", "Normal", "Vector", "FragmentIndex",
    "CryptoObject00", "CryptoObject01",
    "CryptoMaterial00", "CryptoMaterial01",
    "Denoising Albedo", "Denoising Normal",
}
MATTES = ["ViewLayer.CryptoObject", "ViewLayer.CryptoMaterial"]


def listed(node):
    return {socket.name for socket in node.outputs if socket.enabled}


def main(path):
    print(f"Blender {bpy.app.version_string}: {path}")
    image = bpy.data.images.load(path)
    try:
        image.update()  # reads the file; a multilayer image keeps no flat pixels, so this may complain
    except RuntimeError:
        pass
    problems = []
    if image.type != "MULTILAYER":
        problems.append(f"image type {image.type}, not MULTILAYER")

    scene = bpy.context.scene
    if hasattr(scene, "node_tree"):  # Blender 3.x and 4.x: the scene's compositing tree
        scene.use_nodes = True
        tree = scene.node_tree
    else:  # Blender 5: compositing trees are node groups
        tree = bpy.data.node_groups.new("check", "CompositorNodeTree")
        scene.compositing_node_group = tree
    node = tree.nodes.new("CompositorNodeImage")
    node.image = image
    main_passes = listed(node)
    print("  main layer passes:", sorted(main_passes))
    if not MAIN_PASSES <= main_passes:
        problems.append(f"main layer lacks {sorted(MAIN_PASSES - main_passes)}")
    try:
        node.layer = "ViewLayer"
        passes = listed(node)
    except TypeError as error:
        passes = set()
        problems.append(f"no ViewLayer layer: {error}")
    print("  ViewLayer passes:", sorted(passes))
    if not VIEW_LAYER_PASSES <= passes:
        problems.append(f"ViewLayer lacks {sorted(VIEW_LAYER_PASSES - passes)}")

    denoise = tree.nodes.new("CompositorNodeDenoise")
    for output, socket in [("Denoising Normal", "Normal"), ("Denoising Albedo", "Albedo")]:
        if output in passes:
            link = tree.links.new(node.outputs[output], denoise.inputs[socket])
            print(f"  Denoise node: {output} -> {socket}: {'linked' if link.is_valid else 'INVALID'}")
            if not link.is_valid:
                problems.append(f"the Denoise node refuses {output} as its {socket}")

    matte = tree.nodes.new("CompositorNodeCryptomatteV2")
    matte.source = "IMAGE"
    matte.image = image
    for name in MATTES:
        try:
            matte.layer_name = name
            print(f"  Cryptomatte layer {name}: found")
        except TypeError as error:
            problems.append(f"Cryptomatte layer {name} not found: {error}")

    for problem in problems:
        print("  PROBLEM:", problem)
    if problems:
        sys.exit(1)
    print("  ok: Blender lists every pass, the Denoise node takes the denoising passes, both Cryptomattes found")


if __name__ == "__main__":
    main(sys.argv[-1])
