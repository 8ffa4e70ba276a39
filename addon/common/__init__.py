"""Blender data to numpy arrays and back, and the helpers every area shares. No operators and
no algorithms (those live in Rust).

One module per kind of Blender data: ``meshes`` (vertices, faces, paint masks), ``armatures``
(deform bones, B-Bone curves, which armature an operator acts on), ``groups`` (vertex-group
weights read and written), ``keys`` (F-curves and keys in bulk), ``modifiers``, ``objects``
(visibility, parenting), ``transforms`` (world matrices in double precision); ``mirror``
(left/right bone names), ``reports`` (why data cannot be read or changed, for the status bar),
``files`` and ``panels`` (the sidebar tab, registering an area) serve every area. Reads use
``foreach_get``.
"""
