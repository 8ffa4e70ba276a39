"""Weights: Auto Weights skins meshes to an armature with the Rust core's bone heat,
nearest-bone (bilinear) or inverse-distance weights. ``operators`` holds the operator,
``binding`` reads and writes the Blender data, ``compute`` computes without bpy."""
